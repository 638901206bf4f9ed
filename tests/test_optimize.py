"""NSGA-II campaign: grid (eq. 43-44), objectives and constraints (eq. 45, Table 3), cache, checkpoint/resume
after SIGKILL, Dask cluster against the in-process run, lost workers, NetCDF result contract."""

import json
import math
import os
import pickle
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from lnss_lib.__main__ import _parse_sets, main
from lnss_lib.config import PROJECT_DIR, load_profile
from lnss_lib.evaluator import DESIGN_KEYS, METRIC_KEYS, context_for, evaluate_design
from lnss_lib.optimize import (CampaignSettings, EvaluationCache, WalkerDesignProblem,
                               constraint_matrix, constraint_violation, evaluation_hash, final_population,
                               hypervolume, non_dominated_mask, objective_matrix, read_cache_records, run_campaign,
                               synthetic_evaluation)

CLI = [sys.executable, "-m", "lnss_lib", "campaign"]
SYNTHETIC = ["--profile", "ci", "--evaluator", "synthetic", "--no-progress"]


@pytest.fixture(scope="module")
def settings():
    return CampaignSettings.from_profile(load_profile("paper"))


def _metrics(**values):
    base = {k: np.array([math.nan]) for k in METRIC_KEYS}
    base.update({k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()})
    return base


# --- grid, objectives, constraints -----------------------------------------------------------

def test_grid_eq43_44_round_trip_bounds_and_rounding(settings, rng):
    grid = settings.grid
    np.testing.assert_array_equal(grid.n_levels, [200, 80, 358, 89, 3, 3])
    x = np.column_stack([rng.integers(0, n + 1, 500) for n in grid.n_levels])
    physical = grid.descale(x)
    np.testing.assert_allclose(grid.scale(physical), x, atol=1e-9)
    assert np.all(physical >= grid.lower) and np.all(physical <= grid.upper)
    np.testing.assert_array_equal(grid.descale(np.zeros(6)), [[4000.0, 0.0, 1.0, 1.0, 2, 1]])
    np.testing.assert_array_equal(grid.descale(grid.n_levels), [[24000.0, 0.8, 359.0, 90.0, 5, 4]])
    np.testing.assert_array_equal(grid.descale([[-7, -1, 999, 500, 9, -3]]), [[4000.0, 0.0, 359.0, 90.0, 5, 1]])
    assert grid.descale([[0, 30, 0, 0, 0.6, 1.4]])[0, 1] == 0.3  # no binary noise; Np and Ns rounded
    np.testing.assert_array_equal(grid.descale([[0, 0, 0, 0, 0.6, 1.4]])[0, 4:], [3, 2])
    design = grid.designs([[21, 60, 89, 50, 0, 3]])[0]
    assert design == {"sma_km": 6100.0, "ecc": 0.6, "aop_deg": 90.0, "inc_deg": 51.0, "n_planes": 2,
                      "sats_per_plane": 4}
    assert isinstance(design["n_planes"], int)
    np.testing.assert_allclose(grid.scale([6143.0, 0.6, 90.0, 51.7, 2, 8])[0], [21.43, 60.0, 89.0, 50.7, 0, 7])


def test_bad_settings_raise_clear_errors():
    profile = load_profile("ci")
    cases = [({"objectives": ["n_sat", "-pdop"]}, "campaign.objectives"),
             ({"constraints": {"pdop_mean_3sigma": {"max": 10.0, "min": 1.0}}}, "campaign.constraints"),
             ({"variables": {"ecc": {"lower": 0.5, "upper": 0.1, "step": 0.01}}}, "campaign.variables.ecc"),
             ({"variables": {"n_planes": {"lower": 1.5, "upper": 5, "step": 1}}}, "campaign.variables.n_planes"),
             ({"evaluator": "matlab"}, "campaign.evaluator"),
             ({"population": 1}, "campaign.population"),
             ({"crossover_prob": 1.5}, "campaign.crossover_prob")]
    for change, message in cases:
        bad = load_profile("ci", overrides={"campaign": change})
        with pytest.raises(ValueError, match=message):
            CampaignSettings.from_profile(bad)
    del profile["campaign"]
    with pytest.raises(ValueError, match=r"no \[campaign\] section"):
        CampaignSettings.from_profile(profile)


