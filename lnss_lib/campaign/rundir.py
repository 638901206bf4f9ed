"""The run directory: ``run.json``, ``checkpoint.pkl`` and the NetCDF results.

* ``run.json``: the profile (with every override, its name included), the evaluation hash and the provenance
  (start time, package versions, commit), written first under a SHA-256 of all of it (``checksum``,
  :func:`run_checksum`): an edited line (a renamed profile, a forged commit) is refused;
* ``evaluations.jsonl``: the evaluation journal (:mod:`lnss_lib.campaign.journal`);
* ``checkpoint.pkl``: after every generation, the algorithm (population, random generator,
  termination state) and the per-generation history, pickled behind a header holding the SHA-256 of
  the pickle and written atomically. Loading checks the checksum, and the unpickler admits only the
  classes and functions a checkpoint holds (:data:`CHECKPOINT_GLOBALS`), so a forged or damaged file
  is refused (:class:`CheckpointError`) instead of running code or loading silently;
* ``evaluations.nc``, ``front.nc``, ``history.nc`` (:func:`export_results`);
* ``run.lock``: the pid of the process that holds the run (information only: the lock itself is an
  ``flock`` on the run folder, :class:`RunLock`).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..atomicio import write_bytes_atomic, write_netcdf_atomic
from ..config import OUTPUTS_DIR, profile_hash, unreadable_reason
from ..errors import ConfigError
from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS, METRIC_KEYS
from ..settings import Settings, settings_from_profile
from .fitness import (
    constraint_matrix,
    constraint_violation,
    metric_columns,
    non_dominated_mask,
    objective_matrix,
)
from .journal import read_cache_records
from .settings import CampaignPlan

__all__ = [
    "load_run",
    "load_checkpoint",
    "final_population",
    "export_results",
    "write_results",
    "write_checkpoint",
    "start_run",
    "default_run_dir",
    "atomic_write_bytes",
    "check_resumable",
    "RunLock",
    "CheckpointError",
    "LOCK_FILE",
    "RUN_FILE",
    "CHECKPOINT_FILE",
    "RESULT_FILES",
    "CHECKPOINT_FORMAT",
    "CHECKPOINT_GLOBALS",
    "CHECKPOINT_MAGIC",
    "run_checksum",
    "check_new_run_dir",
    "run_kernel_cpu",
]

RUN_FILE, CHECKPOINT_FILE, LOCK_FILE = "run.json", "checkpoint.pkl", "run.lock"
RESULT_FILES = ("evaluations.nc", "front.nc", "history.nc")
CHECKPOINT_FORMAT = 2  # 1: a bare pickle; 2: header line with the SHA-256, then the pickle
CHECKPOINT_MAGIC = b"LNSS campaign checkpoint\n"


atomic_write_bytes = write_bytes_atomic


def run_checksum(run: dict) -> str:
    """SHA-256 (hex) of ``run.json``'s canonical JSON without its ``checksum`` field."""
    content = {k: v for k, v in run.items() if k != "checksum"}
    return hashlib.sha256(
        json.dumps(content, sort_keys=True, separators=(",", ":"), default=str).encode()
    ).hexdigest()


def load_run(run_dir) -> dict:
    """``run.json`` of a run directory (profile, evaluation hash, creation time); ConfigError if absent, unreadable
    (a damaged line: not JSON, nested too deep, a number too long to read) or edited after the run started (its
    ``checksum`` no longer matches; a run.json written before runs recorded one has none)."""
    path = Path(run_dir) / RUN_FILE
    if not path.is_file():
        raise ConfigError(f"{run_dir} is not a campaign run directory (no {RUN_FILE})")
    try:
        run = json.loads(path.read_text())
    except (
        ValueError,
        RecursionError,
    ) as error:  # JSONDecodeError, UnicodeDecodeError, a 5000-digit integer
        raise ConfigError(f"{path} is not readable JSON ({unreadable_reason(error)})") from None
    if (
        not isinstance(run, dict)
        or not isinstance(run.get("profile"), dict)
        or "evaluation_hash" not in run
    ):
        raise ConfigError(f"{path} lacks the profile or the evaluation hash of the run")
    if "checksum" in run and run["checksum"] != run_checksum(run):
        raise ConfigError(
            f"{path} was edited after the run started (its SHA-256 is not the checksum it recorded): "
            f"a run keeps its settings and provenance; start a new run with --profile and --set"
        )
    return run


