"""The evaluation journal: a torn or damaged line, a lost journal, duplicated and error records, the evaluation hash."""

import json

import numpy as np
import pytest

from lnss_lib.campaign.journal import EvaluationCache, encode_record, read_cache_records
from lnss_lib.keys import DESIGN_KEYS


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


def _synthetic(run_dir, generations=4, **kwargs):
    from lnss_lib.campaign import run_campaign

    return run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "generations": generations}},
        workers=0,
        run_dir=run_dir,
        progress=False,
        **kwargs,
    )


def _resume(run_dir):
    from lnss_lib.campaign import run_campaign

    return run_campaign(resume=run_dir, workers=0, progress=False)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    return _synthetic(tmp_path_factory.mktemp("journal") / "reference").run_dir


def _assert_same_final_population(run_dir, reference):
    from lnss_lib.campaign import final_population

    for got, want in zip(final_population(run_dir), final_population(reference)):
        np.testing.assert_array_equal(got, want)


def test_damaged_earlier_line_or_missing_journal_is_evaluated_again(tmp_path, uninterrupted):
    """The line of a generation-1 design still in the population damaged after generation
    2 (unreadable, or one digit changed), the header line damaged, or the journal deleted: resume evaluates
    the designs again and ends as the uninterrupted run (it failed with ``error: (191, 34, 9, 70, 1, 1)``,
    a KeyError, or kept the changed digit)."""
    from lnss_lib.campaign import final_population

    reference = {tuple(r["key"]): r["metrics"] for r in read_cache_records(uninterrupted)}
    for damage in (
        "earlier line",
        "one digit",
        "nested too deep",
        "a 5000-digit integer",
        "header",
        "missing journal",
    ):
        run_dir = tmp_path / damage.replace(" ", "_")
        _synthetic(run_dir, max_generations=2)
        journal = run_dir / "evaluations.jsonl"
        lines = journal.read_bytes().splitlines(keepends=True)
        if damage == "missing journal":
            journal.unlink()
        else:
            population = {tuple(int(v) for v in row) for row in final_population(run_dir)[0]}
            index = (
                0
                if damage == "header"
                else next(
                    i
                    for i, line in enumerate(lines[1:], 1)
                    if json.loads(line)["generation"] == 1
                    and tuple(json.loads(line)["key"]) in population
                )
            )
            if (
                damage == "one digit"
            ):  # still valid JSON: the first digit of pdop_mean_3sigma changed
                at = lines[index].index(b'"pdop_mean_3sigma": ') + len(b'"pdop_mean_3sigma": ')
                lines[index] = (
                    lines[index][:at]
                    + str((int(chr(lines[index][at])) + 1) % 10).encode()
                    + lines[index][at + 1 :]
                )
            elif (
                damage == "nested too deep"
            ):  # json.loads raised RecursionError: resume and export exited 1
                lines[index] = b'{"a": ' * 100_000 + b"1" + b"}" * 100_000 + b"\n"
            elif (
                damage == "a 5000-digit integer"
            ):  # json.loads raised ValueError (int string conversion limit)
                lines[index] = b'{"key": [' + b"9" * 5000 + b', 1, 1, 1, 1, 1], "generation": 1}\n'
            else:  # a damaged disk block
                lines[index] = b"\x00" * (len(lines[index]) - 1) + b"\n"
            journal.write_bytes(b"".join(lines))
        if damage in ("header", "missing journal"):
            result = _resume(run_dir)
        else:  # the skipped line is named
            with pytest.warns(
                RuntimeWarning, match=f"evaluations.jsonl: line.s. {index + 1} damaged"
            ):
                result = _resume(run_dir)
        assert result.generations == 4, damage
        _assert_same_final_population(run_dir, uninterrupted)
        records = read_cache_records(run_dir)
        assert len({tuple(r["key"]) for r in records}) == len(records)
        for record in records:  # every metric kept or evaluated again is the uninterrupted run's
            assert json.dumps(record["metrics"]) == json.dumps(reference[tuple(record["key"])]), (
                damage
            )


def test_duplicated_records_count_once(tmp_path, uninterrupted):
    """A journal holding every record twice (two writers) exports each design once."""
    from lnss_lib.campaign import export_results

    run_dir = _synthetic(tmp_path / "run", max_generations=2).run_dir
    journal = run_dir / "evaluations.jsonl"
    lines = journal.read_bytes().splitlines(keepends=True)
    unique = len(lines) - 1
    journal.write_bytes(b"".join(lines + lines[1:]))
    assert len(read_cache_records(run_dir)) == unique
    evaluations, _, _ = export_results(run_dir)
    assert evaluations.sizes["design"] == unique
    _resume(run_dir)
    _assert_same_final_population(run_dir, uninterrupted)
    evaluations = export_results(run_dir)[0]
    designs = {tuple(row) for row in np.column_stack([evaluations[k].values for k in DESIGN_KEYS])}
    assert len(designs) == evaluations.sizes["design"] == len(read_cache_records(uninterrupted))


