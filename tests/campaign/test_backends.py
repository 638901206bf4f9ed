"""Evaluation tasks and backends: the synthetic evaluator, a Dask cluster on loopback against the in-process
run, and a lost worker."""

import math
import os
import signal
import subprocess
import time

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import final_population, read_cache_records, synthetic_evaluation
from lnss_lib.config import PROJECT_DIR
from lnss_lib.keys import METRIC_KEYS
from lnss_lib.settings import load_settings

from .helpers import (
    CLI,
    KILL_SETTINGS,
    SYNTHETIC,
    _cli,
    _journal_count,
    _start_worker,
    _wait_for_workers,
    dask_cluster,
)


def test_synthetic_evaluator_flags_impact():
    profile = load_settings("ci")
    hit = synthetic_evaluation(profile, 4000.0, 0.8, 90.0, 50.0, 2, 2)
    assert (
        hit["impact"]
        and not hit["evaluated"]
        and math.isnan(hit["pdop_mean_3sigma"])
        and hit["n_sat"] == 4
    )
    ok = synthetic_evaluation(profile, 8000.0, 0.5, 90.0, 80.0, 4, 4)
    assert ok["evaluated"] and all(math.isfinite(ok[k]) for k in METRIC_KEYS)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """``dask scheduler`` and two ``dask worker`` processes bound to 127.0.0.1."""
    with dask_cluster(tmp_path_factory.mktemp("dask"), 2) as running:
        yield running


def test_dask_cluster_run_equals_local_run(cluster, real_run, tmp_path):
    address, workers = cluster
    run_dir = tmp_path / "dask"
    _cli(
        [
            "--profile",
            "ci",
            "--scheduler-address",
            address,
            "--run-dir",
            str(run_dir),
            "--no-progress",
        ]
    )
    x_ref, f_ref = final_population(real_run.run_dir)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)
    ref = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    got = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    xr.testing.assert_identical(got.drop_attrs(), ref.drop_attrs())
    used = {r["worker"].rsplit(":", 1)[1] for r in read_cache_records(run_dir)}
    assert (
        used <= {str(w.pid) for w in workers} and len(used) == 2
    )  # evaluated in both worker processes


def test_lost_worker_costs_only_its_designs(cluster, synthetic_reference, tmp_path):
    address, _ = cluster
    extra = _start_worker(address)
    try:
        _wait_for_workers(address, 3)
        run_dir = tmp_path / "lost"
        proc = subprocess.Popen(
            CLI
            + SYNTHETIC
            + KILL_SETTINGS
            + ["--scheduler-address", address, "--run-dir", str(run_dir)],
            cwd=PROJECT_DIR,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
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
    assert any(
        r["worker"].endswith(f":{extra.pid}") for r in records
    )  # the killed worker had taken designs
    keys = [tuple(r["key"]) for r in records]
    assert len(keys) == len(set(keys))
    x_ref, f_ref = final_population(synthetic_reference)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)


def _sigint_guarded(pid: int) -> bool:
    """Whether process ``pid`` blocks or ignores SIGINT (``SigBlk`` / ``SigIgn`` of /proc/PID/status)."""
    status = dict(
        line.split(":\t", 1)
        for line in open(f"/proc/{pid}/status").read().splitlines()
        if ":\t" in line
    )
    bit = 1 << (signal.SIGINT - 1)
    return bool((int(status["SigBlk"], 16) | int(status["SigIgn"], 16)) & bit)


@pytest.mark.skipif(
    not os.path.exists(f"/proc/{os.getpid()}/status"), reason="reads signal masks from /proc"
)
def test_local_workers_keep_the_sigint_guard_and_a_ctrl_c_at_their_start_is_honoured(monkeypatch):
    """Local workers never see the terminal's Ctrl-C: the first ones and one the nanny restarts after a crash (which
    ran without the guard: only the first ones inherited an ignored SIGINT). A Ctrl-C while the workers start is
    raised once they are up and the cluster is closed (it was ignored, and the campaign went on); this process
    takes SIGINT afterwards as it did before."""
    from dask.distributed import LocalCluster

    from lnss_lib.campaign import backends

    def task(shared, item, numba_threads=0):
        return os.getpid()

    # a shell's background job starts with SIGINT ignored: compare with the state found
    guarded_before = _sigint_guarded(os.getpid())
    backend = backends.DaskBackend(None, task, max_resubmits=1, n_workers=2)
    try:
        first = set(backend.client.run(os.getpid).values())
        assert len(first) == 2 and all(_sigint_guarded(pid) for pid in first)
        os.kill(min(first), signal.SIGKILL)  # a crashed worker: its nanny starts another
        # a nanny's restart imports dask and lnss_lib afresh: seconds on a quiet machine, minutes under load
        deadline, now = time.monotonic() + 600, first
        while time.monotonic() < deadline and not (len(now) == 2 and now - first):
            time.sleep(0.5)
            now = set(backend.client.run(os.getpid, on_error="ignore").values())
        restarted = now - first
        assert len(restarted) == 1 and all(_sigint_guarded(pid) for pid in restarted)
    finally:
        backend.close()
    assert _sigint_guarded(os.getpid()) == guarded_before

    started = []

    class CtrlCWhileStarting(LocalCluster):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            started.append(self)
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C before the workers are all up

    monkeypatch.setattr("dask.distributed.LocalCluster", CtrlCWhileStarting)
    with pytest.raises(KeyboardInterrupt):
        backends.DaskBackend(None, task, max_resubmits=1, n_workers=1)
    assert started and started[0].status.name == "closed"
    assert _sigint_guarded(os.getpid()) == guarded_before
