"""Run directory: the NetCDF result contract of a real campaign, the command line, SIGKILL, Ctrl-C and resume,
damaged and forged checkpoints, publication."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr
from terminal import foreground_signals

from lnss_lib.__main__ import main
from lnss_lib.campaign import CampaignPlan, final_population, read_cache_records
from lnss_lib.config import PROJECT_DIR
from lnss_lib.config import parse_sets as _parse_sets
from lnss_lib.evaluator import context_for, evaluate_design
from lnss_lib.keys import DESIGN_KEYS, METRIC_KEYS
from lnss_lib.settings import load_settings

from .helpers import CLI, KILL_SETTINGS, SYNTHETIC, _cli, _journal_count, _run_until


def test_set_parser_and_cli_errors(capsys):
    assert _parse_sets(
        ["campaign.generations=4", "epoch.duration_days=1.5", "campaign.seed=3"]
    ) == {"campaign": {"generations": 4, "seed": 3}, "epoch": {"duration_days": 1.5}}
    assert main(["campaign", "--set", "campaign.generations"]) == 2
    assert "SECTION.KEY=VALUE" in capsys.readouterr().err
    assert main(["campaign", "--resume", "/nonexistent/run", "--profile", "ci"]) == 2
    assert "--resume continues a run" in capsys.readouterr().err


def test_real_campaign_netcdf_contract(real_run):
    settings = CampaignPlan.of(load_settings("ci"))
    ev = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    front = xr.open_dataset(real_run.run_dir / "front.nc", engine="h5netcdf").load()
    history = xr.open_dataset(real_run.run_dir / "history.nc", engine="h5netcdf").load()
    expected = {
        *DESIGN_KEYS,
        *METRIC_KEYS,
        "feasible",
        "impact",
        "error",
        "constraint_violation",
        "generation",
    }
    for ds in (ev, front):
        assert set(ds.data_vars) == expected and set(ds.dims) == {"design"}
        for name in ("sma_km", "ecc", "aop_deg", "inc_deg"):
            assert ds[name].dtype == np.float64
        for name in ("n_planes", "sats_per_plane", "n_sat", "generation"):
            assert np.issubdtype(ds[name].dtype, np.integer)
        assert ds.feasible.dtype == bool and ds.impact.dtype == bool
        assert ds.attrs["profile"] == "ci" and ds.attrs["objectives"].split(",") == list(
            settings.objectives
        )
        assert json.loads(ds.attrs["parameters"])["campaign"]["population"] == 6
        assert "pymoo" in json.loads(ds.attrs["versions"])
    assert ev.sizes["design"] == real_run.n_evaluations == len(read_cache_records(real_run.run_dir))
    designs = np.column_stack([ev[k].values for k in DESIGN_KEYS])
    assert len({tuple(row) for row in designs}) == ev.sizes["design"]  # every design once
    np.testing.assert_allclose(
        settings.grid.descale(np.rint(settings.grid.scale(designs))), designs
    )
    np.testing.assert_array_equal(ev.n_sat, ev.n_planes * ev.sats_per_plane)
    assert (
        ev.generation.min() == 1
        and ev.generation.max() == 3
        and np.all(np.diff(ev.generation) >= 0)
    )
    # violations and feasibility follow from the stored metrics (Table 3 limits, independently written)
    pdop, avail, dv = (
        ev.pdop_mean_3sigma.values,
        ev.pdop_avail_pct.values,
        ev.dv_total_kms_per_year.values,
    )
    with np.errstate(invalid="ignore"):
        manual = (
            np.where(np.isnan(pdop), 1e3, np.maximum(pdop / 10 - 1, 0))
            + np.where(np.isnan(avail), 1e3, np.maximum(1 - avail / 70, 0))
            + np.where(np.isnan(dv), 1e3, np.maximum(dv - 1, 0))
        )
    np.testing.assert_allclose(ev.constraint_violation, manual, rtol=1e-12)
    assert np.all(ev.constraint_violation >= 0)
    np.testing.assert_array_equal(ev.feasible, (ev.constraint_violation == 0) & ~np.isnan(pdop))
    assert np.all(front.feasible) and front.sizes["design"] <= int(ev.feasible.sum())
    np.testing.assert_array_equal(history.generation, [1, 2, 3])
    np.testing.assert_array_equal(history.n_evaluations_cum[-1], ev.sizes["design"])
    assert np.all(history.n_evaluated + history.n_cache_hits == history.n_designs)


def test_history_holds_each_generations_time_split(real_run):
    history = xr.open_dataset(real_run.run_dir / "history.nc", engine="h5netcdf").load()
    records = read_cache_records(real_run.run_dir)
    from lnss_lib.keys import TIMING_KEYS as parts

    for gen in history.generation.values:
        mine = [r for r in records if r["generation"] == gen]
        row = history.sel(generation=gen)
        for part in parts:
            expected = np.mean([r["timing_s"].get(part, 0.0) for r in mine]) if mine else 0.0
            assert row[f"time_{part}_s"].item() == pytest.approx(expected, rel=1e-12, abs=1e-15)
        task = np.mean([r["task_wall_s"] for r in mine]) if mine else 0.0
        split = sum(row[f"time_{part}_s"].item() for part in parts) + row["time_overhead_s"].item()
        assert split == pytest.approx(task, rel=1e-9, abs=1e-12)
        assert row["time_campaign_s"].item() >= 0.0
    assert history["time_propagation_s"].values[0] > 0.0


def test_real_campaign_cache_holds_a_fresh_evaluation(real_run):
    ev = xr.open_dataset(real_run.run_dir / "evaluations.nc", engine="h5netcdf").load()
    ok = np.flatnonzero(~np.isnan(ev.pdop_avail_pct.values))
    row = ev.isel(design=int(ok[-1]))
    fresh = evaluate_design(
        context_for(load_settings("ci")), **{k: row[k].item() for k in DESIGN_KEYS}
    )
    for key in METRIC_KEYS:
        np.testing.assert_allclose(fresh[key], row[key].item(), rtol=1e-12, equal_nan=True)


def test_sigkill_at_any_moment_then_resume_matches_uninterrupted(synthetic_reference, tmp_path):
    run_dir = tmp_path / "killed"
    # kills: before the first checkpoint, mid-generation 2, mid-generation 5; then run to the end
    assert _run_until(
        SYNTHETIC + KILL_SETTINGS + ["--workers", "0", "--run-dir", str(run_dir)], run_dir, 2
    )
    assert not (run_dir / "checkpoint.pkl").exists()
    assert _run_until(["--resume", str(run_dir), "--workers", "0", "--no-progress"], run_dir, 9)
    assert _run_until(["--resume", str(run_dir), "--workers", "0", "--no-progress"], run_dir, 27)
    _cli(["--resume", str(run_dir), "--workers", "0", "--no-progress"])
    x_ref, f_ref = final_population(synthetic_reference)
    x, f = final_population(run_dir)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(f, f_ref)
    keys = [tuple(r["key"]) for r in read_cache_records(run_dir)]
    assert (
        len(keys) == len(set(keys)) == len(read_cache_records(synthetic_reference))
    )  # nothing evaluated twice
    ref = xr.open_dataset(synthetic_reference / "evaluations.nc", engine="h5netcdf").load()
    got = xr.open_dataset(run_dir / "evaluations.nc", engine="h5netcdf").load()
    xr.testing.assert_identical(got.drop_attrs(), ref.drop_attrs())
    # resuming a finished run only rewrites the results
    assert (
        "0 evaluations"
        in _cli(["--resume", str(run_dir), "--workers", "0", "--no-progress"]).stdout
    )


def test_checkpoint_written_by_the_old_optimize_module_still_loads(tmp_path, monkeypatch):
    import pickle
    import types

    from lnss_lib.campaign import DesignGrid, WalkerDesignProblem, load_checkpoint, run_campaign
    from lnss_lib.campaign.rundir import CHECKPOINT_FILE

    run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "generations": 2}},
        workers=0,
        run_dir=tmp_path / "run",
        progress=False,
    )
    checkpoint = load_checkpoint(tmp_path / "run")
    old = types.ModuleType("lnss_lib.optimize")
    with monkeypatch.context() as patch:  # pickle the classes under the module name they had before
        patch.setitem(sys.modules, "lnss_lib.optimize", old)
        for cls, name in (
            (WalkerDesignProblem, "WalkerDesignProblem"),
            (CampaignPlan, "CampaignSettings"),
            (DesignGrid, "DesignGrid"),
        ):  # the campaign plan was CampaignSettings then
            patch.setattr(old, name, cls, raising=False)
            patch.setattr(cls, "__module__", "lnss_lib.optimize")
        CampaignPlan.__qualname__ = "CampaignSettings"
        try:
            data = pickle.dumps(checkpoint)
        finally:
            CampaignPlan.__qualname__ = "CampaignPlan"
    assert b"CampaignSettings" in data
    assert b"lnss_lib.optimize" in data and "lnss_lib.optimize" not in sys.modules
    (tmp_path / "run" / CHECKPOINT_FILE).write_bytes(data)
    loaded = load_checkpoint(tmp_path / "run")
    assert type(loaded["algorithm"].problem) is WalkerDesignProblem
    np.testing.assert_array_equal(
        loaded["algorithm"].pop.get("X"), checkpoint["algorithm"].pop.get("X")
    )
    assert run_campaign(resume=tmp_path / "run", workers=0, progress=False).generations == 2


def test_ctrl_c_on_a_dask_campaign_is_one_line_and_resumes(synthetic_reference, tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) on a campaign
    with local Dask workers: one line, exit 130, no worker left; the checkpoint resumes to the
    uninterrupted result. Before: 67 lines of worker tracebacks."""
    run_dir = tmp_path / "interrupted"
    proc = subprocess.Popen(
        CLI + SYNTHETIC + KILL_SETTINGS + ["--workers", "2", "--run-dir", str(run_dir)],
        cwd=PROJECT_DIR,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=foreground_signals,
    )
    deadline = time.monotonic() + 120
    while proc.poll() is None and _journal_count(run_dir) < 9:  # inside generation 2
        assert time.monotonic() < deadline, "campaign did not progress"
        time.sleep(0.02)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 130 and err.strip() == "error: interrupted", err
    deadline = time.monotonic() + 30
    while subprocess.run(
        ["pgrep", "-s", str(proc.pid)], capture_output=True
    ).stdout:  # workers wind down
        assert time.monotonic() < deadline, "worker processes left behind"
        time.sleep(0.2)
    _cli(["--resume", str(run_dir), "--workers", "0", "--no-progress"])
    for got, want in zip(final_population(run_dir), final_population(synthetic_reference)):
        np.testing.assert_array_equal(got, want)


