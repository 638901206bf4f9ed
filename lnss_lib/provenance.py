"""Provenance of a result: the workbook's git commit and the versions of the packages it depends on (recorded in
every manifest, run folder and shipped result)."""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
from importlib import metadata

from . import kernel_cpu
from .config import PROJECT_DIR

__all__ = ["MANIFEST_PACKAGES", "GIT_DIRS", "git_revision", "package_versions"]

MANIFEST_PACKAGES = (
    "numpy",
    "scipy",
    "spiceypy",
    "sgp4",
    "numba",
    "xarray",
    "pymoo",
    "plotly",
    "dask",
    "distributed",
    "papermill",
    "skyfield-data",
    "h5netcdf",
    "pandas",
)


GIT_DIRS = (
    "/usr/bin",
    "/bin",
    "/usr/local/bin",
    "/opt/homebrew/bin",
)  # where a system's git is installed


def git_revision() -> str:
    """The workbook's git commit (with ``-dirty`` if a tracked file outside the shipped results
    ``outputs/reference/`` is modified), or ``unknown``. Git is run from the system folders :data:`GIT_DIRS`, never
    found through ``PATH`` (a folder a user or a job may prepend), and without the caller's ``GIT_*`` variables."""
    executable = shutil.which("git", path=os.pathsep.join(GIT_DIRS))
    if executable is None:
        return "unknown"
    env = {key: value for key, value in os.environ.items() if not key.startswith("GIT_")}

    def git(*args: str) -> str:
        return subprocess.run(
            [executable, *args],
            cwd=PROJECT_DIR,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
            env=env,
        ).stdout.strip()

    try:
        dirty = git(
            "status",
            "--porcelain",
            "--untracked-files=no",
            "--",
            ".",
            ":(exclude)outputs/reference",
        )
        return git("describe", "--always") + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on, and the processor model its kernels were compiled
    for (``kernel_cpu``: :func:`lnss_lib.kernel_cpu`, which fixes their round-off)."""
    versions = {"python": platform.python_version(), "kernel_cpu": kernel_cpu()}
    for name in MANIFEST_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions
