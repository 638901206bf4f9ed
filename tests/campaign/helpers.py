"""Command-line helpers shared by the campaign tests: run, SIGKILL and count journal lines."""

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
