"""Every command with bad input: one line on stderr naming the value, exit 2 (bad input) or 1 (failure),
no traceback, no existing file changed and nothing left behind (issue 13). In-process through
``lnss_lib.__main__.main`` except the concurrency test, which needs two processes."""

import errno
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from lnss_lib import config
from lnss_lib.__main__ import main
from lnss_lib.campaign.rundir import RunLock
from lnss_lib.config import PROJECT_DIR, load_profile
from lnss_lib.errors import ConfigError

EPOCH = ["--epoch-tdb", "2025-05-01T00:00:00"]
ELFO = ["--elements", "6143", "0.6", "51.7", "0", "90", "0"]
WALKER = {"--sma-km": "6143", "--ecc": "0.6", "--aop-deg": "90", "--inc-deg": "51.7", "--planes": "2",
          "--sats-per-plane": "2"}
SYNTHETIC = ["campaign", "--profile", "ci", "--evaluator", "synthetic", "--workers", "0", "--no-progress"]


def walker(**changes):
    args = dict(WALKER, **{f"--{k.replace('_', '-')}": v for k, v in changes.items()})
    return ["evaluate", "--profile", "ci"] + [item for pair in args.items() for item in pair]


def elements(*values):
    return ["propagate", *EPOCH, "--elements", *values, "--days", "0.1"]


def one_line_error(capsys, code, expected_code, *needles):
    """The command's stderr is one line, no traceback, naming every needle; the exit code as expected."""
    err = capsys.readouterr().err.strip()
    assert code == expected_code, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


BAD_VALUES = [
    # propagate: numbers of the command line
    (["propagate", *EPOCH, *ELFO, "--days", "nan"], "--days nan"),
    (["propagate", *EPOCH, *ELFO, "--days", "inf"], "--days inf"),
    (["propagate", *EPOCH, *ELFO, "--days", "-1"], "--days -1"),
    (["propagate", *EPOCH, *ELFO, "--days", "one"], "'one'"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--step-s", "0"], "--step-s 0"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--srp-cr-area-mass", "nan"], "--srp-cr-area-mass nan"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--srp-cr-area-mass", "inf"], "--srp-cr-area-mass inf"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--degree", "101"], "--degree 101"),
    (elements("6143", "1.0", "51.7", "0", "90", "0"), "e = 1.0"),
    (elements("0", "0.6", "51.7", "0", "90", "0"), "a_km = 0.0"),
    (elements("6143", "0.6", "181", "0", "90", "0"), "inc_deg = 181.0"),
    (elements("6143", "0.6", "-1", "0", "90", "0"), "inc_deg = -1.0"),
    (elements("6143", "nan", "51.7", "0", "90", "0"), "e = nan"),
    (elements("6143", "0.6", "51.7", "inf", "90", "0"), "raan_deg = inf"),
    (["propagate", *EPOCH, "--state-km", "1e4", "0", "0", "0", "nan", "0", "--days", "1"], "nan"),
    (["propagate", "--epoch-tdb", "2025-13-45", *ELFO, "--days", "1"], "YYYY-MM-DDTHH:MM:SS"),
    (["propagate", "--epoch-tdb", "yesterday", *ELFO, "--days", "1"], "'yesterday'"),
    (["propagate", "--epoch-tdb", "2060-01-01T00:00:00", *ELFO, "--days", "1"], "1900-01-01 to 2051-01-01"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--out", "/nonexistent/folder/x.csv"], "/nonexistent/folder"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--out", "orbit.txt"], "orbit.txt"),
    # evaluate: the same element checks, and the counts
    (walker(ecc="1.0"), "--ecc"),
    (walker(ecc="nan"), "e = nan"),
    (walker(sma_km="-5"), "a_km = -5.0"),
    (walker(inc_deg="200"), "inc_deg = 200.0"),
    (walker(planes="0"), "n_planes = 0"),
    (walker(sats_per_plane="0"), "sats_per_plane = 0"),
    (walker(planes="two"), "'two'"),
    (["evaluate", "--profile", "ci", "--sma-km", "6143"], "missing --ecc"),
    (["evaluate", "--constellation", "/nonexistent/constellation.toml"], "/nonexistent/constellation.toml"),
    (["evaluate", "--profile", "nosuchprofile", *sum(map(list, WALKER.items()), [])], "'nosuchprofile'"),
    # --set: unknown keys, wrong types, non-finite and out-of-range values, on every command
    (walker() + ["--set", "spacecraft.cr=nan"], "spacecraft.cr = nan"),
    (walker() + ["--set", "spacecraft.crr=1.3"], "spacecraft.cr"),
    (walker() + ["--set", "dop.elevation_mask_deg=95"], "[0, 90]"),
    (walker() + ["--set", "epoch.duration_days=inf"], "epoch.duration_days = inf"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--set", "gravity.degree=3.5"], "gravity.degree = 3.5"),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--set", "spacecraft.area_m2=0"], "spacecraft.area_m2 = 0"),
    (["reproduce", "--profile", "ci", "--set", "campaign.populaton=4"], "campaign.population"),
    (["reproduce", "--profile", "ci", "--set", "integrator.settings.paper.rtol=-1e-6"], "rtol = -1e-06"),
    (SYNTHETIC + ["--set", "campaign.populaton=4"], "did you mean campaign.population"),
    (SYNTHETIC + ["--set", "campaign.population='many'"], "campaign.population = 'many'"),
    (SYNTHETIC + ["--set", "campaign.population"], "SECTION.KEY=VALUE"),
    (SYNTHETIC + ["--set", "campaign.max_errors=-1"], "campaign.max_errors = -1"),
    (SYNTHETIC + ["--workers", "-2"], "--workers -2"),
    (["campaign", "--resume", "/nonexistent/run"], "/nonexistent/run"),
]


