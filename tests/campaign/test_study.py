"""A study: its file checked like a profile, two ci campaigns on one cluster giving each campaign's results alone bit for
bit, a study killed and resumed, and a real cluster of separate processes (a worker killed, a foreign one refused)."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import final_population, read_cache_records, run_campaign
from lnss_lib.campaign.study import STUDY_FILE, load_study, run_study
from lnss_lib.config import PROJECT_DIR
from lnss_lib.errors import ConfigError, WorkerMismatchError

from .helpers import _journal_count, dask_cluster

STUDY_CLI = [sys.executable, "-m", "lnss_lib", "study"]
SEEDS = (1, 2)
SETS = ["campaign.evaluator=synthetic", "campaign.generations=7", "campaign.synthetic_delay_s=0.03"]
PAIR = "".join(
    f'[[campaigns]]\nname = "seed{seed}"\nprofile = "ci"\nseed = {seed}\nset = {SETS!r}\n\n'
    for seed in SEEDS
).replace("'", '"')


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """Each campaign of the pair run alone, in this process: ``{name: run folder}``."""
    folder = tmp_path_factory.mktemp("alone")
    overrides = {
        "campaign": {"evaluator": "synthetic", "generations": 7, "synthetic_delay_s": 0.03}
    }
    return {
        f"seed{seed}": run_campaign(
            "ci",
            overrides={"campaign": {**overrides["campaign"], "seed": seed}},
            workers=0,
            run_dir=folder / f"seed{seed}",
            progress=False,
        ).run_dir
        for seed in SEEDS
    }


@pytest.fixture
def pair_file(tmp_path):
    path = tmp_path / "pair.toml"
    path.write_text('[study]\ndescription = "two seeds of ci"\n\n' + PAIR)
    return path


def assert_same_campaign(run_dir, reference) -> None:
    """Same final population and the same evaluations (every design and metric, in order) as ``reference``."""
    x_ref, f_ref = final_population(reference)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)
    ref = xr.open_dataset(reference / "evaluations.nc", engine="h5netcdf").load()
    got = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    xr.testing.assert_identical(got.drop_attrs(), ref.drop_attrs())
    keys = [tuple(r["key"]) for r in read_cache_records(run_dir)]
    assert (
        len(keys) == len(set(keys)) == len(read_cache_records(reference))
    )  # nothing evaluated twice


@pytest.mark.parametrize(
    "text, named",
    [
        ('[study]\ncolour = "red"\n', "study.colour"),
        ('[[campaigns]]\nname = "a"\nprofile = "ci"\nseed = "one"\n', "seed = 'one'"),
        ('[[campaigns]]\nname = "a"\nprofile = "nosuch"\n', "nosuch"),
        ('[[campaigns]]\nname = "a"\nprofile = "ci"\nset = ["campaign.population=-3"]\n', "-3"),
        ('[[campaigns]]\nname = "a/b"\nprofile = "ci"\n', "'a/b'"),
        ('[[campaigns]]\nprofile = "ci"\n', "lacks name"),
        (
            '[[campaigns]]\nname = "a"\nprofile = "ci"\n\n[[campaigns]]\nname = "a"\nprofile = "ci"\n',
            "'a'",
        ),
        ('[[campaigns]]\nname = "a"\nprofile = "ci"\nfront_validation = true\n', "max_designs = 0"),
        ('[study]\ndescription = "none"\n', "at least one [[campaigns]]"),
        ("[campaign]\nseed = 1\n", "[campaign] is not a study table"),
    ],
)
def test_study_file_checked_before_any_work(tmp_path, text, named):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as raised:
        run_study(path, run_dir=tmp_path / "run", workers=0, progress=False)
    assert named in str(raised.value) and str(path) in str(raised.value)
    assert not (tmp_path / "run").exists()


def test_shipped_study_files_load():
    for path in sorted((PROJECT_DIR / "params" / "studies").glob("*.toml")):
        study = load_study(path)
        assert study.campaigns and all(c.overrides["campaign"]["seed"] for c in study.campaigns)


def test_study_on_one_cluster_gives_each_campaign_alone(alone, pair_file, tmp_path):
    result = run_study(pair_file, run_dir=tmp_path / "study", workers=2, progress=False)
    assert set(result.campaigns) == set(alone)
    for name, reference in alone.items():
        assert result.campaigns[name].run_dir == tmp_path / "study" / name
        assert_same_campaign(tmp_path / "study" / name, reference)
    assert (tmp_path / "study" / STUDY_FILE).read_text() == pair_file.read_text()


def _records(study_dir) -> int:
    return sum(_journal_count(study_dir / f"seed{seed}") for seed in SEEDS)


def test_killed_study_resumes_to_the_uninterrupted_result(alone, pair_file, tmp_path):
    study_dir = tmp_path / "killed"
    proc = subprocess.Popen(
        STUDY_CLI
        + [str(pair_file), "--run-dir", str(study_dir), "--workers", "2", "--no-progress"],
        cwd=PROJECT_DIR,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 120
    while (
        proc.poll() is None and _records(study_dir) < 30
    ):  # both campaigns mid-search (84 designs in all)
        assert time.monotonic() < deadline, "study did not progress"
        time.sleep(0.01)
    assert proc.poll() is None, proc.stderr.read().decode()
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert _records(study_dir) < 84
    done = subprocess.run(
        STUDY_CLI + ["--resume", str(study_dir), "--workers", "2", "--no-progress"],
        cwd=PROJECT_DIR,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    for name, reference in alone.items():
        assert_same_campaign(study_dir / name, reference)


def test_real_cluster_with_a_worker_killed_mid_generation(alone, pair_file, tmp_path):
    with dask_cluster(tmp_path, 2) as (address, workers):
        study_dir = tmp_path / "cluster"
        proc = subprocess.Popen(
            STUDY_CLI
            + [
                str(pair_file),
                "--run-dir",
                str(study_dir),
                "--scheduler-address",
                address,
                "--no-progress",
            ],
            cwd=PROJECT_DIR,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 120
        while _records(study_dir) < 20:
            assert time.monotonic() < deadline and proc.poll() is None, "study did not progress"
            time.sleep(0.01)
        workers[0].send_signal(signal.SIGKILL)
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    assert "resubmitted after lost workers" in out
    killed = f":{workers[0].pid}"
    assert any(
        r["worker"].endswith(killed)
        for seed in SEEDS
        for r in read_cache_records(study_dir / f"seed{seed}")
    )
    for name, reference in alone.items():
        assert_same_campaign(study_dir / name, reference)


def test_worker_with_other_kernels_is_refused(pair_file, tmp_path):
    with dask_cluster(tmp_path, 1, worker_env={"NUMBA_CPU_NAME": "generic"}) as (address, _):
        with pytest.raises(WorkerMismatchError) as raised:
            run_study(
                pair_file, run_dir=tmp_path / "refused", scheduler_address=address, progress=False
            )
        done = subprocess.run(
            STUDY_CLI
            + [
                str(pair_file),
                "--run-dir",
                str(tmp_path / "cli"),
                "--scheduler-address",
                address,
                "--no-progress",
            ],
            cwd=PROJECT_DIR,
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert raised.value.differences["kernel_cpu"][
        0
    ] == "generic" and raised.value.worker.startswith("tcp://127.0.0.1:")
    assert (
        done.returncode == 1 and "is refused" in done.stderr and "kernel_cpu generic" in done.stderr
    )
    assert not any((tmp_path / "refused").glob("*/run.json"))


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["study"], "a study FILE (with --run-dir) or --resume RUN_DIR"),
        (["study", "params/studies/ci_pair.toml"], "a new study needs --run-dir"),
        (["study", "params/studies/nosuch.toml", "--run-dir", "x"], "nosuch.toml: no such file"),
        (["study", "--resume", "/nonexistent/study"], "not a study folder"),
        (
            ["study", "params/studies/ci_pair.toml", "--run-dir", "x", "--workers", "-2"],
            "--workers -2",
        ),
    ],
)
def test_bad_study_command_is_one_line_exit_2(capsys, monkeypatch, tmp_path, argv, needle):
    from lnss_lib.__main__ import main

    argv = [str(PROJECT_DIR / a) if a.startswith("params/") else a for a in argv]
    monkeypatch.chdir(tmp_path)
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and needle in err, err
    assert not any(tmp_path.iterdir())
