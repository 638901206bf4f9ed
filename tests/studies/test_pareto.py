"""Pareto analysis: fronts under chosen constraints, the Table 6 rule, the figure builders."""

import numpy as np
import pytest
import xarray as xr

from lnss_lib.figures import dop_against_availability, pareto_3d, variable_relationships
from lnss_lib.studies import pareto
from lnss_lib.studies.pareto import (
    TABLE6_COLUMNS,
    load_campaign,
    pareto_front,
    parse_constraints,
    satisfies,
    synthetic_campaign,
    table6,
)


def _campaign(rows, constraints="pdop_mean_3sigma <= 10,dv_total_kms_per_year <= 1"):
    ds = synthetic_campaign(len(rows))
    for key in (
        "n_sat",
        "pdop_mean_3sigma",
        "pdop_avail_pct",
        "hdop_mean_3sigma",
        "hdop_avail_pct",
        "dv_total_kms_per_year",
        "dv_opt_kms_per_year",
        "gps_visible_mean",
        "gps_pdop_mean",
    ):
        ds[key] = ("design", np.array([r.get(key, 1.0) for r in rows], dtype=float))
    ds.attrs["objectives"] = "n_sat,pdop_mean_3sigma,-pdop_avail_pct,dv_total_kms_per_year"
    ds.attrs["constraints"] = constraints
    return ds


def test_parse_constraints_and_errors():
    assert parse_constraints("pdop_mean_3sigma <= 10,pdop_avail_pct >= 70") == [
        ("pdop_mean_3sigma", "max", 10.0),
        ("pdop_avail_pct", "min", 70.0),
    ]
    with pytest.raises(ValueError, match="pdop ~ 3"):
        parse_constraints("pdop ~ 3")


def test_front_drops_dominated_and_handles_maximised_objectives():
    ds = _campaign(
        [
            {
                "n_sat": 8,
                "pdop_mean_3sigma": 2.0,
                "pdop_avail_pct": 99,
                "dv_total_kms_per_year": 0.5,
            },  # front
            {
                "n_sat": 8,
                "pdop_mean_3sigma": 2.0,
                "pdop_avail_pct": 90,
                "dv_total_kms_per_year": 0.5,
            },  # lower availability
            {
                "n_sat": 4,
                "pdop_mean_3sigma": 5.0,
                "pdop_avail_pct": 80,
                "dv_total_kms_per_year": 0.5,
            },  # front (fewer sats)
            {
                "n_sat": 9,
                "pdop_mean_3sigma": 2.5,
                "pdop_avail_pct": 99,
                "dv_total_kms_per_year": 0.6,
            },  # dominated by 0
        ]
    )
    assert pareto_front(ds).design.values.tolist() == [0, 2]


def test_ties_are_kept_and_constraints_apply():
    ds = _campaign(
        [
            {
                "n_sat": 8,
                "pdop_mean_3sigma": 2.0,
                "pdop_avail_pct": 99,
                "dv_total_kms_per_year": 0.5,
            },
            {
                "n_sat": 8,
                "pdop_mean_3sigma": 2.0,
                "pdop_avail_pct": 99,
                "dv_total_kms_per_year": 0.5,
            },
            {
                "n_sat": 4,
                "pdop_mean_3sigma": 1.0,
                "pdop_avail_pct": 99,
                "dv_total_kms_per_year": 3.0,
            },  # violates Delta-V
        ]
    )
    assert pareto_front(ds).design.values.tolist() == [0, 1]
    relaxed = pareto_front(ds, relax=("dv_total_kms_per_year",))
    assert relaxed.design.values.tolist() == [0, 1, 2]
    assert "dv_total" not in relaxed.attrs["front_constraints"]


