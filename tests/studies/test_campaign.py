"""Notebook 06's tables and figures (synthetic or hand-made data; one short synthetic campaign)."""

import json

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import CampaignSettings, run_campaign
from lnss_lib.config import load_profile
from lnss_lib.keys import DESIGN_KEYS


@pytest.fixture(scope="module")
def settings():
    return CampaignSettings.from_profile(load_profile("paper"))


def _history(n_evaluated, wall_s, n_cache_hits, n_designs):
    gens = np.arange(1, len(n_evaluated) + 1)
    n_evaluated = np.asarray(n_evaluated)
    return xr.Dataset({"n_evaluated": ("generation", n_evaluated), "wall_s": ("generation", np.asarray(wall_s, float)),
                       "n_cache_hits": ("generation", np.asarray(n_cache_hits)),
                       "n_designs": ("generation", np.asarray(n_designs)),
                       "designs_per_s": ("generation", n_evaluated / np.asarray(wall_s, float)),
                       "hypervolume": ("generation", np.linspace(0.0, 0.5, len(gens))),
                       "min_cv_pop": ("generation", np.linspace(2.0, 0.0, len(gens))),
                       "n_evaluations_cum": ("generation", np.cumsum(n_evaluated)),
                       "n_feasible_cum": ("generation", np.arange(len(gens))),
                       "n_feasible_pop": ("generation", np.arange(len(gens)) // 2)},
                      coords={"generation": gens})


def test_settings_and_grid_tables_follow_the_settings(settings):
    from dataclasses import replace

    from lnss_lib.studies.campaign import design_grid_table, settings_table

    table = settings_table(settings)
    assert table.loc["Population size", "this profile"] == settings.population
    assert table.loc["Total evaluations", "this profile"] == settings.population * settings.generations
    assert table.loc["Total evaluations", "paper"] == table.loc["Population size", "paper"] * table.loc[
        "No. of generations", "paper"]
    assert table.loc["Crossover fraction", "this profile"] == settings.crossover_prob
    changed = settings_table(replace(settings, population=7, ftol=0.0, mutation_prob_var=0.0, seed=11))
    assert changed.loc["Population size", "this profile"] == 7
    assert changed.loc["Function tolerance", "this profile"] == "off"
    assert changed.loc["Function tolerance", "note"] == "fixed generations"
    assert changed.loc["Mutation function", "note"].endswith("1/6")
    assert changed.loc["Seed", "this profile"] == 11
    grid = design_grid_table(settings)
    spec = load_profile("paper")["campaign"]["variables"]
    for label, key in zip(grid.index, DESIGN_KEYS):
        v = spec[key]
        assert (grid.loc[label, "lower"], grid.loc[label, "upper"], grid.loc[label, "step"]) == (
            v["lower"], v["upper"], v["step"])
        assert grid.loc[label, "levels"] == round((v["upper"] - v["lower"]) / v["step"]) + 1


def test_constraint_table_counts_each_bound_from_the_constraints():
    from lnss_lib.keys import bound_text
    from lnss_lib.studies.campaign import constraint_table
    from lnss_lib.studies.pareto import parse_constraints, satisfies, synthetic_campaign

    ev = synthetic_campaign(60, seed=3)
    pdop = ev["pdop_mean_3sigma"].values.copy()
    avail = ev["pdop_avail_pct"].values.copy()
    pdop[:4], avail[:3] = np.nan, np.nan            # impacts / no coverage fail every bound on them
    ev["pdop_mean_3sigma"], ev["pdop_avail_pct"] = ("design", pdop), ("design", avail)
    constraints = parse_constraints(ev.attrs["constraints"])
    table = constraint_table(ev, constraints)
    assert list(table.index) == ["evaluated without impact", "PDOP (3-sigma mean) <= 10", "PDOP availability >= 70 %",
                                 "Delta-V total <= 1 km/s/yr", "satellites <= 20",
                                 "navigation bounds only (no Delta-V or stability bound)", "all Table 3 bounds (feasible)"]
    assert table.loc["evaluated without impact", "designs"] == 57
    assert table.loc["PDOP (3-sigma mean) <= 10", "designs"] == int(np.sum(pdop[4:] <= 10.0))
    assert table.loc["PDOP availability >= 70 %", "designs"] == int(np.sum(avail[3:] >= 70.0))
    assert table.loc["Delta-V total <= 1 km/s/yr", "designs"] == int(np.sum(ev.dv_total_kms_per_year.values <= 1.0))
    navigation = satisfies(ev, [c for c in constraints if c[0] != "dv_total_kms_per_year"])
    assert table.loc["navigation bounds only (no Delta-V or stability bound)", "designs"] == int(navigation.sum())
    assert table.loc["all Table 3 bounds (feasible)", "designs"] == int(ev.feasible.sum())
    np.testing.assert_allclose(table["share (%)"], 100.0 * table["designs"] / 60)
    # other bounds: labels and counts follow the constraints, not fixed Table 3 numbers
    looser = constraint_table(ev, [("pdop_mean_3sigma", "max", 5.0), ("dv_total_kms_per_year", "max", 2.0)])
    assert looser.loc["PDOP (3-sigma mean) <= 5", "designs"] == int(np.sum(pdop[4:] <= 5.0))
    assert looser.loc["Delta-V total <= 2 km/s/yr", "designs"] == int(np.sum(ev.dv_total_kms_per_year.values <= 2.0))
    assert looser.loc["navigation bounds only (no Delta-V or stability bound)", "designs"] == int(np.sum(pdop[4:] <= 5.0))
    assert bound_text("hdop_avail_pct", "min", 90.5) == "HDOP availability >= 90.5 %"
    with pytest.raises(ValueError, match="'between'"):
        constraint_table(ev, [("n_sat", "between", 3.0)])
    empty = constraint_table(ev.isel(design=slice(0, 0)), constraints)
    assert (empty["designs"] == 0).all() and (empty["share (%)"] == 0).all()


def test_throughput_table_from_hand_made_history(tmp_path):
    from lnss_lib.studies.campaign import run_throughput_table, steady_designs_per_s, throughput_table

    history = _history([6, 5, 4], [2.0, 1.0, 1.0], [0, 1, 2], [6, 6, 6])
    timing = {"n_evaluations": 15, "worker_budget_s": 8.0, "propagation_s": 2.0, "metrics_s": 1.0,
              "in_task_overhead_s": 1.0, "campaign_overhead_s": 4.0}
    t = throughput_table(history, 3, timing, 2)["value"]
    assert t["unique designs evaluated"] == 15 and t["unique feasible designs"] == 3 and t["worker processes"] == 2
    assert t["campaign wall time (s, generations)"] == 4.0
    assert t["designs per second (overall)"] == pytest.approx(15 / 4)
    assert t["designs per second (generation 2 on)"] == pytest.approx(9 / 2)
    assert t["propagation (% of worker time)"] == pytest.approx(25.0)
    assert t["campaign overhead (%)"] == pytest.approx(50.0)
    assert t["cache hits (% of requested designs)"] == pytest.approx(100 * 3 / 18)
    assert t["projected 120 x 1000 campaign at this profile's fidelity (h, this machine)"] == pytest.approx(
        120000 / 4.5 / 3600)
    one = _history([6], [3.0], [0], [6])
    assert steady_designs_per_s(one, 6) == pytest.approx(2.0)
    with pytest.raises(ValueError, match="workers"):
        throughput_table(history, 3, timing, 0)
    # from a run directory: workers counted from the cache records, shares from their timings
    records = [{"worker": w, "timing_s": {"propagation": 0.5, "dop": 0.1, "deltav": 0.1, "gps": 0.05},
                "task_wall_s": 1.0} for w in ("a", "b", "a", "b", "b")]
    (tmp_path / "evaluations.jsonl").write_text("\n".join(json.dumps(r) for r in [{"header": 1}] + records) + "\n")
    t = run_throughput_table(tmp_path, history, xr.Dataset({"feasible": ("design", [True, False])}), records)["value"]
    assert t["worker processes"] == 2 and t["unique designs evaluated"] == 5 and t["unique feasible designs"] == 1
    assert t["propagation (% of worker time)"] == pytest.approx(100 * 2.5 / 8.0)
    assert t["in-task overhead (%)"] == pytest.approx(100 * (5.0 - 2.5 - 1.25) / 8.0)


def test_load_or_run_loads_latest_paper_run_and_runs_others(tmp_path, monkeypatch, capsys):
    import lnss_lib.studies.campaign as study
    import lnss_lib.outputs as pipeline
    from lnss_lib.campaign import export_results
    from lnss_lib.studies.campaign import latest_run_dir, load_or_run

    folders = {"paper": tmp_path / "paper", "ci": tmp_path / "ci"}
    for folder in folders.values():
        folder.mkdir()
    monkeypatch.setattr(pipeline, "output_dir", lambda name, kind: folders[name])
    with pytest.raises(FileNotFoundError, match="--profile paper"):
        load_or_run("paper")
    synthetic = {"campaign": {"evaluator": "synthetic", "generations": 2}}
    run_campaign("ci", overrides=synthetic, workers=0, run_dir=folders["paper"] / "run_1", progress=False)
    newer = run_campaign("ci", overrides={"campaign": {"evaluator": "synthetic", "generations": 3}}, workers=0,
                         run_dir=folders["paper"] / "run_2", progress=False)
    (folders["paper"] / "run_3").mkdir()               # no checkpoint: not a run to load
    assert latest_run_dir(folders["paper"], "paper") == newer.run_dir
    run_dir, ev, front, history, records = load_or_run("paper")
    assert run_dir == newer.run_dir and f"loaded {newer.run_dir.name}" in capsys.readouterr().out   # no machine path
    expected = export_results(newer.run_dir)
    for got, want in zip((ev, front, history), expected):
        xr.testing.assert_identical(got.drop_attrs(), want.drop_attrs())
    assert history.sizes["generation"] == 3 and len(records) == ev.sizes["design"]
    real_run_campaign = study.run_campaign

    def synthetic_run(name, progress):
        result = real_run_campaign(name, overrides=synthetic, workers=0, run_dir=folders[name] / "run_x",
                                   progress=progress)
        study.write_results(result.run_dir, folders[name])
        return result

    monkeypatch.setattr(study, "run_campaign", synthetic_run)
    run_dir, ev, front, history, records = load_or_run("ci")
    assert run_dir == folders["ci"] / "run_x" and "ran " in capsys.readouterr().out
    assert history.sizes["generation"] == 2 and len(records) == ev.sizes["design"] > 0


def test_campaign_figures_carry_the_data():
    from lnss_lib.figures import campaign_convergence, campaign_throughput, designs_pdop_deltav
    from lnss_lib.studies.pareto import pareto_front, synthetic_campaign

    history = _history([6, 5, 4], [2.0, 1.0, 1.0], [0, 1, 2], [6, 6, 6])
    fig = campaign_convergence(history, "convergence")
    assert len(fig.data) == 5 and fig.layout.title.text == "convergence"
    np.testing.assert_array_equal(fig.data[1].y, history.min_cv_pop.values)
    np.testing.assert_array_equal(fig.data[4].y, history.n_feasible_pop.values)
    assert fig.layout.yaxis2.type == "log" and fig.layout.yaxis.type != "log"
    bars = campaign_throughput(history, "throughput")
    np.testing.assert_allclose(bars.data[0].y, [3.0, 5.0, 4.0])
    ev = synthetic_campaign(40, seed=5)
    pdop = ev["pdop_mean_3sigma"].values.copy()
    pdop[:7] = np.nan
    ev["pdop_mean_3sigma"] = ("design", pdop)
    front = pareto_front(ev)
    fig = designs_pdop_deltav(ev, front, 2.0, 5.0, "scatter")
    assert len(fig.data[0].x) == 33 and len(fig.data[0].text) == 33
    assert len(fig.data) == (2 if front.sizes["design"] else 1) and front.sizes["design"] > 0
    lines = [s for s in fig.layout.shapes]
    assert {(s.x0, s.x1) for s in lines if s.x0 == s.x1} == {(2.0, 2.0)}
    assert {(s.y0, s.y1) for s in lines if s.y0 == s.y1} == {(5.0, 5.0)}
    notes = {a.text: a for a in fig.layout.annotations}
    assert notes["Delta-V bound"].x == pytest.approx(np.log10(2.0))
    assert notes["PDOP bound"].y == pytest.approx(np.log10(5.0))
    assert fig.layout.xaxis.range[0] < np.log10(np.nanmin(ev.dv_total_kms_per_year.values))
    assert len(designs_pdop_deltav(ev, front.isel(design=slice(0, 0)), 1.0, 10.0, "no front").data) == 1
    with pytest.raises(ValueError, match="positive"):
        designs_pdop_deltav(ev, front, 0.0, 10.0, "bad")
