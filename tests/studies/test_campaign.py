"""Notebook 06's tables and figures (synthetic or hand-made data; one short synthetic campaign)."""

import json

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import CampaignPlan, run_campaign
from lnss_lib.campaign.journal import encode_record
from lnss_lib.keys import DESIGN_KEYS
from lnss_lib.settings import load_settings


@pytest.fixture(scope="module")
def settings():
    return CampaignPlan.of(load_settings("paper"))


def _history(n_evaluated, wall_s, n_cache_hits, n_designs):
    gens = np.arange(1, len(n_evaluated) + 1)
    n_evaluated = np.asarray(n_evaluated)
    return xr.Dataset(
        {
            "n_evaluated": ("generation", n_evaluated),
            "wall_s": ("generation", np.asarray(wall_s, float)),
            "n_cache_hits": ("generation", np.asarray(n_cache_hits)),
            "n_designs": ("generation", np.asarray(n_designs)),
            "designs_per_s": ("generation", n_evaluated / np.asarray(wall_s, float)),
            "hypervolume": ("generation", np.linspace(0.0, 0.5, len(gens))),
            "min_cv_pop": ("generation", np.linspace(2.0, 0.0, len(gens))),
            "n_evaluations_cum": ("generation", np.cumsum(n_evaluated)),
            "n_feasible_cum": ("generation", np.arange(len(gens))),
            "n_feasible_pop": ("generation", np.arange(len(gens)) // 2),
        },
        coords={"generation": gens},
    )


def test_settings_and_grid_tables_follow_the_settings(settings):
    from dataclasses import replace

    from lnss_lib.studies.campaign import design_grid_table, settings_table

    table = settings_table(settings)
    assert table.loc["Population size", "this profile"] == settings.population
    assert (
        table.loc["Total evaluations", "this profile"] == settings.population * settings.generations
    )
    assert (
        table.loc["Total evaluations", "paper"]
        == table.loc["Population size", "paper"] * table.loc["No. of generations", "paper"]
    )
    assert table.loc["Crossover fraction", "this profile"] == settings.crossover_prob
    changed = settings_table(
        replace(settings, population=7, ftol=0.0, mutation_prob_var=0.0, seed=11)
    )
    assert changed.loc["Population size", "this profile"] == 7
    assert changed.loc["Function tolerance", "this profile"] == "off"
    assert changed.loc["Function tolerance", "note"] == "fixed generations"
    assert changed.loc["Mutation function", "note"].endswith("1/6")
    assert changed.loc["Seed", "this profile"] == 11
    grid = design_grid_table(settings)
    spec = load_settings("paper").campaign.variables
    for label, key in zip(grid.index, DESIGN_KEYS):
        v = spec[key]
        assert (grid.loc[label, "lower"], grid.loc[label, "upper"], grid.loc[label, "step"]) == (
            v.lower,
            v.upper,
            v.step,
        )
        assert grid.loc[label, "levels"] == round((v.upper - v.lower) / v.step) + 1


def test_constraint_table_counts_each_bound_from_the_constraints():
    from lnss_lib.keys import bound_text
    from lnss_lib.studies.campaign import constraint_table
    from lnss_lib.studies.pareto import parse_constraints, satisfies, synthetic_campaign

    ev = synthetic_campaign(60, seed=3)
    pdop = ev["pdop_mean_3sigma"].values.copy()
    avail = ev["pdop_avail_pct"].values.copy()
    pdop[:4], avail[:3] = np.nan, np.nan  # impacts / no coverage fail every bound on them
    ev["pdop_mean_3sigma"], ev["pdop_avail_pct"] = ("design", pdop), ("design", avail)
    constraints = parse_constraints(ev.attrs["constraints"])
    table = constraint_table(ev, constraints)
    assert list(table.index) == [
        "evaluated without impact",
        "PDOP (3-sigma mean) <= 10",
        "PDOP availability >= 70 %",
        "Delta-V total <= 1 km/s/yr",
        "satellites <= 20",
        "navigation bounds only (no Delta-V or stability bound)",
        "all Table 3 bounds (feasible)",
    ]
    assert table.loc["evaluated without impact", "designs"] == 57
    assert table.loc["PDOP (3-sigma mean) <= 10", "designs"] == int(np.sum(pdop[4:] <= 10.0))
    assert table.loc["PDOP availability >= 70 %", "designs"] == int(np.sum(avail[3:] >= 70.0))
    assert table.loc["Delta-V total <= 1 km/s/yr", "designs"] == int(
        np.sum(ev.dv_total_kms_per_year.values <= 1.0)
    )
    navigation = satisfies(ev, [c for c in constraints if c[0] != "dv_total_kms_per_year"])
    assert table.loc["navigation bounds only (no Delta-V or stability bound)", "designs"] == int(
        navigation.sum()
    )
    assert table.loc["all Table 3 bounds (feasible)", "designs"] == int(ev.feasible.sum())
    np.testing.assert_allclose(table["share (%)"], 100.0 * table["designs"] / 60)
    # other bounds: labels and counts follow the constraints, not fixed Table 3 numbers
    looser = constraint_table(
        ev, [("pdop_mean_3sigma", "max", 5.0), ("dv_total_kms_per_year", "max", 2.0)]
    )
    assert looser.loc["PDOP (3-sigma mean) <= 5", "designs"] == int(np.sum(pdop[4:] <= 5.0))
    assert looser.loc["Delta-V total <= 2 km/s/yr", "designs"] == int(
        np.sum(ev.dv_total_kms_per_year.values <= 2.0)
    )
    assert looser.loc["navigation bounds only (no Delta-V or stability bound)", "designs"] == int(
        np.sum(pdop[4:] <= 5.0)
    )
    assert bound_text("hdop_avail_pct", "min", 90.5) == "HDOP availability >= 90.5 %"
    with pytest.raises(ValueError, match="'between'"):
        constraint_table(ev, [("n_sat", "between", 3.0)])
    empty = constraint_table(ev.isel(design=slice(0, 0)), constraints)
    assert (empty["designs"] == 0).all() and (empty["share (%)"] == 0).all()


def test_throughput_table_from_hand_made_history(tmp_path):
    from lnss_lib.studies.campaign import (
        run_throughput_table,
        steady_designs_per_s,
        throughput_table,
    )

    history = _history([6, 5, 4], [2.0, 1.0, 1.0], [0, 1, 2], [6, 6, 6])
    timing = {
        "n_evaluations": 15,
        "worker_budget_s": 8.0,
        "propagation_s": 2.0,
        "metrics_s": 1.0,
        "in_task_overhead_s": 1.0,
        "campaign_overhead_s": 4.0,
    }
    t = throughput_table(history, 3, timing, 2)["value"]
    assert (
        t["unique designs evaluated"] == 15
        and t["unique feasible designs"] == 3
        and t["worker processes"] == 2
    )
    assert t["campaign wall time (s, generations)"] == 4.0
    assert t["designs per second (overall)"] == pytest.approx(15 / 4)
    assert t["designs per second (generation 2 on)"] == pytest.approx(9 / 2)
    assert t["propagation (% of worker time)"] == pytest.approx(25.0)
    assert t["campaign overhead (%)"] == pytest.approx(50.0)
    assert t["cache hits (% of requested designs)"] == pytest.approx(100 * 3 / 18)
    assert t[
        "projected 120 x 1000 campaign at this profile's fidelity (h, this machine)"
    ] == pytest.approx(120000 / 4.5 / 3600)
    assert t["... with this run's cache hits (h)"] == pytest.approx(
        (1 - 3 / 18) * 120000 / 4.5 / 3600
    )
    one = _history([6], [3.0], [0], [6])
    assert steady_designs_per_s(one, 6) == pytest.approx(2.0)
    with pytest.raises(ValueError, match="workers"):
        throughput_table(history, 3, timing, 0)
    # from a run directory: workers counted from the cache records, shares from their timings
    records = [
        {
            "key": [i, 0, 0, 0, 0, 0],
            "generation": 1,
            "worker": w,
            "task_wall_s": 1.0,
            "timing_s": {"propagation": 0.5, "dop": 0.1, "deltav": 0.1, "gps": 0.05},
        }
        for i, w in enumerate(("a", "b", "a", "b", "b"))
    ]
    (tmp_path / "evaluations.jsonl").write_text(
        "\n".join(
            [json.dumps({"evaluation_hash": "h", "format": 2})]
            + [encode_record(r) for r in records]
        )
        + "\n"
    )
    t = run_throughput_table(
        tmp_path, history, xr.Dataset({"feasible": ("design", [True, False])}), records
    )["value"]
    assert (
        t["worker processes"] == 2
        and t["unique designs evaluated"] == 5
        and t["unique feasible designs"] == 1
    )
    assert t["propagation (% of worker time)"] == pytest.approx(100 * 2.5 / 8.0)
    assert t["in-task overhead (%)"] == pytest.approx(100 * (5.0 - 2.5 - 1.25) / 8.0)


TINY = """[profile]
name = "{name}"
inherits = "ci"
[campaign]
evaluator = "synthetic"
generations = 2
companion_profile = ""
notebook_mode = "{mode}"
"""


@pytest.fixture
def tiny_profiles(tmp_path, monkeypatch):
    """Profiles ``tiny`` (notebook_mode load) and ``tinyrun`` (run): ci with the synthetic evaluator, 2
    generations; ``outputs/`` in ``tmp_path``."""
    import shutil

    from lnss_lib import config, outputs
    from lnss_lib.campaign import rundir, runner

    params = tmp_path / "params"
    params.mkdir()
    for item in config.PARAMS_DIR.iterdir():
        (params / item.name).symlink_to(item)
    for name, mode in (("tiny", "load"), ("tinyrun", "run")):
        (params / f"{name}.toml").write_text(TINY.format(name=name, mode=mode))
    monkeypatch.setattr(config, "PARAMS_DIR", params)
    for module in (outputs, rundir, runner):
        monkeypatch.setattr(module, "OUTPUTS_DIR", tmp_path / "outputs")
    yield tmp_path / "outputs"
    shutil.rmtree(params)


def test_load_or_run_shows_the_profiles_run_or_says_why_not(tiny_profiles, capsys):
    """The newest run is not trusted: The run shown and published is the newest whose
    settings are the profile's; otherwise the note names the run and the differing settings, and the
    profile returned is the run's own."""
    from lnss_lib.campaign import export_results
    from lnss_lib.campaign.publication import load_published
    from lnss_lib.studies.campaign import latest_run_dir, load_or_run

    folder = tiny_profiles / "tiny" / "campaign"
    with pytest.raises(FileNotFoundError, match="--profile tiny"):
        load_or_run("tiny")
    own = run_campaign("tiny", workers=0, run_dir=folder / "run_1", progress=False)
    assert own.publication.startswith("published as the campaign of profile 'tiny'")
    longer = run_campaign(
        "tiny",
        overrides={"campaign": {"generations": 3}},
        workers=0,
        run_dir=folder / "run_2",
        progress=False,
    )
    assert (
        longer.publication.startswith("not published")
        and "campaign.generations = 3 (profile: 2)" in longer.publication
    )
    physics = run_campaign(
        "tiny",
        overrides={"gravity": {"degree": 4}},
        workers=0,
        run_dir=folder / "run_3",
        progress=False,
    )
    assert "evaluation settings differ" in physics.publication
    (folder / "run_4").mkdir()  # no checkpoint: not a run to load
    assert latest_run_dir(folder, "tiny") == (own.run_dir, [])
    shown = load_or_run("tiny")
    assert (
        shown.run_dir == own.run_dir and "the campaign of profile 'tiny', published" in shown.note
    )
    published = load_published(folder)
    assert published.pointer["run_dir"] == "run_1" and published.pointer["evaluator"] == "synthetic"
    for got, want, pub in zip(
        (shown.evaluations, shown.front, shown.history),
        export_results(own.run_dir),
        (published.evaluations, published.front, published.history),
    ):
        xr.testing.assert_identical(got.drop_attrs(), want.drop_attrs())
        xr.testing.assert_identical(pub.drop_attrs(), want.drop_attrs())
    # the run that matches the --set overrides is shown, and not published
    shown = load_or_run("tiny", '{"campaign": {"generations": 3}}')
    assert shown.run_dir == longer.run_dir and "not published" in shown.note
    assert (
        shown.history.sizes["generation"] == 3
        and load_published(folder).pointer["run_dir"] == "run_1"
    )
    # no run is the profile's: the newest is shown with the reason, and its own settings
    (own.run_dir / "checkpoint.pkl").unlink()
    shown = load_or_run("tiny")
    assert shown.run_dir == physics.run_dir and "NOT the campaign of profile 'tiny'" in shown.note
    assert "gravity.degree = 4 (profile: 8)" in shown.note and shown.settings.gravity.degree == 4
    assert load_published(folder).pointer["run_dir"] == "run_1"
    # run mode runs the campaign with the notebook's overrides
    ran = load_or_run("tinyrun", '{"campaign": {"generations": 3}}')
    assert ran.history.sizes["generation"] == 3 and ran.settings.campaign.generations == 3
    assert (
        "not published" in ran.note
        and load_published(tiny_profiles / "tinyrun" / "campaign") is None
    )
    ran = load_or_run("tinyrun")
    assert ran.history.sizes["generation"] == 2 and "published" in ran.note
    assert (
        load_published(tiny_profiles / "tinyrun" / "campaign").pointer["run_dir"]
        == ran.run_dir.name
    )


def test_notebooks_fall_back_to_the_shipped_results(tiny_profiles, monkeypatch):
    """With no local run that is the profile's, notebooks 06-07 show the shipped reference results
    and say so (nothing runs); a local run that is the profile's wins; a reference that is not the profile's
    (stale) is never shown."""
    from lnss_lib.campaign import reference
    from lnss_lib.studies.campaign import (
        constraint_table,
        load_or_run,
        run_throughput_table,
        shown_campaign,
    )

    monkeypatch.setattr(reference, "REFERENCE_DIR", tiny_profiles / "reference")
    folder = tiny_profiles / "tiny" / "campaign"
    elsewhere = run_campaign(
        "tiny", workers=0, run_dir=tiny_profiles / "elsewhere" / "run", progress=False
    )
    reference.export_reference(elsewhere.run_dir)
    shown = load_or_run("tiny")
    assert shown.run_dir == tiny_profiles / "reference" / "tiny" and shown.records == []
    assert (
        "shipped reference results" in shown.note
        and "a complete run of 2 generations" in shown.note
    )
    assert not list(folder.glob("run_*")) and shown.settings.campaign.evaluator == "synthetic"
    table = run_throughput_table(shown.run_dir, shown.history, shown.evaluations, shown.records)[
        "value"
    ]
    assert table["unique designs evaluated"] == elsewhere.n_evaluations
    assert table["unique feasible designs"] == elsewhere.n_feasible
    bounds = constraint_table(shown.evaluations, CampaignPlan.of(shown.settings).constraints)[
        "designs"
    ]
    assert bounds["all Table 3 bounds (feasible)"] == elsewhere.n_feasible
    notebook7 = shown_campaign("tiny")
    assert notebook7.run_dir == shown.run_dir and "nothing is published" in notebook7.note
    with pytest.raises(
        FileNotFoundError, match="are not the campaign of profile 'tiny' as set here"
    ):
        load_or_run("tiny", '{"campaign": {"seed": 5}}')
    own = run_campaign("tiny", workers=0, run_dir=folder / "run_1", progress=False)
    shown = load_or_run("tiny")
    assert shown.run_dir == own.run_dir and "published" in shown.note
    assert shown_campaign("tiny").run_dir.parent == folder / "published"


def test_paper_profile_without_a_local_run_shows_the_shipped_results(tmp_path, monkeypatch, capsys):
    """`reproduce --profile paper` with no local campaign draws notebooks 06-07 from the
    shipped results instead of running a campaign."""
    from lnss_lib import outputs
    from lnss_lib.campaign.reference import load_reference
    from lnss_lib.cli.reproduce import say_which_campaign
    from lnss_lib.studies.campaign import load_or_run, shown_campaign

    monkeypatch.setattr(outputs, "OUTPUTS_DIR", tmp_path)
    shipped = load_reference("paper")
    for shown in (load_or_run("paper"), shown_campaign("paper")):
        assert shown.run_dir == shipped.folder and "shipped reference results" in shown.note
        assert shown.history.sizes["generation"] == shipped.history.sizes["generation"]
    assert not list((tmp_path / "paper" / "campaign").glob("run_*"))
    say_which_campaign("paper", None, {"06", "07"})
    said = capsys.readouterr().err
    assert "campaign of paper: no run in" in said and "outputs/reference/paper " in said
    assert "notebook 07's figures: " in said and "outputs/reference/paper_dv_physical" in said


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
    assert (
        len(designs_pdop_deltav(ev, front.isel(design=slice(0, 0)), 1.0, 10.0, "no front").data)
        == 1
    )
    with pytest.raises(ValueError, match="positive"):
        designs_pdop_deltav(ev, front, 0.0, 10.0, "bad")


def test_readers_follow_the_publication(tiny_profiles):
    """Notebooks 07, 08, 10 and the index read the published run (the pointer), not files in the campaign folder."""
    from lnss_lib import pipeline
    from lnss_lib.campaign.publication import load_published
    from lnss_lib.outputs import display_path
    from lnss_lib.studies.design_life import campaign_designs
    from lnss_lib.studies.pareto import load_campaign

    folder = tiny_profiles / "tiny" / "campaign"
    run_campaign("tiny", workers=0, run_dir=folder / "run_1", progress=False)
    run_campaign(
        "tiny",
        overrides={"campaign": {"seed": 7}},
        workers=0,
        run_dir=folder / "run_2",
        progress=False,
    )
    published = load_published(folder)
    assert published.pointer["run_dir"] == "run_1" and int(published.evaluations.attrs["seed"]) != 7
    evaluations, front = load_campaign("tiny")
    xr.testing.assert_identical(evaluations, published.evaluations)
    xr.testing.assert_identical(front, published.front)
    designs, note = campaign_designs(folder, 2)
    assert len(designs) == 2 and f"published in {display_path(folder)}" in note
    assert campaign_designs(tiny_profiles / "nothing", 2)[0] == []
    page = pipeline.write_index("tiny").read_text()
    assert f"{published.folder.name}/front.nc" in page and "run_2" not in page