def test_table6_rule_on_a_synthetic_front():
    ds = synthetic_campaign(400, seed=3)
    front = pareto_front(ds)
    table = table6(front)
    assert list(table.columns) == list(TABLE6_COLUMNS)
    assert len(table) >= 1
    assert (table.pdop_avail_pct >= 90).all() and (table.hdop_avail_pct >= 90).all()
    assert (table.dv_total_kms_per_year <= 1.0).all()
    eligible = front.where(
        (front.pdop_avail_pct >= 90)
        & (front.hdop_avail_pct >= 90)
        & (front.dv_total_kms_per_year <= 1.0),
        drop=True,
    )
    fewest = table[table["why selected"].str.contains("fewest satellites")]
    assert fewest.n_sat.iloc[0] == eligible.n_sat.min()
    best_pdop = table[
        table["why selected"].str.contains(r"^best PDOP$|; best PDOP$|^best PDOP;", regex=True)
    ]
    assert best_pdop.pdop_mean_3sigma.iloc[0] == pytest.approx(
        float(eligible.pdop_mean_3sigma.min())
    )
    under_ten = table[table["why selected"].str.contains("fewer than 10")]
    assert (under_ten.n_sat < 10).all()


def test_table6_empty_when_nothing_qualifies():
    table = table6(pareto_front(synthetic_campaign(50)), dv_max_kms_per_year=0.0)
    assert table.empty and list(table.columns) == list(TABLE6_COLUMNS)


def test_satisfies_treats_nan_as_failing():
    ds = _campaign([{"pdop_mean_3sigma": np.nan}, {"pdop_mean_3sigma": 3.0}])
    assert satisfies(ds, [("pdop_mean_3sigma", "max", 10.0)]).tolist() == [False, True]


def test_figure_builders_plot_the_front():
    ds = synthetic_campaign(120, seed=1)
    front = pareto_front(ds)
    fig = pareto_3d(
        front, "hdop_mean_3sigma", "pdop_mean_3sigma", "dv_total_kms_per_year", title="t"
    )
    assert len(fig.data) == len(np.unique(front["n_sat"].values))  # one trace a satellite count
    assert sum(len(t.x) for t in fig.data) == front.sizes["design"]
    fig = dop_against_availability(front, ds, "pdop_mean_3sigma", title="t")
    assert [len(t.x) for t in fig.data] == [ds.sizes["design"], front.sizes["design"]]
    fig = variable_relationships(front, ds, "sma_km", title="t")
    assert len(fig.data) == 6


def test_missing_campaign_names_the_command(tmp_path, monkeypatch):
    import lnss_lib.outputs as pipeline

    monkeypatch.setattr(pipeline, "OUTPUTS_DIR", tmp_path)
    with pytest.raises(FileNotFoundError, match="python -m lnss_lib campaign --profile nowhere"):
        load_campaign("nowhere")
    assert isinstance(synthetic_campaign(3), xr.Dataset)


def test_hypervolume_milestones_and_generation_curve():
    from lnss_lib.figures import generation_curve
    from lnss_lib.studies.pareto import hypervolume_milestones

    history = xr.Dataset(
        {"hypervolume": ("generation", [0.0, 0.5, 0.9, 0.995, 0.9995, 1.0])},
        coords={"generation": np.arange(1, 7)},
    )
    table = hypervolume_milestones(history)
    assert list(table["first generation"]) == [4, 5] and (table["generations run"] == 6).all()
    assert table.loc[0.99, "share of the generations run (%)"] == pytest.approx(100 * 4 / 6)
    nothing = hypervolume_milestones(history * 0.0)
    assert nothing["first generation"].isna().all()
    fig = generation_curve(history, "hypervolume", "hv", marks={"99 %": 4})
    assert list(fig.data[0].y) == list(history.hypervolume.values) and fig.layout.shapes[0].x0 == 4