def run_kernel_cpu(run: dict) -> str | None:
    """The processor model a run's kernels were compiled for when it started (``run.json`` ``versions``), or None
    (a run started before runs recorded it)."""
    versions = run.get("versions")
    model = versions.get("kernel_cpu") if isinstance(versions, dict) else None
    return model if isinstance(model, str) else None


# classes pickled by older checkpoints under their old names: module lnss_lib.optimize (before the campaign
# package) and CampaignSettings (the campaign plan before the settings were typed; same fields)
_MOVED_CLASSES = {
    ("lnss_lib.optimize", "WalkerDesignProblem"): (
        "lnss_lib.campaign.problem",
        "WalkerDesignProblem",
    ),
    ("lnss_lib.optimize", "CampaignSettings"): ("lnss_lib.campaign.settings", "CampaignPlan"),
    ("lnss_lib.campaign.settings", "CampaignSettings"): (
        "lnss_lib.campaign.settings",
        "CampaignPlan",
    ),
    ("lnss_lib.optimize", "DesignGrid"): ("lnss_lib.campaign.grid", "DesignGrid"),
}

# every global a checkpoint of the NSGA-II of :func:`~lnss_lib.campaign.problem.build_algorithm` names
# (module: names); anything else in a checkpoint file is refused
CHECKPOINT_GLOBALS = {
    "builtins": ("float", "int", "complex", "bool", "set", "frozenset", "slice"),
    "collections": ("OrderedDict", "deque"),
    "copyreg": ("_reconstructor",),
    "numpy": ("dtype", "ndarray", "sum"),
    "numpy._core.multiarray": ("_reconstruct", "scalar"),
    "numpy.core.multiarray": ("_reconstruct", "scalar"),
    "numpy.random._pcg64": ("PCG64",),
    "numpy.random._pickle": ("__bit_generator_ctor", "__generator_ctor", "__randomstate_ctor"),
    "numpy.random.bit_generator": ("SeedSequence", "__pyx_unpickle_SeedSequence"),
    "lnss_lib.campaign.grid": ("DesignGrid",),
    "lnss_lib.campaign.problem": ("WalkerDesignProblem",),
    "lnss_lib.campaign.settings": ("CampaignPlan",),
    "lnss_lib.sections": ("VariableBounds",),  # the plan's [campaign] variables
    "pymoo.algorithms.moo.nsga2": ("NSGA2", "binary_tournament"),
    "pymoo.core.callback": ("Callback",),
    "pymoo.core.duplicate": ("DefaultDuplicateElimination", "default_attr"),
    "pymoo.core.evaluator": ("Evaluator",),
    "pymoo.core.individual": ("Individual",),
    "pymoo.core.initialization": ("Initialization",),
    "pymoo.core.mating": ("Mating",),
    "pymoo.core.population": ("Population",),
    "pymoo.core.problem": ("ElementwiseEvaluationFunction", "LoopedElementwiseEvaluation"),
    "pymoo.core.repair": ("NoRepair",),
    "pymoo.core.variable": ("Real",),
    "pymoo.operators.crossover.sbx": ("SBX",),
    "pymoo.operators.mutation.pm": ("PM",),
    "pymoo.operators.repair.rounding": ("RoundingRepair",),
    "pymoo.operators.sampling.rnd": ("IntegerRandomSampling",),
    "pymoo.operators.selection.tournament": ("TournamentSelection",),
    "pymoo.operators.survival.rank_and_crowding.classes": ("RankAndCrowding",),
    "pymoo.operators.survival.rank_and_crowding.metrics": (
        "FunctionalDiversity",
        "calc_crowding_distance",
    ),
    "pymoo.termination.collection": ("TerminationCollection",),
    "pymoo.termination.ftol": ("MultiObjectiveSpaceTermination",),
    "pymoo.termination.max_gen": ("MaximumGenerationTermination",),
    "pymoo.termination.robust": ("RobustTermination",),
    "pymoo.util.display.column": ("Column",),
    "pymoo.util.display.display": ("Display",),
    "pymoo.util.display.multi": ("MultiObjectiveOutput", "NumberOfNondominatedSolutions"),
    "pymoo.util.display.output": ("NumberOfEvaluations", "NumberOfGenerations"),
    "pymoo.util.display.single": ("AverageConstraintViolation", "MinimumConstraintViolation"),
    "pymoo.util.nds.non_dominated_sorting": ("NonDominatedSorting",),
    "pymoo.util.sliding_window": ("SlidingWindow",),
}


