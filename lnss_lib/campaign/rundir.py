"""The run directory: ``run.json``, ``checkpoint.pkl`` and the NetCDF results.

* ``run.json``: the profile (with every override) and the evaluation hash, written first;
* ``evaluations.jsonl``: the evaluation journal (:mod:`lnss_lib.campaign.journal`);
* ``checkpoint.pkl``: after every generation, the pickled algorithm (population, random
  generator, termination state) and the per-generation history, written to a temporary file
  and moved into place with ``os.replace``;
* ``evaluations.nc``, ``front.nc``, ``history.nc`` (:func:`export_results`).
"""

from __future__ import annotations

import json
import os
import pickle
import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..config import OUTPUTS_DIR
from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS, METRIC_KEYS
from .fitness import constraint_matrix, constraint_violation, metric_columns, non_dominated_mask, objective_matrix
from .journal import read_cache_records
from .settings import CampaignSettings, evaluation_hash

__all__ = ["load_run", "load_checkpoint", "final_population", "export_results", "write_results",
           "write_checkpoint", "start_run", "default_run_dir", "atomic_write_bytes",
           "RUN_FILE", "CHECKPOINT_FILE", "RESULT_FILES", "CHECKPOINT_FORMAT"]

RUN_FILE, CHECKPOINT_FILE = "run.json", "checkpoint.pkl"
RESULT_FILES = ("evaluations.nc", "front.nc", "history.nc")
CHECKPOINT_FORMAT = 1


def atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with tmp.open("wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


def load_run(run_dir) -> dict:
    """``run.json`` of a run directory (profile, evaluation hash, creation time); ValueError if absent."""
    path = Path(run_dir) / RUN_FILE
    if not path.is_file():
        raise ValueError(f"{run_dir} is not a campaign run directory (no {RUN_FILE})")
    return json.loads(path.read_text())


# classes pickled by checkpoints written before the campaign package (module lnss_lib.optimize)
_MOVED_CLASSES = {("lnss_lib.optimize", "WalkerDesignProblem"): "lnss_lib.campaign.problem",
                  ("lnss_lib.optimize", "CampaignSettings"): "lnss_lib.campaign.settings",
                  ("lnss_lib.optimize", "DesignGrid"): "lnss_lib.campaign.grid"}


class _CheckpointUnpickler(pickle.Unpickler):
    """Reads checkpoints of either layout: classes of ``lnss_lib.optimize`` load from their new modules."""

    def find_class(self, module, name):
        return super().find_class(_MOVED_CLASSES.get((module, name), module), name)


def load_checkpoint(run_dir) -> dict | None:
    """The last checkpoint of a run (keys generation, algorithm, history, finished), or None before the first."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.is_file():
        return None
    with path.open("rb") as handle:
        return _CheckpointUnpickler(handle).load()


def write_checkpoint(run_dir, generation: int, algorithm, history: list[dict], finished: bool) -> None:
    """Pickle the algorithm and the history after ``generation`` into ``checkpoint.pkl`` (atomically)."""
    atomic_write_bytes(Path(run_dir) / CHECKPOINT_FILE, pickle.dumps(
        {"format": CHECKPOINT_FORMAT, "generation": generation, "algorithm": algorithm, "history": history,
         "finished": finished}))


def final_population(run_dir) -> tuple[np.ndarray, np.ndarray]:
    """(scaled X (n, 6) int, F (n, k)) of the population in a run's last checkpoint."""
    checkpoint = load_checkpoint(run_dir)
    if checkpoint is None:
        raise ValueError(f"{run_dir} has no checkpoint yet")
    pop = checkpoint["algorithm"].pop
    return np.asarray(pop.get("X")).astype(int), np.asarray(pop.get("F"), dtype=float)


def _dataset_from_records(records: list[dict], settings: CampaignSettings, attrs: dict,
                          extras: tuple[str, ...] = ()) -> xr.Dataset:
    records = sorted(records, key=lambda r: (r["generation"], r["order"]))
    keys = np.array([r["key"] for r in records], dtype=float).reshape(-1, len(DESIGN_KEYS))
    designs = settings.grid.descale(keys) if len(records) else np.zeros((0, len(DESIGN_KEYS)))
    columns = metric_columns(records, extras) if records else {k: np.zeros(0) for k in (*METRIC_KEYS, *extras, "ok")}
    cv = constraint_violation(constraint_matrix(columns, settings.constraints, settings.nan_violation)) \
        if records else np.zeros(0)
    data = {}
    for j, name in enumerate(DESIGN_KEYS):
        data[name] = ("design", designs[:, j].astype(np.int64 if name in INTEGER_DESIGN_KEYS else np.float64))
    for name in METRIC_KEYS + extras:
        data[name] = ("design", np.asarray(columns[name]).astype(np.int64 if name == "n_sat" else np.float64))
    data["feasible"] = ("design", np.asarray(columns["ok"], dtype=bool) & (cv == 0.0))
    data["impact"] = ("design", np.array([r["impact"] for r in records], dtype=bool))
    data["constraint_violation"] = ("design", cv.astype(np.float64))
    data["generation"] = ("design", np.array([r["generation"] for r in records], dtype=np.int64))
    ds = xr.Dataset(data, attrs=attrs)
    units = {"sma_km": "km", "aop_deg": "deg", "inc_deg": "deg", "dv_total_kms_per_year": "km/s per satellite per year",
             "dv_opt_kms_per_year": "km/s per satellite per year", "pdop_avail_pct": "%", "hdop_avail_pct": "%",
             "sk_dv_estimate_kms_per_year": "km/s per satellite per year (mean over satellites)",
             "sk_dv_estimate_max_kms_per_year": "km/s per year (worst satellite)",
             "dv_total_max_kms_per_year": "km/s per year (worst satellite)",
             "dv_opt_max_kms_per_year": "km/s per year (worst satellite)", "screen_min_perilune_alt_km": "km"}
    for name, unit in units.items():
        if name in ds:
            ds[name].attrs["units"] = unit
    if "stable_screen" in ds:
        ds["stable_screen"].attrs["description"] = "1: no perilune reaches the surface over the screened design life; 0: one does"
    ds["feasible"].attrs["description"] = "evaluated without impact and every campaign constraint met (Table 3)"
    ds["constraint_violation"].attrs["description"] = ("sum of positive normalised constraint values "
                                                       "(value/limit - 1 for max, 1 - value/limit for min)")
    ds["generation"].attrs["description"] = "generation in which the design was first evaluated"
    return ds


def export_results(run_dir) -> tuple[xr.Dataset, xr.Dataset, xr.Dataset]:
    """(evaluations, front, history) Datasets of a run directory, finished or not.

    evaluations: every unique design evaluated (dim ``design``, in order of first evaluation);
    front: the feasible designs that no other feasible design dominates in the campaign's
    objectives; history: per generation (dim ``generation``) the counts, best values,
    hypervolume, minimum population violation and wall time.
    """
    from ..config import package_versions

    run = load_run(run_dir)
    profile = run["profile"]
    settings = CampaignSettings.from_profile(profile)
    checkpoint = load_checkpoint(run_dir)
    history = checkpoint["history"] if checkpoint else []
    attrs = {
        "profile": profile["profile"]["name"],
        "objectives": ",".join(settings.objectives),
        "constraints": ",".join(f"{m} {'<=' if k == 'max' else '>='} {v:g}" for m, k, v in settings.constraints),
        "parameters": json.dumps(profile, sort_keys=True),
        "versions": json.dumps(package_versions(), sort_keys=True),
        "evaluation_hash": run["evaluation_hash"],
        "evaluator": settings.evaluator,
        "seed": settings.seed,
        "generations_done": len(history),
        "finished": int(bool(checkpoint and checkpoint.get("finished"))),
    }
    records = read_cache_records(run_dir)
    extras = settings.extra_metrics
    evaluations = _dataset_from_records(records, settings, attrs, extras)
    feasible = evaluations["feasible"].values
    columns = {k: evaluations[k].values for k in METRIC_KEYS + extras}
    f = objective_matrix(columns, settings.objectives, settings.nan_objective)
    front_index = np.flatnonzero(feasible)[non_dominated_mask(f[feasible])] if feasible.any() else np.zeros(0, int)
    front = evaluations.isel(design=front_index)
    front.attrs = {**attrs, "description": "feasible designs not dominated by any other feasible design in the "
                                           "campaign objectives"}
    names = sorted({k for h in history for k in h if k != "generation"})
    hist = xr.Dataset({k: ("generation", np.array([h[k] for h in history])) for k in names},
                      coords={"generation": np.array([h["generation"] for h in history], dtype=np.int64)},
                      attrs={**attrs, "hypervolume_reference": json.dumps(dict(settings.hypervolume))})
    return evaluations, front, hist


def write_results(run_dir, publish_dir=None) -> list[Path]:
    """Write evaluations.nc, front.nc and history.nc (h5netcdf, atomically) into the run directory and,
    if given, ``publish_dir``; returns the paths written."""
    datasets = export_results(run_dir)
    written = []
    for folder in [Path(run_dir)] + ([Path(publish_dir)] if publish_dir else []):
        for name, ds in zip(RESULT_FILES, datasets):
            target = folder / name
            tmp = folder / f".{name}.tmp{os.getpid()}"
            ds.to_netcdf(tmp, engine="h5netcdf")
            os.replace(tmp, target)
            written.append(target)
    return written


def default_run_dir(profile_name: str) -> Path:
    """A new ``outputs/<profile>/campaign/run_<time>`` (the folder runs are published from)."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = OUTPUTS_DIR / profile_name / "campaign"
    base.mkdir(parents=True, exist_ok=True)
    candidate, n = base / f"run_{stamp}", 1
    while candidate.exists():
        n += 1
        candidate = base / f"run_{stamp}_{n}"
    return candidate


def start_run(run_dir: Path, profile: dict) -> None:
    from ..config import package_versions

    run_dir.mkdir(parents=True, exist_ok=True)
    if (run_dir / RUN_FILE).exists():
        raise ValueError(f"{run_dir} already holds a campaign; continue it with --resume {run_dir}")
    run = {"profile": profile, "evaluation_hash": evaluation_hash(profile),
           "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "versions": package_versions()}
    atomic_write_bytes(run_dir / RUN_FILE, json.dumps(run, indent=1, default=str).encode())
