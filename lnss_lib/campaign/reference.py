"""Shipped reference results: a run folder exported as its profile's results, ``outputs/reference/<profile>/``.

The paper's 120 x 1000 campaigns take hours, so a fresh clone reads these. The folder holds
NetCDF files with CF-1.8 attributes, each under :data:`MAX_FILE_BYTES`, and a ``README.md`` with provenance:

* ``front.nc``: the campaign's front (feasible designs no feasible design dominates; every column);
* ``history.nc``: per generation the hypervolume, feasible counts, best objectives, cache hits, smallest
  violation and wall time (and, in its attributes, where the worker time went);
* ``population.nc``: the final population (the last checkpoint's), one row per design;
* ``evaluations.nc``: the designs that Figures 8-16 and Table 6 read (:func:`analysis_mask`), thinned to a
  seeded sample when they would not fit (the front is always kept); its attributes count every design
  evaluated and the designs meeting each bound (:func:`~lnss_lib.campaign.fitness.bound_masks`).

The run folder is checked first (:func:`check_run_folder`: checksummed checkpoint and run.json, unedited settings,
the journal's evaluation hash, and settings that are its profile's as it stands in ``params/``, as a publication
requires), the files are written into a temporary folder beside the target and the folder replaces the previous
export by rename. A target that is not a previous export is left alone, and a complete export is never replaced by
a partial one (:func:`check_replaceable`). A run that has not finished is exported all the same and marked partial
(README and the ``finished`` / ``partial`` attributes). :func:`load_reference` reads an export back.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from ..atomicio import write_bytes_atomic, write_text_atomic
from ..config import REFERENCE_DIR, profile_hash
from ..errors import ConfigError
from ..keys import DESIGN_KEYS, TIMING_KEYS, label
from ..settings import load_settings, settings_from_profile
from .fitness import bound_masks, deltav_constraint, parse_constraints, satisfies
from .journal import JOURNAL_FILE, parse_journal, read_cache_records
from .rundir import check_resumable, export_results, load_checkpoint, load_run
from .settings import CampaignPlan, evaluation_hash, recorded_evaluation_hashes, run_differences
from .timing import campaign_timing, concurrent_workers

__all__ = [
    "REFERENCE_DIR",
    "REFERENCE_FILES",
    "README_FILE",
    "MAX_FILE_BYTES",
    "Reference",
    "check_run_folder",
    "analysis_mask",
    "thin_to_fit",
    "export_reference",
    "load_reference",
    "cf_variable_attrs",
    "check_replaceable",
    "cf_dataset",
    "netcdf_bytes",
    "run_provenance",
    "write_export",
]

REFERENCE_FILES = ("evaluations.nc", "front.nc", "history.nc", "population.nc")
README_FILE = "README.md"
MAX_FILE_BYTES = 5_000_000
THINNING_SEED = 0
PAPER_REFERENCE = (
    "Malik & Yang, Lunar Navigation System Optimization for Targeted Coverage with Semi-Analytical "
    "Station Keeping Model and Earth-GPS Integration (Section 5, Tables 3, 5 and 6, Figures 8-16)"
)

_UNITS = {"designs_per_s": "s-1"}  # where a name's suffix does not say its unit (:func:`_unit`)
_SUFFIX_UNITS = (
    ("kms_per_year", "km s-1 yr-1"),
    ("_km", "km"),
    ("_deg", "degree"),
    ("_pct", "percent"),
    ("_day", "day"),
    ("_s", "s"),
)
_LONG_NAMES = {
    "n_designs": "designs asked for in the generation",
    "n_evaluated": "designs evaluated in the generation",
    "n_cache_hits": "designs of the generation answered by the evaluation journal",
    "n_errors": "evaluations that raised in the generation",
    "n_errors_cum": "evaluations that raised so far",
    "n_evaluations_cum": "unique designs evaluated so far",
    "n_feasible_cum": "unique feasible designs so far",
    "n_feasible_pop": "feasible designs in the population",
    "min_cv_pop": "smallest constraint violation in the population",
    "hypervolume": "hypervolume of the feasible designs so far (normalised by the reference point)",
    "wall_s": "wall time of the generation",
    "designs_per_s": "designs evaluated per second of the generation",
    "time_campaign_s": "worker time per design outside the tasks",
    "time_overhead_s": "in-task overhead per design",
    "feasible": "feasible under the campaign's bounds",
    "impact": "a satellite impacts the Moon",
    "error": "message of an evaluation that raised",
    "constraint_violation": "sum of normalised constraint excesses",
    "generation": "generation",
    "design": "design (row)",
}


def _unit(name: str) -> str:
    """The CF unit of a key by its unit suffix (``_km``, ``_deg``, ``_pct`` also inside, as ``pdop_avail_pct_life``,
    ``_day``, ``_s``, ``kms_per_year``; ``time_`` keys are seconds), ``"1"`` for a count or ratio."""
    base = name.removeprefix("best_")
    if base in _UNITS:
        return _UNITS[base]
    if base.startswith("time_"):
        return "s"
    for suffix, unit in _SUFFIX_UNITS:
        if base.endswith(suffix) or (suffix == "_pct" and "_pct_" in base):
            return unit
    return "1"


def _long_name(name: str) -> str:
    if name in _LONG_NAMES:
        return _LONG_NAMES[name]
    if name.startswith("best_"):
        return f"best {_long_name(name[5:])} among the feasible designs so far"
    if name.startswith("time_") and name[5:-2] in TIMING_KEYS:
        return f"{name[5:-2]} time per design evaluated"
    text = (label(name) if label(name) != name else name.replace("_", " ")).split(" (")[0]
    return (
        f"{text} (per satellite and year)"
        if name.startswith("dv_") and "_max_" not in name
        else text
    )


def cf_variable_attrs(ds: xr.Dataset, long_names: dict | None = None) -> xr.Dataset:
    """A copy of ``ds`` with CF-1.8 ``units`` (none on text; :func:`_unit`) and ``long_name`` on every variable and
    coordinate: ``long_names`` first, then the campaign's names (labels of :mod:`lnss_lib.keys`)."""
    ds = ds.copy()
    long_names = long_names or {}
    for name in list(ds.data_vars) + list(ds.coords):
        attrs = {k: v for k, v in ds[name].attrs.items() if k != "units"}
        if ds[name].dtype.kind not in "US":
            attrs["units"] = _unit(str(name))
        ds[name].attrs = {**attrs, "long_name": long_names.get(str(name)) or _long_name(str(name))}
    return ds


