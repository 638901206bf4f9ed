"""Notebooks 06-07 on a validated front: estimate against closed loop, the validated Table 6 and
the headline table, on a synthetic validated.nc."""

import numpy as np
import pytest
import xarray as xr

from lnss_lib.paper import SMALLEST_CONSTELLATION
from lnss_lib.studies.front_validation import (
    NONE_VALIDATED,
    estimate_table,
    front_outliers,
    front_statistics,
    headline_table,
    validated_table6,
)

ROWS = [  # n_planes, sats_per_plane, status, estimate max, closed-loop max, PDOP availability over the life
    (2, 3, "kept", 0.30, 0.35, 95.0),  # 6: meets both bounds
    (2, 3, "kept", 0.10, 0.90, 92.0),  # 6: meets both, dearer: not the cheapest; outside a factor 2
    (2, 3, "failed", 0.05, 0.20, 99.0),  # 6: cheapest of all but lost a satellite: excluded
    (2, 4, "kept", 0.40, 1.40, 99.0),  # 8: above the Delta-V bound
    (3, 4, "kept", 0.50, 0.60, 85.0),  # 12: below the availability
    (4, 4, "kept", 0.20, 0.22, 99.0),  # 16: meets both
    (4, 4, "error", 0.10, np.nan, np.nan),  # 16: raised
]


@pytest.fixture
def validated():
    n = len(ROWS)
    planes, per_plane, status, est, closed, avail = (np.array(c) for c in zip(*ROWS))
    data = {
        "sma_km": 6000.0 + 100.0 * np.arange(n),
        "ecc": np.full(n, 0.4),
        "aop_deg": np.full(n, 90.0),
        "inc_deg": np.full(n, 60.0),
        "n_planes": planes.astype(int),
        "sats_per_plane": per_plane.astype(int),
        "n_sat": (planes * per_plane).astype(int),
        "selected_for": np.full(n, "front"),
        "status": status,
        "sk_dv_estimate_kms_per_year": est.astype(float) * 0.9,
        "sk_dv_estimate_max_kms_per_year": est.astype(float),
        "closed_loop_dv_kms_per_year": closed.astype(float) * 0.9,
        "closed_loop_dv_max_kms_per_year": closed.astype(float),
        "pdop_avail_pct": np.full(n, 95.0),
        "hdop_avail_pct": np.full(n, 99.0),
        "pdop_avail_pct_life": avail.astype(float),
        "hdop_avail_pct_life": avail.astype(float),
        "pdop_avail_pct_worst_month": avail.astype(float) - 5.0,
        "hdop_avail_pct_worst_month": avail.astype(float),
    }
    for key in (
        "mean_visible_sats",
        "pdop_mean_3sigma",
        "hdop_mean_3sigma",
        "dv_total_kms_per_year",
        "dv_opt_kms_per_year",
        "gps_visible_mean",
        "gps_pdop_mean",
    ):
        data[key] = np.arange(n, dtype=float)
    return xr.Dataset({k: ("design", v) for k, v in data.items()})


def test_headline_table_smallest_per_size_none_and_failed_excluded(validated):
    table = headline_table(
        validated,
        (6, 8, 12, 16),
        availability_min_pct=90.0,
        dv_max_kms_per_year=1.0,
        paper=SMALLEST_CONSTELLATION,
    )
    assert list(table.index) == [
        "smallest",
        "6 satellites",
        "8 satellites",
        "12 satellites",
        "16 satellites",
        "paper (abstract)",
    ]
    assert (
        table.loc["smallest", "n_sat"] == 6
        and table.loc["smallest", "closed_loop_dv_max_kms_per_year"] == 0.35
    )
    assert table.loc["6 satellites", "sma_km"] == 6000.0  # the failed 0.20 design is excluded
    assert (
        table.loc["6 satellites", "flown"] == 3
        and table.loc["6 satellites", "failed or error"] == 1
    )
    assert table.loc["8 satellites", "result"] == NONE_VALIDATED  # over the Delta-V bound
    assert table.loc["12 satellites", "result"] == NONE_VALIDATED  # under the availability
    assert table.loc["16 satellites", "closed_loop_dv_max_kms_per_year"] == 0.22
    assert table.loc["paper (abstract)", "n_sat"] == SMALLEST_CONSTELLATION["n_sat"]
    empty = headline_table(
        None, (6,), availability_min_pct=90.0, dv_max_kms_per_year=1.0, paper=SMALLEST_CONSTELLATION
    )
    assert (empty.loc[["smallest", "6 satellites"], "result"] == NONE_VALIDATED).all()


def test_estimate_statistics_over_kept_designs(validated):
    table = estimate_table(validated)
    stats = front_statistics(table)
    assert stats.loc["worst satellite", "kept"] == 5 and stats.loc["worst satellite", "failed"] == 1
    assert (
        stats.loc["worst satellite", "error"] == 1 and stats.loc["worst satellite", "compared"] == 5
    )
    # kept pairs (est, closed): (0.3, 0.35) (0.1, 0.9) (0.4, 1.4) (0.5, 0.6) (0.2, 0.22): 3 of 5 within a factor 2
    assert stats.loc["worst satellite", "within a factor 2 (share)"] == pytest.approx(0.6)
    outliers = front_outliers(table)
    assert set(outliers.index) == {1, 2, 3}  # the failed design is listed too