@pytest.mark.parametrize("argv, needle", BAD_VALUES, ids=[" ".join(a[-3:]) for a, _ in BAD_VALUES])
def test_bad_value_is_one_line_exit_2(capsys, tmp_path, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    before = set(os.listdir(tmp_path))
    one_line_error(capsys, main(argv), 2, needle)
    assert set(os.listdir(tmp_path)) == before


def test_debug_shows_the_traceback():
    with pytest.raises(ConfigError, match="e = 1.0"):
        main(elements("6143", "1.0", "51.7", "0", "90", "0") + ["--debug"])


def test_impact_is_a_failure_with_its_time(capsys):
    code = main(["propagate", *EPOCH, "--elements", "5900", "0.7", "80", "0", "0", "180", "--days", "20",
                 "--degree", "8", "--step-s", "3600"])
    one_line_error(capsys, code, 1, "hits the Moon", "days after the start")


def test_full_disk_keeps_the_existing_output(capsys, tmp_path, monkeypatch):
    """A writer that fails half way (ENOSPC) leaves the previous file intact and no temporary file."""
    from lnss_lib import atomicio

    out = tmp_path / "orbit.csv"
    out.write_text("previous result\n")

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomicio.os, "fsync", full)
    code = main(["propagate", *EPOCH, *ELFO, "--days", "0.05", "--degree", "2", "--out", str(out)])
    one_line_error(capsys, code, 1, str(out), "No space left on device")
    assert out.read_text() == "previous result\n" and os.listdir(tmp_path) == ["orbit.csv"]
    nc = tmp_path / "orbit.nc"
    nc.write_bytes(b"old")
    code = main(["propagate", *EPOCH, *ELFO, "--days", "0.05", "--degree", "2", "--out", str(nc)])
    one_line_error(capsys, code, 1, str(nc))
    assert nc.read_bytes() == b"old" and sorted(os.listdir(tmp_path)) == ["orbit.csv", "orbit.nc"]


def test_bad_input_leaves_an_existing_output_alone(capsys, tmp_path):
    out = tmp_path / "orbit.csv"
    out.write_text("previous result\n")
    one_line_error(capsys, main(["propagate", *EPOCH, *ELFO, "--days", "nan", "--out", str(out)]), 2, "--days nan")
    assert out.read_text() == "previous result\n"


def test_atomic_writers_never_truncate(tmp_path, monkeypatch):
    from lnss_lib import atomicio

    target = tmp_path / "table.csv"
    target.write_text("a,b\n1,2\n")
    monkeypatch.setattr(atomicio.os, "replace", lambda *a: (_ for _ in ()).throw(OSError(errno.EIO, "I/O error")))
    with pytest.raises(OSError, match="I/O error"):
        atomicio.write_text_atomic(target, "x")
    assert target.read_text() == "a,b\n1,2\n" and os.listdir(tmp_path) == ["table.csv"]


@pytest.fixture
def params_dir(tmp_path, monkeypatch):
    """A params folder holding paper.toml and whatever a test writes next to it."""
    folder = tmp_path / "params"
    folder.mkdir()
    shutil.copy(config.PARAMS_DIR / "paper.toml", folder / "paper.toml")
    monkeypatch.setattr(config, "PARAMS_DIR", folder)
    return folder