def test_objectives_signs_and_nan_penalty(settings):
    metrics = _metrics(n_sat=[8, 12], pdop_mean_3sigma=[2.5, math.nan], pdop_avail_pct=[95.0, 0.0],
                       hdop_mean_3sigma=[1.0, math.nan], hdop_avail_pct=[90.0, 0.0],
                       dv_total_kms_per_year=[0.8, 2.0], dv_opt_kms_per_year=[0.6, 1.5],
                       gps_visible_mean=[7.0, 3.0], gps_pdop_mean=[900.0, math.nan])
    f = objective_matrix(metrics, settings.objectives, settings.nan_objective)
    np.testing.assert_array_equal(f[0], [8, 2.5, -95.0, 1.0, -90.0, 0.8, 0.6, -7.0, 900.0])
    np.testing.assert_array_equal(f[1], [12, 1e6, -0.0, 1e6, -0.0, 2.0, 1.5, -3.0, 1e6])
    assert np.all(np.isfinite(f))


def test_constraints_of_table3_normalised(settings):
    assert settings.constraints == (("pdop_mean_3sigma", "max", 10.0), ("pdop_avail_pct", "min", 70.0),
                                    ("dv_total_kms_per_year", "max", 1.0), ("n_sat", "max", 20.0))
    metrics = _metrics(n_sat=[12, 20, 4], pdop_mean_3sigma=[12.0, 10.0, math.nan], pdop_avail_pct=[56.0, 70.0, 0.0],
                       dv_total_kms_per_year=[2.5, 1.0, math.nan])
    g = constraint_matrix(metrics, settings.constraints, settings.nan_violation)
    np.testing.assert_allclose(g[0], [0.2, 0.2, 1.5, -0.4])
    np.testing.assert_allclose(g[1], [0.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(g[2], [1e3, 1.0, 1e3, -0.8])
    np.testing.assert_allclose(constraint_violation(g), [1.9, 0.0, 2001.0])


def test_problem_evaluates_through_its_source_and_pickles_without_it(settings):
    calls = []

    def source(x):
        calls.append(np.array(x))
        n = len(x)
        values = {k: np.full(n, math.nan) for k in METRIC_KEYS}
        values["n_sat"] = np.array([4] * n)
        return values

    problem = WalkerDesignProblem(settings, source)
    out = problem.evaluate(np.array([[1, 2, 3, 4, 0, 1], [5, 6, 7, 8, 1, 2]]), return_as_dictionary=True)
    assert out["F"].shape == (2, 9) and np.all(np.isfinite(out["F"])) and np.all(out["G"][:, :3] == 1e3)
    assert len(calls) == 1 and calls[0].shape == (2, 6)
    clone = pickle.loads(pickle.dumps(problem))
    assert clone.metrics_source is None
    with pytest.raises(ValueError, match="no metrics source"):
        clone.evaluate(np.zeros((1, 6), dtype=int))


def test_non_dominated_mask_against_brute_force_and_pymoo(rng):
    from pymoo.util.nds.non_dominated_sorting import find_non_dominated

    f = rng.integers(0, 6, size=(300, 3)).astype(float)
    brute = np.array([not any(np.all(f[j] <= f[i]) and np.any(f[j] < f[i]) for j in range(len(f)))
                      for i in range(len(f))])
    mask = non_dominated_mask(f, chunk=37)
    np.testing.assert_array_equal(mask, brute)
    g = rng.random((200, 4))
    np.testing.assert_array_equal(np.flatnonzero(non_dominated_mask(g)), np.sort(find_non_dominated(g)))


def test_hypervolume_closed_forms():
    ref = (("n_sat", 20.0), ("pdop_mean_3sigma", 10.0))
    one = _metrics(n_sat=[10], pdop_mean_3sigma=[5.0])
    assert hypervolume(one, np.array([True]), ref) == pytest.approx(0.25)
    assert hypervolume(one, np.array([False]), ref) == 0.0
    two = _metrics(n_sat=[10, 4, 12], pdop_mean_3sigma=[5.0, 8.0, 12.0])  # third lies outside the box
    # union of [0.5, 1] x [0.5, 1] and [0.2, 1] x [0.8, 1]: 0.25 + 0.3 * 0.2
    assert hypervolume(two, np.ones(3, dtype=bool), ref) == pytest.approx(0.31)


def test_evaluation_hash_ignores_campaign_only_keys():
    base = evaluation_hash(load_profile("ci"))
    for change in ({"campaign": {"population": 50, "seed": 9, "objectives": ["n_sat"], "generations": 2}},
                   {"campaign": {"constraints": {"n_sat": {"max": 12}}}}):
        assert evaluation_hash(load_profile("ci", overrides=change)) == base
    for change in ({"gravity": {"degree": 10}}, {"campaign": {"evaluator": "synthetic"}},
                   {"campaign": {"variables": {"ecc": {"lower": 0.0, "upper": 0.8, "step": 0.02}}}},
                   {"campaign": {"overrides": {"epoch": {"duration_days": 1.0}}}}):
        assert evaluation_hash(load_profile("ci", overrides=change)) != base
    assert evaluation_hash(load_profile("quick")) == evaluation_hash(load_profile("paper"))


def test_cache_survives_a_torn_line_and_checks_the_hash(tmp_path):
    path = tmp_path / "evaluations.jsonl"
    cache = EvaluationCache(path, "abc")
    cache.add((1, 2, 3, 4, 0, 0), {"generation": 1, "order": 0})
    cache.close()
    with path.open("a") as handle:
        handle.write('{"key": [9, 9, 9')  # a write cut short by SIGKILL
    cache = EvaluationCache(path, "abc")
    assert list(cache.records) == [(1, 2, 3, 4, 0, 0)]
    cache.add((5, 5, 5, 5, 1, 1), {"generation": 2, "order": 3})
    cache.close()
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [line.get("key") for line in lines] == [None, [1, 2, 3, 4, 0, 0], [5, 5, 5, 5, 1, 1]]
    with pytest.raises(ValueError, match="evaluation hash"):
        EvaluationCache(path, "other")


def test_synthetic_evaluator_flags_impact():
    profile = load_profile("ci")
    hit = synthetic_evaluation(profile, 4000.0, 0.8, 90.0, 50.0, 2, 2)
    assert hit["impact"] and not hit["feasible"] and math.isnan(hit["pdop_mean_3sigma"]) and hit["n_sat"] == 4
    ok = synthetic_evaluation(profile, 8000.0, 0.5, 90.0, 80.0, 4, 4)
    assert ok["feasible"] and all(math.isfinite(ok[k]) for k in METRIC_KEYS)


def test_set_parser_and_cli_errors(capsys):
    assert _parse_sets(["campaign.generations=4", "epoch.duration_days=1.5", "campaign.seed=3"]) == {
        "campaign": {"generations": 4, "seed": 3}, "epoch": {"duration_days": 1.5}}
    assert main(["campaign", "--set", "campaign.generations"]) == 2
    assert "SECTION.KEY=VALUE" in capsys.readouterr().err
    assert main(["campaign", "--resume", "/nonexistent/run", "--profile", "ci"]) == 2
    assert "--resume continues a run" in capsys.readouterr().err


def test_tolerance_termination_stops_early(tmp_path):
    overrides = {"campaign": {"evaluator": "synthetic", "generations": 40, "ftol": 10.0, "ftol_period": 3}}
    result = run_campaign("ci", overrides=overrides, workers=0, run_dir=tmp_path / "tol", progress=False)
    history = xr.open_dataset(result.run_dir / "history.nc", engine="h5netcdf")
    first_feasible = int(history.generation[history.n_feasible_pop > 0][0])
    assert result.generations < 40 and result.generations <= first_feasible + 4
    assert history.attrs["finished"] == 1
    fixed = run_campaign("ci", overrides={"campaign": {"evaluator": "synthetic", "generations": 5}}, workers=0,
                         run_dir=tmp_path / "fixed", progress=False)
    assert fixed.generations == 5


# --- a real campaign in-process (the reference for the Dask run) ----------------------------------

@pytest.fixture(scope="module")
def real_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("real") / "run"
    result = run_campaign("ci", workers=0, run_dir=run_dir, progress=False)
    return result


def test_real_campaign_netcdf_contract(real_run):
    settings = CampaignSettings.from_profile(load_profile("ci"))
    ev = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    front = xr.open_dataset(real_run.run_dir / "front.nc", engine="h5netcdf").load()
    history = xr.open_dataset(real_run.run_dir / "history.nc", engine="h5netcdf").load()
    expected = {*DESIGN_KEYS, *METRIC_KEYS, "feasible", "impact", "constraint_violation", "generation"}
    for ds in (ev, front):
        assert set(ds.data_vars) == expected and set(ds.dims) == {"design"}
        for name in ("sma_km", "ecc", "aop_deg", "inc_deg"):
            assert ds[name].dtype == np.float64
        for name in ("n_planes", "sats_per_plane", "n_sat", "generation"):
            assert np.issubdtype(ds[name].dtype, np.integer)
        assert ds.feasible.dtype == bool and ds.impact.dtype == bool
        assert ds.attrs["profile"] == "ci" and ds.attrs["objectives"].split(",") == list(settings.objectives)
        assert json.loads(ds.attrs["parameters"])["campaign"]["population"] == 6
        assert "pymoo" in json.loads(ds.attrs["versions"])
    assert ev.sizes["design"] == real_run.n_evaluations == len(read_cache_records(real_run.run_dir))
    designs = np.column_stack([ev[k].values for k in DESIGN_KEYS])
    assert len({tuple(row) for row in designs}) == ev.sizes["design"]  # every design once
    np.testing.assert_allclose(settings.grid.descale(np.rint(settings.grid.scale(designs))), designs)
    np.testing.assert_array_equal(ev.n_sat, ev.n_planes * ev.sats_per_plane)
    assert ev.generation.min() == 1 and ev.generation.max() == 3 and np.all(np.diff(ev.generation) >= 0)
    # violations and feasibility follow from the stored metrics (Table 3 limits, independently written)
    pdop, avail, dv = ev.pdop_mean_3sigma.values, ev.pdop_avail_pct.values, ev.dv_total_kms_per_year.values
    with np.errstate(invalid="ignore"):
        manual = (np.where(np.isnan(pdop), 1e3, np.maximum(pdop / 10 - 1, 0))
                  + np.where(np.isnan(avail), 1e3, np.maximum(1 - avail / 70, 0))
                  + np.where(np.isnan(dv), 1e3, np.maximum(dv - 1, 0)))
    np.testing.assert_allclose(ev.constraint_violation, manual, rtol=1e-12)
    assert np.all(ev.constraint_violation >= 0)
    np.testing.assert_array_equal(ev.feasible, (ev.constraint_violation == 0) & ~np.isnan(pdop))
    assert np.all(front.feasible) and front.sizes["design"] <= int(ev.feasible.sum())
    np.testing.assert_array_equal(history.generation, [1, 2, 3])
    np.testing.assert_array_equal(history.n_evaluations_cum[-1], ev.sizes["design"])
    assert np.all(history.n_evaluated + history.n_cache_hits == history.n_designs)


def test_real_campaign_cache_holds_a_fresh_evaluation(real_run):
    ev = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    ok = np.flatnonzero(~np.isnan(ev.pdop_avail_pct.values))
    row = ev.isel(design=int(ok[-1]))
    fresh = evaluate_design(context_for(load_profile("ci")), **{k: row[k].item() for k in DESIGN_KEYS})
    for key in METRIC_KEYS:
        np.testing.assert_allclose(fresh[key], row[key].item(), rtol=1e-12, equal_nan=True)


# --- SIGKILL and resume through the command line -------------------------------------------------

def _journal_count(run_dir):
    path = run_dir / "evaluations.jsonl"
    return max(0, path.read_bytes().count(b"\n") - 1) if path.exists() else 0


def _run_until(args, run_dir, n_records, timeout_s=120):
    """Start the CLI, SIGKILL it once the cache holds ``n_records`` designs; False if it finished first."""
    proc = subprocess.Popen(CLI + args, cwd=PROJECT_DIR, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + timeout_s
    while proc.poll() is None and _journal_count(run_dir) < n_records:
        assert time.monotonic() < deadline, "campaign did not progress"
        time.sleep(0.01)
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        return True
    assert proc.returncode == 0, proc.stderr.read().decode()
    return False


def _cli(args, timeout_s=300):
    done = subprocess.run(CLI + args, cwd=PROJECT_DIR, capture_output=True, text=True, timeout=timeout_s)
    assert done.returncode == 0, done.stderr
    return done


KILL_SETTINGS = ["--set", "campaign.generations=7", "--set", "campaign.synthetic_delay_s=0.03"]


@pytest.fixture(scope="module")
def synthetic_reference(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("synthetic") / "reference"
    _cli(SYNTHETIC + KILL_SETTINGS + ["--workers", "0", "--run-dir", str(run_dir)])
    return run_dir


def test_sigkill_at_any_moment_then_resume_matches_uninterrupted(synthetic_reference, tmp_path):
    run_dir = tmp_path / "killed"
    # kills: before the first checkpoint, mid-generation 2, mid-generation 5; then run to the end
    assert _run_until(SYNTHETIC + KILL_SETTINGS + ["--workers", "0", "--run-dir", str(run_dir)], run_dir, 2)
    assert not (run_dir / "checkpoint.pkl").exists()
    assert _run_until(["--resume", str(run_dir), "--workers", "0", "--no-progress"], run_dir, 9)
    assert _run_until(["--resume", str(run_dir), "--workers", "0", "--no-progress"], run_dir, 27)
    _cli(["--resume", str(run_dir), "--workers", "0", "--no-progress"])
    x_ref, f_ref = final_population(synthetic_reference)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)
    keys = [tuple(r["key"]) for r in read_cache_records(run_dir)]
    assert len(keys) == len(set(keys)) == len(read_cache_records(synthetic_reference))  # nothing evaluated twice
    ref = xr.open_dataset(synthetic_reference / "evaluations.nc", engine="h5netcdf").load()
    got = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    xr.testing.assert_identical(got.drop_attrs(), ref.drop_attrs())
    # resuming a finished run only rewrites the results
    assert "0 evaluations" in _cli(["--resume", str(run_dir), "--workers", "0", "--no-progress"]).stdout


# --- a real Dask cluster on loopback ------------------------------------------------------------

def _start_worker(scheduler_address):
    return subprocess.Popen(["dask", "worker", scheduler_address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                             "--host", "127.0.0.1"], cwd=PROJECT_DIR, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env={**os.environ, "NUMBA_NUM_THREADS": "1"})


def _wait_for_workers(address, n):
    from dask.distributed import Client

    with Client(address, timeout=60) as client:
        client.wait_for_workers(n, timeout=120)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """``dask scheduler`` and two ``dask worker`` processes bound to 127.0.0.1."""
    scheduler_file = tmp_path_factory.mktemp("dask") / "scheduler.json"
    procs = [subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(scheduler_file)], cwd=PROJECT_DIR,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              env={**os.environ, "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"})]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert time.monotonic() < deadline and procs[0].poll() is None, "dask scheduler did not start"
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        workers = [_start_worker(address) for _ in range(2)]
        procs += workers
        _wait_for_workers(address, 2)
        yield address, workers
    finally:
        for proc in reversed(procs):
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in procs:
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()


def test_dask_cluster_run_equals_local_run(cluster, real_run, tmp_path):
    address, workers = cluster
    run_dir = tmp_path / "dask"
    _cli(["--profile", "ci", "--scheduler-address", address, "--run-dir", str(run_dir), "--no-progress"])
    x_ref, f_ref = final_population(real_run.run_dir)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)
    ref = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    got = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    xr.testing.assert_identical(got.drop_attrs(), ref.drop_attrs())
    used = {r["worker"].rsplit(":", 1)[1] for r in read_cache_records(run_dir)}
    assert used <= {str(w.pid) for w in workers} and len(used) == 2  # evaluated in both worker processes