def cf_dataset(ds: xr.Dataset, title: str, provenance: dict) -> xr.Dataset:
    """``ds`` with CF-1.8 global attributes (title, institution, source, history, references, Conventions) and
    ``units`` / ``long_name`` on every variable and coordinate; attributes are plain numbers and strings."""
    ds = cf_variable_attrs(ds)
    keep = {k: v for k, v in ds.attrs.items() if k not in ("finished",)}
    ds.attrs = {
        "title": title,
        "institution": "LNSS workbook",
        "source": provenance["source"],
        "history": provenance["history"],
        "references": PAPER_REFERENCE,
        "Conventions": "CF-1.8",
        **keep,
        "profile_hash": provenance["profile_hash"],
        "finished": int(provenance["finished"]),
        "partial": int(not provenance["finished"]),
        "run_commit": provenance["run_commit"],
        "export_commit": provenance["export_commit"],
    }
    return ds


def check_run_folder(run_dir, settings=None, owner: str | None = None) -> tuple[dict, dict]:
    """(run.json, last checkpoint) of a run folder fit to export, else ConfigError (no run, settings edited after
    the start, an evaluation hash that is not the settings', a journal of other physics, no generation yet, settings
    that are not ``settings``) or :class:`~lnss_lib.campaign.rundir.CheckpointError` (a checkpoint that fails its
    checksum or names a foreign class). ``settings``: those the run must be a campaign of (default: its profile's as
    it stands in ``params/``), which ``owner`` names in a refusal (default: the profile)."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ConfigError(
            f"{run_dir} is not a folder (a campaign run folder: run.json, checkpoint.pkl, "
            f"{JOURNAL_FILE})"
        )
    run = load_run(run_dir)
    checkpoint = load_checkpoint(run_dir)
    check_resumable(run_dir, run, checkpoint)
    if run["evaluation_hash"] not in recorded_evaluation_hashes(run["profile"]):
        raise ConfigError(
            f"{run_dir / 'run.json'}: evaluation hash {run['evaluation_hash']} is not that of its "
            f"settings ({evaluation_hash(run['profile'])}): an edited or foreign run folder, refused"
        )
    journal = run_dir / JOURNAL_FILE
    with open(journal, "rb") if journal.is_file() else contextlib.nullcontext(None) as handle:
        header = parse_journal(handle.readline())[0] if handle else {}
    if header.get("evaluation_hash") != run["evaluation_hash"]:
        raise ConfigError(
            f"{journal}: evaluation hash {header.get('evaluation_hash')} (the run's: "
            f"{run['evaluation_hash']}): a journal of other physics or none, refused"
        )
    if checkpoint is None or not checkpoint["history"]:
        raise ConfigError(f"{run_dir} has no finished generation yet: nothing to export")
    name = run["profile"].get("profile", {}).get("name")
    owner = owner or f"profile {name!r}"
    try:
        reasons = run_differences(
            run["profile"], settings if settings is not None else load_settings(name)
        )
    except ConfigError as error:
        reasons = [f"profile {name!r} does not load ({error})"]
    if reasons:
        raise ConfigError(
            f"{run_dir} is not a campaign of {owner} as it stands: {'; '.join(reasons)}; only "
            f"a run of its own settings is exported as its results"
        )
    return run, checkpoint


def _export_state(folder: Path) -> bool | None:
    """Whether the export in ``folder`` is complete (its README says so), None when ``folder`` is not an export
    (a file, or a folder holding anything but :data:`REFERENCE_FILES` and the README of one)."""
    if not folder.is_dir() or sorted(p.name for p in folder.iterdir()) != sorted(
        (*REFERENCE_FILES, README_FILE)
    ):
        return None
    readme = (folder / README_FILE).read_text(errors="replace")
    if not readme.startswith(f"# Reference results: campaign of profile `{folder.name}`"):
        return None
    return "**Run: complete.**" in readme


def check_replaceable(target: Path, finished: bool) -> None:
    """Refuse (ConfigError) to replace ``target`` unless it is missing or a previous export, and a complete export
    by a partial one (``finished`` False): shipped results are only ever replaced by results as good."""
    if not target.exists():
        return
    state = _export_state(target)
    if state is None:
        raise ConfigError(
            f"{target} is not a previous export ({', '.join((*REFERENCE_FILES, README_FILE))} and "
            f"nothing else): left alone, nothing written"
        )
    if state and not finished:
        raise ConfigError(
            f"{target} holds a complete export and this run has not finished: a partial run never "
            f"replaces complete results; resume the run to its end, then export it"
        )


def analysis_mask(evaluations: xr.Dataset) -> tuple[np.ndarray, str]:
    """(mask over ``design``, the rule in words) of the designs notebook 07 reads: the feasible ones; when none
    is feasible, those without impact meeting every bound but the Delta-V bound (notebook 07's relaxed front)."""
    feasible = evaluations["feasible"].values.astype(bool)
    if feasible.any():
        return feasible, "the feasible designs"
    metric, _ = deltav_constraint(evaluations)
    others = [c for c in parse_constraints(evaluations.attrs["constraints"]) if c[0] != metric]
    mask = satisfies(evaluations, others) & ~evaluations["impact"].values.astype(bool)
    return (
        mask,
        f"no design is feasible: the designs without impact meeting every bound but {metric}'s",
    )


def machine_text() -> str:
    """The machine a file is written on, as the exports record it: platform and CPU count."""
    return f"{platform.platform()}, {os.cpu_count()} CPU(s)"


def netcdf_bytes(ds: xr.Dataset) -> bytes:
    encoding = {
        name: {"zlib": True, "complevel": 4}
        for name in ds.data_vars
        if ds[name].dtype.kind not in "US"
    }
    return bytes(ds.to_netcdf(engine="h5netcdf", encoding=encoding))


def thin_to_fit(
    evaluations: xr.Dataset, front: xr.Dataset, encode, limit_bytes: float
) -> tuple[xr.Dataset, bytes]:
    """The analysis designs (:func:`analysis_mask`) and their file ``encode(dataset) -> bytes``, under
    ``limit_bytes``: all of them when they fit, else the front and a seeded uniform sample of the rest, as many as
    fit (attributes ``selection``, ``n_designs_evaluated``, ``n_selected``, ``n_kept``, ``thinning``)."""
    mask, rule = analysis_mask(evaluations)
    index = np.flatnonzero(mask)
    in_front = np.isin(index, _front_rows(evaluations, front))
    rng = np.random.default_rng(THINNING_SEED)
    order = np.concatenate([index[in_front], rng.permutation(index[~in_front])])
    keep = order.size
    while True:
        ds = evaluations.drop_vars("error").isel(design=np.sort(order[:keep]))
        ds.attrs = {
            **evaluations.attrs,
            "selection": rule,
            "n_designs_evaluated": int(evaluations.sizes["design"]),
            "n_selected": int(index.size),
            "n_kept": int(keep),
            "thinning": (
                "none: every selected design"
                if keep == index.size
                else f"the {int(in_front.sum())} front designs and a uniform sample (seed {THINNING_SEED}) "
                f"of the other selected designs, {keep} of {index.size} kept to stay under "
                f"{limit_bytes:.0f} bytes"
            ),
        }
        data = encode(ds)
        if len(data) < limit_bytes or keep <= in_front.sum():
            return ds, data
        keep = max(int(in_front.sum()), int(keep * 0.95 * limit_bytes / len(data)))


def _front_rows(evaluations: xr.Dataset, front: xr.Dataset) -> np.ndarray:
    """Rows of ``evaluations`` that are designs of ``front`` (matched on the design variables)."""
    keys = np.column_stack([evaluations[k].values.astype(float) for k in DESIGN_KEYS])
    front_keys = {
        tuple(row) for row in np.column_stack([front[k].values.astype(float) for k in DESIGN_KEYS])
    }
    return np.array([i for i, row in enumerate(map(tuple, keys)) if row in front_keys], dtype=int)


def _population(evaluations: xr.Dataset, checkpoint: dict, plan: CampaignPlan) -> xr.Dataset:
    """The last checkpoint's population as rows of ``evaluations`` (its designs were all evaluated)."""
    designs = plan.grid.descale(np.asarray(checkpoint["algorithm"].pop.get("X"), dtype=float))
    keys = np.column_stack([evaluations[k].values.astype(float) for k in DESIGN_KEYS])
    row = {tuple(np.round(k, 9)): i for i, k in enumerate(keys)}
    rows = [row.get(tuple(np.round(d, 9))) for d in designs]
    if None in rows:
        raise ConfigError(
            f"{sum(r is None for r in rows)} design(s) of the last checkpoint's population are not in "
            f"the journal (damaged lines): resume the run once to evaluate them again, then export"
        )
    population = evaluations.drop_vars("error").isel(design=rows)
    population.attrs = {**evaluations.attrs, "generation": int(checkpoint["generation"])}
    return population


def run_provenance(run: dict, checkpoint: dict) -> dict:
    """What a run folder says of its run (``run.json`` and its last checkpoint): profile, profile hash, evaluation
    hash, evaluator, seed, population x generations, generations done and whether it finished; and ``created_utc``,
    ``versions`` (package -> version, as text) and ``run_commit``, each only when run.json is under its checksum
    (:func:`~lnss_lib.campaign.rundir.load_run` checked it), else said to be not verifiable."""
    settings = settings_from_profile(run["profile"])
    plan = CampaignPlan.of(settings)
    provenance = {
        "profile": settings.name,
        "profile_hash": profile_hash(run["profile"]),
        "evaluation_hash": run["evaluation_hash"],
        "evaluator": plan.evaluator,
        "seed": plan.seed,
        "population": plan.population,
        "generations": plan.generations,
        "generations_done": len(checkpoint["history"]),
        "finished": bool(checkpoint.get("finished")),
    }
    if "checksum" not in run:
        unsealed = "not verifiable (run.json of a run that recorded no checksum)"
        return {
            **provenance,
            "created_utc": unsealed,
            "versions": {"packages": unsealed},
            "run_commit": unsealed,
        }
    versions = run.get("versions")
    return {
        **provenance,
        "created_utc": str(run.get("created_utc", "unknown")),
        "versions": {str(k): str(v) for k, v in versions.items()}
        if isinstance(versions, dict)
        else {},
        "run_commit": str(run.get("commit", "not recorded in run.json")),
    }


def _readme(provenance: dict, files: dict[str, int], counts: dict) -> str:
    p = provenance
    state = (
        "complete"
        if p["finished"]
        else (
            f"PARTIAL: {p['generations_done']} of {p['generations']} generations "
            f"(the run had not finished when it was exported)"
        )
    )
    lines = [
        f"# Reference results: campaign of profile `{p['profile']}`",
        "",
        "Exported by `python -m lnss_lib campaign --export-reference RUN_DIR` from a run folder; read by "
        "notebooks 06-07 when no local run matches the profile (`lnss_lib.campaign.reference`).",
        "",
        f"**Run: {state}.**",
        "",
        "| provenance | value |",
        "| --- | --- |",
        f"| profile | `{p['profile']}`, hash `{p['profile_hash']}` |",
        f"| evaluation hash | `{p['evaluation_hash']}` (evaluator `{p['evaluator']}`) |",
        f"| seed | {p['seed']} |",
        f"| population x generations | {p['population']} x {p['generations']} |",
        f"| generations completed | {p['generations_done']} |",
        f"| complete | {'yes' if p['finished'] else 'no'} |",
        f"| wall time (sum over generations) | {p['wall_s']:.0f} s ({p['wall_s'] / 3600:.2f} h) |",
        f"| unique designs evaluated / feasible | {counts['n_designs']} / {counts['n_feasible']} |",
        f"| run started (UTC) | {p['created_utc']} |",
        f"| commit of the run | {p['run_commit']} |",
        f"| commit of the export | {p['export_commit']} |",
        f"| machine | {p['machine']} |",
        f"| exported (UTC) | {p['exported_utc']} |",
        f"| packages (of the run) | {', '.join(f'{k} {v}' for k, v in p['versions'].items())} |",
        "",
        "| file | bytes | holds |",
        "| --- | --- | --- |",
    ]
    holds = {
        "evaluations.nc": counts["thinning"],
        "front.nc": "the campaign's front (feasible, non-dominated)",
        "history.nc": "per generation: hypervolume, feasible counts, best objectives, cache hits, wall time",
        "population.nc": "the final population",
    }
    lines += [f"| `{name}` | {size} | {holds[name]} |" for name, size in files.items()]
    lines += [
        "",
        "NetCDF-4 with CF-1.8 attributes; the run's full settings are in each file's `parameters` attribute.",
    ]
    return "\n".join(lines) + "\n"


def write_export(root: Path, name: str, payloads: dict, readme, check_target) -> Path:
    """Write an export ``root/name``: ``payloads`` (path inside the export -> bytes, each under
    :data:`MAX_FILE_BYTES`, else RuntimeError and nothing written) and the README text ``readme(sizes)`` (sizes: path
    -> bytes) into a staging folder in ``root``, then, once ``check_target(target)`` passes, put it in the target's
    place by rename: a previous export is moved aside first and removed after, so readers see the old files or the
    new, never a mix. Returns the target."""
    too_big = {k: len(v) for k, v in payloads.items() if len(v) >= MAX_FILE_BYTES}
    if too_big:
        raise RuntimeError(
            f"reference files over {MAX_FILE_BYTES} bytes: {too_big}; nothing written"
        )
    root.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=root))
    target = root / name
    try:
        for path, data in payloads.items():
            (staging / path).parent.mkdir(mode=0o755, exist_ok=True)
            write_bytes_atomic(staging / path, data)
        write_text_atomic(staging / README_FILE, readme({k: len(v) for k, v in payloads.items()}))
        os.chmod(staging, 0o755)
        check_target(target)
        if target.exists():
            retired = Path(tempfile.mkdtemp(prefix=f".{name}-old-", dir=root))
            os.replace(target, retired / name)
            os.replace(staging, target)
            shutil.rmtree(retired, ignore_errors=True)
        else:
            os.replace(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return target


def export_reference(run_dir, root=None, *, export_commit: str = "unknown") -> Path:
    """Export the run folder ``run_dir`` (checked by :func:`check_run_folder`) into ``root/<profile>/``, replacing
    a previous export as one unit (temporary folder, then rename); returns the folder. ``export_commit``: the
    workbook commit that exports (the run's own is read from run.json when it recorded one)."""
    run_dir, root = Path(run_dir), Path(REFERENCE_DIR if root is None else root)
    run, checkpoint = check_run_folder(run_dir)
    evaluations, front, history = export_results(run_dir)
    plan = CampaignPlan.of(settings_from_profile(run["profile"]))
    name = evaluations.attrs["profile"]
    workers = concurrent_workers(read_cache_records(run_dir))
    wall_s = float(history["wall_s"].sum())
    finished = bool(checkpoint.get("finished"))
    check_replaceable(root / name, finished)
    provenance = {
        **run_provenance(run, checkpoint),
        "wall_s": wall_s,
        "export_commit": export_commit,
        "machine": f"{machine_text()}, {workers} worker process(es)",
        "exported_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    provenance["source"] = (
        f"NSGA-II campaign (pymoo), profile {name}, evaluator {plan.evaluator}, "
        f"{provenance['generations_done']} of {plan.generations} generations"
    )
    provenance["history"] = (
        f"{provenance['exported_utc']} exported from a run folder started "
        f"{provenance['created_utc']} ({'complete' if finished else 'partial'} run)"
    )
    history.attrs["worker_time"] = json.dumps(campaign_timing(run_dir, workers, wall_s))
    history.attrs["workers"] = workers
    constraints = plan.constraints
    evaluations.attrs["designs_meeting_bounds"] = json.dumps(
        {k: int(v.sum()) for k, v in bound_masks(evaluations, constraints).items()}
    )
    title = f"Designs read by Figures 8-16 and Table 6 ({name})"
    thinned, thinned_bytes = thin_to_fit(
        evaluations,
        front,
        lambda ds: netcdf_bytes(cf_dataset(ds, title, provenance)),
        MAX_FILE_BYTES,
    )
    payloads = {
        "evaluations.nc": thinned_bytes,
        "front.nc": netcdf_bytes(
            cf_dataset(front.drop_vars("error"), f"Campaign front ({name})", provenance)
        ),
        "history.nc": netcdf_bytes(
            cf_dataset(history, f"Campaign history per generation ({name})", provenance)
        ),
        "population.nc": netcdf_bytes(
            cf_dataset(
                _population(evaluations, checkpoint, plan), f"Final population ({name})", provenance
            )
        ),
    }
    counts = {
        "n_designs": int(evaluations.sizes["design"]),
        "n_feasible": int(evaluations["feasible"].sum()),
        "thinning": f"{thinned.attrs['selection']}; thinning: {thinned.attrs['thinning']}",
    }
    return write_export(
        root,
        name,
        payloads,
        lambda sizes: _readme(provenance, sizes, counts),
        lambda target: check_replaceable(target, finished),
    )


@dataclass(frozen=True)
class Reference:
    """An export read back: its folder, README text and the four datasets (``evaluations`` thinned)."""

    folder: Path
    readme: str
    evaluations: xr.Dataset
    front: xr.Dataset
    history: xr.Dataset
    population: xr.Dataset

    @property
    def finished(self) -> bool:
        return bool(int(self.history.attrs["finished"]))

    @property
    def profile(self) -> dict:
        """The run's settings as stored (the ``parameters`` attribute)."""
        return json.loads(self.history.attrs["parameters"])


def load_reference(profile_name: str, root=None) -> Reference | None:
    """The shipped results of ``profile_name`` (``root/<profile>/``, default :data:`REFERENCE_DIR`), or None when
    there are none; ValueError when the folder lacks a file."""
    folder = Path(REFERENCE_DIR if root is None else root) / profile_name
    if not folder.is_dir():
        return None
    missing = [name for name in (*REFERENCE_FILES, README_FILE) if not (folder / name).is_file()]
    if missing:
        raise ValueError(
            f"{folder} is not a complete reference export (missing {', '.join(missing)}); export it "
            f"again: python -m lnss_lib campaign --export-reference RUN_DIR"
        )
    datasets = [xr.load_dataset(folder / name, engine="h5netcdf") for name in REFERENCE_FILES]
    return Reference(folder, (folder / README_FILE).read_text(), *datasets)
