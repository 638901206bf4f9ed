"""The scheduling model behind ``bench campaign --scaling`` (list scheduling of one generation)."""

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lnss_lib.bench.campaign import _busy_fraction, _greedy_makespan


def test_greedy_makespan_by_hand():
    assert _greedy_makespan(np.array([3.0, 1.0, 1.0, 1.0]), 2, 0.0) == 3.0  # 3 | 1 + 1 + 1
    assert _greedy_makespan(np.array([1.0, 1.0, 1.0, 3.0]), 2, 0.0) == 4.0  # in order: 1+1 | 1+3
    assert _greedy_makespan(np.ones(4), 4, 0.5) == pytest.approx(
        2.5
    )  # last task handed out at 1.5 s
    assert _greedy_makespan(np.ones(6), 1, 0.0) == 6.0


def test_busy_fraction_is_one_for_perfect_balance_and_drops_with_idle_workers():
    assert _busy_fraction(np.ones(8), 4, 0.0, 0.0) == pytest.approx(1.0)
    assert _busy_fraction(np.ones(8), 16, 0.0, 0.0) == pytest.approx(0.5)  # half the workers idle
    assert _busy_fraction(np.array([4.0, 1.0, 1.0, 1.0, 1.0]), 2, 0.0, 0.0) == pytest.approx(1.0)
    assert _busy_fraction(np.array([8.0, 1.0]), 2, 0.0, 0.0) == pytest.approx(9.0 / 16.0)


def _history(evaluated, population=120):
    return [
        {
            "generation": g + 1,
            "n_designs": population,
            "n_evaluated": n,
            "n_cache_hits": population - n,
            "wall_s": 1.0,
        }
        for g, n in enumerate(evaluated)
    ]


def test_history_projection_counts_the_runs_evaluations_and_extends_its_tail(tmp_path):
    """``bench campaign --history``: recorded generations as they were, the unrun ones at the last 20's mean."""
    from lnss_lib.bench.campaign import HISTORY_TAIL, evaluated_per_generation
    from lnss_lib.campaign.rundir import write_checkpoint
    from lnss_lib.paper import EVALUATIONS, TABLE_5

    evaluated = [120] + [100] * 9 + [10] * HISTORY_TAIL
    write_checkpoint(
        tmp_path, len(evaluated), None, _history(evaluated), False, profile_fingerprint="x"
    )
    got = evaluated_per_generation(tmp_path)
    assert got["generations_recorded"] == len(evaluated) and got["evaluated_recorded"] == sum(
        evaluated
    )
    assert got["hits_recorded"] == 120 * len(evaluated) - sum(evaluated)
    assert got["evaluated_total"] == sum(evaluated) + 10 * (TABLE_5["generations"] - len(evaluated))
    assert got["hit_fraction"] == pytest.approx(1 - got["evaluated_total"] / EVALUATIONS)


def test_history_projection_refuses_what_is_not_a_table5_run(tmp_path):
    from lnss_lib.bench.campaign import evaluated_per_generation
    from lnss_lib.campaign.rundir import write_checkpoint
    from lnss_lib.errors import ConfigError

    with pytest.raises(ConfigError, match="not a campaign run folder"):
        evaluated_per_generation(tmp_path / "missing")
    with pytest.raises(ConfigError, match="not a campaign run folder"):
        evaluated_per_generation(tmp_path)  # a folder with no checkpoint
    write_checkpoint(
        tmp_path, 2, None, _history([16, 10], population=16), False, profile_fingerprint="x"
    )
    with pytest.raises(ConfigError, match="population of 120"):
        evaluated_per_generation(tmp_path)


