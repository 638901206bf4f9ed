"""Command-line helpers shared by the campaign tests: run, SIGKILL and count journal lines; a Dask cluster of
separate processes on the loopback."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time

from lnss_lib.config import PROJECT_DIR

CLI = [sys.executable, "-m", "lnss_lib", "campaign"]


SYNTHETIC = ["--profile", "ci", "--evaluator", "synthetic", "--no-progress"]


def _journal_count(run_dir):
    path = run_dir / "evaluations.jsonl"
    return max(0, path.read_bytes().count(b"\n") - 1) if path.exists() else 0


def _run_until(args, run_dir, n_records, timeout_s=120):
    """Start the CLI, SIGKILL it once the cache holds ``n_records`` designs; False if it finished first."""
    proc = subprocess.Popen(
        CLI + args, cwd=PROJECT_DIR, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
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
    done = subprocess.run(
        CLI + args, cwd=PROJECT_DIR, capture_output=True, text=True, timeout=timeout_s
    )
    assert done.returncode == 0, done.stderr
    return done


KILL_SETTINGS = ["--set", "campaign.generations=7", "--set", "campaign.synthetic_delay_s=0.03"]


DASK = [sys.executable, "-m", "dask"]
"""The ``dask`` command of this interpreter (not whatever ``dask`` is first on PATH)."""


def _start_worker(scheduler_address, env=None):
    """A ``dask worker`` process (one thread, no nanny: killed, it stays dead) with ``env`` added to this one's."""
    return subprocess.Popen(
        [
            *DASK,
            "worker",
            scheduler_address,
            "--nthreads",
            "1",
            "--no-nanny",
            "--no-dashboard",
            "--host",
            "127.0.0.1",
        ],
        cwd=PROJECT_DIR,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "NUMBA_NUM_THREADS": "1", **(env or {})},
    )


def _wait_for_workers(address, n):
    from dask.distributed import Client

    with Client(address, timeout=60) as client:
        client.wait_for_workers(n, timeout=120)


@contextlib.contextmanager
def dask_cluster(folder, n_workers, worker_env=None):
    """``dask scheduler`` and ``n_workers`` ``dask worker`` processes bound to 127.0.0.1 (a task lost with its worker
    is not retried by the scheduler: the campaign resubmits it); yields ``(address, worker processes)``."""
    scheduler_file = folder / "scheduler.json"
    procs = [
        subprocess.Popen(
            [
                *DASK,
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(scheduler_file),
            ],
            cwd=PROJECT_DIR,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env={**os.environ, "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"},
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert time.monotonic() < deadline and procs[0].poll() is None, (
                "dask scheduler did not start"
            )
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        workers = [_start_worker(address, worker_env) for _ in range(n_workers)]
        procs += workers
        _wait_for_workers(address, n_workers)
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
