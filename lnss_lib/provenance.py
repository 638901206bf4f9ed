"""Provenance of a result: the workbook's git commit and the versions of the packages it depends on (recorded in
every manifest, run folder and shipped result)."""

from __future__ import annotations

import platform
import subprocess
from importlib import metadata

from . import kernel_cpu
from .config import PROJECT_DIR

__all__ = ["MANIFEST_PACKAGES", "git_revision", "package_versions"]

MANIFEST_PACKAGES = ("numpy", "scipy", "spiceypy", "sgp4", "numba", "xarray", "pymoo", "plotly", "dask",
                     "distributed", "papermill", "skyfield-data", "h5netcdf", "pandas")


def git_revision() -> str:
    """The workbook's git commit (with ``-dirty`` if a tracked file outside the shipped results
    ``outputs/reference/`` is modified), or ``unknown``."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=PROJECT_DIR, capture_output=True, text=True, timeout=10,
                              check=True).stdout.strip()

    try:
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)outputs/reference")
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