def _checkpoint_of_a_run(tmp_path):
    from lnss_lib.campaign import run_campaign
    from lnss_lib.campaign.rundir import CHECKPOINT_FILE

    run_dir = tmp_path / "run"
    run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "generations": 2}},
        workers=0,
        run_dir=run_dir,
        progress=False,
    )
    return run_dir, run_dir / CHECKPOINT_FILE


def test_damaged_checkpoint_never_loads(tmp_path):
    """300 random one-byte corruptions and 30 truncations of a checkpoint are all refused
    with CheckpointError (before: 93 of these 300 corruptions loaded silently)."""
    from lnss_lib.campaign.rundir import CheckpointError, load_checkpoint

    run_dir, path = _checkpoint_of_a_run(tmp_path)
    good = path.read_bytes()
    assert load_checkpoint(run_dir)["generation"] == 2
    rng = np.random.default_rng(21)
    for position, flip in zip(rng.integers(0, len(good), 300), rng.integers(1, 256, 300)):
        damaged = bytearray(good)
        damaged[position] ^= int(flip)
        path.write_bytes(bytes(damaged))
        with pytest.raises(CheckpointError, match="delete it and resume"):
            load_checkpoint(run_dir)
    for length in rng.integers(0, len(good), 30):  # cut short
        path.write_bytes(good[:length])
        with pytest.raises(CheckpointError, match="truncated or corrupt"):
            load_checkpoint(run_dir)


class _Exploit:
    """Pickles as a call of ``os.system``: what a forged checkpoint would hold."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def test_forged_checkpoint_is_refused_without_running_code(tmp_path):
    """A checkpoint that would run code when unpickled is refused (raw, with a valid checksum
    header, nested in a plausible checkpoint, or naming an allowed module's other attributes)."""
    import hashlib
    import json
    import pickle

    from lnss_lib.campaign.rundir import CHECKPOINT_MAGIC, CheckpointError, load_checkpoint

    run_dir, path = _checkpoint_of_a_run(tmp_path)
    marker = tmp_path / "code_ran"

    def call(
        module: str, name: str, argument: str
    ) -> bytes:  # protocol 4: STACK_GLOBAL, then REDUCE
        text = [item.encode() for item in (module, name, argument)]
        return (
            b"\x80\x04"
            + b"".join(b"\x8c" + bytes([len(t)]) + t for t in text[:2])
            + b"\x93"
            + b"\x8c"
            + bytes([len(text[2])])
            + text[2]
            + b"\x85R."
        )

    payloads = [
        pickle.dumps(_Exploit(marker)),
        pickle.dumps({"generation": 1, "algorithm": _Exploit(marker)}),
        call("numpy", "load", "/x.npy"),
        call("numpy", "sum.__globals__", "x"),
        call("lnss_lib.campaign.grid", "np.load", "/x.npy"),
        call("builtins", "eval", "1"),
    ]
    for payload in payloads:
        header = json.dumps({"format": 2, "sha256": hashlib.sha256(payload).hexdigest()}).encode()
        for data in (payload, CHECKPOINT_MAGIC + header + b"\n" + payload):
            path.write_bytes(data)
            with pytest.raises(CheckpointError, match="refused"):
                load_checkpoint(run_dir)
            assert not marker.exists()


def test_two_runs_publishing_at_once_publish_one_run(tmp_path):
    """Two campaigns of one profile publishing at once (threads here, each with its own
    flock) while a reader loads: every load holds the three files of one run (before, the three
    files were copied one by one into the same folder: 3 of 6 trials mixed seeds)."""
    import threading

    from lnss_lib.campaign import export_results, run_campaign
    from lnss_lib.campaign.publication import load_published, publish_run

    campaign_dir = tmp_path / "campaign"
    runs = {}
    for seed in (1, 2):
        result = run_campaign(
            "ci",
            overrides={"campaign": {"evaluator": "synthetic", "generations": 2, "seed": seed}},
            workers=0,
            run_dir=campaign_dir / f"run_{seed}",
            progress=False,
        )
        runs[seed] = (result.run_dir, export_results(result.run_dir))
    seen, errors = [], []

    def publisher(seed):
        try:
            for _ in range(4):
                publish_run(runs[seed][0], campaign_dir, runs[seed][1])
        except Exception as error:  # reported below
            errors.append(error)

    def reader():
        try:
            while any(t.is_alive() for t in writers):
                published = load_published(campaign_dir)
                if published is not None:
                    seeds = {
                        int(ds.attrs["seed"])
                        for ds in (published.evaluations, published.front, published.history)
                    }
                    seen.append((published.pointer["run_dir"], seeds))
        except Exception as error:
            errors.append(error)

    writers = [threading.Thread(target=publisher, args=(seed,)) for seed in (1, 2)]
    for thread in writers:
        thread.start()
    read = threading.Thread(target=reader)
    read.start()
    for thread in writers + [read]:
        thread.join()
    assert not errors, errors
    assert seen and all(seeds == {int(run[-1])} for run, seeds in seen), seen
    assert len(list((campaign_dir / "published").iterdir())) == 1  # superseded copies removed


def test_progress_lines_fit_80_columns_and_report_the_summary_rate(tmp_path):
    import os
    import re

    env = {**os.environ, "COLUMNS": "200"}
    args = [
        "--profile",
        "ci",
        "--evaluator",
        "synthetic",
        "--workers",
        "0",
        "--run-dir",
        str(tmp_path / "run"),
        "--set",
        "campaign.generations=4",
        "--set",
        "campaign.synthetic_delay_s=0.02",
    ]
    done = subprocess.run(
        CLI + args, cwd=PROJECT_DIR, capture_output=True, text=True, timeout=300, env=env
    )
    assert done.returncode == 0, done.stderr
    lines = [line for line in re.split(r"[\r\n]", done.stderr) if line.strip()]
    assert lines and max(map(len, lines)) <= 80, max(lines, key=len)
    assert not any("designs |" in line for line in lines)  # piped: no design bar ...
    assert (
        sum("4/4 gen" in line for line in lines) <= 2
    )  # ... and a generation's line once (and on closing)
    shown = float(re.findall(r"([0-9.]+) designs/s", lines[-1])[-1])
    summary = float(re.search(r"\(([0-9.]+) designs/s\)", done.stdout).group(1))
    assert shown == pytest.approx(summary, rel=0.05)
    assert "feasible" in lines[-1] and "min cv" not in done.stderr


def test_a_partial_run_never_replaces_a_finished_publication(tmp_path):
    """A session stopped by --max-generations publishes only where no finished run is published."""
    from lnss_lib.campaign import run_campaign
    from lnss_lib.campaign.publication import load_published, publish_run
    from lnss_lib.errors import ConfigError

    campaign_dir = tmp_path / "campaign"
    synthetic = {"campaign": {"evaluator": "synthetic", "generations": 2}}
    finished = run_campaign(
        "ci", overrides=synthetic, workers=0, run_dir=campaign_dir / "run_1", progress=False
    )
    partial = run_campaign(
        "ci",
        overrides=synthetic,
        workers=0,
        run_dir=campaign_dir / "run_2",
        progress=False,
        max_generations=1,
    )
    assert publish_run(
        partial.run_dir, campaign_dir
    ).is_file()  # nothing finished published yet: it may
    publish_run(finished.run_dir, campaign_dir)
    with pytest.raises(ConfigError, match="has not finished and does not replace it"):
        publish_run(partial.run_dir, campaign_dir)
    assert load_published(campaign_dir).pointer["run_dir"] == "run_1"


@pytest.mark.parametrize("content", ["front.nc", "notes/"])
def test_a_new_run_goes_only_into_a_missing_or_empty_folder(tmp_path, capsys, content):
    """--run-dir on a folder holding anything is refused (exit 2) and the folder is left as it was; a blank
    --run-dir (the current folder) is refused."""
    from lnss_lib.__main__ import main

    run_dir = tmp_path / "run"
    (run_dir / content).parent.mkdir(parents=True, exist_ok=True)
    if content.endswith("/"):
        (run_dir / content).mkdir()
    else:
        (run_dir / content).write_bytes(b"keep")
    before = sorted(p.name for p in run_dir.iterdir())
    args = [
        "campaign",
        "--profile",
        "ci",
        "--evaluator",
        "synthetic",
        "--workers",
        "0",
        "--no-progress",
    ]
    assert main(args + ["--run-dir", str(run_dir)]) == 2
    err = capsys.readouterr().err
    assert (
        "is not empty" in err and content.rstrip("/") in err and len(err.strip().splitlines()) == 1
    )
    assert sorted(p.name for p in run_dir.iterdir()) == before
    assert content.endswith("/") or (run_dir / content).read_bytes() == b"keep"
    for blank in ("", "  "):
        assert main(args + ["--run-dir", blank]) == 2
        assert "a folder path is needed" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(args + ["--run-dir", str(tmp_path / "empty"), "--max-generations", "1"]) == 0
    assert (tmp_path / "empty" / "run.json").is_file()