def test_error_record_gives_way_to_a_later_one(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    cache = EvaluationCache(path, "abc")
    cache.add((1, 1, 1, 1, 1, 1), {"generation": 1, "order": 0, "error": True, "reason": "cause"})
    cache.close()
    assert cache.n_errors == 1
    cache = EvaluationCache(path, "abc")  # a resumed session evaluates it again
    assert (1, 1, 1, 1, 1, 1) not in cache and cache.n_errors == 0
    cache.add(
        (1, 1, 1, 1, 1, 1), {"generation": 1, "order": 0, "error": False, "metrics": {"n_sat": 1}}
    )
    cache.close()
    assert [r["error"] for r in read_cache_records(tmp_path)] == [False]


def test_records_carry_a_crc_and_format_1_journals_still_load(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    record = {"key": [1, 2, 3, 4, 0, 0], "generation": 1, "order": 0, "metrics": {"n_sat": 1}}
    path.write_text(
        json.dumps({"evaluation_hash": "abc", "format": 1}) + "\n" + json.dumps(record) + "\n"
    )
    assert (1, 2, 3, 4, 0, 0) in EvaluationCache(path, "abc")  # a run journalled before the CRC
    path.write_text(
        json.dumps({"evaluation_hash": "abc", "format": 2}) + "\n" + json.dumps(record) + "\n"
    )
    assert len(EvaluationCache(path, "abc")) == 0  # format 2: a line without its CRC is damaged
    line = encode_record(record)
    assert json.loads(line)["crc32"] and line.replace('"generation": 1', '"generation": 2') != line
    path.write_text(
        json.dumps({"evaluation_hash": "abc", "format": 2})
        + "\n"
        + line
        + "\n"
        + line.replace('"generation": 1', '"generation": 2').replace("[1, 2, 3", "[9, 2, 3")
        + "\n"
    )
    assert list(EvaluationCache(path, "abc").records) == [(1, 2, 3, 4, 0, 0)]


def test_a_record_of_another_processor_model_is_no_hit(tmp_path):
    """The evaluation hash leaves out the kernels' processor model: a journal record of another model (its own
    ``kernel_cpu``, or the run's for a record written before records named it) is evaluated again, with a warning
    naming the model; its later record then stands for the design. Before, the cache answered it as a hit."""
    path = tmp_path / "evaluations.jsonl"
    cache = EvaluationCache(path, "abc")
    for key, model in (
        ((1, 1, 1, 1, 1, 1), "model-a"),
        ((2, 2, 2, 2, 2, 2), "model-b"),
        ((3, 3, 3, 3, 3, 3), None),
    ):
        cache.add(
            key,
            {"generation": 1, "order": 0, "metrics": {"n_sat": 1}}
            | ({"kernel_cpu": model} if model else {}),
        )
    cache.close()
    assert len(EvaluationCache(path, "abc")) == 3  # no model asked for: every record a hit
    with pytest.warns(
        RuntimeWarning,
        match=r"2 design\(s\) evaluated on another processor model \(1 with kernels "
        r"compiled for model-b, 1 with kernels compiled for model-c\); here the "
        r"kernels are compiled for model-a: they are evaluated again",
    ):
        cache = EvaluationCache(path, "abc", kernel_cpu="model-a", run_cpu="model-c")
    assert list(cache.records) == [(1, 1, 1, 1, 1, 1)] and cache.n_other_cpu == 2
    cache.add(
        (2, 2, 2, 2, 2, 2),
        {"generation": 3, "order": 0, "metrics": {"n_sat": 2}, "kernel_cpu": "model-a"},
    )
    cache.close()
    assert [(r["key"][0], r["generation"]) for r in read_cache_records(tmp_path)] == [
        (1, 1),
        (2, 3),
        (3, 1),
    ]
    assert (
        len(EvaluationCache(path, "abc", kernel_cpu="model-c", run_cpu="model-c")) == 1
    )  # the unnamed record
    assert (
        len(EvaluationCache(path, "abc", kernel_cpu="model-a", run_cpu=None)) == 3
    )  # model never recorded


def test_resume_on_another_processor_model_evaluates_the_journal_again(tmp_path):
    """A run whose journal records name another processor model: on resume the designs the search asks for are
    evaluated here again (new records of this model), not answered with the other model's round-off."""
    from lnss_lib import kernel_cpu

    run_dir = _synthetic(tmp_path / "run", generations=2, max_generations=1).run_dir
    journal = run_dir / "evaluations.jsonl"
    lines = journal.read_text().splitlines()
    records = [json.loads(line) for line in lines[1:]]
    assert {r.pop("crc32") and r["kernel_cpu"] for r in records} == {kernel_cpu()}
    journal.write_text(
        "\n".join([lines[0]] + [encode_record({**r, "kernel_cpu": "other-model"}) for r in records])
        + "\n"
    )
    with pytest.warns(
        RuntimeWarning, match=f"{len(records)} design.s. evaluated on another processor model"
    ):
        result = _resume(run_dir)
    assert result.generations == 2 and result.session_evaluations >= len(records)
    by_key = {tuple(r["key"]): r for r in read_cache_records(run_dir)}
    assert all(by_key[tuple(r["key"])]["kernel_cpu"] == kernel_cpu() for r in records)