def test_validated_table6_uses_closed_loop_and_excludes_failed(validated):
    table, excluded = validated_table6(
        validated, availability_min_pct=90.0, dv_max_kms_per_year=1.0
    )
    assert excluded == 2
    assert set(table["sma_km"]) <= {6000.0, 6100.0, 6500.0}  # kept, within both closed-loop bounds
    assert (table["closed_loop_dv_max_kms_per_year"] <= 1.0).all() and (
        table["pdop_avail_pct_life"] >= 90.0
    ).all()


def test_figures_draw_every_status_and_the_marks(validated):
    """The estimate-vs-closed-loop scatter has a trace per status present plus y = x and both factor-2 lines; the
    headline chart marks the bound and the paper's claim."""
    from lnss_lib.figures import front_estimate_vs_closed_loop, headline_chart

    fig = front_estimate_vs_closed_loop(
        estimate_table(validated),
        estimate="estimate_worst_satellite",
        closed="closed_loop_worst_satellite",
        title="t",
        floor_kms_per_year=1e-3,
    )
    assert [t.name for t in fig.data] == [
        "kept",
        "failed",
        "estimate = closed loop",
        "factor 2",
        "factor 1/2",
    ]
    assert fig.layout.xaxis.type == "log" and fig.layout.yaxis.type == "log"
    chart = headline_chart(
        validated.to_dataframe(), dv_max_kms_per_year=1.0, paper=SMALLEST_CONSTELLATION, title="t"
    )
    assert chart.layout.shapes[0].y0 == 1.0
    assert list(chart.data[-1].x) == [SMALLEST_CONSTELLATION["n_sat"]]
    assert list(chart.data[-1].y) == [SMALLEST_CONSTELLATION["dv_below_kms_per_year"]]


def test_reestimated_table_prices_the_restores_of_the_front_designs():
    """A validated front re-estimated with today's estimate: the frozen ELFO (moon_op) stays free; the cheapest design of
    the quick operational front (9800 km, e 0.39, i 58 deg, 2 x 4), which flew 0.98 km/s per satellite and year with
    0.48 of navigation restores and was estimated at zero, now gets a navigation part of that order, and the ratios
    are the estimate over the closed loop."""
    from lnss_lib.settings import load_settings
    from lnss_lib.studies.front_validation import reestimated_table

    designs = [
        (6143.0, 0.6, 90.0, 51.7, 2, 1, 0.0, 0.0),
        (9800.0, 0.39, 58.0, 58.0, 2, 4, 0.977, 0.478),
    ]
    a, e, aop, inc, planes, per_plane, closed, closed_nav = (np.array(c) for c in zip(*designs))
    data = {
        "sma_km": a,
        "ecc": e,
        "aop_deg": aop,
        "inc_deg": inc,
        "n_planes": planes.astype(int),
        "sats_per_plane": per_plane.astype(int),
        "n_sat": (planes * per_plane).astype(int),
        "selected_for": np.full(2, "front"),
        "status": np.full(2, "kept"),
        "sk_dv_estimate_kms_per_year": np.zeros(2),
        "sk_dv_estimate_max_kms_per_year": np.zeros(2),
        "closed_loop_dv_kms_per_year": closed,
        "closed_loop_dv_max_kms_per_year": closed * 1.02,
        "closed_loop_dv_navigation_kms_per_year": closed_nav,
    }
    validated = xr.Dataset(
        {k: ("design", v) for k, v in data.items()}, attrs={"max_sats_per_plane": 0}
    )
    table = reestimated_table(load_settings("quick_operational"), validated)
    assert table.loc[0, "estimate_mean"] == 0.0 and table.loc[0, "estimate_navigation"] == 0.0
    front = table.loc[1]
    assert (
        0.5 * 0.478
        < front["estimate_navigation"]
        <= front["estimate_mean"]
        <= front["estimate_worst_satellite"]
    )
    assert front["estimate_mean"] < 2.0 * 0.977  # within a factor 2 of the flown year
    assert front["ratio_navigation"] == pytest.approx(front["estimate_navigation"] / 0.478)
    assert table.loc[1, "ratio_mean"] == pytest.approx(front["estimate_mean"] / 0.977)


def test_deltav_side_by_side_sets_eq45_beside_the_closed_loop(validated):
    from lnss_lib.studies.front_validation import DELTAV_SIDE_BY_SIDE, deltav_side_by_side

    side = deltav_side_by_side(validated)
    assert len(side) == len(ROWS) and set(DELTAV_SIDE_BY_SIDE) <= set(side.columns)
    worst = side["closed_loop_dv_max_kms_per_year"].to_numpy()
    assert list(worst[:-1]) == sorted(worst[:-1]) and np.isnan(
        worst[-1]
    )  # cheapest first, no cost last
    first = validated.isel(
        design=int(np.nanargmin(validated.closed_loop_dv_max_kms_per_year.values))
    )
    assert side.loc[0, "dv_total_kms_per_year"] == float(first.dv_total_kms_per_year)
    assert side.loc[0, "status"] == str(first.status.values)
    without = deltav_side_by_side(validated.drop_vars("dv_opt_kms_per_year"))
    assert (
        without["dv_opt_kms_per_year"].isna().all()
    )  # a validation without a column: NaN, not an error