class CheckpointError(RuntimeError):
    """A checkpoint file that cannot be trusted: ``path`` and the ``reason`` (damaged, or a global it may not name)."""

    def __init__(self, path: Path, reason: str):
        super().__init__(
            f"{path}: {reason}; delete it and resume: the evaluation cache "
            f"{Path(path).parent / 'evaluations.jsonl'} re-uses every design already evaluated"
        )
        self.path = Path(path)
        self.reason = reason


class _CheckpointUnpickler(pickle.Unpickler):
    """Admits only :data:`CHECKPOINT_GLOBALS` (classes of ``lnss_lib.optimize`` load from their new modules)."""

    def __init__(self, handle, path: Path):
        super().__init__(handle)
        self.path = path

    def find_class(self, module, name):
        module, name = _MOVED_CLASSES.get((module, name), (module, name))
        if name not in CHECKPOINT_GLOBALS.get(module, ()):
            raise CheckpointError(
                self.path,
                f"names {module}.{name}, which is not a class or function a campaign "
                f"checkpoint holds: refused (a forged or foreign file)",
            )
        return super().find_class(module, name)


def load_checkpoint(run_dir) -> dict | None:
    """The last checkpoint of a run (keys generation, algorithm, history, finished, profile_hash), or None
    before the first. A damaged file (checksum), a truncated one, or one naming a global outside
    :data:`CHECKPOINT_GLOBALS` raises :class:`CheckpointError` saying how to recover."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.is_file():
        return None
    data = path.read_bytes()
    if data.startswith(CHECKPOINT_MAGIC):
        header_end = data.find(b"\n", len(CHECKPOINT_MAGIC)) + 1
        try:
            header = json.loads(data[len(CHECKPOINT_MAGIC) : header_end])
            expected = str(header["sha256"])
        except (ValueError, TypeError, KeyError):
            raise CheckpointError(
                path, "is truncated or corrupt (its header line does not read)"
            ) from None
        data = data[header_end:] if header_end else b""
        actual = hashlib.sha256(data).hexdigest()
        if actual != expected:
            raise CheckpointError(
                path,
                f"is truncated or corrupt (the SHA-256 of its {len(data)} bytes is "
                f"{actual[:12]}..., its header says {expected[:12]}...)",
            )
    try:
        checkpoint = _CheckpointUnpickler(io.BytesIO(data), path).load()
    except CheckpointError:
        raise
    except (
        Exception
    ) as error:  # whatever a damaged pickle raises (EOFError, UnpicklingError, OverflowError, ...)
        raise CheckpointError(
            path, f"is truncated or corrupt ({type(error).__name__}: {error})"
        ) from None
    if not isinstance(checkpoint, dict) or not {"generation", "algorithm", "history"} <= set(
        checkpoint
    ):
        raise CheckpointError(path, "is truncated or corrupt (not a campaign checkpoint)")
    return checkpoint


def write_checkpoint(
    run_dir,
    generation: int,
    algorithm,
    history: list[dict],
    finished: bool,
    profile_fingerprint: str | None = None,
    asked_keys: list | None = None,
) -> None:
    """Pickle the algorithm and the history after ``generation`` into ``checkpoint.pkl`` behind a header
    with the pickle's SHA-256 (atomically)."""
    profile_fingerprint = profile_fingerprint or profile_hash(load_run(run_dir)["profile"])
    payload = pickle.dumps(
        {
            "format": CHECKPOINT_FORMAT,
            "generation": generation,
            "algorithm": algorithm,
            "history": history,
            "finished": finished,
            "profile_hash": profile_fingerprint,
            "asked_keys": list(asked_keys or []),
        }
    )
    header = json.dumps(
        {"format": CHECKPOINT_FORMAT, "sha256": hashlib.sha256(payload).hexdigest()}
    )
    atomic_write_bytes(
        Path(run_dir) / CHECKPOINT_FILE, CHECKPOINT_MAGIC + header.encode() + b"\n" + payload
    )