def test_force_model_agrees_with_the_previous_one_to_round_off_on_an_integrated_arc(
    paper_profile, epoch_tdb_s
):
    """The right-hand side on the points an RK45 integration of the Table 4 ELFO evaluates equals the previous
    model's recorded accelerations (four interpolations, the truncation loop, the per-term harmonic sums:
    tests/data/force_model_before.md) to round-off (the folded-table sums are reordered); the benchmark's
    replay of the current model gives the same accelerations."""
    from lnss_lib.bench.force_before import current_on_points, rhs_points
    from lnss_lib.ephemeris import EphemerisTable
    from lnss_lib.forces import SCRATCH_SIZE, TERMS, ForceModel, acceleration
    from lnss_lib.propagator import elements_deg_to_states

    recorded = np.load(Path(__file__).parent / "data" / "force_model_before.npz")
    ts, ys = recorded["arc_t_tdb_s"], recorded["arc_state_km_kms"]
    duration = 0.5 * 86400.0
    table = EphemerisTable.build(paper_profile.dynamics, epoch_tdb_s, epoch_tdb_s + duration)
    model = ForceModel.build(paper_profile.dynamics, table)
    args, work = model.kernel_args, model.field.workspace()
    scratch, terms, acc = np.zeros(SCRATCH_SIZE), np.zeros((len(TERMS), 3)), np.empty((len(ts), 3))
    for i in range(len(ts)):
        acceleration(ts[i], ys[i], args, work, scratch, terms, acc[i])
    before = recorded["arc_acceleration_before_kms2"]
    rel = np.linalg.norm(acc - before, axis=1) / np.linalg.norm(before, axis=1)
    assert len(ts) > 100 and ts[0] == epoch_tdb_s and np.max(rel) < 1e-13
    replay = current_on_points(model, ts, ys)
    assert np.array_equal(replay["acceleration"], acc) and replay["rhs_s"] > 0.0
    y0 = elements_deg_to_states(
        paper_profile.dynamics, [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]], epoch_tdb_s
    )[0]
    points, _ = rhs_points(model, y0, epoch_tdb_s, duration, "RK45", 1e-6, 1e-9)
    assert points[0] == epoch_tdb_s and points[-1] <= epoch_tdb_s + duration and len(points) > 100


def _recorded_before():
    """The previous campaign evaluation's metrics on three ci designs
    (tests/data/evaluation_before_ci.md)."""
    return json.loads((Path(__file__).parent / "data" / "evaluation_before_ci.json").read_text())


def test_campaign_evaluation_equals_the_recorded_previous_path():
    """Today's campaign evaluation gives the metrics the path before the evaluation-path work
    (Datasets, every Delta-V model, kernel paths every design; ``bench campaign`` runs it from its
    commit) recorded: bit for bit where the kernels are compiled for the recorded processor model,
    else within the round-off of kernels compiled for another (up to 2e-7 relative measured,
    docs/NOTES.md: 1e-6 allowed); the design inside the Moon infeasible in both."""
    from lnss_lib import kernel_cpu
    from lnss_lib.bench.evaluation_path import evaluate_now
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.evaluator import context_for
    from lnss_lib.keys import METRIC_KEYS
    from lnss_lib.settings import load_settings

    recorded = _recorded_before()
    context = context_for(load_settings(recorded["profile"]))
    rtol = 0.0 if kernel_cpu() == recorded["kernel_cpu"] else 1e-6
    assert [d["metrics"] is None for d in recorded["designs"]] == [False, False, True]
    for design in recorded["designs"]:
        _, now = evaluate_now(context, WalkerDesign(*design["walker"]).elements_deg())
        if design["metrics"] is None:
            assert now is None
            continue
        for key in METRIC_KEYS:
            assert now[key] == pytest.approx(design["metrics"][key], rel=rtol, nan_ok=True), key


def test_evaluation_comparison_counts_designs_and_differing_metrics():
    """``bench campaign``'s before/now comparison: an infeasible design is skipped, a design whose
    metrics differ is counted, and without the path before today's is timed alone."""
    from lnss_lib.bench.evaluation_path import compare_evaluations, evaluate_now
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.evaluator import context_for
    from lnss_lib.settings import load_settings

    context = context_for(load_settings("ci"))
    designs = [WalkerDesign(*d["walker"]).elements_deg() for d in _recorded_before()["designs"]]

    def before(elements):  # today's path with the second design's Delta-V moved
        wall_s, metrics = evaluate_now(context, elements)
        if metrics is not None and elements is designs[1]:
            metrics = {**metrics, "dv_total_kms_per_year": metrics["dv_total_kms_per_year"] + 1e-9}
        return wall_s, metrics

    got = compare_evaluations(context, designs, before, repeats=1)
    assert got["n_designs"] == 2 and got["n_differing"] == 1
    assert got["before_s"] > 0.0 and got["now_s"] > 0.0
    alone = compare_evaluations(context, designs, repeats=1)
    assert alone["n_designs"] == 2 and alone["n_differing"] == 0
    assert math.isnan(alone["before_s"]) and alone["now_s"] > 0.0


