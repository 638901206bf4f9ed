"""Every command with bad input: one line on stderr naming the value, exit 2 (bad input) or 1 (failure),
no traceback, no existing file changed and nothing left behind. In-process through
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

from lnss_lib import config, profile_rules
from lnss_lib.__main__ import main
from lnss_lib.campaign.rundir import RunLock, run_checksum
from lnss_lib.config import PROJECT_DIR
from lnss_lib.errors import ConfigError, SpiceError
from lnss_lib.settings import load_settings

EPOCH = ["--epoch-tdb", "2025-05-01T00:00:00"]
ELFO = ["--elements", "6143", "0.6", "51.7", "0", "90", "0"]
WALKER = {
    "--sma-km": "6143",
    "--ecc": "0.6",
    "--aop-deg": "90",
    "--inc-deg": "51.7",
    "--planes": "2",
    "--sats-per-plane": "2",
}
SYNTHETIC = [
    "campaign",
    "--profile",
    "ci",
    "--evaluator",
    "synthetic",
    "--workers",
    "0",
    "--no-progress",
]


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
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--srp-cr-area-mass", "nan"],
        "--srp-cr-area-mass nan",
    ),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--srp-cr-area-mass", "inf"],
        "--srp-cr-area-mass inf",
    ),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--degree", "101"], "--degree 101"),
    (elements("6143", "1.0", "51.7", "0", "90", "0"), "e = 1.0"),
    (elements("0", "0.6", "51.7", "0", "90", "0"), "sma_km = 0.0"),
    (elements("6143", "0.6", "181", "0", "90", "0"), "inc_deg = 181.0"),
    (elements("6143", "0.6", "-1", "0", "90", "0"), "inc_deg = -1.0"),
    (elements("6143", "nan", "51.7", "0", "90", "0"), "e = nan"),
    (elements("6143", "0.6", "51.7", "inf", "90", "0"), "raan_deg = inf"),
    (["propagate", *EPOCH, "--state-km", "1e4", "0", "0", "0", "nan", "0", "--days", "1"], "nan"),
    (["propagate", "--epoch-tdb", "2025-13-45", *ELFO, "--days", "1"], "YYYY-MM-DDTHH:MM:SS"),
    (["propagate", "--epoch-tdb", "yesterday", *ELFO, "--days", "1"], "'yesterday'"),
    (
        ["propagate", "--epoch-tdb", "2060-01-01T00:00:00", *ELFO, "--days", "1"],
        "1900-01-01 to 2051-01-01",
    ),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--out", "/nonexistent/folder/x.csv"],
        "/nonexistent/folder",
    ),
    (["propagate", *EPOCH, *ELFO, "--days", "1", "--out", "orbit.txt"], "orbit.txt"),
    # evaluate: the same element checks, and the counts
    (walker(ecc="1.0"), "--ecc"),
    (walker(ecc="nan"), "e = nan"),
    (walker(sma_km="-5"), "sma_km = -5.0"),
    (walker(inc_deg="200"), "inc_deg = 200.0"),
    (walker(planes="0"), "n_planes = 0"),
    (walker(sats_per_plane="0"), "sats_per_plane = 0"),
    (walker(planes="two"), "'two'"),
    (["evaluate", "--profile", "ci", "--sma-km", "6143"], "missing --ecc"),
    (
        ["evaluate", "--constellation", "/nonexistent/constellation.toml"],
        "/nonexistent/constellation.toml",
    ),
    (
        ["evaluate", "--profile", "nosuchprofile", *sum(map(list, WALKER.items()), [])],
        "'nosuchprofile'",
    ),
    # --set: unknown keys, wrong types, non-finite and out-of-range values, on every command
    (walker() + ["--set", "spacecraft.cr=nan"], "spacecraft.cr = nan"),
    (walker() + ["--set", "spacecraft.crr=1.3"], "spacecraft.cr"),
    (walker() + ["--set", "dop.elevation_mask_deg=95"], "[0, 90]"),
    (walker() + ["--set", "epoch.duration_days=inf"], "epoch.duration_days = inf"),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--set", "gravity.degree=3.5"],
        "gravity.degree = 3.5",
    ),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--set", "spacecraft.area_m2=0"],
        "spacecraft.area_m2 = 0",
    ),
    (["reproduce", "--profile", "ci", "--set", "campaign.populaton=4"], "campaign.population"),
    (
        ["reproduce", "--profile", "ci", "--set", "integrator.settings.paper.rtol=-1e-6"],
        "rtol = -1e-06",
    ),
    (SYNTHETIC + ["--set", "campaign.populaton=4"], "did you mean campaign.population"),
    (SYNTHETIC + ["--set", "campaign.population='many'"], "campaign.population = 'many'"),
    (SYNTHETIC + ["--set", "campaign.population"], "SECTION.KEY=VALUE"),
    (SYNTHETIC + ["--set", "campaign.max_errors=-1"], "campaign.max_errors = -1"),
    (SYNTHETIC + ["--workers", "-2"], "--workers -2"),
    (["campaign", "--resume", "/nonexistent/run"], "/nonexistent/run"),
    # tolerances a double cannot meet (the compiled loop failed and the command exited 0)
    (
        [
            "propagate",
            *EPOCH,
            *ELFO,
            "--days",
            "0.1",
            "--set",
            "integrator.settings.paper.rtol=1e-300",
            "--set",
            "integrator.settings.paper.atol=1e-300",
        ],
        "integrator.settings.paper.rtol = 1e-300",
    ),
    (walker() + ["--set", "stability.atol=1e-20"], "stability.atol = 1e-20"),
    # a text setting outside its allowed set (was accepted, then every design "infeasible")
    (walker() + ["--set", "frames.element_frame=nosuch"], "frames.element_frame = 'nosuch'"),
    (["reproduce", "--profile", "ci", "--set", "dop.los_axes=up"], "allowed: 'moon_fixed', 'enu'"),
    (SYNTHETIC + ["--set", "deltav.model=magic"], "deltav.model = 'magic'"),
    # dates: one strict ISO 8601 reader (01-05-2025 and 1/5/2025 ran from 2025-01-05; a zone was accepted)
    (
        ["propagate", "--epoch-tdb", "01-05-2025", *ELFO, "--days", "1"],
        "'01-05-2025' is not an ISO 8601 date",
    ),
    (["propagate", "--epoch-tdb", "1/5/2025", *ELFO, "--days", "1"], "YYYY-MM-DDTHH:MM:SS"),
    (
        ["propagate", "--epoch-tdb", "2025-05-01T00:00:00Z", *ELFO, "--days", "1"],
        "with a zone, which is not allowed",
    ),
    (
        ["propagate", "--epoch-tdb", "2025-05-01T05:00:00+05:00", *ELFO, "--days", "1"],
        "with a zone",
    ),
    (["propagate", "--epoch-tdb", "2025-02-30", *ELFO, "--days", "1"], "no calendar date"),
    (walker() + ["--set", 'epoch.start_tdb="01-05-2025"'], "epoch.start_tdb = '01-05-2025'"),
    (
        walker() + ["--set", 'benchmark.epochs_tdb=["2025-05-01T00:00:00-07:00"]'],
        "benchmark.epochs_tdb",
    ),
    (walker() + ["--set", 'gps.exclude_launched_after="20250530"'], "YYYY-MM-DD"),
    # a scheduler address checked before work (nonsense was an internal error, port 99999 waited 60 s)
    (
        SYNTHETIC + ["--scheduler-address", "nonsense"],
        "--scheduler-address 'nonsense' is not a Dask scheduler",
    ),
    (SYNTHETIC + ["--scheduler-address", "tcp://127.0.0.1:99999"], "PORT in 1-65535"),
]


@pytest.mark.parametrize("argv, needle", BAD_VALUES, ids=[" ".join(a[-3:]) for a, _ in BAD_VALUES])
def test_bad_value_is_one_line_exit_2(capsys, tmp_path, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    before = set(os.listdir(tmp_path))
    one_line_error(capsys, main(argv), 2, needle)
    assert set(os.listdir(tmp_path)) == before


def test_impact_is_a_failure_with_its_time(capsys):
    code = main(
        [
            "propagate",
            *EPOCH,
            "--elements",
            "5900",
            "0.7",
            "80",
            "0",
            "0",
            "180",
            "--days",
            "20",
            "--degree",
            "8",
            "--step-s",
            "3600",
        ]
    )
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
    one_line_error(
        capsys,
        main(["propagate", *EPOCH, *ELFO, "--days", "nan", "--out", str(out)]),
        2,
        "--days nan",
    )
    assert out.read_text() == "previous result\n"


def test_atomic_writers_never_truncate(tmp_path, monkeypatch):
    from lnss_lib import atomicio

    target = tmp_path / "table.csv"
    target.write_text("a,b\n1,2\n")
    monkeypatch.setattr(
        atomicio.os, "replace", lambda *a: (_ for _ in ()).throw(OSError(errno.EIO, "I/O error"))
    )
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


@pytest.mark.parametrize(
    "text, needles",
    [
        (
            '[profile]\ninherits = "paper"\n[spacecraft]\ncr = \n',
            ("bad.toml", "TOML syntax error", "line 4"),
        ),
        (
            '[profile]\ninherits = "paper"\n\n[spacecraft]\ncr = "high"\n',
            ("bad.toml, line 5", "spacecraft.cr = 'high'"),
        ),
        (
            '[profile]\ninherits = "paper"\n[spacecraft]\nmass_kg = -1.0\n',
            ("bad.toml, line 4", "mass_kg = -1.0", "[0.001, 1e+06]"),
        ),
        (
            '[profile]\ninherits = "paper"\n[gravty]\ndegree = 8\n',
            ("unknown key gravty", "did you mean gravity"),
        ),
        ('[profile]\nname = "bad"\n[epoch]\nstart_tdb = "2025-05-01T00:00:00"\n', ("missing key",)),
    ],
)
def test_profile_file_errors_name_file_and_line(capsys, params_dir, text, needles):
    (params_dir / "bad.toml").write_text(text)
    one_line_error(capsys, main(walker() + ["--profile", "bad"]), 2, *needles)


def test_python_api_checks_the_same_values():
    with pytest.raises(ConfigError, match="spacecraft.cr = nan"):
        load_settings("ci", overrides={"spacecraft": {"cr": float("nan")}})
    with pytest.raises(ConfigError, match="unknown key gps.gain_fle"):
        load_settings("ci", overrides={"gps": {"gain_fle": "x.csv"}})
    from lnss_lib.gain_pattern import load_gain_pattern

    for path, content, needle in (
        ("empty.csv", "", "header line"),
        ("text.csv", "off_boresight_deg,g\n0,1\nx,2\n", "line 3"),
        ("nan.csv", "off_boresight_deg,g\n0,1\n1,nan\n", "line 3"),
    ):
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
    one_line_error(
        capsys,
        code,
        1,
        "campaign stopped",
        "1 evaluation error",
        "campaign.max_errors = 0",
        "gain table holds NaN",
    )
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    errors = ev["error"].values
    assert (errors != "").sum() == 1 and "FloatingPointError: gain table holds NaN" in errors[
        errors != ""
    ][0]
    assert not ev["feasible"].values[errors != ""].any()
    # with a tolerance the run goes on and counts the errors in its summary
    code = main(
        SYNTHETIC + ["--run-dir", str(tmp_path / "tolerant"), "--set", "campaign.max_errors=1000"]
    )
    out = capsys.readouterr().out
    assert (
        code == 0
        and " evaluation errors)" in out
        and "(0 evaluation errors)" not in out.replace(", 0 eval", "")
    )


def test_stopped_campaign_resumes_once_the_cause_is_gone(capsys, tmp_path, monkeypatch):
    """A run stopped by an evaluation error evaluates that design again when resumed, and
    ends as the uninterrupted run once the cause is removed."""
    from lnss_lib.campaign import final_population, tasks

    real = tasks.synthetic_evaluation
    reference = _synthetic_run(tmp_path, "reference")
    with monkeypatch.context() as patch:
        patch.setattr(
            tasks,
            "synthetic_evaluation",
            lambda profile, sma_km, *args, **kwargs: (
                (_ for _ in ()).throw(FloatingPointError("gain table holds NaN"))
                if sma_km > 12000.0
                else real(profile, sma_km, *args, **kwargs)
            ),
        )
        run_dir = tmp_path / "stopped"
        code = main(SYNTHETIC + ["--run-dir", str(run_dir), "--set", "campaign.generations=2"])
        one_line_error(capsys, code, 1, "campaign stopped", "gain table holds NaN")
        code = main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"])
        one_line_error(
            capsys, code, 1, "campaign stopped", "gain table holds NaN"
        )  # the cause is still there
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0
    for got, want in zip(final_population(run_dir), final_population(reference)):
        np.testing.assert_array_equal(got, want)
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    assert (ev["error"].values == "").all() and ev.attrs["n_evaluation_errors"] == 0


def test_deleting_the_lock_file_does_not_unlock_a_run(capsys, tmp_path):
    """The lock is an flock on the run folder; run.lock only names the owner."""
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    lock = RunLock(run_dir)
    try:
        (run_dir / "run.lock").unlink()
        one_line_error(
            capsys,
            main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
            1,
            "in use by another campaign process",
        )
    finally:
        lock.release()
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_forged_checkpoint_is_one_line_and_runs_nothing(capsys, tmp_path):
    """--resume of a run folder whose checkpoint would run code refuses it (exit 1)."""
    import pickle

    class Exploit:
        def __reduce__(self):
            return os.system, (f"touch {tmp_path / 'code_ran'}",)

    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    (run_dir / "checkpoint.pkl").write_bytes(pickle.dumps(Exploit()))
    one_line_error(
        capsys,
        main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
        1,
        "checkpoint.pkl",
        "posix.system",
        "refused",
    )
    assert not (tmp_path / "code_ran").exists()


def test_forged_profile_name_in_a_run_folder_is_refused(capsys, tmp_path):
    """A run folder's stored profile name builds output paths; a path-like name is refused."""
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    run_file = run_dir / "run.json"
    forged = json.loads(run_file.read_text())
    forged["profile"]["profile"]["name"] = "../../elsewhere"
    run_file.write_text(json.dumps(forged))
    one_line_error(
        capsys,
        main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
        2,
        "run.json was edited after the run started",
    )
    run_file.write_text(
        json.dumps({**forged, "checksum": run_checksum(forged)})
    )  # a forger who re-seals it
    one_line_error(
        capsys,
        main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
        2,
        "profile.name",
        "forged",
    )