def final_population(run_dir) -> tuple[np.ndarray, np.ndarray]:
    """(scaled X (n, 6) int, F (n, k)) of the population in a run's last checkpoint."""
    checkpoint = load_checkpoint(run_dir)
    if checkpoint is None:
        raise ValueError(f"{run_dir} has no checkpoint yet")
    pop = checkpoint["algorithm"].pop
    return np.asarray(pop.get("X")).astype(int), np.asarray(pop.get("F"), dtype=float)


def _dataset_from_records(
    records: list[dict], plan: CampaignPlan, attrs: dict, extras: tuple[str, ...] = ()
) -> xr.Dataset:
    records = sorted(records, key=lambda r: (r["generation"], r["order"]))
    keys = np.array([r["key"] for r in records], dtype=float).reshape(-1, len(DESIGN_KEYS))
    designs = plan.grid.descale(keys) if len(records) else np.zeros((0, len(DESIGN_KEYS)))
    columns = (
        metric_columns(records, extras)
        if records
        else {k: np.zeros(0) for k in (*METRIC_KEYS, *extras, "ok")}
    )
    cv = (
        constraint_violation(constraint_matrix(columns, plan.constraints, plan.nan_violation))
        if records
        else np.zeros(0)
    )
    data = {}
    for j, name in enumerate(DESIGN_KEYS):
        data[name] = (
            "design",
            designs[:, j].astype(np.int64 if name in INTEGER_DESIGN_KEYS else np.float64),
        )
    for name in METRIC_KEYS + extras:
        data[name] = (
            "design",
            np.asarray(columns[name]).astype(np.int64 if name == "n_sat" else np.float64),
        )
    data["feasible"] = ("design", np.asarray(columns["ok"], dtype=bool) & (cv == 0.0))
    data["impact"] = ("design", np.array([r["impact"] for r in records], dtype=bool))
    data["error"] = (
        "design",
        np.array([r["reason"] if r.get("error") else "" for r in records], dtype=str),
    )
    data["constraint_violation"] = ("design", cv.astype(np.float64))
    data["generation"] = ("design", np.array([r["generation"] for r in records], dtype=np.int64))
    ds = xr.Dataset(data, attrs=attrs)
    units = {
        "sma_km": "km",
        "aop_deg": "deg",
        "inc_deg": "deg",
        "dv_total_kms_per_year": "km/s per satellite per year",
        "dv_opt_kms_per_year": "km/s per satellite per year",
        "pdop_avail_pct": "%",
        "hdop_avail_pct": "%",
        "sk_dv_estimate_kms_per_year": "km/s per satellite per year (mean over satellites)",
        "sk_dv_estimate_max_kms_per_year": "km/s per year (worst satellite)",
        "dv_total_max_kms_per_year": "km/s per year (worst satellite)",
        "dv_opt_max_kms_per_year": "km/s per year (worst satellite)",
        "screen_min_perilune_alt_km": "km",
    }
    for name, unit in units.items():
        if name in ds:
            ds[name].attrs["units"] = unit
    if "stable_screen" in ds:
        ds["stable_screen"].attrs["description"] = (
            "1: no perilune reaches the surface over the screened design life; 0: one does"
        )
    ds["feasible"].attrs["description"] = (
        "evaluated without impact and every campaign constraint met (Table 3)"
    )
    ds["constraint_violation"].attrs["description"] = (
        "sum of positive normalised constraint values "
        "(value/limit - 1 for max, 1 - value/limit for min)"
    )
    ds["generation"].attrs["description"] = "generation in which the design was first evaluated"
    ds["error"].attrs["description"] = (
        "message of an evaluation that raised (an error, not an infeasible "
        "design; its metrics are NaN); empty when the evaluation ran"
    )
    return ds


def export_results(run_dir) -> tuple[xr.Dataset, xr.Dataset, xr.Dataset]:
    """(evaluations, front, history) Datasets of a run directory, finished or not.

    evaluations: every unique design evaluated (dim ``design``, in order of first evaluation);
    front: the feasible designs that no other feasible design dominates in the campaign's
    objectives; history: per generation (dim ``generation``) the counts, best values,
    hypervolume, minimum population violation and wall time.
    """
    from ..provenance import package_versions

    run = load_run(run_dir)
    profile = run["profile"]
    run_settings = settings_from_profile(profile)
    plan = CampaignPlan.of(run_settings)
    checkpoint = load_checkpoint(run_dir)
    history = checkpoint["history"] if checkpoint else []
    attrs = {
        "profile": run_settings.name,
        "objectives": ",".join(plan.objectives),
        "constraints": ",".join(
            f"{m} {'<=' if k == 'max' else '>='} {v:g}" for m, k, v in plan.constraints
        ),
        "parameters": json.dumps(profile, sort_keys=True),
        "versions": json.dumps(package_versions(), sort_keys=True),
        "evaluation_hash": run["evaluation_hash"],
        "evaluator": plan.evaluator,
        "seed": plan.seed,
        "generations_done": len(history),
        "finished": int(bool(checkpoint and checkpoint.get("finished"))),
    }
    records = read_cache_records(run_dir)
    attrs["n_evaluation_errors"] = sum(bool(r.get("error")) for r in records)
    extras = plan.extra_metrics
    evaluations = _dataset_from_records(records, plan, attrs, extras)
    feasible = evaluations["feasible"].values
    columns = {k: evaluations[k].values for k in METRIC_KEYS + extras}
    f = objective_matrix(columns, plan.objectives, plan.nan_objective)
    front_index = (
        np.flatnonzero(feasible)[non_dominated_mask(f[feasible])]
        if feasible.any()
        else np.zeros(0, int)
    )
    front = evaluations.isel(design=front_index)
    front.attrs = {
        **attrs,
        "description": "feasible designs not dominated by any other feasible design in the "
        "campaign objectives",
    }
    names = sorted({k for h in history for k in h if k != "generation"})
    hist = xr.Dataset(
        {k: ("generation", np.array([h[k] for h in history])) for k in names},
        coords={"generation": np.array([h["generation"] for h in history], dtype=np.int64)},
        attrs={**attrs, "hypervolume_reference": json.dumps(dict(plan.hypervolume))},
    )
    return evaluations, front, hist


def write_results(run_dir) -> list[Path]:
    """Write evaluations.nc, front.nc and history.nc (h5netcdf, atomically) into the run directory; returns
    the paths written (publication as the profile's campaign: :mod:`lnss_lib.campaign.publication`)."""
    written = []
    for name, ds in zip(RESULT_FILES, export_results(run_dir)):
        written.append(write_netcdf_atomic(ds, Path(run_dir) / name))
    return written


