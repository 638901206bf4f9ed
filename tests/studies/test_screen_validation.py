"""The screen's validation study: random Table 3 designs and the agreement statistic."""

import math

import numpy as np
import pandas as pd
import pytest

from lnss_lib.keys import DESIGN_KEYS
from lnss_lib.settings import load_settings
from lnss_lib.studies.screen_validation import (
    CASE_KEYS,
    MISS_COLUMNS,
    agreement,
    case_agreement,
    load_measured,
    measured_table,
    random_designs,
    validation_table,
)


def _row(design, plane, screen_day, truth_day, screen_min=100.0, truth_min=120.0):
    return {
        **dict(zip(DESIGN_KEYS, design)),
        "plane": plane,
        "screen_impact_day": screen_day,
        "screen_min_perilune_alt_km": screen_min,
        "truth_impact_day": truth_day,
        "truth_min_perilune_alt_km": truth_min,
    }


def test_agreement_counts_designs_and_lists_every_disagreeing_plane():
    a, b, c, d = (
        (6000.0, 0.1, 90.0, 50.0, 2, 1),
        (9000.0, 0.5, 0.0, 17.0, 2, 1),
        (20000.0, 0.4, 30.0, 58.0, 2, 1),
        (7000.0, 0.2, 10.0, 80.0, 2, 1),
    )
    nan = math.nan
    table = pd.DataFrame(
        [
            _row(a, 0, nan, nan),
            _row(a, 1, nan, nan),  # both stable: agree
            _row(b, 0, 5.0, 4.3),
            _row(b, 1, nan, 80.0),  # both unstable (plane 1 missed): the design agrees
            _row(c, 0, nan, 41.0, 35.0, 0.0),
            _row(c, 1, nan, nan),  # missed impact
            _row(d, 0, 12.0, nan, 0.0, 30.0),
            _row(d, 1, nan, nan),  # false alarm
        ]
    )
    out = agreement(table)
    assert (out["n_designs"], out["n_agree"], out["missed_impacts"], out["false_alarms"]) == (
        4,
        2,
        1,
        1,
    )
    assert out["agreement_pct"] == pytest.approx(50.0) and out[
        "plane_agreement_pct"
    ] == pytest.approx(62.5)
    misses = out["misses"]
    assert list(misses.columns) == [*MISS_COLUMNS, "call"] and len(misses) == 3
    assert list(misses["call"]) == ["missed impact", "missed impact", "false alarm"]
    assert list(misses["truth_impact_day"].fillna(-1.0)) == [80.0, 41.0, -1.0]


def test_random_designs_are_seeded_on_the_table3_grid_above_the_surface():
    settings = load_settings("ci_operational")
    designs = random_designs(settings, 30, seed=7)
    assert designs == random_designs(settings, 30, seed=7) and designs != random_designs(
        settings, 30, seed=8
    )
    variables = settings.campaign.variables
    for row in designs:
        for key, value in zip(DESIGN_KEYS, row):
            v = variables[key]
            assert v.lower <= value <= v.upper
            assert (value - v.lower) / v.step == pytest.approx(
                round((value - v.lower) / v.step), abs=1e-6
            )
        assert row[0] * (1.0 - row[1]) > settings.constants.r_moon_mean_km


def test_validation_table_flies_one_satellite_per_plane():
    settings = load_settings("ci_operational")
    table = validation_table(settings, [(7800.0, 0.74, 0.0, 17.0, 2, 3)], life_days=12.0)
    assert list(table["plane"]) == [0, 1] and table.attrs["element_frame"] == "moon_op"
    # moon_op 7800/0.74/0/17: the full model hits the surface on day 5 in both planes, and so does the screen
    assert np.all(table["truth_impact_day"] < 8.0) and np.all(table["screen_impact_day"] < 8.0)
    assert agreement(table)["agreement_pct"] == 100.0


def test_case_agreement_counts_per_frame_and_life_and_the_validity_limits_calls():
    a, b = (6000.0, 0.1, 90.0, 50.0, 1, 1), (21000.0, 0.6, 30.0, 58.0, 1, 1)
    nan = math.nan
    rows = []
    for frame, life, truth_b in (("moon_op", 365.25, nan), ("moon_op", 1826.25, 400.0)):
        rows += [
            {**_row(a, 0, nan, nan), "screen_outside_validity": False},
            {**_row(b, 0, 0.0, truth_b), "screen_outside_validity": True},
        ]
        for row in rows[-2:]:
            row.update(element_frame=frame, life_days=life)
    cases = case_agreement(pd.DataFrame(rows)).set_index("life_days")
    year, five = cases.loc[365.25], cases.loc[1826.25]
    assert (year.n_designs, year.n_agree, year.false_alarms, year.missed_impacts) == (2, 1, 1, 0)
    assert (year.validity_limit_calls, year.validity_limit_false_alarms) == (1, 1)
    assert (five.n_agree, five.n_truth_unstable, five.validity_limit_false_alarms) == (2, 1, 0)
    assert five.agreement_pct == pytest.approx(100.0) and year.agreement_pct == pytest.approx(50.0)


@pytest.fixture(scope="module")
def measured():
    return load_measured()


def test_the_shipped_measurement_covers_both_frames_and_lives_and_agrees(measured):
    """The shipped full-size measurement (its README gives the provenance): both element frames over one year on at
    least 40 random designs each, and five years in both frames; the screen agrees on at least 95 % of the designs of
    every case."""
    cases = case_agreement(measured).set_index(list(CASE_KEYS))
    assert set(cases.index) == {
        (frame, life)
        for frame in ("moon_op", "lunar_equator_of_epoch")
        for life in (365.25, 1826.25)
    }
    assert (cases.xs(365.25, level="life_days")["n_designs"] >= 40).all()
    assert (cases["agreement_pct"] >= 95.0).all(), cases


def test_the_shipped_screen_verdicts_are_todays_screen(measured):
    """The screen columns of the shipped measurement are what today's screen says (a change of the screen or of its
    settings must re-assemble the file): the first two designs of each case screened again."""
    for (frame, life), rows in measured.groupby(list(CASE_KEYS), sort=False):
        settings = load_settings("operational", overrides={"frames": {"element_frame": frame}})
        for design, planes in list(rows.groupby(list(DESIGN_KEYS), sort=False))[:2]:
            again = measured_table(
                [
                    {
                        "element_frame": frame,
                        "life_days": life,
                        "design": list(design),
                        "impact_day": [None] * len(planes),
                        "min_perilune_alt_km": [None] * len(planes),
                        "flown_planes": [],
                        "wall_s": 0.0,
                    }
                ],
                {frame: settings},
            )
            np.testing.assert_allclose(
                again["screen_impact_day"], planes["screen_impact_day"], rtol=1e-6
            )
            np.testing.assert_allclose(
                again["screen_min_perilune_alt_km"],
                planes["screen_min_perilune_alt_km"],
                rtol=1e-6,
            )
