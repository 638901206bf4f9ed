"""A study's shipped results: a finished study folder exported as ``outputs/reference/<study>/``.

A study is read as its campaigns side by side (the seed question, :mod:`lnss_lib.studies.seed_question`), so its
export keeps of each campaign what such a comparison reads, small: ``<campaign>/history.nc`` (per generation the
hypervolume, feasible counts, best objectives, journal hits and wall time) and ``<campaign>/front.nc`` (the campaign's
front, every column), NetCDF with the CF-1.8 attributes of a campaign's export (:mod:`lnss_lib.campaign.reference`),
each file under :data:`~lnss_lib.campaign.reference.MAX_FILE_BYTES`; and a ``README.md`` with the study's
provenance: per campaign its profile and profile hash, evaluation hash, seed, population x generations, wall time,
designs, start time, commit and packages; the exporting commit and machine.

Only a whole study, the study file's as it stands, is exported (:func:`check_study_folder`): the folder's
``study.toml`` gives the campaigns of one file of ``params/studies/`` (whose name the export takes), every campaign
has finished, and every campaign's run folder passes a campaign export's checks against the settings the study
gives it (:func:`~lnss_lib.campaign.reference.check_run_folder`: checksummed run.json and checkpoint, unedited
settings, the evaluation hash of the physics as it stands). Anything else is refused (ConfigError naming the
problem) and nothing is written. The files are written into a staging folder beside the target, which then
replaces a previous export of the study by rename; a target that is not one is left alone.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from ..config import PARAMS_DIR, REFERENCE_DIR
from ..errors import ConfigError
from ..settings import load_settings
from .costs import COSTS_FILE, costs_netcdf
from .journal import read_cache_records
from .reference import (
    README_FILE,
    cf_dataset,
    check_run_folder,
    machine_text,
    netcdf_bytes,
    run_provenance,
    write_export,
)
from .rundir import RUN_FILE, export_results, load_checkpoint
from .study import STUDY_FILE, Study, load_study
from .timing import concurrent_workers

__all__ = [
    "STUDIES_DIR",
    "STUDY_RESULT_FILES",
    "StudyReference",
    "check_study_folder",
    "export_study_reference",
    "load_study_reference",
]

STUDIES_DIR = PARAMS_DIR / "studies"
STUDY_RESULT_FILES = ("front.nc", "history.nc")  # of each campaign, in its own folder


@dataclass(frozen=True)
class StudyReference:
    """A study's export read back: its folder, README text and each campaign's history and front (by name, in
    the natural order of the names: seed2 before seed10)."""

    folder: Path
    readme: str
    histories: dict[str, xr.Dataset]
    fronts: dict[str, xr.Dataset]


def _study_file_of(stored: Study, studies_dir: Path) -> Study:
    """The study file of ``studies_dir`` whose campaigns (names, profiles, overrides) are ``stored``'s."""
    matches = []
    for path in sorted(studies_dir.glob("*.toml")):
        try:
            study = load_study(path)
        except ConfigError:  # a file that no longer loads is no study a run folder can be
            continue
        if study.campaigns == stored.campaigns:
            matches.append(study)
    if len(matches) != 1:
        raise ConfigError(
            f"the campaigns of the stored {STUDY_FILE} are those of "
            + (
                f"{len(matches)} study files ({', '.join(s.name for s in matches)}): ambiguous"
                if matches
                else f"no study file in {studies_dir} as it stands (edited since the study ran?)"
            )
            + "; only a study file's own study is exported as its results"
        )
    return matches[0]


