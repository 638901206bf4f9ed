"""The README as a newcomer reads it: a page or two, the answer from the shipped results, the two commands."""

import re
from pathlib import Path

from lnss_lib.findings import study_answer

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
ANSWER = re.compile(r"<!-- answer: [^\n]*-->\n(.*?)\n<!-- end of answer -->", re.S)


def test_readme_fits_on_a_page_or_two():
    lines = README.splitlines()
    assert len(lines) <= 150
    assert [line for line in lines if len(line) > 100] == []


def test_readme_names_no_issue_or_commit():
    assert re.findall(r"(?i)\bissues? \d+|#\d+\b", README) == []
    hashes = [
        word
        for word in re.findall(r"\b[0-9a-f]{7,40}\b", README)
        if re.search(r"[a-f]", word) and re.search(r"\d", word)
    ]
    assert hashes == []


def test_readme_answer_is_the_one_the_shipped_results_give():
    block = ANSWER.search(README)
    assert block is not None, "the README has no answer block"
    answer = study_answer()
    assert answer is not None, "no shipped results to answer from (outputs/reference/)"
    assert block.group(1) == answer.markdown(), (
        "the README's answer is out of step with outputs/reference/; paste lnss_lib.findings.study_answer().markdown()"
    )


def test_readme_opens_on_the_answer_then_the_two_commands():
    assert (
        README.index("## The answer")
        < README.index("## Set up and run")
        < README.index("## What you get")
    )
    commands = re.findall(r"^pip install -r requirements.txt && (.+?)\s+#", README, re.M)
    assert commands == ["python -m lnss_lib reproduce", "python -m pytest"]
    assert (
        "pip install -r requirements.txt && python -m pytest" in (ROOT / ".ci" / "run").read_text()
    )


def test_readme_points_only_inside_the_repository():
    assert "../shared" not in README
    for path in re.findall(r"`((?:docs|outputs/reference|params|lnss_lib)/[\w./*-]*)`", README):
        assert list(ROOT.glob(path)), f"README names {path}, which the repository does not hold"