@pytest.mark.parametrize("text, needles", [
    ('[profile]\ninherits = "paper"\n[spacecraft]\ncr = \n', ("bad.toml", "TOML syntax error", "line 4")),
    ('[profile]\ninherits = "paper"\n\n[spacecraft]\ncr = "high"\n', ("bad.toml, line 5", "spacecraft.cr = 'high'")),
    ('[profile]\ninherits = "paper"\n[spacecraft]\nmass_kg = -1.0\n', ("bad.toml, line 4", "mass_kg = -1.0", "(0, inf)")),
    ('[profile]\ninherits = "paper"\n[gravty]\ndegree = 8\n', ("unknown key gravty", "did you mean gravity")),
    ('[profile]\nname = "bad"\n[epoch]\nstart_tdb = "2025-05-01T00:00:00"\n', ("missing key",)),
])
def test_profile_file_errors_name_file_and_line(capsys, params_dir, text, needles):
    (params_dir / "bad.toml").write_text(text)
    one_line_error(capsys, main(walker() + ["--profile", "bad"]), 2, *needles)


def test_python_api_checks_the_same_values():
    with pytest.raises(ConfigError, match="spacecraft.cr = nan"):
        load_profile("ci", overrides={"spacecraft": {"cr": float("nan")}})
    with pytest.raises(ConfigError, match="unknown key gps.gain_fle"):
        load_profile("ci", overrides={"gps": {"gain_fle": "x.csv"}})
    from lnss_lib.gps import load_gain_pattern

    for path, content, needle in (("empty.csv", "", "header line"), ("text.csv", "off_boresight_deg,g\n0,1\nx,2\n", "line 3"),
                                  ("nan.csv", "off_boresight_deg,g\n0,1\n1,nan\n", "line 3")):
        file = config.PROJECT_DIR / "outputs" / f".test_{path}"
        file.parent.mkdir(exist_ok=True)
        file.write_text(content)
        try:
            with pytest.raises(ConfigError, match=needle):
                load_gain_pattern(file, "g")
        finally:
            file.unlink()


# ---- campaign: evaluation errors, folders, locks, resume ------------------------------------------------------

def _synthetic_run(tmp_path, name="run", extra=()):
    run_dir = tmp_path / name
    code = main(SYNTHETIC + ["--run-dir", str(run_dir), "--set", "campaign.generations=2", *extra])
    assert code == 0
    return run_dir


def test_crashing_evaluator_stops_the_campaign(capsys, tmp_path, monkeypatch):
    from lnss_lib.campaign import tasks

    real = tasks.synthetic_evaluation

    def crash_on_some(profile, sma_km, *args, **kwargs):
        if sma_km > 12000.0:
            raise FloatingPointError("gain table holds NaN")
        return real(profile, sma_km, *args, **kwargs)

    monkeypatch.setattr(tasks, "synthetic_evaluation", crash_on_some)
    run_dir = tmp_path / "run"
    code = main(SYNTHETIC + ["--run-dir", str(run_dir)])
    one_line_error(capsys, code, 1, "campaign stopped", "1 evaluation error", "campaign.max_errors = 0",
                   "gain table holds NaN")
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    errors = ev["error"].values
    assert (errors != "").sum() == 1 and "FloatingPointError: gain table holds NaN" in errors[errors != ""][0]
    assert not ev["feasible"].values[errors != ""].any()
    # with a tolerance the run goes on and counts the errors in its summary
    code = main(SYNTHETIC + ["--run-dir", str(tmp_path / "tolerant"), "--set", "campaign.max_errors=1000"])
    out = capsys.readouterr().out
    assert code == 0 and " evaluation errors)" in out and "(0 evaluation errors)" not in out.replace(", 0 eval", "")


def test_stopped_campaign_resumes_once_the_cause_is_gone(capsys, tmp_path, monkeypatch):
    """Issue 21 item 7: a run stopped by an evaluation error evaluates that design again when resumed, and
    ends as the uninterrupted run once the cause is removed."""
    from lnss_lib.campaign import final_population, tasks

    real = tasks.synthetic_evaluation
    reference = _synthetic_run(tmp_path, "reference")
    with monkeypatch.context() as patch:
        patch.setattr(tasks, "synthetic_evaluation", lambda profile, sma_km, *args, **kwargs: (
            (_ for _ in ()).throw(FloatingPointError("gain table holds NaN")) if sma_km > 12000.0
            else real(profile, sma_km, *args, **kwargs)))
        run_dir = tmp_path / "stopped"
        code = main(SYNTHETIC + ["--run-dir", str(run_dir), "--set", "campaign.generations=2"])
        one_line_error(capsys, code, 1, "campaign stopped", "gain table holds NaN")
        code = main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"])
        one_line_error(capsys, code, 1, "campaign stopped", "gain table holds NaN")   # the cause is still there
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0
    for got, want in zip(final_population(run_dir), final_population(reference)):
        np.testing.assert_array_equal(got, want)
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    assert (ev["error"].values == "").all() and ev.attrs["n_evaluation_errors"] == 0


