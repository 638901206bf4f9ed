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
from lnss_lib.objectives import DESIGN_KEYS, METRIC_KEYS, context_for, evaluate_design
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