def test_rejected_campaign_leaves_no_folder(capsys, tmp_path):
    for bad in (
        ["--set", "spacecraft.cr=nan"],
        ["--set", "campaign.population=1"],
        ["--set", "campaign.seed=1.5"],
    ):
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
    run_file.write_text(json.dumps({**edited, "checksum": run_checksum(edited)}))
    one_line_error(
        capsys,
        main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
        2,
        "differ from those the run",
    )
    run_file.write_text(original)
    lock = RunLock(run_dir)
    try:
        one_line_error(
            capsys,
            main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
            1,
            "in use by another campaign process",
            f"pid {os.getpid()}",
        )
    finally:
        lock.release()
    (run_dir / "run.lock").write_text("999999999\n")  # stale: its process is gone, no flock held
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_truncated_checkpoint_says_how_to_recover(capsys, tmp_path):
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    checkpoint = run_dir / "checkpoint.pkl"
    checkpoint.write_bytes(checkpoint.read_bytes()[:100])
    one_line_error(
        capsys,
        main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]),
        1,
        "truncated or corrupt",
        "delete it and resume",
        "evaluations.jsonl",
    )
    checkpoint.unlink()
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_torn_journal_line_costs_one_design(capsys, tmp_path):
    reference = _synthetic_run(tmp_path, "reference")
    run_dir = _synthetic_run(tmp_path, "torn", extra=["--max-generations", "1"])
    journal = run_dir / "evaluations.jsonl"
    data = journal.read_bytes()
    lines = data.splitlines(keepends=True)
    journal.write_bytes(
        b"".join(lines[:-1]) + lines[-1][:20] + b"\n"
    )  # last record torn, newline after it
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0
    ref = xr.open_dataset(reference / "evaluations.nc", engine="h5netcdf").load()
    ev = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    assert ev.sizes["design"] == ref.sizes["design"]
    assert np.array_equal(np.sort(ev["sma_km"].values), np.sort(ref["sma_km"].values))