def test_lost_worker_costs_only_its_designs(cluster, synthetic_reference, tmp_path):
    address, _ = cluster
    extra = _start_worker(address)
    try:
        _wait_for_workers(address, 3)
        run_dir = tmp_path / "lost"
        proc = subprocess.Popen(CLI + SYNTHETIC + KILL_SETTINGS + ["--scheduler-address", address, "--run-dir",
                                                                   str(run_dir)],
                                cwd=PROJECT_DIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while _journal_count(run_dir) < 10:
            assert time.monotonic() < deadline and proc.poll() is None, "campaign did not progress"
            time.sleep(0.01)
        extra.send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    finally:
        if extra.poll() is None:
            extra.kill()
        extra.wait()
    records = read_cache_records(run_dir)
    assert any(r["worker"].endswith(f":{extra.pid}") for r in records)  # the killed worker had taken designs
    keys = [tuple(r["key"]) for r in records]
    assert len(keys) == len(set(keys))
    x_ref, f_ref = final_population(synthetic_reference)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)


# --- notebook 06 tables and figures (synthetic or hand-made data, no campaign) ---------------------

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

    from lnss_lib.optimize import design_grid_table, settings_table

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
    from lnss_lib.optimize import constraint_label, constraint_table
    from lnss_lib.pareto import parse_constraints, satisfies, synthetic_campaign

    ev = synthetic_campaign(60, seed=3)
    pdop = ev["pdop_mean_3sigma"].values.copy()
    avail = ev["pdop_avail_pct"].values.copy()
    pdop[:4], avail[:3] = np.nan, np.nan            # impacts / no coverage fail every bound on them
    ev["pdop_mean_3sigma"], ev["pdop_avail_pct"] = ("design", pdop), ("design", avail)
    constraints = parse_constraints(ev.attrs["constraints"])
    table = constraint_table(ev, constraints)
    assert list(table.index) == ["evaluated without impact", "PDOP_3sigma <= 10", "PDOP availability >= 70 %",
                                 "Delta-V_total <= 1 km/s/yr", "n_sat <= 20",
                                 "navigation bounds only (no Delta-V bound)", "all Table 3 bounds (feasible)"]
    assert table.loc["evaluated without impact", "designs"] == 57
    assert table.loc["PDOP_3sigma <= 10", "designs"] == int(np.sum(pdop[4:] <= 10.0))
    assert table.loc["PDOP availability >= 70 %", "designs"] == int(np.sum(avail[3:] >= 70.0))
    assert table.loc["Delta-V_total <= 1 km/s/yr", "designs"] == int(np.sum(ev.dv_total_kms_per_year.values <= 1.0))
    navigation = satisfies(ev, [c for c in constraints if c[0] != "dv_total_kms_per_year"])
    assert table.loc["navigation bounds only (no Delta-V bound)", "designs"] == int(navigation.sum())
    assert table.loc["all Table 3 bounds (feasible)", "designs"] == int(ev.feasible.sum())
    np.testing.assert_allclose(table["share (%)"], 100.0 * table["designs"] / 60)
    # other bounds: labels and counts follow the constraints, not fixed Table 3 numbers
    looser = constraint_table(ev, [("pdop_mean_3sigma", "max", 5.0), ("dv_total_kms_per_year", "max", 2.0)])
    assert looser.loc["PDOP_3sigma <= 5", "designs"] == int(np.sum(pdop[4:] <= 5.0))
    assert looser.loc["Delta-V_total <= 2 km/s/yr", "designs"] == int(np.sum(ev.dv_total_kms_per_year.values <= 2.0))
    assert looser.loc["navigation bounds only (no Delta-V bound)", "designs"] == int(np.sum(pdop[4:] <= 5.0))
    assert constraint_label("hdop_avail_pct", "min", 90.5) == "HDOP availability >= 90.5 %"
    with pytest.raises(ValueError, match="'between'"):
        constraint_table(ev, [("n_sat", "between", 3.0)])
    empty = constraint_table(ev.isel(design=slice(0, 0)), constraints)
    assert (empty["designs"] == 0).all() and (empty["share (%)"] == 0).all()


