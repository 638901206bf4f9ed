"""The validated front: the campaign's front flown in closed loop over the design life.

After NSGA-II, :func:`validate_front` flies every selected design (:func:`select_designs`: the feasible
non-dominated designs up to ``[front_validation] max_designs``, plus the headline's candidates) with the
service controller over ``[design_life] life_days``, every satellite (``max_sats_per_plane`` 0), controlled run only
(:func:`lnss_lib.design_life.evaluation.run_design_life` with ``natural=False``, then ``life_navigation`` and
``life_metrics``), elements in the profile's element frame (:meth:`lnss_lib.constellation.WalkerDesign.elements_deg`).
Designs run on the campaign's backend (:func:`lnss_lib.campaign.backends.open_backend` with
:func:`validation_task`); each finished design is appended to ``validated.jsonl`` in the run folder (the campaign
journal's format and parser, :mod:`lnss_lib.campaign.journal`: a torn last line is dropped, a resumed validation
flies only the designs not journaled), then ``validated.nc`` is written atomically beside ``front.nc``
(:data:`VALIDATED_FILE`, dimension ``design``, CF-1.8). A design whose closed loop raises is kept with
``status = "error"`` and its message, one that loses a satellite (impact, escape) under control with
``status = "failed"``; none is dropped. A closed loop that raises is an error, never a result: as the campaign's
evaluation errors (:class:`~lnss_lib.campaign.callbacks.ErrorGuard`), more than ``[campaign] max_errors`` of them stop
the validation (:class:`~lnss_lib.campaign.callbacks.CampaignStopped`, after ``validated.nc`` is written with what was
flown, the run left unpublished); an error record is flown again when the validation is resumed. The campaign layer imports the design-life kernels (layer 2), never the other
way round.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from .. import kernel_cpu
from ..atomicio import write_netcdf_atomic
from ..errors import ConfigError
from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS, METRIC_KEYS, closed_loop_dv_key
from ..progress import CellProgress
from ..settings import FrontValidationSettings, Settings, settings_from_profile
from .callbacks import CampaignStopped
from .journal import EvaluationCache
from .rundir import export_results, load_checkpoint, load_run, run_kernel_cpu
from .settings import CampaignPlan, evaluation_profile
from .tasks import cap_numba_threads, worker_fields

__all__ = [
    "VALIDATED_FILE",
    "VALIDATION_JOURNAL",
    "COST_KEY",
    "STATUSES",
    "CLOSED_LOOP_KEYS",
    "N_MINUS_1_KEYS",
    "select_designs",
    "validation_task",
    "validated_dataset",
    "validate_front",
    "ValidationResult",
    "check_validatable",
]

VALIDATED_FILE, VALIDATION_JOURNAL = "validated.nc", "validated.jsonl"
COST_KEY = "sk_dv_estimate_max_kms_per_year"
"""The ranking of :func:`select_designs`: the campaign's worst-satellite Delta-V estimate (cheapest first)."""
STATUSES = ("kept", "failed", "error")


def _closed_loop_keys() -> tuple[str, ...]:
    from ..design_life.service import PURPOSES

    return (
        "closed_loop_dv_kms_per_year",
        "closed_loop_dv_max_kms_per_year",
        *(closed_loop_dv_key(p) for p in PURPOSES),
        "min_perilune_alt_km",
        "impact_day",
        "n_lost",
        "pdop_avail_pct_worst_month",
        "hdop_avail_pct_worst_month",
        "pdop_avail_pct_life",
        "hdop_avail_pct_life",
        "requirement_held",
        "n_maneuvers",
        *N_MINUS_1_KEYS,
        "wall_s",
    )


N_MINUS_1_KEYS = (
    "n_minus_1_sat",
    "pdop_avail_pct_worst_month_n_minus_1",
    "pdop_avail_pct_life_n_minus_1",
    "hdop_avail_pct_worst_month_n_minus_1",
    "hdop_avail_pct_life_n_minus_1",
)
"""A headline design's service with its worst single satellite lost (the satellite, then availabilities in %), read
from its own flight (:func:`lnss_lib.design_life.evaluation.satellite_loss`); NaN for designs flown for the front
only."""


CLOSED_LOOP_KEYS = _closed_loop_keys()
"""The numbers :func:`validation_task` returns for a design (NaN where undefined: an error, no impact)."""

_LONG_NAMES = {  # where a CF long_name says more than the key's label (lnss_lib.keys.LABELS)
    "closed_loop_dv_kms_per_year": "closed-loop station-keeping Delta-V per satellite and year (mean over satellites)",
    "closed_loop_dv_max_kms_per_year": "closed-loop station-keeping Delta-V per year of the worst satellite",
    "impact_day": "first day a satellite is lost under control (NaN: none)",
    "requirement_held": "1: the controller held every quantity it keeps within its tolerance (box_held); 0: not",
    "wall_s": "wall time of the design's closed loop",
    "selected_for": "why the design was flown: front, headline or front+headline",
    "status": "kept: no satellite lost; failed: a satellite lost under control; error: the closed loop raised",
    "error": "message of a closed loop that raised (empty when none)",
    "n_sat": "satellites of the design",
}