def test_two_resumes_of_one_run_one_refuses(tmp_path):
    run_dir = _synthetic_run(
        tmp_path,
        extra=[
            "--max-generations",
            "1",
            "--set",
            "campaign.synthetic_delay_s=0.4",
            "--set",
            "campaign.generations=3",
        ],
    )
    command = [
        sys.executable,
        "-m",
        "lnss_lib",
        "campaign",
        "--resume",
        str(run_dir),
        "--workers",
        "0",
        "--no-progress",
    ]
    first = subprocess.Popen(
        command, cwd=PROJECT_DIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    deadline = time.monotonic() + 60
    while not (run_dir / "run.lock").read_text().strip().startswith(str(first.pid)):
        assert time.monotonic() < deadline and first.poll() is None, first.communicate()
        time.sleep(0.05)
    second = subprocess.run(command, cwd=PROJECT_DIR, capture_output=True, text=True, timeout=120)
    out, err = first.communicate(timeout=120)
    assert first.returncode == 0, err
    assert second.returncode == 1 and "in use by another campaign process" in second.stderr
    assert len(second.stderr.strip().splitlines()) == 1 and "Traceback" not in second.stderr
    keys = [
        tuple(json.loads(line)["key"])
        for line in (run_dir / "evaluations.jsonl").read_text().splitlines()[1:]
    ]
    assert len(keys) == len(set(keys))


# ---- confined paths, exit classes, messages that name the key or the file -----------------------

WALKER_ARGS = [item for pair in WALKER.items() for item in pair]


@pytest.fixture
def own_outputs(tmp_path, monkeypatch):
    """Outputs under tmp_path/outputs and a clean registry of --profile-file names (restored afterwards)."""
    from lnss_lib.campaign import rundir, runner

    outputs = tmp_path / "outputs"
    for module in (config, rundir, runner):
        monkeypatch.setattr(module, "OUTPUTS_DIR", outputs)
    monkeypatch.setenv(config.PROFILE_FILES_ENV, "{}")
    return outputs


@pytest.mark.parametrize("name", ["{tmp}/x", "../params/ci", "ci.toml", "params/ci", "./ci", "c i"])
def test_profile_is_a_name_in_params(capsys, tmp_path, monkeypatch, name):
    """`--profile /abs/x` loaded /abs/x.toml and wrote under /abs/x/: a profile is a name of params/."""
    shutil.copy(config.PARAMS_DIR / "ci.toml", tmp_path / "x.toml")
    monkeypatch.chdir(config.PROJECT_DIR)
    name = name.format(tmp=tmp_path)
    err = one_line_error(
        capsys, main(["evaluate", "--profile", name, *WALKER_ARGS]), 2, repr(name), "--profile-file"
    )
    assert "ci, ci_operational" in err
    assert sorted(os.listdir(tmp_path)) == ["x.toml"]


def test_profile_file_runs_and_writes_under_its_stem(capsys, tmp_path, own_outputs):
    profile_file = tmp_path / "elsewhere" / "mine.toml"
    profile_file.parent.mkdir()
    shutil.copy(config.PARAMS_DIR / "ci.toml", profile_file)
    command = [
        "campaign",
        "--profile-file",
        str(profile_file),
        "--evaluator",
        "synthetic",
        "--workers",
        "0",
        "--no-progress",
        "--set",
        "campaign.generations=1",
    ]
    assert main(command) == 0, capsys.readouterr().err
    assert [p.name for p in own_outputs.iterdir()] == ["mine"]
    assert sorted(os.listdir(profile_file.parent)) == ["mine.toml"]
    assert load_settings("mine").profile.name == "mine"


@pytest.mark.parametrize(
    "file_name, needle",
    [
        ("x y.toml", "'x y' is not allowed"),
        ("ci.toml", "params/ci.toml"),
        ("mine.txt", "ending in .toml"),
        ("../x.toml", "ending in .toml"),
    ],
)
def test_profile_file_name_is_checked(capsys, tmp_path, own_outputs, file_name, needle):
    path = tmp_path / file_name
    if path.suffix == ".toml" and ".." not in file_name:
        shutil.copy(config.PARAMS_DIR / "ci.toml", path)
    one_line_error(
        capsys,
        main(["evaluate", "--profile-file", str(path), *WALKER_ARGS]),
        2,
        "--profile-file",
        needle,
    )
    assert not own_outputs.exists()


def test_inherits_and_also_name_profiles_only(capsys, tmp_path, own_outputs):
    for key, value in (("inherits", f"{config.PARAMS_DIR}/ci"), ("also", ["../params/ci"])):
        path = tmp_path / "mine.toml"
        path.write_text(
            f'[profile]\ninherits = "paper"\n{key} = {config.toml_literal(value)}\n'
            if key == "also"
            else f"[profile]\ninherits = {config.toml_literal(value)}\n"
        )
        one_line_error(
            capsys,
            main(["evaluate", "--profile-file", str(path), *WALKER_ARGS]),
            2,
            f"profile.{key}",
            "unknown profile",
        )


@pytest.mark.parametrize(
    "setting",
    [
        'gravity.file="../../etc/passwd"',
        'gravity.file="/etc/passwd"',
        'gps.tle_file="data/../../README.md"',
        'ephemeris.kernels=["/etc/hosts"]',
        'ephemeris.planetary_spk="skyfield-data:../../../x.bsp"',
        'validation.capstone.file="../pyproject.toml"',
    ],
)
def test_data_paths_stay_under_params_data(capsys, setting):
    """Data-file keys accepted `../` and absolute paths, and the error then echoed a line of the file read."""
    err = one_line_error(
        capsys, main(walker() + ["--set", setting]), 2, setting.split("=")[0], "params/data/"
    )
    assert "root:" not in err


def test_a_symlink_out_of_params_data_is_refused(capsys, params_dir):
    (params_dir / "data").mkdir()
    (params_dir / "data" / "field.txt").symlink_to("/etc/passwd")
    (params_dir / "bad.toml").write_text(
        '[profile]\ninherits = "paper"\n[gravity]\nfile = "data/field.txt"\n'
    )
    one_line_error(
        capsys,
        main(walker() + ["--profile", "bad"]),
        2,
        "gravity.file = 'data/field.txt'",
        "params/data/",
    )


def test_no_message_prints_a_line_of_a_file(tmp_path):
    """TOML, gravity, TLE and gain-file errors name the file and line, never the content of the line."""
    from lnss_lib.gain_pattern import load_gain_pattern
    from lnss_lib.gravity import GravityField
    from lnss_lib.tle import read_tle

    secret = "SECRET-7f3a"
    cases = {
        "profile.toml": (
            f"[profile]\ninherits = {secret}\n",
            lambda p: config.read_toml(p),
            "line 2",
        ),
        "field.txt": (
            f"2 0 1.0 0.0\n{secret} 0 1.0 0.0\n",
            lambda p: GravityField.from_file(p, 2, 4902.8, 1738.0),
            "row",
        ),
        "gps.tle": (f"GPS\n1 {secret}\n2 x\n", read_tle, "line 2"),
        "gain.csv": (
            f"off_boresight_deg,g\n0,1\n{secret},2\n",
            lambda p: load_gain_pattern(p, "g"),
            "line 3",
        ),
    }
    for name, (text, read, where) in cases.items():
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(ValueError) as info:
            read(path)
        assert str(path) in str(info.value) and where in str(info.value), info.value
        assert secret not in str(info.value), info.value


def test_internal_errors_are_not_bad_input(capsys, monkeypatch):
    """A KeyError (or any unexpected exception) is a failure with the traceback on request, not bad input."""
    from lnss_lib.cli import evaluate as cli

    for error in (
        KeyError("inc"),
        KeyError((191, 34, 9, 70, 1, 1)),
        TypeError("unsupported operand"),
    ):

        def broken(*args, _error=error, **kwargs):
            raise _error

        monkeypatch.setattr(cli, "evaluate_cli", broken)
        one_line_error(
            capsys,
            main(walker()),
            1,
            f"internal error: {type(error).__name__}: ",
            "(run with --debug for the traceback)",
        )

    def numpy_fails(*args, **kwargs):
        return np.linspace(0.0, 1.0, -1)  # a ValueError raised inside numpy: a bug, not bad input

    monkeypatch.setattr(cli, "evaluate_cli", numpy_fails)
    one_line_error(capsys, main(walker()), 1, "internal error: ValueError: ")
    assert main(walker() + ["--debug"]) == 1
    err = capsys.readouterr().err
    assert (
        "Traceback" in err
        and "linspace" in err
        and err.strip().splitlines()[-1].startswith("error: internal error")
    )


def test_debug_keeps_the_exit_code(capsys):
    """`--debug` adds the traceback and keeps exit 2 for bad input (it turned it into 1)."""
    assert main(elements("6143", "1.0", "51.7", "0", "90", "0") + ["--debug"]) == 2
    err = capsys.readouterr().err
    assert (
        "Traceback" in err
        and "ConfigError" in err
        and err.strip().splitlines()[-1].startswith("error: ")
    )
    assert "e = 1.0" in err.strip().splitlines()[-1]


def test_every_command_takes_set_and_profile_file():
    """The README says every command that runs a profile takes --set; `bench` did not. A study names its campaigns'
    profiles and overrides in its file (each `set` entry checked like --set), so `study` takes neither flag."""
    from lnss_lib.__main__ import build_parser

    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    for name, command in commands.items():
        flags = {flag for action in command._actions for flag in action.option_strings}
        if name == "study":
            assert not {"--set", "--profile", "--profile-file"} & flags
            continue
        assert {"--set", "--profile", "--profile-file"} <= flags, name


def test_bench_applies_and_checks_set(capsys, monkeypatch):
    from lnss_lib.bench import dop

    one_line_error(
        capsys,
        main(["bench", "dop", "--profile", "ci", "--set", "gravity.degree=500"]),
        2,
        "gravity.degree = 500",
    )
    seen = {}
    monkeypatch.setattr(
        dop,
        "run",
        lambda profile_name, overrides=None: seen.update(name=profile_name, overrides=overrides),
    )
    assert main(["bench", "dop", "--profile", "ci", "--set", "dop.elevation_mask_deg=10.0"]) == 0
    assert seen == {"name": "ci", "overrides": {"dop": {"elevation_mask_deg": 10.0}}}
    one_line_error(capsys, main(["bench", "dop", "--scaling"]), 2, "--scaling", "bench dop")
    one_line_error(
        capsys, main(["bench", "dop", "--history", "runs/x"]), 2, "--history", "bench dop"
    )
    one_line_error(
        capsys, main(["bench", "dop", "--before-after"]), 2, "--before-after", "bench dop"
    )
    one_line_error(
        capsys,
        main(["bench", "campaign", "--profile", "ci", "--history", "no/such/run"]),
        2,
        "--history no/such/run",
        "not a campaign run folder",
    )


MESSAGES = [
    # too few epochs: named by the two keys, before any work
    (
        walker() + ["--set", "epoch.duration_days=0.01"],
        ("epoch.duration_days = 0.01", "epoch.step_s = 900.0"),
    ),
    (
        walker() + ["--set", "epoch.step_s=864000.0"],
        ("epoch.duration_days", "epoch.step_s = 864000.0"),
    ),
    (
        walker() + ["--design-life-days", "0.01"],
        ("--design-life-days 0.01", "life_evaluation.sample_step_s = 900.0"),
    ),
    # an unquoted date: TOML reads it as a date-time; say how to write it
    (
        walker() + ["--set", "epoch.start_tdb=2025-05-01T00:00:00"],
        ("epoch.start_tdb", "quote it", "'epoch.start_tdb=\"2025-05-01T00:00:00\"'"),
    ),
    (walker() + ["--set", "epoch.start_tdb=2025-05-01"], ("epoch.start_tdb", "quote it")),
    # a SPICE failure: what was asked and the kernels, not SPICE's banner
    (walker() + ["--set", 'frames.gravity="MOON_NOSUCH"'], ("MOON_NOSUCH",)),
    (
        walker() + ["--set", 'frames.moon_fixed="MOON_NOSUCH"'],
        ("MOON_NOSUCH",),
    ),  # not "infeasible": exit 2
]


@pytest.mark.parametrize("argv, needles", MESSAGES, ids=[a[-1] for a, _ in MESSAGES])
def test_messages_name_the_key(capsys, argv, needles):
    err = one_line_error(capsys, main(argv), 2, *needles)
    assert "Toolkit" not in err and "=====" not in err and "series (" not in err


def test_binary_constellation_file_is_named(capsys, tmp_path):
    path = tmp_path / "constellation.toml"
    path.write_bytes(bytes(range(256)) * 4)
    one_line_error(
        capsys,
        main(["evaluate", "--constellation", str(path), "--profile", "ci"]),
        2,
        str(path),
        "not a TOML text file",
    )


def test_damaged_kernel_is_named_and_not_kept(tmp_path):
    """SPICE errors name the kernel file and what was asked; a kernel SPICE cannot read is not left loaded."""
    from lnss_lib.ephemeris import _LOADED, kernel_span_tdb_s, load_kernels

    load_kernels([])
    before = (set(_LOADED), kernel_span_tdb_s())
    junk = tmp_path / "junk.bsp"
    junk.write_bytes(b"\x7fELF" + bytes(range(256)) * 20)
    with pytest.raises(SpiceError) as info:
        load_kernels([junk])
    message = str(info.value)
    assert (
        str(junk) in message
        and "SPICE(" in message
        and "Toolkit" not in message
        and "\n" not in message
    )
    assert info.value.kernels == (str(junk),) and not isinstance(
        info.value, ValueError
    )  # never "infeasible"
    assert (set(_LOADED), kernel_span_tdb_s()) == before


def test_secular_model_on_an_unbound_orbit_names_the_cause():
    """ "P = nan s" came from averaging an escaping orbit over a NaN period."""
    from lnss_lib.deltav import secular_drift

    t = np.linspace(0.0, 86400.0, 97)
    r = np.array([1.0e4, 0.0, 0.0]) + np.outer(
        t, [0.0, 5.0, 0.0]
    )  # 5 km/s at 10,000 km: hyperbolic
    states = np.column_stack([r, np.tile([0.0, 5.0, 0.0], (t.size, 1))])
    with pytest.raises(ValueError, match="bound orbit") as info:
        secular_drift(t, states, 4902.8)
    assert "nan" not in str(info.value)


def test_full_journal_disk_names_the_journal(capsys, tmp_path, monkeypatch):
    """Errno 28 while appending to the evaluation journal names the journal (it printed only the errno)."""
    from lnss_lib.campaign import journal

    class FullDisk:
        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

        flush = close = lambda self: None

    real_init = journal.EvaluationCache.__init__

    def init(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        self._handle.close()
        self._handle = FullDisk()

    monkeypatch.setattr(journal.EvaluationCache, "__init__", init)
    run_dir = tmp_path / "run"
    one_line_error(
        capsys,
        main(SYNTHETIC + ["--run-dir", str(run_dir)]),
        1,
        str(run_dir / "evaluations.jsonl"),
        "No space left on device",
    )


# ---- text settings, infeasible versus error, physically absurd values ----------------------


def _bad_text(key: str):
    """An override setting ``key`` (``*`` = the paper integrator setting) to a value outside its allowed set."""
    parts = key.replace("*", "paper").split(".")
    ref = config._reference()
    for part in parts[:-1]:
        ref = ref[part if part in ref else next(iter(ref))]
    value = ["NOSUCH"] if isinstance(ref[parts[-1]], list) else "NOSUCH"
    for part in reversed(parts):
        value = {part: value}
    return value


RULES = dict(profile_rules.rules())
CHECKED_TEXT = sorted(
    key for key, rule in RULES.items() if rule.choices or rule.form or rule.names_integrator_setting
)


@pytest.mark.parametrize("key", CHECKED_TEXT)
def test_every_text_setting_is_checked_against_its_allowed_values(key):
    """Each text setting refuses an unknown value before any work, naming the key and what is allowed."""
    with pytest.raises(ConfigError, match="allowed") as caught:
        load_settings("ci", overrides=_bad_text(key))
    assert key.replace("*", "paper") in str(caught.value) and "NOSUCH" in str(caught.value)
    if RULES[key].choices:
        assert all(repr(v) in str(caught.value) for v in RULES[key].choices)
    if not key.startswith("campaign."):
        with pytest.raises(
            ConfigError, match="allowed"
        ):  # and in campaign.overrides, which evaluations use
            load_settings("ci", overrides={"campaign": {"overrides": _bad_text(key)}})


# text keys whose values are not a fixed set: data paths (confined by the loader), free text, names checked
# against files by their readers before work (gain column, catalogue names, campaign objectives and constraints)
OPEN_TEXT = {
    "profile.name",
    "profile.description",
    "gravity.file",
    "ephemeris.kernels",
    "ephemeris.planetary_spk",
    "validation.capstone.file",
    "gps.tle_file",
    "gps.gain_file",
    "gps.gain_column",
    "gnss.nominal_file",
    "benchmark.epoch_constellations",
    "campaign.objectives",
}


def _text_keys(table: dict, prefix: str = "", rule: str = ""):
    for name, value in table.items():
        key, rule_key = (
            f"{prefix}{name}",
            ("integrator.settings.*" if rule == "integrator.settings." else f"{rule}{name}"),
        )
        table_rule = RULES.get(rule_key)  # None for a named entry ("integrator.settings.*")
        if isinstance(value, dict) and not (
            table_rule and (table_rule.free or table_rule.sections)
        ):
            yield from _text_keys(value, f"{key}.", f"{rule_key}.")
        elif isinstance(value, str) or (
            isinstance(value, list) and value and all(isinstance(v, str) for v in value)
        ):
            yield key, rule_key


@pytest.mark.parametrize("profile_name", config.available_profiles())
def test_no_text_setting_escapes_the_checks(profile_name):
    """A new text setting must get an allowed set (its Rule's choices, form or names_integrator_setting) or be
    declared open."""
    checked = set(CHECKED_TEXT) | OPEN_TEXT
    unchecked = [
        key
        for key, rule in _text_keys(load_settings(profile_name).as_dict())
        if rule not in checked
    ]
    assert not unchecked, unchecked


def test_config_and_ephemeris_errors_propagate_only_impossible_designs_are_infeasible(
    ci_profile, monkeypatch
):
    """evaluate_constellation turns InfeasibleDesignError (no closed orbit, impact) into an infeasible design
    and lets every other error through (it caught ValueError: ConfigError and EphemerisRangeError too)."""
    from types import SimpleNamespace

    from lnss_lib import evaluator
    from lnss_lib.ephemeris import tdb_seconds
    from lnss_lib.errors import EphemerisRangeError, ImpactError

    context = SimpleNamespace(
        settings=ci_profile,
        deltav=ci_profile.deltav,
        t0_tdb_s=tdb_seconds("2060-01-01T00:00:00", "TDB"),
        extra_metrics=(),
    )
    elfo = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]]
    with pytest.raises(EphemerisRangeError):
        evaluator.evaluate_constellation(context, elfo)
    context.t0_tdb_s = tdb_seconds("2025-05-01T00:00:00", "TDB")
    bad = evaluator.evaluate_constellation(context, [[1800.0, 0.5, 51.7, 0.0, 90.0, 0.0]])
    assert bad["evaluated"] is False and "perilune" in bad["reason"]
    for error, infeasible in (
        (ConfigError("frames.element_frame = 'x'", key="frames.element_frame"), False),
        (RuntimeError("propagation failed"), False),
        (ImpactError("impact: satellite 0 hits the Moon", sat=0, t_tdb_s=0.0, days=1.0), True),
    ):
        monkeypatch.setattr(
            evaluator, "campaign_metrics", lambda *a, error=error, **k: (_ for _ in ()).throw(error)
        )
        if infeasible:
            assert evaluator.evaluate_constellation(context, elfo)["reason"].startswith("impact")
        else:
            with pytest.raises(type(error)):
                evaluator.evaluate_constellation(context, elfo)


