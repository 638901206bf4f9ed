"""The size question on synthetic validated fronts (lnss_lib.studies.size_question)."""

import numpy as np
import xarray as xr

from lnss_lib.paper import SMALLEST_CONSTELLATION
from lnss_lib.studies.size_question import size_profile, size_table, what_breaks

BOUNDS = {"availability_min_pct": 90.0, "dv_max_kms_per_year": 1.0}


def validated(rows, n_planes, sats_per_plane):
    """``rows``: (status, worst-month PDOP availability %, worst satellite's closed-loop Delta-V km/s/yr)."""
    status, worst, dv = (np.array(c) for c in zip(*rows))
    n = len(rows)
    data = {
        "sma_km": 6000.0 + 100.0 * np.arange(n),
        "ecc": np.full(n, 0.2),
        "aop_deg": np.full(n, 90.0),
        "inc_deg": np.full(n, 60.0),
        "n_planes": np.full(n, n_planes),
        "sats_per_plane": np.full(n, sats_per_plane),
        "status": status,
        "pdop_avail_pct_worst_month": worst.astype(float),
        "pdop_avail_pct_life": worst.astype(float) + 3.0,
        "closed_loop_dv_max_kms_per_year": dv.astype(float),
        "closed_loop_dv_kms_per_year": dv.astype(float) / 2,
        "min_perilune_alt_km": np.full(n, 300.0),
    }
    return xr.Dataset({k: ("design", v) for k, v in data.items()})


def test_each_size_reads_its_best_flown_design_and_says_what_breaks():
    six = validated(
        [("kept", 85.0, 0.3), ("kept", 80.0, 0.1), ("kept", 95.0, 1.3), ("failed", 97.0, 0.2)], 2, 3
    )
    eight = validated([("kept", 91.0, 0.8), ("kept", 93.0, 0.9), ("kept", 93.0, 0.4)], 2, 4)
    twelve = validated([("failed", 99.0, 0.1)], 3, 4)
    table = size_table(
        {6: six, 8: eight, 9: None, 12: twelve}, paper=SMALLEST_CONSTELLATION, **BOUNDS
    )
    rows = table.iloc[:-1].set_index("n_sat")  # the paper's claim, last, is six satellites too
    assert rows.loc[6, "result"] == "misses" and rows.loc[6, "pdop_avail_pct_worst_month"] == 85.0
    assert rows.loc[6, "what breaks"] == (
        "best worst month within 1 km/s/yr: 85.0 %; 90 % flown only at 1.30 km/s/yr "
        "(worst satellite); 1 design(s) reaching it lost a satellite"
    )
    assert (
        rows.loc[8, "result"] == "meets" and rows.loc[8, "closed_loop_dv_max_kms_per_year"] == 0.4
    )  # tie: cheaper
    assert rows.loc[8, "what breaks"] == "" and rows.loc[8, "flown"] == 3
    assert rows.loc[9, "result"] == "not run"
    assert (
        rows.loc[12, "result"] == "none kept within the Delta-V bound"
        and rows.loc[12, "failed or error"] == 1
    )
    assert (
        table["result"].iloc[-1].startswith("claimed")
        and table["n_sat"].iloc[-1] == SMALLEST_CONSTELLATION["n_sat"]
    )
    assert what_breaks(eight, **BOUNDS) == ""
    assert size_profile(9) == "operational_n9"


def test_size_chart_draws_every_flown_design_once_beside_the_requirement_and_the_claim():
    from lnss_lib.figures import size_chart

    six = validated([("kept", 85.0, 0.3), ("kept", 95.0, 1.3), ("failed", 97.0, 0.2)], 2, 3)
    fig = size_chart({6: six, 9: None}, paper=SMALLEST_CONSTELLATION, title="t", **BOUNDS)
    designs = [t for t in fig.data if not t.name.startswith("paper")]
    assert sorted(y for t in designs for y in t.y) == [85.0, 95.0, 97.0]
    assert {t.name for t in designs} == {
        "kept, within 1 km/s/yr",
        "kept, above 1 km/s/yr",
        "failed, within 1 km/s/yr",
    }
    assert all(5.7 <= x <= 6.3 for t in designs for x in t.x)
    assert fig.layout.shapes[0].y0 == BOUNDS["availability_min_pct"]