def test_throughput_table_from_hand_made_history(tmp_path):
    from lnss_lib.optimize import run_throughput_table, steady_designs_per_s, throughput_table

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
    import lnss_lib.optimize as optimize
    import lnss_lib.pipeline as pipeline
    from lnss_lib.optimize import export_results, latest_run_dir, load_or_run

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
    assert run_dir == newer.run_dir and f"loaded {newer.run_dir}" in capsys.readouterr().out
    expected = export_results(newer.run_dir)
    for got, want in zip((ev, front, history), expected):
        xr.testing.assert_identical(got.drop_attrs(), want.drop_attrs())
    assert history.sizes["generation"] == 3 and len(records) == ev.sizes["design"]
    real_run_campaign = optimize.run_campaign

    def synthetic_run(name, progress):
        result = real_run_campaign(name, overrides=synthetic, workers=0, run_dir=folders[name] / "run_x",
                                   progress=progress)
        optimize.write_results(result.run_dir, folders[name])
        return result

    monkeypatch.setattr(optimize, "run_campaign", synthetic_run)
    run_dir, ev, front, history, records = load_or_run("ci")
    assert run_dir == folders["ci"] / "run_x" and "ran " in capsys.readouterr().out
    assert history.sizes["generation"] == 2 and len(records) == ev.sizes["design"] > 0


def test_campaign_figures_carry_the_data():
    from lnss_lib.figures import campaign_convergence, campaign_throughput, designs_pdop_deltav
    from lnss_lib.pareto import pareto_front, synthetic_campaign

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