def test_design_life_lets_ephemeris_errors_through():
    from lnss_lib.cli.evaluate import design_life_cli
    from lnss_lib.errors import EphemerisRangeError

    with pytest.raises(EphemerisRangeError):
        design_life_cli(
            "ci",
            10.0,
            walker=(6143.0, 0.6, 90.0, 51.7, 2, 1),
            overrides={"epoch": {"start_tdb": "2060-01-01T00:00:00"}},
        )


@pytest.mark.parametrize(
    "days, needles",
    [
        (
            "1e7",
            (
                "--design-life-days 10000000.0",
                "27,378.5 years",
                "allowed: 0 < days <= 9,376 from 2025-05-01T00:00:00",
            ),
        ),
        ("9377", ("--design-life-days 9377.0", "2051-01-01")),
    ],
)
def test_design_life_past_the_kernels_is_refused_before_the_evaluation(
    capsys, monkeypatch, days, needles
):
    """A life past the kernels' span is refused with the range of lives they allow, before the 10-day evaluation
    (which ran first, then the year was printed as '****')."""
    from lnss_lib.cli import evaluate as cli

    monkeypatch.setattr(
        cli, "evaluate_cli", lambda *args, **kwargs: pytest.fail("the evaluation ran")
    )
    one_line_error(capsys, main(walker() + ["--design-life-days", days]), 2, *needles)


