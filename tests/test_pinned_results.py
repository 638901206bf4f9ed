"""Results pinned before a refactor (issue 22 "Must not change", issue 23 item 2): each test recomputes one pin
and compares it with ``tests/data/pinned_results.json`` field by field (floats within the pin's relative
tolerance, NaN equal to NaN; ints, bools and strings exact).

What each pin holds, the fields left out (all run-dependent: timings, worker ids, checksums over timings,
package versions, settings hashes and the profile echo; ``pinned_results.EXCLUDED`` names each with its
reason) and how to regenerate the file (``PYTHONPATH=$PWD python tests/pinned_results.py --write``, which
records the commit it ran on): see ``tests/pinned_results.py``. Runtime on a quiet core, numba cache warm:
about 2 s, 13 s, 9 s and 4 s.
"""

import math

import pytest

from lnss_lib import kernel_cpu
from pinned_results import EXCLUDED, PINS, RTOL, differences, load_fixture


@pytest.fixture(scope="module")
def recorded():
    return load_fixture()


@pytest.mark.parametrize("name", list(PINS))
def test_pinned_result(recorded, name):
    if kernel_cpu() != recorded["meta"]["kernel_cpu"]:
        pytest.skip(f"the pins hold the bits of kernels compiled for {recorded['meta']['kernel_cpu']}; this processor "
                    f"cannot run that code, so its kernels are compiled for {kernel_cpu()}, whose round-off the "
                    "adaptive step control amplifies beyond the pins' tolerance (up to 2e-7 relative after 10 days)")
    diffs = differences(recorded["pins"][name], PINS[name](), RTOL[name])
    assert not diffs, (f"{len(diffs)} pinned value(s) of {name} changed (recorded at commit "
                       f"{recorded['meta']['commit'][:12]}):\n" + "\n".join(diffs[:30]))


def test_fixture_records_its_commit_and_exclusions(recorded):
    meta = recorded["meta"]
    assert len(meta["commit"]) == 40 and not meta["dirty"]
    assert meta["kernel_cpu"] and not meta["kernel_cpu"].startswith("host:")
    assert meta["excluded"] == EXCLUDED and meta["rtol"] == RTOL
    assert set(recorded["pins"]) == set(PINS)


def test_comparison_reports_each_kind_of_difference():
    expected = {"a": 1.0, "n": math.nan, "i": 3, "b": True, "s": "lsq", "l": [1.0, 2.0], "wall_s": 1.0}
    assert differences(expected, {**expected, "n": math.nan, "wall_s": 9.0}, 1e-12) == []
    assert differences(expected, {**expected, "a": 1.0 + 1e-13}, 1e-12) == []
    cases = [("a", 1.0 + 1e-11), ("a", math.nan), ("n", 0.0), ("i", 4), ("i", 3.0), ("b", 1), ("s", "kepler"),
             ("l", [1.0]), ("l", [1.0, 2.1])]
    for key, value in cases:
        assert len(differences(expected, {**expected, key: value}, 1e-12)) == 1, (key, value)
    assert differences(expected, {k: v for k, v in expected.items() if k != "s"}, 1e-12) == ["<root>: missing keys ['s']"]
    assert differences(expected, {**expected, "new": 0}, 1e-12) == ["<root>: unexpected keys ['new']"]