def test_smallest_constellation_closest_design_and_paper_ranges():
    from lnss_lib.studies.pareto import (
        closest_to_feasible,
        front_against_paper,
        smallest_constellation,
    )

    ds = _campaign(
        [
            {"n_sat": 6, "pdop_avail_pct": 95, "hdop_avail_pct": 95, "dv_total_kms_per_year": 2.0},
            {"n_sat": 6, "pdop_avail_pct": 95, "hdop_avail_pct": 91, "dv_total_kms_per_year": 1.5},
            {"n_sat": 4, "pdop_avail_pct": 80, "hdop_avail_pct": 95, "dv_total_kms_per_year": 0.5},
            {"n_sat": 9, "pdop_avail_pct": 99, "hdop_avail_pct": 99, "dv_total_kms_per_year": 0.1},
        ]
    )
    small = smallest_constellation(ds, "dv_total_kms_per_year", 90.0)
    assert small.n_sat == 6 and small.dv_total_kms_per_year == 1.5
    assert smallest_constellation(ds, "dv_total_kms_per_year", 100.0) is None
    ds["constraint_violation"] = ("design", np.array([0.3, 0.2, 0.05, 0.4]))
    assert closest_to_feasible(ds).n_sat == 4
    table = front_against_paper(ds, {"dv_total_kms_per_year": (0.0, 1.0)})
    row = table.loc["Delta-V total (km/s/yr)"]
    assert row["front designs in the paper's range (%)"] == 50.0 and row[
        "front median"
    ] == pytest.approx(1.0)
    assert "least-squares" in row["why"]


def test_figures_shade_the_papers_ranges():
    ds = synthetic_campaign(30, seed=2)
    front = pareto_front(ds)
    claims = {"hdop_mean_3sigma": (1.0, 5.0), "ecc": (0.6, 0.7), "gps_pdop_mean": (3862.0, 10883.0)}
    fig = dop_against_availability(front, ds, "hdop_mean_3sigma", title="t", paper_ranges=claims)
    assert [(s.y0, s.y1) for s in fig.layout.shapes] == [(1.0, 5.0)]
    fig = variable_relationships(front, ds, "ecc", title="t", paper_ranges=claims)
    vertical = [(s.x0, s.x1) for s in fig.layout.shapes if str(s.yref).endswith("domain")]
    horizontal = [(s.y0, s.y1, s.yref) for s in fig.layout.shapes if str(s.xref).endswith("domain")]
    assert vertical == [(0.6, 0.7)] * 3 and horizontal == [(3862.0, 10883.0, "y3")]
    assert not dop_against_availability(front, ds, "pdop_mean_3sigma", title="t").layout.shapes


def test_frame_readings_reads_the_campaigns_frame_and_evaluates_the_other():
    front = pareto.synthetic_campaign(12, seed=3).isel(design=slice(0, 4))
    calls = []

    def evaluate(settings, row):  # the other reading: PDOP doubled, one design impacts
        calls.append((settings, float(row["sma_km"])))
        i = int(np.flatnonzero(front.sma_km.values == row["sma_km"])[0])
        out = {
            k: float(front[k].values[i])
            for k in ("pdop_mean_3sigma", "pdop_avail_pct", "dv_total_kms_per_year", "n_sat")
        }
        out["pdop_mean_3sigma"] *= 2.0
        out["evaluated"] = i != 0
        return out

    table = pareto.frame_readings(
        front,
        {"moon_op": "op settings", "lunar_equator_of_epoch": "eq settings"},
        front_frame="moon_op",
        evaluate=evaluate,
    )
    assert len(calls) == 4 and {c[0] for c in calls} == {"eq settings"}
    op, eq = table[table.frame == "moon_op"], table[table.frame == "lunar_equator_of_epoch"]
    np.testing.assert_allclose(op.pdop_mean_3sigma.values, front.pdop_mean_3sigma.values)
    np.testing.assert_allclose(eq.pdop_mean_3sigma.values, 2.0 * front.pdop_mean_3sigma.values)
    assert list(op.meets_bounds) == list(front.feasible.values)
    assert not eq.meets_bounds.iloc[0] and bool(eq.impact.iloc[0])
    summary = pareto.frame_summary(table)
    assert (
        list(summary.index) == ["moon_op", "lunar_equator_of_epoch"]
        and (summary["designs"] == 4).all()
    )
    assert summary.loc["lunar_equator_of_epoch", "meet bounds"] == int(eq.meets_bounds.sum())