def check_study_folder(run_dir, studies_dir=None) -> tuple[Study, dict[str, tuple[dict, dict]]]:
    """(the study file, ``{campaign: (run.json, last checkpoint)}``) of a study folder fit to export, else
    ConfigError naming the problem: not a study folder, a study that is no file's of ``studies_dir`` (default
    :data:`STUDIES_DIR`), campaigns not started or not finished, or a campaign folder that fails
    :func:`~lnss_lib.campaign.reference.check_run_folder` against the settings the study gives it."""
    run_dir = Path(run_dir)
    if not (run_dir / STUDY_FILE).is_file():
        raise ConfigError(
            f"{run_dir} is not a study folder (no {STUDY_FILE}; a study runs with "
            f"python -m lnss_lib study FILE --run-dir DIR)"
        )
    study = _study_file_of(
        load_study(run_dir / STUDY_FILE, name=run_dir.name),
        Path(STUDIES_DIR if studies_dir is None else studies_dir),
    )
    planned = {
        c.name: load_settings(c.profile, overrides=c.overrides or None) for c in study.campaigns
    }
    unfinished = []
    for name, settings in planned.items():
        folder = run_dir / name
        checkpoint = load_checkpoint(folder) if (folder / RUN_FILE).is_file() else None
        if checkpoint is None:
            unfinished.append(f"{name} not started")
        elif not checkpoint.get("finished"):
            unfinished.append(
                f"{name} at {len(checkpoint['history'])} of {settings.campaign.generations} generations"
            )
    if unfinished:
        raise ConfigError(
            f"study {study.name} in {run_dir} has not finished ({'; '.join(unfinished)}): continue it with "
            f"python -m lnss_lib study --resume {run_dir}, then export it"
        )
    runs = {
        name: check_run_folder(
            run_dir / name, settings, owner=f"campaign {name!r} of study {study.name!r}"
        )
        for name, settings in planned.items()
    }
    return study, runs


def _campaign_files(
    study: str, name: str, run_dir: Path, run: dict, checkpoint: dict, stamp: dict
) -> tuple[dict[str, bytes], dict]:
    """(``{"<name>/front.nc": bytes, "<name>/history.nc": bytes}``, the campaign's provenance) of one finished
    campaign of ``study``; ``stamp``: the export's commit and time."""
    evaluations, front, history = export_results(run_dir)
    p = {
        **run_provenance(run, checkpoint),
        "campaign": name,
        "wall_s": float(history["wall_s"].sum()),
        "n_designs": int(evaluations.sizes["design"]),
        "n_feasible": int(evaluations["feasible"].sum()),
        "n_front": int(front.sizes["design"]),
        "workers": concurrent_workers(read_cache_records(run_dir)),
        **stamp,
    }
    p["source"] = (
        f"NSGA-II campaign (pymoo) {name} of study {study}, profile {p['profile']}, evaluator "
        f"{p['evaluator']}, seed {p['seed']}, {p['generations_done']} generations"
    )
    p["history"] = (
        f"{p['exported_utc']} exported from a study folder; the campaign started {p['created_utc']}"
    )
    files = {}
    for file, ds, title in (
        ("front.nc", front.drop_vars("error"), "Campaign front"),
        ("history.nc", history, "Campaign history per generation"),
    ):
        ds.attrs.update(study=study, campaign=name)
        files[f"{name}/{file}"] = netcdf_bytes(cf_dataset(ds, f"{title} ({study}: {name})", p))
    return files, p


def _title(study: str) -> str:
    return f"# Reference results: study `{study}`"


def _packages(provenance: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in provenance["versions"].items())


def _readme(study: Study, provenance: list[dict], sizes: dict[str, int], stamp: dict) -> str:
    lines = [
        _title(study.name),
        "",
        study.description,
        "",
        f"Exported by `python -m lnss_lib study --export-reference RUN_DIR` from the folder of "
        f"`python -m lnss_lib study params/studies/{study.name}.toml --run-dir RUN_DIR`; read by notebook 07 "
        f"(`lnss_lib.campaign.study_reference`, `lnss_lib.studies.seed_question`).",
        "",
        "**Study: complete** (every campaign ran to its last generation).",
        "",
        "| campaign | profile (hash) | evaluation hash | seed | population x generations | wall time (sum over "
        "generations) | unique designs / feasible / front | worker processes | run started (UTC) | commit of the run |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {p['campaign']} | `{p['profile']}` (`{p['profile_hash']}`) | `{p['evaluation_hash']}` "
        f"(evaluator `{p['evaluator']}`) | {p['seed']} | {p['population']} x {p['generations']} | "
        f"{p['wall_s']:.0f} s ({p['wall_s'] / 3600:.2f} h) | {p['n_designs']} / {p['n_feasible']} / "
        f"{p['n_front']} | {p['workers']} | {p['created_utc']} | {p['run_commit']} |"
        for p in provenance
    ]
    lines += [
        "",
        "| provenance | value |",
        "| --- | --- |",
        f"| study file | `params/studies/{study.name}.toml` |",
        f"| commit of the export | {stamp['export_commit']} |",
        f"| machine (of the export) | {stamp['machine']} |",
        f"| exported (UTC) | {stamp['exported_utc']} |",
    ]
    if len({_packages(p) for p in provenance}) == 1:
        lines.append(f"| packages (of the runs) | {_packages(provenance[0])} |")
    else:
        lines += [f"| packages of {p['campaign']} | {_packages(p)} |" for p in provenance]
    holds = {
        "front.nc": "the campaign's front (feasible, non-dominated; every column)",
        "history.nc": "per generation: hypervolume, feasible counts, best objectives, journal hits, wall time",
        COSTS_FILE: "per design of every campaign: generation, ordering keys and task time (read by the cluster "
        "replay of notebook 06)",
    }
    lines += ["", "| file | bytes | holds |", "| --- | --- | --- |"]
    lines += [f"| `{path}` | {size} | {holds[Path(path).name]} |" for path, size in sizes.items()]
    lines += [
        "",
        "NetCDF-4 with CF-1.8 attributes; each campaign's full settings are in its files' `parameters` "
        "attribute.",
    ]
    return "\n".join(lines) + "\n"


