"""The validated front: selection rules, validated.nc round trip, failed and raising closed loops
kept and marked, a resumed validation equal to an uninterrupted one, the wiring into the campaign and the CLI."""

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import run_campaign, validation
from lnss_lib.campaign.runner import validate_run
from lnss_lib.campaign.validation import (
    CLOSED_LOOP_KEYS,
    N_MINUS_1_KEYS,
    STATUSES,
    VALIDATED_FILE,
    VALIDATION_JOURNAL,
    select_designs,
    validation_task,
)
from lnss_lib.config import PROJECT_DIR
from lnss_lib.design_life.service import PURPOSES
from lnss_lib.keys import DESIGN_KEYS, closed_loop_dv_key
from lnss_lib.settings import load_settings

VALIDATING = {
    "campaign": {
        "evaluator": "synthetic",
        "max_errors": 10,  # the stand-in's injected errors tolerated
        # judged on the 10-day availability: a search whose front holds designs of every kind the
        # validation treats (kept, failed, raising), whatever the life estimate's stand-in says
        "objectives": [
            "n_sat",
            "pdop_mean_3sigma",
            "-pdop_avail_pct",
            "hdop_mean_3sigma",
            "-hdop_avail_pct",
            "sk_dv_estimate_kms_per_year",
            "sk_dv_estimate_max_kms_per_year",
            "-gps_visible_mean",
            "gps_pdop_mean",
        ],
        "constraints": {
            "pdop_avail_pct_worst_month_estimate": "off",
            "pdop_avail_pct": {"min": 70.0},
        },
    },
    "front_validation": {
        "max_designs": 2,
        "headline_per_size": 2,
        "headline_sizes": [10, 12],
        "availability_min_pct": 75.0,
    },
}


def fake_closed_loop(settings, design, *, numba_threads=0):
    """A closed-form stand-in for :func:`validation_task` (no physics): i < 3 deg loses a satellite, 5 planes raise."""
    if design["n_planes"] == 5:
        return {
            **dict.fromkeys(CLOSED_LOOP_KEYS, math.nan),
            "status": "error",
            "error": "RuntimeError: injected",
        }
    dv = design["sma_km"] / 1e5
    record = {k: dv for k in CLOSED_LOOP_KEYS}
    lost = design["inc_deg"] < 3.0
    record.update(
        closed_loop_dv_max_kms_per_year=1.5 * dv,
        impact_day=10.0 if lost else math.nan,
        n_lost=float(lost),
        requirement_held=1.0,
        n_maneuvers=3.0,
        wall_s=0.5,
    )
    return {**record, "status": "failed" if lost else "kept", "error": ""}


def _datasets(cost, n_sat, avail, feasible, front_rows):
    n = len(cost)
    data = {
        "sma_km": ("design", 5000.0 + 100.0 * np.arange(n)),
        "ecc": ("design", np.full(n, 0.3)),
        "aop_deg": ("design", np.full(n, 90.0)),
        "inc_deg": ("design", np.full(n, 60.0)),
        "n_planes": ("design", np.ones(n, dtype=np.int64)),
        "sats_per_plane": ("design", np.asarray(n_sat)),
        "n_sat": ("design", np.asarray(n_sat)),
        "pdop_avail_pct": ("design", np.asarray(avail, float)),
        "sk_dv_estimate_max_kms_per_year": ("design", np.asarray(cost, float)),
        "feasible": ("design", np.asarray(feasible, bool)),
    }
    evaluations = xr.Dataset(data)
    return evaluations, evaluations.isel(design=list(front_rows))


def test_selection_rules():
    """Front capped at max_designs by the worst-satellite estimate (NaN last); headline per size among feasible
    designs meeting the availability; a design chosen twice listed once as front+headline; off selects nothing."""
    import dataclasses

    fv = load_settings("ci_operational").front_validation
    cost = [0.5, 0.1, np.nan, 0.3, 0.2, 0.05, 0.9, 0.04]
    n_sat = [6, 6, 8, 8, 12, 12, 6, 16]
    avail = [95, 99, 100, 80, 91, 95, 100, 50]
    feasible = [1, 1, 1, 1, 1, 1, 1, 0]
    evaluations, front = _datasets(cost, n_sat, avail, feasible, [0, 1, 2, 3])
    fv = dataclasses.replace(
        fv,
        max_designs=3,
        headline_per_size=1,
        headline_sizes=(6, 8, 12, 16),
        availability_min_pct=90.0,
    )
    chosen = select_designs(evaluations, front, fv)
    by_sma = {row["sma_km"]: row["selected_for"] for row in chosen}
    # front: rows 1 (0.1), 3 (0.3), 0 (0.5); row 2 (NaN) dropped by the cap
    # headline: 6 -> row 1 (0.1); 8 -> row 2 (only one with avail >= 90); 12 -> row 5 (0.05); 16: row 7 infeasible
    assert by_sma == {
        5100.0: "front+headline",
        5300.0: "front",
        5000.0: "front",
        5200.0: "headline",
        5500.0: "headline",
    }
    assert [row["sma_km"] for row in chosen][:3] == [5100.0, 5300.0, 5000.0]
    assert all(set(DESIGN_KEYS) <= set(row) for row in chosen)
    assert select_designs(evaluations, front, dataclasses.replace(fv, max_designs=0)) == []
    uncapped = select_designs(
        evaluations, front, dataclasses.replace(fv, max_designs=10, headline_per_size=0)
    )
    assert [row["sma_km"] for row in uncapped] == [5100.0, 5300.0, 5000.0, 5200.0]


@pytest.fixture(scope="module")
def validated_run(tmp_path_factory):
    """A synthetic ci_operational run validated with the stand-in closed loop (in process)."""
    run_dir = tmp_path_factory.mktemp("validated") / "run"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validation, "validation_task", fake_closed_loop)
        result = run_campaign(
            "ci_operational", overrides=VALIDATING, workers=0, run_dir=run_dir, progress=False
        )
    assert run_dir / VALIDATED_FILE in result.files
    return run_dir


def test_validated_file_round_trips(validated_run):
    """validated.nc holds the schema notebook 07 reads and reads back with the same values and attributes."""
    ds = xr.load_dataset(validated_run / VALIDATED_FILE, engine="h5netcdf")
    names = {
        *DESIGN_KEYS,
        "n_sat",
        "sk_dv_estimate_kms_per_year",
        "sk_dv_estimate_max_kms_per_year",
        "pdop_avail_pct",
        "hdop_avail_pct",
        "pdop_mean_3sigma",
        "selected_for",
        "status",
        "error",
        *CLOSED_LOOP_KEYS,
        *(closed_loop_dv_key(p) for p in PURPOSES),
    }
    assert names <= set(ds.data_vars) and ds.sizes["design"] >= 3
    assert (
        ds.attrs["complete"] == 1
        and ds.attrs["life_days"] == 30.0
        and ds.attrs["controller"] == "service"
    )
    assert ds.attrs["element_frame"] == "moon_op" and ds.attrs["profile"] == "ci_operational"
    assert (
        ds["requirement_held"].dtype == np.int8
        and ds["closed_loop_dv_kms_per_year"].attrs["units"] == "km s-1 yr-1"
    )
    units = {
        "min_perilune_alt_km": "km",
        "impact_day": "day",
        "pdop_avail_pct_life": "percent",
        "wall_s": "s",
        "n_lost": "1",
        "closed_loop_dv_navigation_kms_per_year": "km s-1 yr-1",
        "inc_deg": "degree",
    }
    assert {name: ds[name].attrs["units"] for name in units} == units
    assert set(ds["status"].values) <= set(STATUSES)
    assert set(ds["selected_for"].values) <= {"front", "headline", "front+headline"}
    front = xr.load_dataset(validated_run / "front.nc", engine="h5netcdf")
    assert (ds["selected_for"].values != "headline").sum() == min(2, front.sizes["design"])
    assert "headline" in set(ds["selected_for"].values) and "front+headline" in set(
        ds["selected_for"].values
    )
    expected = ds["sma_km"].values / 1e5
    kept = ds["status"].values == "kept"
    np.testing.assert_array_equal(ds["closed_loop_dv_kms_per_year"].values[kept], expected[kept])
    copy = validated_run.parent / "copy.nc"
    from lnss_lib.atomicio import write_netcdf_atomic

    write_netcdf_atomic(ds, copy)
    xr.testing.assert_identical(xr.load_dataset(copy, engine="h5netcdf"), ds)


def test_failed_and_raising_designs_are_kept(validated_run):
    """A lost satellite is 'failed' with its impact day; a raising closed loop is 'error' with its message."""
    ds = xr.load_dataset(validated_run / VALIDATED_FILE, engine="h5netcdf")
    assert set(ds["status"].values) == set(STATUSES)  # the stand-in gives each status on this front
    for i in range(ds.sizes["design"]):
        status = str(ds["status"].values[i])
        if ds["n_planes"].values[i] == 5:
            assert status == "error" and "injected" in str(ds["error"].values[i])
            assert math.isnan(ds["closed_loop_dv_kms_per_year"].values[i])
        elif ds["inc_deg"].values[i] < 3.0:
            assert (
                status == "failed"
                and ds["n_lost"].values[i] == 1
                and ds["impact_day"].values[i] == 10.0
            )
        else:
            assert status == "kept" and ds["error"].values[i] == ""


def test_raising_closed_loops_stop_the_validation(tmp_path, capsys):
    """More closed loops raising than campaign.max_errors (0) stop the validation like the campaign's evaluation
    errors: CampaignStopped naming the design and the journal, validated.nc written with the error kept and marked
    incomplete, the run not published; from the command line exit 1 in one line; resumed once the cause is gone, the
    error record is flown again."""
    from lnss_lib.campaign.callbacks import CampaignStopped

    run_dir = tmp_path / "run"
    strict = {**VALIDATING, "campaign": {**VALIDATING["campaign"], "max_errors": 0}}
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validation, "validation_task", fake_closed_loop)
        with pytest.raises(
            CampaignStopped, match="closed loop.s. raised, more than campaign.max_errors = 0"
        ) as stop:
            run_campaign(
                "ci_operational", overrides=strict, workers=0, run_dir=run_dir, progress=False
            )
        assert (
            "injected" in str(stop.value)
            and VALIDATION_JOURNAL in str(stop.value)
            and stop.value.errors == 1
        )
        ds = xr.load_dataset(run_dir / VALIDATED_FILE, engine="h5netcdf")
        assert ds.attrs["complete"] == 0 and list(ds["status"].values).count("error") == 1
        code, err = _cli(["--validate", str(run_dir), "--no-progress"], capsys)
    assert code == 1 and err.count("\n") == 1 and "more than campaign.max_errors" in err
    flown = []

    def mended(settings, design, *, numba_threads=0):
        flown.append(design)
        return fake_closed_loop(settings, {**design, "n_planes": 1})

    result, _ = validate_run(run_dir, workers=0, progress=False, task=mended)
    assert [d["n_planes"] for d in flown].count(5) >= 1 and "error" not in set(
        result.dataset["status"].values
    )
    assert result.dataset.attrs["complete"] == 1


def test_closed_loop_into_the_moon_is_failed_or_error():
    """The real task: a 7800 km e 0.74 i 17 deg orbit whose 290 km perilune the monthly swing takes into the surface
    within days (the half-monthly swing of e) is 'failed' with its impact day within the 6-day life; an orbit through the surface
    is 'error' with the reason. Neither raises."""
    settings = load_settings("ci_operational", overrides={"design_life": {"life_days": 6.0}})
    record = validation_task(settings, dict(zip(DESIGN_KEYS, (7800.0, 0.74, 0.0, 17.0, 1, 1))))
    assert (
        record["status"] == "failed" and record["n_lost"] == 1 and 0.0 < record["impact_day"] <= 6.0
    )
    record = validation_task(settings, dict(zip(DESIGN_KEYS, (2000.0, 0.3, 90.0, 60.0, 1, 1))))
    assert record["status"] == "error" and "hits the Moon" in record["error"]


def test_headline_candidates_report_their_worst_single_loss():
    """The real task on the Table 4 ELFO as 2 x 2 for 6 days: flown as a headline candidate it reports the satellite
    whose loss costs most and the service without it, never above the full constellation's (a row fewer in every
    geometry matrix); flown for the front only, no N-1 (NaN)."""
    settings = load_settings("ci_operational", overrides={"design_life": {"life_days": 6.0}})
    design = dict(zip(DESIGN_KEYS, (6143.0, 0.6, 90.0, 51.7, 2, 2)))
    headline = validation_task(settings, design | {"selected_for": "front+headline"})
    assert headline["status"] == "kept" and headline["n_minus_1_sat"] in range(4)
    for key in (
        "pdop_avail_pct_worst_month",
        "pdop_avail_pct_life",
        "hdop_avail_pct_worst_month",
        "hdop_avail_pct_life",
    ):
        assert headline[f"{key}_n_minus_1"] <= headline[key] + 1e-9
    assert (
        headline["pdop_avail_pct_life_n_minus_1"] < headline["pdop_avail_pct_life"]
    )  # four satellites: 3 fix nothing
    front = validation_task(settings, design | {"selected_for": "front"})
    assert all(math.isnan(front[k]) for k in N_MINUS_1_KEYS)
    assert {k: front[k] for k in CLOSED_LOOP_KEYS if k not in N_MINUS_1_KEYS and k != "wall_s"} == {
        k: headline[k] for k in CLOSED_LOOP_KEYS if k not in N_MINUS_1_KEYS and k != "wall_s"
    }


def test_raising_closed_loop_is_an_error_record(monkeypatch):
    """An exception inside the design life becomes status 'error' with the exception's message."""
    import lnss_lib.design_life.evaluation as evaluation

    def boom(*args, **kwargs):
        raise FloatingPointError("no convergence")

    monkeypatch.setattr(evaluation, "run_design_life", boom)
    record = validation_task(
        load_settings("ci_operational"), dict(zip(DESIGN_KEYS, (6143.0, 0.6, 90.0, 51.7, 2, 1)))
    )
    assert record["status"] == "error" and record["error"] == "FloatingPointError: no convergence"
    assert all(math.isnan(record[k]) for k in CLOSED_LOOP_KEYS if k != "wall_s")


def test_resumed_validation_equals_uninterrupted(validated_run, tmp_path):
    """A journal cut after k designs, with a torn last line, resumes to the same validated.nc, flying only the rest."""
    reference = xr.load_dataset(validated_run / VALIDATED_FILE, engine="h5netcdf")
    run_dir = tmp_path / "run"
    shutil.copytree(validated_run, run_dir)
    journal = run_dir / VALIDATION_JOURNAL
    lines = journal.read_bytes().splitlines(keepends=True)
    k = 2
    journal.write_bytes(
        b"".join(lines[: 1 + k]) + lines[1 + k][:40]
    )  # header, k designs, a torn line
    (run_dir / VALIDATED_FILE).unlink()
    flown = []

    def counting(settings, design, *, numba_threads=0):
        flown.append(design)
        return fake_closed_loop(settings, design)

    result, _ = validate_run(run_dir, workers=0, progress=False, task=counting)
    n = reference.sizes["design"]
    n_error = int((reference["status"].values == "error").sum())
    assert (
        len(flown) == n - k or len(flown) == n - k + n_error
    )  # error records of a past session are retried
    assert result.n_journaled == n
    xr.testing.assert_identical(
        xr.load_dataset(run_dir / VALIDATED_FILE, engine="h5netcdf"), reference
    )


def test_campaign_killed_during_validation_resumes_without_nsga2(tmp_path):
    """A run stopped during its validation and resumed finishes the validation; no design is evaluated again."""
    run_dir = tmp_path / "run"
    calls = []

    def dies_after_one(settings, design, *, numba_threads=0):
        if calls:
            raise KeyboardInterrupt
        calls.append(design)
        return fake_closed_loop(settings, design)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validation, "validation_task", dies_after_one)
        with pytest.raises(KeyboardInterrupt):
            run_campaign(
                "ci_operational", overrides=VALIDATING, workers=0, run_dir=run_dir, progress=False
            )
    assert not (run_dir / VALIDATED_FILE).exists()
    evaluations_before = (run_dir / "evaluations.jsonl").read_bytes()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validation, "validation_task", fake_closed_loop)
        result = run_campaign("ci_operational", resume=run_dir, workers=0, progress=False)
    assert result.session_evaluations == 0
    assert (run_dir / "evaluations.jsonl").read_bytes() == evaluations_before
    assert xr.load_dataset(run_dir / VALIDATED_FILE, engine="h5netcdf").attrs["complete"] == 1


def _cli(args, capsys):
    """``python -m lnss_lib campaign ARGS`` in this process: (exit code, stderr)."""
    from lnss_lib.__main__ import main

    code = main(["campaign", *args])
    return code, capsys.readouterr().err


def test_early_stop_does_not_validate(tmp_path, capsys):
    """--max-generations that stops before NSGA-II finishes writes no validated.nc; --validate then refuses."""
    run_dir = tmp_path / "run"
    run_campaign(
        "ci_operational",
        overrides=VALIDATING,
        workers=0,
        run_dir=run_dir,
        progress=False,
        max_generations=1,
    )
    assert not (run_dir / VALIDATED_FILE).exists() and not (run_dir / VALIDATION_JOURNAL).exists()
    code, err = _cli(["--validate", str(run_dir)], capsys)
    assert code == 2 and "not finished" in err and "Traceback" not in err


def test_cli_validate_errors(tmp_path, capsys):
    """Clean one-line errors, exit 2: no folder, a profile that validates nothing, flags that do not apply (one
    run as a process: no traceback on stderr)."""
    done = subprocess.run(
        [sys.executable, "-m", "lnss_lib", "campaign", "--validate", str(tmp_path / "absent")],
        cwd=PROJECT_DIR,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and "not a folder" in done.stderr and "Traceback" not in done.stderr
    off = tmp_path / "off"
    run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic"}},
        workers=0,
        run_dir=off,
        progress=False,
    )
    code, err = _cli(["--validate", str(off), "--no-progress"], capsys)
    assert code == 2 and "max_designs = 0" in err
    code, err = _cli(["--validate", str(off), "--profile", "ci"], capsys)
    assert code == 2 and "drop --profile" in err