def _order_by_cost(ds: xr.Dataset, index: np.ndarray) -> np.ndarray:
    """``index`` (rows of ``ds``) sorted cheapest first by :data:`COST_KEY` (stable; NaN or no column: last)."""
    if COST_KEY not in ds or not index.size:
        return index
    return index[np.argsort(ds[COST_KEY].values[index], kind="stable")]


def _key(row: dict) -> tuple:
    return tuple(int(row[k]) if k in INTEGER_DESIGN_KEYS else float(row[k]) for k in DESIGN_KEYS)


def select_designs(
    evaluations: xr.Dataset, front: xr.Dataset, fv: FrontValidationSettings
) -> list[dict]:
    """The designs to fly, each ``{DESIGN_KEYS..., "selected_for"}``, front first.

    ``front``: every feasible non-dominated design, the ``max_designs`` cheapest by :data:`COST_KEY` when there are
    more. Headline: for each of ``headline_sizes``, the ``headline_per_size`` cheapest feasible designs of
    ``evaluations`` with that ``n_sat`` and ``pdop_avail_pct >= availability_min_pct``. A design chosen for both is
    listed once, ``"front+headline"``. Nothing is chosen when ``max_designs`` is 0 (validation off).
    """
    if fv.max_designs == 0:
        return []
    chosen: dict[tuple, dict] = {}

    def add(ds: xr.Dataset, rows: np.ndarray, reason: str) -> None:
        for i in rows:
            row = {k: ds[k].values[i].item() for k in DESIGN_KEYS}
            key = _key(row)
            if key in chosen:
                if reason not in chosen[key]["selected_for"].split("+"):
                    chosen[key]["selected_for"] += f"+{reason}"
            else:
                chosen[key] = {**dict(zip(DESIGN_KEYS, key)), "selected_for": reason}

    front_rows = (
        np.flatnonzero(front["feasible"].values.astype(bool))
        if front.sizes.get("design")
        else np.zeros(0, int)
    )
    add(front, _order_by_cost(front, front_rows)[: fv.max_designs], "front")
    if fv.headline_per_size and evaluations.sizes.get("design"):
        feasible = evaluations["feasible"].values.astype(bool)
        avail_ok = evaluations["pdop_avail_pct"].values >= fv.availability_min_pct
        for size in fv.headline_sizes:
            rows = np.flatnonzero(feasible & avail_ok & (evaluations["n_sat"].values == size))
            add(evaluations, _order_by_cost(evaluations, rows)[: fv.headline_per_size], "headline")
    return list(chosen.values())


def _failed_record(message: str, wall_s: float) -> dict:
    return {
        **dict.fromkeys(CLOSED_LOOP_KEYS, math.nan),
        "wall_s": wall_s,
        "status": "error",
        "error": message,
        **worker_fields(),
    }


