"""The evaluation journal: a torn last line, the evaluation hash, one parser for the cache and the reader."""

import json

import pytest

from lnss_lib.campaign.journal import EvaluationCache


def test_cache_survives_a_torn_line_and_checks_the_hash(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    cache = EvaluationCache(path, "abc")
    cache.add((1, 2, 3, 4, 0, 0), {"generation": 1, "order": 0})
    cache.close()
    with path.open("a") as handle:
        handle.write('{"key": [9, 9, 9')  # a write cut short by SIGKILL
    cache = EvaluationCache(path, "abc")
    assert list(cache.records) == [(1, 2, 3, 4, 0, 0)]
    cache.add((5, 5, 5, 5, 1, 1), {"generation": 2, "order": 3})
    cache.close()
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [line.get("key") for line in lines] == [None, [1, 2, 3, 4, 0, 0], [5, 5, 5, 5, 1, 1]]
    with pytest.raises(ValueError, match="evaluation hash"):
        EvaluationCache(path, "other")