def test_shadow_factor_equals_the_three_angle_computation_bit_for_bit():
    """forces.shadow_factor (full sunlight told from the cosines) gives the previous computation's value exactly:
    random geometries round the Moon and the Earth, and satellites on the umbra and penumbra edges behind the Moon."""
    from lnss_lib.forces import conical_fraction, shadow_factor, shadow_geometry

    def shadow_factor_before(r, sun, bx, by, bz, radius_body, radius_sun):
        """The three angles at every call (the computation the shortcut replaced)."""
        inside, sin_a, sin_b, cos_c = shadow_geometry(*r, *sun, bx, by, bz, radius_body, radius_sun)
        return 0.0 if inside else conical_fraction(sin_a, sin_b, cos_c)

    rng = np.random.default_rng(9)
    r_moon, r_earth, r_sun, au = 1737.4, 6378.137, 696000.0, 1.495978707e8
    sun = np.array([au, 0.0, 0.0])
    earth = np.array([-3.0e5, 2.4e5, 1.0e4])
    unit = rng.normal(size=(20000, 3))
    unit /= np.linalg.norm(unit, axis=1)[:, None]
    positions = list(unit * rng.uniform(r_moon * 0.999, 6.0e4, size=(20000, 1)))
    for along in (2.0e3, 1.0e4, 4.0e4):  # behind the Moon, across the umbra and penumbra edges
        half_width = r_moon - along * (r_sun - r_moon) / au, r_moon + along * (r_sun + r_moon) / au
        for edge in half_width:
            for offset in edge * (1.0 + np.linspace(-1e-3, 1e-3, 401)):
                positions.append(np.array([-along, offset, 0.0]))
    near_earth = earth + unit[:5000] * rng.uniform(r_earth, 5.0e4, size=(5000, 1))
    values = {"lit": 0, "partial": 0, "dark": 0}
    for body, radius, points in (
        ((0.0, 0.0, 0.0), r_moon, positions),
        (tuple(earth), r_earth, near_earth),
    ):
        for r in points:
            new = shadow_factor(r, sun, *body, radius, r_sun)
            assert new == shadow_factor_before(r, sun, *body, radius, r_sun), (r, body)
            values["lit" if new == 1.0 else "dark" if new == 0.0 else "partial"] += 1
    assert min(values.values()) > 100  # every branch is exercised


def test_run_pace_after_subtracts_the_measured_shares(tmp_path):
    """``bench campaign --history``: the run's last generations' pace as recorded, less the evaluation path's measured
    share of its task time and the shadow's share of the propagation, by hand."""
    from lnss_lib.bench.campaign import HISTORY_TAIL, history_after
    from lnss_lib.campaign.journal import JOURNAL_FILE, EvaluationCache
    from lnss_lib.campaign.rundir import write_checkpoint

    generations = HISTORY_TAIL + 5
    history = [
        {
            "generation": g + 1,
            "n_designs": 120,
            "n_evaluated": 100,
            "n_cache_hits": 20,
            "wall_s": 4.0,
        }
        for g in range(generations)
    ]
    write_checkpoint(tmp_path, generations, None, history, False, profile_fingerprint="x")
    journal = EvaluationCache(tmp_path / JOURNAL_FILE, "h")
    for g in range(1, generations + 1):
        for i in range(100):  # 100 tasks of 0.07 s on two workers: 3.5 s a worker
            journal.add(
                (g, i, 0, 0, 0, 0),
                {"ok": True, "generation": g, "worker": f"w{i % 2}", "task_wall_s": 0.07},
            )
    journal.close()
    evaluation = {
        "before_s": 0.1,
        "now_s": 0.09,
        "now_propagation_s": 0.08,
    }  # 10 % of the task time saved
    kernels = {
        "new_s": 0.9,
        "shadow_before_s": 0.2,
        "shadow_new_s": 0.1,
    }  # 10 % of the right-hand side
    got = history_after(tmp_path, evaluation, kernels)
    shadow = 0.1 * 0.08 / 0.1  # of the propagation's share of the previous evaluation
    assert got["generation_before_s"] == pytest.approx(4.0)
    assert got["generation_after_s"] == pytest.approx(4.0 - 3.5 * (0.1 + shadow))