def test_campaign_with_a_bad_text_setting_stops_before_work(capsys, tmp_path):
    run_dir = tmp_path / "run"
    code = main(
        [
            "campaign",
            "--profile",
            "ci",
            "--workers",
            "0",
            "--no-progress",
            "--run-dir",
            str(run_dir),
            "--set",
            "frames.element_frame=nosuch",
        ]
    )
    one_line_error(capsys, code, 2, "frames.element_frame = 'nosuch'", "moon_op")
    assert not run_dir.exists()


ABSURD = [
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--srp-cr-area-mass", "1e12"],
        ("--srp-cr-area-mass 1000000000000.0", "solar sails"),
    ),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "1", "--set", "spacecraft.mass_kg=1e-300"],
        ("spacecraft.mass_kg = 1e-300", "[0.001, 1e+06]"),
    ),
    (walker() + ["--set", "spacecraft.area_m2=1e12"], ("cr * area_m2 / mass_kg", "solar sails")),
    (walker() + ["--set", "spacecraft.cr=3"], ("spacecraft.cr = 3", "perfect mirror")),
    (walker(sma_km="1e5"), ("sma_km = 100000.0", "Hill sphere (61,500 km)")),
    (walker(sma_km="1e12"), ("sma_km = 1000000000000.0", "Hill sphere")),
    (elements("1e5", "0.1", "51.7", "0", "90", "0"), ("sma_km = 100000.0", "Hill sphere")),
    (
        ["propagate", *EPOCH, "--state-km", "1e6", "0", "0", "0", "0.1", "0", "--days", "1"],
        ("1e+06 km", "Earth-Moon distance"),
    ),
    (
        ["propagate", *EPOCH, *ELFO, "--days", "10", "--step-s", "1e-6"],
        ("samples", "at most 10,000,000"),
    ),
    (
        walker() + ["--set", "standalone_elfo.sma_km=1e5"],
        ("standalone_elfo.sma_km = 100000.0", "Hill sphere"),
    ),
    (
        SYNTHETIC + ["--set", "campaign.variables.sma_km={lower=4000.0,upper=1e5,step=100.0}"],
        ("sma_km", "Hill sphere"),
    ),
    # states: one check of a lunar orbit's state (3.3 times light speed ran to 575 AU; inside the Moon exited 1)
    (
        ["propagate", *EPOCH, "--state-km", "3000", "0", "0", "1e6", "0", "0", "--days", "0.1"],
        ("--state-km", "speed of light"),
    ),
    (
        ["propagate", *EPOCH, "--state-km", "3000", "0", "0", "2.0", "0", "0", "--days", "0.1"],
        ("escape speed", "1.808"),
    ),
    (
        ["propagate", *EPOCH, "--state-km", "60000", "0", "0", "0", "0.34", "0", "--days", "0.1"],
        ("Hill sphere",),
    ),
    (
        ["propagate", *EPOCH, "--state-km", "1000", "0", "0", "0", "1", "0", "--days", "0.1"],
        ("inside the Moon", "1737.4"),
    ),
    # sizes and seeds: bounded by what memory holds and what the outputs store, refused before any work
    (
        SYNTHETIC + ["--set", "campaign.seed=99999999999999999999999999"],
        ("campaign.seed", "26 digits", "2**63 - 1"),
    ),
    (SYNTHETIC + ["--set", f"campaign.seed={2**64}"], ("campaign.seed", "int64")),
    (  # the setting's own range, not only what the outputs store
        SYNTHETIC + ["--set", f"gravity.degree={'9' * 400}"],
        ("gravity.degree", "400 digits", "allowed: [0, 100]"),
    ),
    (
        SYNTHETIC + ["--set", f"gravity.degree={'9' * 5000}"],
        (
            "gravity.degree",
            "not a TOML literal (a number of more than 4300 digits)",
            "5015 characters",
        ),
    ),
    (
        SYNTHETIC + ["--set", f"campaign.hypervolume.dv_total_kms_per_year={'9' * 400}"],
        ("hypervolume", "too large"),
    ),
    (walker(planes="9" * 400), ("--planes", "too large")),
    (
        SYNTHETIC + ["--set", "campaign.population=1000000000"],
        ("campaign.population", "[2, 5000]", "domination matrix"),
    ),
    (walker() + ["--set", "dop.lat_step_deg=1e-9"], ("dop.lat_step_deg", "at most 100,000 points")),
    (
        walker()
        + [
            "--set",
            "integrator.settings.paper.rtol=1e10",
            "--set",
            "integrator.settings.paper.atol=1e10",
        ],
        ("integrator.settings.paper.rtol = 10000000000.0", "SciPy's default rtol"),
    ),
]


