"""A profile's published campaign: ``outputs/<profile>/campaign/published.json`` and the folder it names.

A run folder belongs to the process that holds its lock; the notebooks (06-08, 10) read instead the
profile's publication: a folder ``published/<run>-<id>/`` holding the run's ``evaluations.nc``,
``front.nc`` and ``history.nc`` (and ``validated.nc`` when the run validated its front,
:mod:`lnss_lib.campaign.validation`), written complete and never changed afterwards, and the pointer
``published.json`` naming it (run, hashes, evaluator, generations), replaced atomically. Publishing
and reading take an ``flock`` on the campaign folder (exclusive and shared), so two campaigns of one
profile that finish at once publish one after the other and a reader always gets the three files of
one run. A run is published as the profile's only when its stored profile is the profile's
(:func:`run_differences` empty: same profile hash, hence same evaluator and evaluation settings), and never
replaces a finished run's publication by an unfinished one (a session stopped by ``--max-generations``).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from ..atomicio import write_netcdf_atomic, write_text_atomic
from ..config import profile_hash
from ..errors import ConfigError
from .rundir import RESULT_FILES, export_results, load_run
from .settings import run_differences
from .validation import VALIDATED_FILE

__all__ = [
    "Publication",
    "run_differences",
    "publish_run",
    "load_published",
    "published_folder",
    "POINTER_FILE",
    "PUBLISHED_DIR",
]

POINTER_FILE, PUBLISHED_DIR = "published.json", "published"


@dataclass(frozen=True)
class Publication:
    """A profile's published campaign: ``pointer`` (published.json), its folder, the three datasets and the
    validated front (None when the run has none)."""

    pointer: dict
    folder: Path
    evaluations: xr.Dataset
    front: xr.Dataset
    history: xr.Dataset
    validated: xr.Dataset | None = None


@contextlib.contextmanager
def _locked(campaign_dir: Path, exclusive: bool):
    import fcntl

    fd = os.open(campaign_dir, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(fd)


def publish_run(run_dir, campaign_dir, datasets=None) -> Path:
    """Publish ``run_dir`` as the campaign of ``campaign_dir`` (the caller checked :func:`run_differences`):
    ``datasets`` (default :func:`~lnss_lib.campaign.rundir.export_results`) into a new folder, then the
    pointer; superseded folders are removed. Returns the pointer's path; ConfigError, nothing written, when a
    finished run is published and this one has not finished."""
    run_dir, campaign_dir = Path(run_dir), Path(campaign_dir)
    datasets = datasets if datasets is not None else export_results(run_dir)
    run = load_run(run_dir)
    root = campaign_dir / PUBLISHED_DIR
    with _locked(campaign_dir, exclusive=True):
        current = _pointer(campaign_dir)
        if current and current.get("finished") is True and not datasets[0].attrs["finished"]:
            raise ConfigError(
                f"{campaign_dir / POINTER_FILE} publishes the finished run {current.get('run_dir')!r}; "
                f"this run has not finished and does not replace it"
            )
        root.mkdir(exist_ok=True)
        folder = Path(tempfile.mkdtemp(prefix=f"{run_dir.name}-", dir=root))
        for name, ds in zip(RESULT_FILES, datasets):
            write_netcdf_atomic(ds, folder / name)
        validated = run_dir / VALIDATED_FILE
        if validated.is_file():
            write_netcdf_atomic(
                xr.load_dataset(validated, engine="h5netcdf"), folder / VALIDATED_FILE
            )
        attrs = datasets[0].attrs
        pointer = {
            "folder": f"{PUBLISHED_DIR}/{folder.name}",
            "run_dir": os.path.relpath(run_dir, campaign_dir),
            "profile": run["profile"]["profile"]["name"],
            "profile_hash": profile_hash(run["profile"]),
            "evaluation_hash": run["evaluation_hash"],
            "evaluator": attrs["evaluator"],
            "generations_done": int(attrs["generations_done"]),
            "finished": bool(attrs["finished"]),
            "validated": (folder / VALIDATED_FILE).is_file(),
            "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        }
        write_text_atomic(campaign_dir / POINTER_FILE, json.dumps(pointer, indent=1))
        for old in root.iterdir():
            if old != folder:
                shutil.rmtree(old, ignore_errors=True)
    return campaign_dir / POINTER_FILE


def _pointer(campaign_dir: Path) -> dict | None:
    path = campaign_dir / POINTER_FILE
    if not path.is_file():
        return None
    try:
        pointer = json.loads(path.read_text())
        folder = Path(pointer["folder"])
    except (ValueError, TypeError, KeyError):
        raise ValueError(
            f"{path} is not a publication pointer (JSON naming its folder); delete it and run "
            f"the campaign or notebook 06 again"
        ) from None
    if folder.is_absolute() or ".." in folder.parts:
        raise ValueError(f"{path}: folder {str(folder)!r} is outside {campaign_dir}")
    return pointer


def published_folder(campaign_dir) -> Path | None:
    """The folder of ``campaign_dir``'s publication (its files never change), or None when nothing is published."""
    pointer = _pointer(Path(campaign_dir))
    return Path(campaign_dir) / pointer["folder"] if pointer else None


def load_published(campaign_dir) -> Publication | None:
    """The publication of ``campaign_dir`` loaded into memory (one run's three files), or None."""
    campaign_dir = Path(campaign_dir)
    if not campaign_dir.is_dir():
        return None
    with _locked(campaign_dir, exclusive=False):
        pointer = _pointer(campaign_dir)
        if pointer is None:
            return None
        folder = campaign_dir / pointer["folder"]
        datasets = [xr.load_dataset(folder / name, engine="h5netcdf") for name in RESULT_FILES]
        validated = folder / VALIDATED_FILE
        datasets.append(
            xr.load_dataset(validated, engine="h5netcdf") if validated.is_file() else None
        )
    return Publication(pointer, folder, *datasets)
