"""The life-long navigation estimate against the closed loop (lnss_lib.studies.life_navigation)."""

import numpy as np
import pandas as pd
import pytest

from lnss_lib.settings import load_settings
from lnss_lib.studies import life_navigation as ln

LIFE_DAYS = 91.3125
"""Three navigation windows: a quarter of the quick operational life."""


@pytest.fixture(scope="module")
def settings():
    return load_settings("ci_operational")


def test_a_frozen_design_that_keeps_its_service_is_estimated_as_flown(settings):
    """The Table 4 ELFO, frozen in moon_op, as two planes of four: its natural motion keeps every requirement, so the
    closed loop flies no navigation restore, and the estimate's availability over the life and in its worst month
    are the closed loop's within 2 points (the lattice's sampling of 64 epochs a window: about 1 point)."""
    elfo = settings.standalone_elfo
    design = (elfo.sma_km, elfo.ecc, elfo.aop_deg, elfo.inc_deg, 2, 4)
    closed = ln.closed_loop_availability(settings, design, LIFE_DAYS)
    est = ln.estimated_availability(settings, design, LIFE_DAYS)
    assert not closed["lost"]
    for key in ln.AVAILABILITY_KEYS:
        months = np.asarray(closed["months"][key])
        assert months.size == 3 and est[f"{key}_windows"].size == 3
        assert est[f"{key}_worst_month_estimate"] == pytest.approx(months.min(), abs=2.0)
        assert est[f"{key}_life_estimate"] == pytest.approx(months.mean(), abs=2.0)


def test_validation_designs_are_whole_constellations_spanning_table3_and_the_frozen_family():
    designs = ln.availability_validation_designs(load_settings("operational"))
    sizes = [d["design"][4] * d["design"][5] for d in designs]
    assert len(designs) >= 24 and min(sizes) >= ln.MIN_SATS and max(sizes) <= ln.MAX_SATS
    assert {"life_evaluation", "frozen", "random", "Table 4 ELFO"} <= {d["source"] for d in designs}
    assert len({d["design"] for d in designs}) == len(designs)


def test_statistics_and_outliers_follow_the_points_rule():
    """Three designs ranked alike, one off by more than the points target: rho 1, two of three within, the third
    listed with its error."""
    table = pd.DataFrame(
        {
            "pdop_avail_pct_worst_month": [10.0, 50.0, 90.0],
            "pdop_avail_pct_worst_month_estimate": [12.0, 49.0, 99.0],
            "hdop_avail_pct_worst_month": [20.0, 60.0, 95.0],
            "hdop_avail_pct_worst_month_estimate": [20.0, 60.0, 95.0],
        }
    )
    stats = ln.life_navigation_statistics(table)
    assert stats["spearman_rho_pdop_avail_pct"] == pytest.approx(1.0)
    assert stats["within_points_share_pdop_avail_pct"] == pytest.approx(2.0 / 3.0)
    assert not stats["meets_targets_pdop_avail_pct"] and stats["meets_targets_hdop_avail_pct"]
    outliers = ln.life_navigation_outliers(table)
    assert list(outliers.index) == [2] and outliers["pdop_avail_pct_worst_month_error"].iloc[
        0
    ] == pytest.approx(9.0)
