"""Results pinned before a refactor that must not change them, on every processor model: each
test recomputes one pin and compares it field by field (floats within a relative tolerance, NaN equal to NaN; ints,
bools and strings exact) with the record of the model the kernels are compiled for here
(``tests/data/pinned_results/<model>.json``, within the pin's ``RTOL``) and with every other model's record, within
the cross-model tolerance derived from the recorded models' own differences (``pinned_results.cross_model_rtol``).
On a model without a record the second comparison alone guards the results; nothing is skipped.

What each pin holds, the fields left out (all run-dependent: timings, worker ids, checksums over timings,
package versions, settings hashes and the profile echo; ``pinned_results.EXCLUDED`` names each with its
reason) and how to record this machine's model (``PYTHONPATH=$PWD python tests/pinned_results.py --write``, which
records the commit it ran on): see ``tests/pinned_results.py``. Runtime on a quiet core, numba cache warm:
about 2 s, 13 s, 9 s and 4 s.
"""

import math

import pytest
from pinned_results import (
    CROSS_MODEL_FACTOR,
    EXCLUDED,
    PINS,
    RTOL,
    check_pin,
    cross_model_rtol,
    differences,
    fixture_path,
    largest_relative_difference,
    load_fixtures,
    pin_cross_model_rtol,
)

from lnss_lib import kernel_cpu


@pytest.fixture(scope="module")
def recorded():
    return load_fixtures()


@pytest.mark.parametrize("name", list(PINS))
def test_pinned_result(recorded, name):
    diffs = check_pin(name, PINS[name](), recorded, kernel_cpu())
    assert not diffs, (
        f"{len(diffs)} pinned value(s) of {name} changed (kernels compiled here for {kernel_cpu()}; "
        f"records of {', '.join(recorded)}):\n" + "\n".join(diffs[:30])
    )


def test_records_name_their_commit_model_and_exclusions(recorded):
    """Each record made at a clean commit under the current tolerances, in the file of its model, holding pins of
    today's list; every pin recorded somewhere and most on two models or more, so that the cross-model tolerance is
    measured, not assumed (a pin whose results changed is re-recorded on the models that can run it; the others'
    records leave it out, :func:`pinned_results.pin_cross_model_rtol`)."""
    assert len(recorded) >= 2
    for model, record in recorded.items():
        meta = record["meta"]
        assert len(meta["commit"]) == 40 and not meta["dirty"], model
        assert fixture_path(model).is_file(), model
        assert set(meta["excluded"]) <= set(EXCLUDED) and meta["rtol"] == RTOL, model
        assert set(record["pins"]) <= set(PINS), model
    holders = [sum(name in record["pins"] for record in recorded.values()) for name in PINS]
    assert min(holders) >= 1 and sum(h >= 2 for h in holders) > len(PINS) / 2


@pytest.mark.parametrize("name", list(PINS))
def test_models_differ_by_round_off_alone(recorded, name):
    """The recorded models agree in every int, bool, string and shape (the search took the same path), and their
    floats within a relative 1e-5: a last-bit difference carried through 10 days of adaptive steps (measured at most
    4e-6, in a 3-sigma DOP mean of the quick campaign), while a change of a force model or a setting moves results by
    1e-3 or more; the cross-model tolerance derived from them lies between the pin's own tolerance and 1e-4."""
    records = [record["pins"][name] for record in recorded.values() if name in record["pins"]]
    assert RTOL[name] <= pin_cross_model_rtol(name, recorded) <= 1e-4
    for other in records[1:]:
        assert differences(records[0], other, math.inf) == []
        assert largest_relative_difference(records[0], other) < 1e-5


def test_cross_model_tolerance_is_measured_from_the_records():
    first = {"a": 100.0, "l": [1.0, math.nan], "i": 3, "wall_s": 1.0}
    second = {"a": 100.0 + 3e-6, "l": [1.0 - 2e-9, math.nan], "i": 3, "wall_s": 2.0}
    assert largest_relative_difference(first, second) == pytest.approx(3e-8, rel=1e-6)
    assert largest_relative_difference(first, first) == 0.0
    assert cross_model_rtol("random_paper_designs", [first, second]) == pytest.approx(
        1e-6
    )  # 10 x 3e-8, rounded up
    assert CROSS_MODEL_FACTOR * 3e-8 < cross_model_rtol("random_paper_designs", [first, second])
    assert cross_model_rtol("random_paper_designs", [first, first]) == RTOL["random_paper_designs"]
    assert cross_model_rtol("evaluate_table4", [first]) == RTOL["evaluate_table4"]
    recorded = {
        "model-a": {"meta": {"commit": "a" * 40}, "pins": {"evaluate_table4": first}},
        "model-b": {"meta": {"commit": "b" * 40}, "pins": {"evaluate_table4": second}},
    }
    assert check_pin("evaluate_table4", first, recorded, "model-a") == []
    assert check_pin("evaluate_table4", second, recorded, "model-b") == []
    assert (
        check_pin("evaluate_table4", first, recorded, "model-c") == []
    )  # a model without a record
    moved = check_pin("evaluate_table4", {**first, "a": 100.01}, recorded, "model-c")
    assert len(moved) == 2 and all("): a: 100.01, expected" in line for line in moved)
    assert len(check_pin("evaluate_table4", {**first, "i": 4}, recorded, "model-a")) == 2
    # a pin recorded on model-a alone: checked on model-b within the tolerance measured on the other pins (1e-6)
    recorded["model-a"]["pins"]["random_paper_designs"] = first
    assert pin_cross_model_rtol("random_paper_designs", recorded) == pytest.approx(1e-6)
    assert check_pin("random_paper_designs", second, recorded, "model-b") == []
    moved = check_pin("random_paper_designs", {**second, "a": 100.01}, recorded, "model-b")
    assert len(moved) == 1 and moved[0].startswith("model-a (rtol 1e-06")


def test_comparison_reports_each_kind_of_difference():
    expected = {
        "a": 1.0,
        "n": math.nan,
        "i": 3,
        "b": True,
        "s": "lsq",
        "l": [1.0, 2.0],
        "wall_s": 1.0,
    }
    assert differences(expected, {**expected, "n": math.nan, "wall_s": 9.0}, 1e-12) == []
    assert differences(expected, {**expected, "a": 1.0 + 1e-13}, 1e-12) == []
    cases = [
        ("a", 1.0 + 1e-11),
        ("a", math.nan),
        ("n", 0.0),
        ("i", 4),
        ("i", 3.0),
        ("b", 1),
        ("s", "kepler"),
        ("l", [1.0]),
        ("l", [1.0, 2.1]),
    ]
    for key, value in cases:
        assert len(differences(expected, {**expected, key: value}, 1e-12)) == 1, (key, value)
    assert differences(expected, {k: v for k, v in expected.items() if k != "s"}, 1e-12) == [
        "<root>: missing keys ['s']"
    ]
    assert differences(expected, {**expected, "new": 0}, 1e-12) == [
        "<root>: unexpected keys ['new']"
    ]