def test_deleting_the_lock_file_does_not_unlock_a_run(capsys, tmp_path):
    """Issue 21 item 6: the lock is an flock on the run folder; run.lock only names the owner."""
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    lock = RunLock(run_dir)
    try:
        (run_dir / "run.lock").unlink()
        one_line_error(capsys, main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]), 1,
                       "in use by another campaign process")
    finally:
        lock.release()
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_forged_checkpoint_is_one_line_and_runs_nothing(capsys, tmp_path):
    """Issue 21 item 9: --resume of a run folder whose checkpoint would run code refuses it (exit 1)."""
    import pickle

    class Exploit:
        def __reduce__(self):
            return os.system, (f"touch {tmp_path / 'code_ran'}",)

    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    (run_dir / "checkpoint.pkl").write_bytes(pickle.dumps(Exploit()))
    one_line_error(capsys, main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]), 1,
                   "checkpoint.pkl", "posix.system", "refused")
    assert not (tmp_path / "code_ran").exists()


def test_rejected_campaign_leaves_no_folder(capsys, tmp_path):
    for bad in (["--set", "spacecraft.cr=nan"], ["--set", "campaign.population=1"], ["--set", "campaign.seed=1.5"]):
        code = main(SYNTHETIC + ["--run-dir", str(tmp_path / "new" / "run"), *bad])
        one_line_error(capsys, code, 2, bad[1].split("=")[0])
        assert not (tmp_path / "new").exists()


def test_resume_refuses_edited_settings_and_a_locked_run(capsys, tmp_path):
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    run_file = run_dir / "run.json"
    original = run_file.read_text()
    edited = json.loads(original)
    edited["profile"]["campaign"]["population"] = 8
    run_file.write_text(json.dumps(edited))
    one_line_error(capsys, main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]), 2, "differ from those the run")
    run_file.write_text(original)
    lock = RunLock(run_dir)
    try:
        one_line_error(capsys, main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]), 1,
                       "in use by another campaign process", f"pid {os.getpid()}")
    finally:
        lock.release()
    (run_dir / "run.lock").write_text("999999999\n")     # stale: its process is gone, no flock held
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_truncated_checkpoint_says_how_to_recover(capsys, tmp_path):
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    checkpoint = run_dir / "checkpoint.pkl"
    checkpoint.write_bytes(checkpoint.read_bytes()[:100])
    one_line_error(capsys, main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]), 1,
                   "truncated or corrupt", "delete it and resume", "evaluations.jsonl")
    checkpoint.unlink()
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_torn_journal_line_costs_one_design(capsys, tmp_path):
    reference = _synthetic_run(tmp_path, "reference")
    run_dir = _synthetic_run(tmp_path, "torn", extra=["--max-generations", "1"])
    journal = run_dir / "evaluations.jsonl"
    data = journal.read_bytes()
    lines = data.splitlines(keepends=True)
    journal.write_bytes(b"".join(lines[:-1]) + lines[-1][:20] + b"\n")   # last record torn, newline after it
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0
    ref = xr.open_dataset(reference / "evaluations.nc", engine="h5netcdf").load()
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    assert ev.sizes["design"] == ref.sizes["design"]
    assert np.array_equal(np.sort(ev["sma_km"].values), np.sort(ref["sma_km"].values))


def test_two_resumes_of_one_run_one_refuses(tmp_path):
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1", "--set", "campaign.synthetic_delay_s=0.4",
                                              "--set", "campaign.generations=3"])
    command = [sys.executable, "-m", "lnss_lib", "campaign", "--resume", str(run_dir), "--workers", "0",
               "--no-progress"]
    first = subprocess.Popen(command, cwd=PROJECT_DIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (run_dir / "run.lock").read_text().strip().startswith(str(first.pid)):
        assert time.monotonic() < deadline and first.poll() is None, first.communicate()
        time.sleep(0.05)
    second = subprocess.run(command, cwd=PROJECT_DIR, capture_output=True, text=True, timeout=120)
    out, err = first.communicate(timeout=120)
    assert first.returncode == 0, err
    assert second.returncode == 1 and "in use by another campaign process" in second.stderr
    assert len(second.stderr.strip().splitlines()) == 1 and "Traceback" not in second.stderr
    keys = [tuple(json.loads(line)["key"]) for line in (run_dir / "evaluations.jsonl").read_text().splitlines()[1:]]
    assert len(keys) == len(set(keys))
