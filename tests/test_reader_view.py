"""What a reader sees: the outputs index and converted notebooks opened in headless Chromium (network off).

A page fails on a grey tile (a figure without its picture), an image that does not load, a table header that
is a raw key (``pdop_mean_3sigma`` where the label registry has "PDOP (3-sigma mean)") or a number with more
digits than any quantity's format gives (:func:`lnss_lib.keys.value_format`: at most 3 decimals, else at most 4
significant digits). The index is written from the outputs the notebooks of this test session wrote (nbval runs
them first, under ``ci``); the notebooks are two executed by ``reproduce`` here. Skipped, saying why, without
Chromium."""

import json
import re
import shutil
import subprocess
import sys

import pytest

import lnss_lib.pipeline as pipeline
from lnss_lib.config import available_profiles
from lnss_lib.outputs import profile_dir

CHROMIUM = (
    shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
)
pytestmark = [
    pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH (apt-get install chromium)"),
    pytest.mark.notebook_outputs,  # the index of this session's notebook outputs; two notebooks run again here
]
PROFILE = "ci"
NOTEBOOKS = ("02_dop_grid", "05_standalone_elfo")
RAW_KEY = re.compile(r"^[a-z][a-z0-9]*(_[a-z0-9]+)+$")
NUMBER = re.compile(r"\d+\.\d+(?:e[+-]?\d+)?")

REPORT_SCRIPT = """<script>
window.addEventListener('load', () => {
  const text = nodes => [...nodes].map(n => n.textContent.trim());
  const report = {
    images: document.images.length,
    broken: [...document.images].filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt || i.src.slice(0, 60)),
    grey: text(document.querySelectorAll('.noimg')),
    headers: text(document.querySelectorAll('th')),
    cells: text(document.querySelectorAll('td')),
  };
  const pre = document.createElement('pre');
  pre.id = 'reader-report';
  pre.textContent = JSON.stringify(report);
  document.body.appendChild(pre);
});
</script>"""


def reader_view(page, tmp_path) -> dict:
    """Open ``page`` (every image loaded at once, not lazily) in headless Chromium with the network refused;
    what it shows: images, images that did not load, grey tiles, table headers and cells."""
    copy = page.with_name(f"reader_{page.name}")
    copy.write_text(
        page.read_text()
        .replace(' loading="lazy"', "")
        .replace("</body>", REPORT_SCRIPT + "</body>")
    )
    command = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--no-first-run",
        "--disable-sync",
        "--disable-background-networking",
        f"--user-data-dir={tmp_path / 'chromium-profile'}",
        "--proxy-server=127.0.0.1:9",
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--virtual-time-budget=20000",
        "--dump-dom",
        copy.as_uri(),
    ]
    try:
        dom = subprocess.run(
            command, capture_output=True, text=True, timeout=240, check=False
        ).stdout
    finally:
        copy.unlink()
    found = re.search(r'<pre id="reader-report">(.*?)</pre>', dom, re.S)
    assert found, "Chromium did not finish loading the page"
    return json.loads(
        found.group(1)
        .replace("&quot;", '"')
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
    )


def over_long(text: str) -> bool:
    """Whether ``text`` holds a number with more than 3 decimals and more than 4 significant digits."""
    for number in NUMBER.findall(text):
        whole, decimals = number.split("e")[0].split(".")
        if len(decimals) > 3 and len((whole + decimals).lstrip("0")) > 4:
            return True
    return False


def defects(view: dict) -> dict:
    """What a reader would stumble on; empty lists when the page reads well."""
    return {
        "grey tiles": view["grey"],
        "images not shown": view["broken"],
        "raw key headers": [  # a profile's name (a comparison's column) is a name, not a key
            h for h in view["headers"] if RAW_KEY.match(h) and h not in available_profiles()
        ],
        "over-long numbers": [c for c in view["cells"] if over_long(c)],
    }


def test_reader_defects_are_found(tmp_path):
    page = tmp_path / "page.html"
    page.write_text(
        '<html><body><div class="noimg">interactive figure (no PNG)</div><img src="missing.png" alt="fig">'
        "<table><tr><th>pdop_mean_3sigma</th><th>PDOP (3-sigma mean)</th></tr>"
        "<tr><td>868.033267</td><td>1.61634e+04</td><td>2.253</td><td>0.0005503</td></tr></table></body></html>"
    )
    assert defects(reader_view(page, tmp_path)) == {
        "grey tiles": ["interactive figure (no PNG)"],
        "images not shown": ["fig"],
        "raw key headers": ["pdop_mean_3sigma"],
        "over-long numbers": ["868.033267", "1.61634e+04"],
    }


def test_index_shows_every_figure_and_readable_tables(tmp_path):
    figures = sorted((profile_dir(PROFILE) / "figures").glob("*.html"))
    if not figures:
        pytest.skip(
            f"no figures in outputs/{PROFILE}/: the notebooks run first (python -m pytest runs them)"
        )
    index = pipeline.write_index(PROFILE)
    view = reader_view(index, tmp_path)
    assert defects(view) == {
        "grey tiles": [],
        "images not shown": [],
        "raw key headers": [],
        "over-long numbers": [],
    }
    assert view["images"] >= len(figures)  # every figure's tile, and the headline figure when drawn


def test_converted_notebooks_show_their_figures(tmp_path):
    assert pipeline.reproduce(PROFILE, only=list(NOTEBOOKS)) == 0
    for name in NOTEBOOKS:
        executed = profile_dir(PROFILE) / "notebooks" / f"{name}.ipynb"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "jupyter",
                "nbconvert",
                "--to",
                "html",
                str(executed),
                "--output-dir",
                str(tmp_path),
            ],
            check=True,
            capture_output=True,
            timeout=300,
        )
        page = tmp_path / f"{name}.html"
        view = reader_view(page, tmp_path)
        assert view["images"] >= 1, f"{name} shows no figure"
        assert "PNG export skipped" not in executed.read_text(), name
        assert defects(view) == {
            "grey tiles": [],
            "images not shown": [],
            "raw key headers": [],
            "over-long numbers": [],
        }, name