@pytest.mark.parametrize(
    "argv, needles", ABSURD, ids=[" ".join(part[:40] for part in a[-2:]) for a, _ in ABSURD]
)
def test_physically_absurd_values_are_refused_with_the_reason(
    capsys, tmp_path, monkeypatch, argv, needles
):
    monkeypatch.chdir(tmp_path)
    one_line_error(capsys, main(argv), 2, *needles)
    assert os.listdir(tmp_path) == []


def test_hill_radius_follows_from_the_profile_masses(paper_profile):
    from lnss_lib.constants import EARTH_MOON_DISTANCE_KM, MOON_HILL_RADIUS_KM

    ratio = paper_profile.gravity.gm_km3_s2 / paper_profile.constants.gm_earth_km3_s2
    assert MOON_HILL_RADIUS_KM == pytest.approx(
        EARTH_MOON_DISTANCE_KM * (ratio / 3.0) ** (1.0 / 3.0), rel=5e-3
    )


def test_reserved_and_forged_profile_files_are_refused(capsys, tmp_path, monkeypatch):
    """A profile named like the shipped-results folder (outputs/reference/) would put its runs where an export
    replaces folders whole: refused as --profile-file and in LNSS_PROFILE_FILES, which is checked like user input
    (no params/ profile replaced, no device read), as is a new run inside outputs/reference/."""
    from lnss_lib.campaign import run_campaign

    (tmp_path / "reference.toml").write_text('[profile]\ninherits = "ci"\n')
    one_line_error(
        capsys,
        main(
            [
                "propagate",
                "--profile-file",
                str(tmp_path / "reference.toml"),
                *EPOCH,
                *ELFO,
                "--days",
                "0.1",
            ]
        ),
        2,
        "reserved",
    )
    (tmp_path / "fake.toml").write_text('[profile]\ninherits = "ci"\n')
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    for table, needle in (
        ({"ci": str(tmp_path / "fake.toml")}, "params/ci.toml already has the name"),
        ({"x": "/dev/zero"}, "not an existing regular file"),
        ({"x": str(fifo)}, "regular file"),
        ({"reference": str(tmp_path / "reference.toml")}, "reserved"),
        (["x"], "JSON table"),
        ({"../x": str(tmp_path / "fake.toml")}, "not allowed as a profile name"),
    ):
        monkeypatch.setenv("LNSS_PROFILE_FILES", json.dumps(table))
        one_line_error(
            capsys,
            main(["propagate", "--profile", "x", *EPOCH, *ELFO, "--days", "0.1"]),
            2,
            "LNSS_PROFILE_FILES",
            needle,
        )
    monkeypatch.delenv("LNSS_PROFILE_FILES")
    with pytest.raises(ConfigError, match="shipped results"):
        run_campaign(
            "ci",
            overrides={"campaign": {"evaluator": "synthetic"}},
            workers=0,
            progress=False,
            run_dir=config.REFERENCE_DIR / "ci" / "run",
        )
    assert not (config.REFERENCE_DIR / "ci").exists()