def default_run_dir(profile_name: str) -> Path:
    """A new ``outputs/<profile>/campaign/run_<time>`` (the folder runs are published from; not created)."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = OUTPUTS_DIR / profile_name / "campaign"
    candidate, n = base / f"run_{stamp}", 1
    while candidate.exists():
        n += 1
        candidate = base / f"run_{stamp}_{n}"
    return candidate


def check_new_run_dir(run_dir: Path) -> None:
    """Refuse (ConfigError) a folder a new run may not be started in: one holding a run (resume it instead) or any
    other file (a new run never writes among files it did not make); a missing or empty folder is fit."""
    if (run_dir / RUN_FILE).exists():
        raise ConfigError(
            f"{run_dir} already holds a campaign; continue it with --resume {run_dir}",
            key="--run-dir",
        )
    if run_dir.exists() and not run_dir.is_dir():
        raise ConfigError(
            f"--run-dir {run_dir}: not a folder; a new run needs a missing or empty folder",
            key="--run-dir",
        )
    if run_dir.is_dir():
        entries = sorted(entry.name for entry in run_dir.iterdir())
        if entries:
            shown = ", ".join(entries[:3]) + (
                f" and {len(entries) - 3} more" if len(entries) > 3 else ""
            )
            raise ConfigError(
                f"--run-dir {run_dir} is not empty ({shown}); a new run goes into a missing or empty "
                f"folder",
                key="--run-dir",
            )


def start_run(run_dir: Path, settings: Settings, eval_hash: str) -> None:
    """Write ``run.json`` (the settings as TOML data, their hash, the evaluation hash ``eval_hash``, versions and
    the workbook's commit) into ``run_dir`` (the caller holds the run's lock)."""
    from ..provenance import git_revision, package_versions

    run = {
        "profile": settings.as_dict(),
        "profile_hash": settings.hash,
        "evaluation_hash": eval_hash,
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "versions": package_versions(),
        "commit": git_revision(),
    }
    run = json.loads(
        json.dumps(run, default=str)
    )  # the checksum is of what the file will read back
    run["checksum"] = run_checksum(run)
    atomic_write_bytes(run_dir / RUN_FILE, json.dumps(run, indent=1).encode())


def check_resumable(run_dir: Path, run: dict, checkpoint: dict | None) -> None:
    """Refuse (ConfigError) a resume whose ``run.json`` settings were edited after the run started: its
    profile must still give the profile hash recorded in run.json and in the checkpoint."""
    current = profile_hash(run["profile"])
    for recorded, where in (
        (run.get("profile_hash"), RUN_FILE),
        ((checkpoint or {}).get("profile_hash"), CHECKPOINT_FILE),
    ):
        if recorded is not None and recorded != current:
            raise ConfigError(
                f"{run_dir / RUN_FILE}: its settings (profile hash {current}) differ from those the "
                f"run started with ({recorded}, recorded in {where}); a run keeps its settings: undo "
                f"the edit, or start a new run with --profile and --set"
            )


class RunLock:
    """Advisory lock on a run folder: an ``fcntl.flock`` on the folder itself, held while the process runs.

    One process owns a run at a time; a second gets RuntimeError naming the owner. The lock is not a
    file a user can delete: ``run.lock`` only tells the owner's pid. The kernel drops the lock when its
    process dies, so the lock of a killed run is stale by construction: the next process takes it over
    (and writes its own pid).
    """

    def __init__(self, run_dir: Path):
        import fcntl

        self.path = Path(run_dir) / LOCK_FILE
        self._fd = os.open(run_dir, os.O_RDONLY | os.O_DIRECTORY)
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self._fd)
            try:
                owner = self.path.read_text().strip() or "unknown"
            except OSError:
                owner = "unknown"
            raise RuntimeError(
                f"{run_dir} is in use by another campaign process (pid {owner}); wait for it to "
                f"finish or stop it, then --resume {run_dir}"
            ) from None
        atomic_write_bytes(self.path, f"{os.getpid()}\n".encode())

    def release(self) -> None:
        import fcntl

        if self._fd >= 0:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = -1