def validation_task(settings: Settings, design: dict, *, numba_threads: int = 0) -> dict:
    """One design's closed loop over ``[design_life] life_days`` (a backend task; never raises): a JSON-ready record
    of :data:`CLOSED_LOOP_KEYS`, ``status`` and ``error``.

    ``settings``: the run's evaluation settings (:func:`~lnss_lib.campaign.settings.evaluation_profile`). Controlled
    run only; navigation month by month (``[life_evaluation] month_days``) on positions every ``sample_step_s``; for a
    headline candidate also with its worst single satellite lost (:data:`N_MINUS_1_KEYS`).
    """
    from ..constellation import WalkerDesign
    from ..design_life.evaluation import (
        life_metrics,
        life_navigation,
        run_design_life,
        satellite_loss,
    )

    start = time.perf_counter()
    cap_numba_threads(numba_threads)
    try:
        walker = WalkerDesign(*(design[k] for k in DESIGN_KEYS))
        elements = walker.elements_deg(settings.front_validation.max_sats_per_plane)
        runs = run_design_life(settings, elements, natural=False)
        nav = life_navigation(
            settings.dop, settings.dynamics, runs, month_days=settings.life_evaluation.month_days
        )
        m = life_metrics(runs, nav)
        loss = (
            satellite_loss(
                settings.dop,
                settings.dynamics,
                runs["controlled"],
                month_days=settings.life_evaluation.month_days,
            )[1]
            if "headline" in design.get("selected_for", "") and elements.shape[0] > 1
            else None
        )
    except Exception as exc:  # recorded as the design's status: one failed closed loop must not stop the validation
        return _failed_record(f"{type(exc).__name__}: {exc}", time.perf_counter() - start)
    ctl = runs["controlled"]
    monthly = {k: nav[k].sel(run="controlled").values for k in ("pdop_avail_pct", "hdop_avail_pct")}
    lost = len(m["lost_satellites"])
    record = {
        "closed_loop_dv_kms_per_year": m["sk_dv_kms_per_year"],
        "closed_loop_dv_max_kms_per_year": m["sk_dv_max_kms_per_year"],
        **{closed_loop_dv_key(p): float(v) for p, v in m["sk_dv_split"].items()},
        "min_perilune_alt_km": m["min_perilune_alt_km"],
        "impact_day": math.nan if m["impact_day"] is None else m["impact_day"],
        "n_lost": lost,
        "pdop_avail_pct_worst_month": float(np.nanmin(monthly["pdop_avail_pct"])),
        "hdop_avail_pct_worst_month": float(np.nanmin(monthly["hdop_avail_pct"])),
        "pdop_avail_pct_life": m["pdop_avail_pct_life"],
        "hdop_avail_pct_life": m["hdop_avail_pct_life"],
        "requirement_held": int(m["box_held"]),
        "n_maneuvers": m["n_maneuvers"],
        **{
            key: math.nan if loss is None else loss[key.removesuffix("_n_minus_1")]
            for key in N_MINUS_1_KEYS[1:]
        },
        "n_minus_1_sat": math.nan if loss is None else loss["lost_sat"],
        "wall_s": time.perf_counter() - start,
    }
    return {
        **{k: float(record[k]) for k in CLOSED_LOOP_KEYS},
        "status": "failed" if lost else "kept",
        "error": "",
        **worker_fields(),
        "n_sat_flown": int(ctl.sizes["sat"]),
    }


def _is_validation_record(item) -> bool:
    key = item.get("key") if isinstance(item, dict) else None
    return (
        isinstance(key, list)
        and len(key) == len(DESIGN_KEYS)
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in key)
        and item.get("status") in STATUSES
    )


def _metric_names(settings: Settings, evaluations: xr.Dataset) -> list[str]:
    return [k for k in (*METRIC_KEYS, *settings.evaluator.extra_metrics) if k in evaluations]


def validated_dataset(
    selection: list[dict], records: dict, evaluations: xr.Dataset, settings: Settings, attrs: dict
) -> xr.Dataset:
    """``validated.nc`` of the ``selection`` (order kept) with the journal ``records`` (by design key; a design not
    yet flown has NaN numbers and an empty status) and each design's campaign metrics from ``evaluations``."""
    keys = [_key(row) for row in selection]
    row_of = {
        _key({k: evaluations[k].values[i].item() for k in DESIGN_KEYS}): i
        for i in range(evaluations.sizes["design"])
    }
    rows = np.array([row_of[k] for k in keys], dtype=int)
    data = {
        k: (
            "design",
            np.array(
                [key[j] for key in keys], dtype=np.int64 if k in INTEGER_DESIGN_KEYS else float
            ),
        )
        for j, k in enumerate(DESIGN_KEYS)
    }
    for name in _metric_names(settings, evaluations):
        values = evaluations[name].values[rows] if keys else np.zeros(0)
        data[name] = ("design", values.astype(np.int64 if name == "n_sat" else float))
    data["selected_for"] = (
        "design",
        np.array([row["selected_for"] for row in selection], dtype=str),
    )
    found = [records.get(k, {}) for k in keys]
    data["status"] = ("design", np.array([r.get("status", "") for r in found], dtype=str))
    data["error"] = ("design", np.array([r.get("error", "") for r in found], dtype=str))
    for name in CLOSED_LOOP_KEYS:
        values = np.array([r.get(name, math.nan) for r in found], dtype=float)
        kind = (
            np.int8
            if name == "requirement_held"
            else (np.int64 if name in ("n_lost", "n_maneuvers", "n_minus_1_sat") else None)
        )
        data[name] = (
            "design",
            np.where(np.isfinite(values), values, -1).astype(kind) if kind else values,
        )
    ds = xr.Dataset(data, coords={"design": np.arange(len(keys))})
    from .reference import cf_variable_attrs

    ds = cf_variable_attrs(ds, _LONG_NAMES)
    for name in ("requirement_held", "n_lost", "n_maneuvers"):
        ds[name].attrs["comment"] = "-1: not flown yet, or the closed loop raised"
    ds["n_minus_1_sat"].attrs["comment"] = (
        "-1: not flown yet, not a headline candidate, or the closed loop raised"
    )
    ds.attrs = {
        "Conventions": "CF-1.8",
        "title": "LNSS campaign front validated in closed loop",
        "institution": "LNSS workbook",
        **attrs,
        "complete": int(all(r.get("status") in STATUSES for r in found)),
    }
    return ds