@pytest.mark.parametrize(
    "epoch, needle",
    [
        ("2009-07-15T01:00:00+05:00", "zone"),
        ("15/07/2009", "YYYY-MM-DD"),
        ("2009-07-15 01:00:00", "YYYY-MM-DDTHH:MM:SS"),
    ],
)
def test_constellation_file_epoch_is_read_strictly(capsys, tmp_path, epoch, needle):
    """A constellation file's epoch goes through the same reader as --epoch-tdb: a zone or another order is
    refused at load, naming the file and key (a zone was accepted and echoed)."""
    source = (PROJECT_DIR / "params" / "constellations" / "ely2005_elfo_3sat.toml").read_text()
    path = tmp_path / "zoned.toml"
    path.write_text(source.replace('epoch = "2009-07-15T01:00:00"', f'epoch = "{epoch}"'))
    one_line_error(
        capsys,
        main(["evaluate", "--profile", "ci", "--constellation", str(path)]),
        2,
        str(path),
        "epoch",
        needle,
    )


@pytest.mark.parametrize(
    "line, needle",
    [
        ("a_km = 80000.0", "beyond the Moon's Hill sphere (61,500 km)"),
        (f"a_km = {'9' * 400}", "an integer of"),
        ("a_km = 2000.0", "the orbit hits the Moon"),
    ],
)
def test_constellation_file_elements_meet_the_shared_orbit_check(capsys, tmp_path, line, needle):
    """A catalogue or user constellation file's elements go through the element check of --sma-km and propagate
    --elements (a = 80000 km was evaluated, "evaluated": true); a huge integer is refused, not an OverflowError."""
    source = (PROJECT_DIR / "params" / "constellations" / "ely2005_elfo_3sat.toml").read_text()
    path = tmp_path / "user.toml"
    path.write_text(source.replace("a_km = 6541.4", line, 1))
    one_line_error(
        capsys,
        main(["evaluate", "--profile", "ci", "--constellation", str(path), "--json"]),
        2,
        str(path),
        "satellite[0].a_km",
        needle,
    )