def _is_study_export(folder: Path, study: str) -> bool:
    """Whether ``folder`` holds an export of ``study`` (its README, the per-design costs and folders holding
    each campaign's files) and nothing else."""
    readme = folder / README_FILE
    if not readme.is_file() or not readme.read_text(errors="replace").startswith(_title(study)):
        return False
    return all(
        entry.name in (README_FILE, COSTS_FILE)
        or (
            entry.is_dir() and sorted(p.name for p in entry.iterdir()) == sorted(STUDY_RESULT_FILES)
        )
        for entry in folder.iterdir()
    )


def _check_replaceable(target: Path, study: str) -> None:
    if target.exists() and not _is_study_export(target, study):
        raise ConfigError(
            f"{target} is not a previous export of study {study} ({README_FILE} and a folder of "
            f"{', '.join(STUDY_RESULT_FILES)} a campaign, nothing else): left alone, nothing written"
        )


def export_study_reference(
    run_dir, root=None, *, export_commit: str = "unknown", studies_dir=None
) -> Path:
    """Export the finished study folder ``run_dir`` (checked by :func:`check_study_folder`, against the study files
    of ``studies_dir``) into ``root/<study>/`` (default :data:`~lnss_lib.config.REFERENCE_DIR`), replacing a
    previous export of the study as one unit; returns the folder. ``export_commit``: the workbook commit that
    exports (each run's own is read from its run.json)."""
    run_dir, root = Path(run_dir), Path(REFERENCE_DIR if root is None else root)
    study, runs = check_study_folder(run_dir, studies_dir)
    target = root / study.name
    _check_replaceable(target, study.name)
    stamp = {
        "export_commit": export_commit,
        "exported_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": machine_text(),
    }
    payloads, provenance = {}, []
    for campaign in study.campaigns:
        files, p = _campaign_files(
            study.name, campaign.name, run_dir / campaign.name, *runs[campaign.name], stamp
        )
        payloads.update(files)
        provenance.append(p)
    payloads[COSTS_FILE] = costs_netcdf(
        {c.name: run_dir / c.name for c in study.campaigns}, export_commit=export_commit
    )
    return write_export(
        root,
        study.name,
        payloads,
        lambda sizes: _readme(study, provenance, sizes, stamp),
        lambda target: _check_replaceable(target, study.name),
    )


def _natural(name: str) -> list:
    """``seed2`` before ``seed10``: the digits of a name compared as numbers."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def load_study_reference(study: str, root=None) -> StudyReference | None:
    """The shipped results of ``study`` (``root/<study>/``, default :data:`~lnss_lib.config.REFERENCE_DIR`),
    campaigns in the natural order of their names, or None when there are none; ValueError when the folder is not a
    complete export."""
    folder = Path(REFERENCE_DIR if root is None else root) / study
    if not folder.is_dir():
        return None
    if not _is_study_export(folder, study):
        raise ValueError(
            f"{folder} is not a complete export of study {study} ({README_FILE} and each campaign's "
            f"{', '.join(STUDY_RESULT_FILES)}); export it again: python -m lnss_lib study "
            f"--export-reference RUN_DIR"
        )
    names = sorted((p.name for p in folder.iterdir() if p.is_dir()), key=_natural)
    histories, fronts = (
        {name: xr.load_dataset(folder / name / file, engine="h5netcdf") for name in names}
        for file in ("history.nc", "front.nc")
    )
    return StudyReference(folder, (folder / README_FILE).read_text(), histories, fronts)