@dataclass
class ValidationResult:
    """What :func:`validate_front` did: the file written, designs selected, flown this session, and their wall time."""

    path: Path
    n_selected: int
    n_flown: int
    n_journaled: int
    wall_s: float
    dataset: xr.Dataset


def check_validatable(run_dir, settings: Settings) -> None:
    """ConfigError unless ``run_dir`` holds a finished campaign whose profile validates its front."""
    if settings.front_validation.max_designs == 0:
        raise ConfigError(
            f"{run_dir}: profile {settings.name!r} validates no front ([front_validation] max_designs "
            f"= 0); allowed: a run of a profile with max_designs > 0 (operational, quick_operational, "
            f"ci_operational)",
            key="front_validation.max_designs",
        )
    checkpoint = load_checkpoint(run_dir)
    if not (checkpoint and checkpoint.get("finished")):
        done = len(checkpoint["history"]) if checkpoint else 0
        raise ConfigError(
            f"{run_dir}: the campaign is not finished ({done} of {settings.campaign.generations} "
            f"generations); finish it first: python -m lnss_lib campaign --resume {run_dir}",
            key="--validate",
        )


def validate_front(
    run_dir,
    *,
    workers: int | None = None,
    scheduler_address: str | None = None,
    progress: bool = True,
    task: Callable | None = None,
) -> ValidationResult:
    """Fly the run's selected designs not yet in ``validated.jsonl`` and write ``validated.nc`` (see the module
    docstring). The caller holds the run's lock and checked :func:`check_validatable`. ``task``: replaces
    :func:`validation_task` (tests)."""
    from .backends import open_backend

    start = time.perf_counter()
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    settings = settings_from_profile(run["profile"])
    eval_settings = evaluation_profile(settings)
    evaluations, front, _ = export_results(run_dir)
    selection = select_designs(evaluations, front, settings.front_validation)
    journal = EvaluationCache(
        run_dir / VALIDATION_JOURNAL,
        run["evaluation_hash"],
        is_record=_is_validation_record,
        kernel_cpu=kernel_cpu(),
        run_cpu=run_kernel_cpu(run),
    )
    todo = [row for row in selection if _key(row) not in journal]
    plan = CampaignPlan.of(settings)
    backend, stopped = None, None
    bar = CellProgress(
        len(selection), "front validation", "designs", initial=len(selection) - len(todo)
    )
    tqdm_bar = (
        _tqdm(len(selection), len(selection) - len(todo)) if progress and bar.closed else None
    )
    try:
        if todo:
            backend = open_backend(
                eval_settings,
                plan,
                workers,
                scheduler_address,
                task=validation_task if task is None else task,
            )
            for index, record in backend.run(todo):
                journal.add(_key(todo[index]), record)
                bar.update(note=f"{record['status']}")
                if tqdm_bar is not None:
                    tqdm_bar.update(1)
                if journal.n_errors > plan.max_errors:
                    stopped = _stopped(
                        run_dir, journal.n_errors, plan.max_errors, todo[index], record
                    )
                    break
    finally:
        bar.close()
        if tqdm_bar is not None:
            tqdm_bar.close()
        journal.close()
        if backend is not None:
            backend.close()
    records = {tuple(r["key"]): r for r in journal.records.values()}
    attrs = {
        "life_days": float(settings.design_life.life_days),
        "profile": settings.name,
        "profile_hash": settings.hash,
        "evaluation_hash": run["evaluation_hash"],
        "controller": settings.design_life.controller,
        "element_frame": settings.frames.element_frame,
        "max_sats_per_plane": settings.front_validation.max_sats_per_plane,
        "cost_key": COST_KEY,
    }
    ds = validated_dataset(selection, records, evaluations, settings, attrs)
    path = write_netcdf_atomic(ds, run_dir / VALIDATED_FILE)
    if stopped is not None:
        raise stopped
    n_journaled = sum(_key(row) in records for row in selection)
    return ValidationResult(
        path, len(selection), len(todo), n_journaled, time.perf_counter() - start, ds
    )


def _stopped(
    run_dir: Path, n_errors: int, limit: int, design: dict, record: dict
) -> CampaignStopped:
    """The stop of a validation whose closed loops raised more than ``limit`` times (``record``: the last)."""
    shown = {k: design[k] for k in DESIGN_KEYS}
    return CampaignStopped(
        f"front validation stopped: {n_errors} closed loop(s) raised, more than campaign.max_errors = {limit}; design "
        f"{shown}: {record['error']}; every record is in {run_dir / VALIDATION_JOURNAL}; once the cause is removed: "
        f"python -m lnss_lib campaign --validate {run_dir}",
        errors=n_errors,
        first=record,
    )


def _tqdm(total: int, initial: int):
    import sys

    from tqdm import tqdm

    return tqdm(
        total=total, initial=initial, desc="front validation", unit="design", file=sys.stderr
    )