def test_huge_numbers_in_a_profile_file_are_refused(capsys, params_dir):
    """Integers a float cannot hold, in a profile file: one line naming the file, exit 2 (an OverflowError, or a
    ValueError past 4300 digits, before)."""
    for digits, needle in (
        (400, "gravity.degree = an integer of 400 digits is too large; allowed: [0, 100]"),
        (5000, "a number too long"),
    ):
        (params_dir / "huge.toml").write_text(
            f'[profile]\ninherits = "paper"\n\n[gravity]\ndegree = {"9" * digits}\n'
        )
        one_line_error(
            capsys,
            main(["propagate", "--profile", "huge", *EPOCH, *ELFO, "--days", "0.1"]),
            2,
            "huge.toml",
            needle,
        )


@pytest.mark.parametrize(
    "text, reason",
    [
        ('{"epoch": ' * 100_000 + "1" + "}" * 100_000, "nested too deep"),
        ('{"gravity": {"degree": ' + "9" * 5000 + "}}", "a number of more than 4300 digits"),
        ('{"gravity": {"degree": }}', "line 1, column 24: Expecting value"),
    ],
    ids=["nested", "long number", "syntax"],
)
def test_unreadable_overrides_json_says_why(text, reason):
    """A notebook's overrides as JSON text that cannot be read: ConfigError saying why in the text's terms (it gave
    the parser's message cut at 120 characters: Python's advice to raise its digit limit, cut mid-word)."""
    with pytest.raises(ConfigError, match="overrides are not JSON the workbook reads") as raised:
        load_settings("ci", overrides=text)
    assert reason in str(raised.value) and "set_int_max_str_digits" not in str(raised.value)


@pytest.mark.parametrize(
    "content, reason",
    [
        (b'{"a": ' * 100_000 + b"1" + b"}" * 100_000, "nested too deep"),
        (b'{"n": ' + b"9" * 5000 + b"}", "a number of more than 4300 digits"),
        (b'{"profile": {"name": ', "line 1, column 22"),
    ],
    ids=["nested", "long number", "cut short"],
)
def test_unreadable_run_json_is_named(capsys, tmp_path, content, reason):
    """A run.json nested 100,000 deep, holding a 5000-digit integer or cut short: --resume, --validate and
    --export-reference name the file and what is wrong with it in the file's terms, exit 2 (RecursionError or an
    internal error, exit 1, naming no file, before; then Python's advice to raise its digit limit, cut mid-word)."""
    run_dir = _synthetic_run(tmp_path, extra=["--max-generations", "1"])
    capsys.readouterr()
    (run_dir / "run.json").write_bytes(content)
    for flag in ("--resume", "--validate", "--export-reference"):
        message = one_line_error(
            capsys,
            main(["campaign", flag, str(run_dir), "--no-progress"]),
            2,
            "run.json",
            "not readable JSON",
            reason,
        )
        assert "sys.set_int_max_str_digits" not in message