def test_shipped_projection_scales_the_shipped_history_by_the_pace_on_the_same_generations(
    monkeypatch,
):
    """``bench campaign`` on a profile with shipped results: the shipped run's generation times times this machine's
    pace on generations 2.. of the short run, plus the short run's start-up and generation 1; nothing when the short
    run's generations are not the shipped run's: one hypervolume bit apart where the kernels are compiled for the
    shipped run's processor model, more than round-off (1e-5 relative) where they are not."""
    import json

    import xarray as xr

    from lnss_lib import kernel_cpu
    from lnss_lib.bench import campaign as bench

    shipped_wall = np.array([90.0, 4.0, 6.0, 5.0, 5.0, 5.0])
    evaluated, hits, hv = (
        np.array([120, 119, 118, 117, 116, 115]),
        np.arange(6),
        np.linspace(0.1, 0.4, 6),
    )
    history = xr.Dataset(
        {
            "wall_s": ("generation", shipped_wall),
            "n_evaluated": ("generation", evaluated),
            "n_cache_hits": ("generation", hits),
            "hypervolume": ("generation", hv),
        },
        attrs={"versions": json.dumps({"kernel_cpu": kernel_cpu()})},
    )
    monkeypatch.setattr(bench, "load_reference", lambda name: SimpleNamespace(history=history))
    short = [
        {
            "generation": g + 1,
            "n_evaluated": int(evaluated[g]),
            "n_cache_hits": int(hits[g]),
            "hypervolume": float(hv[g]),
            "wall_s": w,
        }
        for g, w in enumerate([30.0, 2.0, 3.0])
    ]
    got = bench.shipped_projection("x", {"history": short, "startup_s": 7.0})
    assert got["generations_compared"] == 3 and got["pace_vs_shipped"] == pytest.approx(5.0 / 10.0)
    assert got["projected_s"] == pytest.approx(7.0 + 30.0 + 0.5 * 25.0)
    short[2]["hypervolume"] = float(np.nextafter(hv[2], 1.0))
    assert bench.shipped_projection("x", {"history": short, "startup_s": 7.0}) is None
    history.attrs["versions"] = json.dumps({"kernel_cpu": "another-model"})
    assert bench.shipped_projection("x", {"history": short, "startup_s": 7.0})[
        "projected_s"
    ] == pytest.approx(49.5)
    short[2]["hypervolume"] = float(hv[2] * (1.0 + 1e-5))
    assert bench.shipped_projection("x", {"history": short, "startup_s": 7.0}) is None
    short[2]["hypervolume"], short[2]["n_evaluated"] = float(hv[2]), int(evaluated[2]) - 1
    assert bench.shipped_projection("x", {"history": short, "startup_s": 7.0}) is None
    monkeypatch.setattr(bench, "load_reference", lambda name: None)
    assert bench.shipped_projection("x", {"history": short, "startup_s": 7.0}) is None


def test_short_run_repeats_thirty_shipped_generations_and_eight_otherwise(monkeypatch):
    """``bench campaign``'s defaults: a profile with shipped results runs its population for
    :data:`PACE_GENERATIONS` (the pace is measured on generations 2-30, not on half a minute), and nothing else; with
    ``before_after`` the operational projection beside it, which has no shipped run to repeat, keeps the short run
    (32 x 8)."""
    from lnss_lib.bench import campaign as bench

    calls = []

    def fake_projection(name, population, generations, workers, overrides=None):
        calls.append((name, population, generations))
        return {"projected_paper_h": 1.0, "records": []}

    monkeypatch.setattr(bench, "_projection", fake_projection)
    monkeypatch.setattr(bench, "shipped_projection", lambda name, projection: None)
    monkeypatch.setattr(bench, "evaluation_comparison", lambda *args: {"records": []})
    monkeypatch.setattr(bench, "kernel_comparison", lambda *args: {})
    bench.run("paper")
    assert calls == [("paper", 120, bench.PACE_GENERATIONS)]
    calls.clear()
    bench.run("paper", before_after=True)
    assert (bench.REFERENCE_DIR / "paper").is_dir() and (
        bench.PARAMS_DIR / "operational.toml"
    ).is_file()
    assert calls == [
        ("paper", 120, bench.PACE_GENERATIONS),
        ("operational", 32, bench.SHORT_GENERATIONS),
    ]
    calls.clear()
    bench.run("quick")
    assert calls[0][2] == min(
        bench.load_settings("quick").campaign.generations, bench.SHORT_GENERATIONS
    )


def test_bench_campaign_runs_the_historical_comparisons_only_when_asked(monkeypatch):
    """The default is the projection alone; ``before_after`` adds the evaluation path and the force model before and
    after (each run from its commit) and the operational projection."""
    from lnss_lib.bench import campaign

    ran = []
    projection = {"projected_paper_h": 1.0, "records": []}
    monkeypatch.setattr(
        campaign, "_projection", lambda name, *a, **k: ran.append(name) or dict(projection)
    )
    monkeypatch.setattr(campaign, "shipped_projection", lambda *a: None)
    monkeypatch.setattr(
        campaign,
        "evaluation_comparison",
        lambda *a: ran.append("evaluation") or {"records": [], "before_s": 1.0},
    )
    monkeypatch.setattr(campaign, "kernel_comparison", lambda *a: ran.append("kernels") or {})
    campaign.run("ci")
    assert ran == ["ci"]
    ran.clear()
    campaign.run("ci", before_after=True)
    assert ran == ["ci", "operational", "evaluation", "kernels"]
