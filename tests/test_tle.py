"""TLE reading, checks and selection (lnss_lib.tle)."""

from __future__ import annotations

import datetime as dt

import pandas as pd
import pytest
from sgp4.io import compute_checksum

from lnss_lib import tle
from lnss_lib.config import data_path
from lnss_lib.settings import load_settings


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


@pytest.fixture(scope="module")
def tle_lines():
    return data_path("data/gps/gps-ops_2025-11-14.tle").read_text().splitlines()


def _with_checksum(line: str) -> str:
    return line[:68] + str(compute_checksum(line))


def _write(tmp_path, lines):
    path = tmp_path / "test.tle"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_tle_file_parses_with_names_and_prns(tle_lines, tmp_path):
    records = tle.read_tle(_write(tmp_path, tle_lines))
    assert len(records) == len(tle_lines) // 3
    first = records[0]
    assert first.name == tle_lines[0].strip()
    assert f"PRN {first.prn:02d}" in first.name
    assert first.satnum == int(tle_lines[1][2:7])
    assert (
        first.designator == "1997-035A" and first.launch_year == 1997 and first.launch_number == 35
    )


def test_bad_checksum_names_file_and_line(tle_lines, tmp_path):
    line1 = tle_lines[1]
    bad = line1[:68] + str((int(line1[68]) + 1) % 10)
    path = _write(tmp_path, [tle_lines[0], bad, tle_lines[2]])
    with pytest.raises(ValueError, match=r"line 2: bad checksum on TLE line 1") as err:
        tle.read_tle(path)
    assert str(path) in str(err.value)


def test_wrong_length_names_line(tle_lines, tmp_path):
    short = tle_lines[2][:30] + tle_lines[2][31:]
    with pytest.raises(ValueError, match=r"line 3: TLE line 2 must be 69 characters long, got 68"):
        tle.read_tle(_write(tmp_path, tle_lines[:2] + [short]))


def test_shifted_columns_are_rejected(tle_lines, tmp_path):
    line1 = tle_lines[1]
    shifted = _with_checksum(
        line1[:8] + line1[9:18] + " " + line1[18:]
    )  # designator one column left
    with pytest.raises(ValueError, match=r"line 2: TLE line 1 column \d+ must be blank"):
        tle.read_tle(_write(tmp_path, [tle_lines[0], shifted, tle_lines[2]]))


def test_line_number_and_satellite_number_mismatch(tle_lines, tmp_path):
    wrong_number = _with_checksum("3" + tle_lines[2][1:])
    with pytest.raises(ValueError, match=r"line 3: expected TLE line number 2"):
        tle.read_tle(_write(tmp_path, tle_lines[:2] + [wrong_number]))
    other_sat = _with_checksum(tle_lines[2][:2] + "99999" + tle_lines[2][7:])
    with pytest.raises(
        ValueError, match=r"lines 2-3: satellite number 24876 on line 1 differs from 99999"
    ):
        tle.read_tle(_write(tmp_path, tle_lines[:2] + [other_sat]))


def test_checksum_counts_digits_and_minus_signs():
    line = "1 " + "-" * 3 + "9" * 2 + " " * 61 + "0"
    assert len(line) == 69
    assert compute_checksum(line) == (1 + 3 * 1 + 2 * 9) % 10


def test_prn_and_launch_exclusions(profile, tle_lines, tmp_path):
    records = tle.read_tle(_write(tmp_path, tle_lines))
    kept, rows = tle.select_satellites(records, exclude_prn=[13, 21])
    table = pd.DataFrame(rows)
    assert {r.prn for r in kept}.isdisjoint({13, 21}) and len(kept) == len(records) - 2
    assert set(table.loc[~table["included"], "prn"]) == {13, 21}
    kept, _ = tle.select_satellites(records, launches_from="2024-242")
    assert {r.prn for r in kept} == {r.prn for r in records} - {1, 21}
    # Profile default: launched after the simulation epoch (2025-05-01) -> GPS BIII-8 (PRN 21, 2025-05-30) out.
    kept, table = tle.gps_catalogue(profile.gps, profile.epoch.start_tdb)
    assert 21 not in {r.prn for r in kept} and len(kept) == len(records) - 1
    later = load_settings("ci", {"epoch": {"start_tdb": "2025-06-15T00:00:00"}})
    assert len(tle.gps_catalogue(later.gps, later.epoch.start_tdb)[0]) == len(records)


def test_launch_date_estimate_from_revolution_count(tle_lines, tmp_path):
    """Without a listed date, epoch - revs / mean motion lands within a month of the real launch."""
    records = {r.prn: r for r in tle.read_tle(_write(tmp_path, tle_lines))}
    estimate, source = tle.launch_date(records[21], {})
    assert source == "estimate" and abs((estimate - dt.date(2025, 5, 30)).days) < 30
    listed, source = tle.launch_date(records[21], {"2025-116A": "2025-05-30"})
    assert source == "table" and listed == dt.date(2025, 5, 30)
