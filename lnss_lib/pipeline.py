"""Orchestration: output folders, run manifests, and headless notebook execution (papermill)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

from .config import OUTPUTS_DIR, PARAMS_DIR, PROJECT_DIR, load_profile, profile_hash

NOTEBOOKS_DIR = PROJECT_DIR / "notebooks"
MANIFEST_PACKAGES = ("numpy", "scipy", "spiceypy", "sgp4", "numba", "xarray", "pymoo", "plotly", "dask",
                     "distributed", "papermill", "skyfield-data", "h5netcdf", "pandas")


def output_dir(profile_name: str, kind: str) -> Path:
    """``outputs/<profile>/<kind>/`` (created): kind is notebooks, figures, tables, data or campaign."""
    allowed = ("notebooks", "figures", "tables", "data", "campaign")
    if kind not in allowed:
        raise ValueError(f"unknown output kind {kind!r}; allowed: {', '.join(allowed)}")
    folder = OUTPUTS_DIR / profile_name / kind
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def notebook_paths(only: list[str] | None = None) -> list[Path]:
    """The workbook's notebooks in order; ``only`` selects by name, stem or number prefix."""
    books = sorted(NOTEBOOKS_DIR.glob("[0-9][0-9]_*.ipynb"))
    if not only:
        return books
    chosen = []
    for key in only:
        key = key.removesuffix(".ipynb")
        matches = [b for b in books if b.stem == key or b.stem.split("_", 1)[0] == key or b.stem.startswith(key)]
        if not matches:
            raise ValueError(f"no notebook matches {key!r}; available: {', '.join(b.stem for b in books)}")
        chosen.extend(m for m in matches if m not in chosen)
    return sorted(chosen)


def data_checksums() -> dict[str, str]:
    """SHA-256 of every data file in ``params/data`` and of the planetary SPK."""
    from .ephemeris import file_sha256, planetary_spk_path

    sums = {str(p.relative_to(PARAMS_DIR)): file_sha256(p) for p in sorted((PARAMS_DIR / "data").rglob("*"))
            if p.is_file() and p.name not in ("README.md", "SHA256SUMS")}
    sums["skyfield-data:de421.bsp"] = file_sha256(planetary_spk_path())
    return sums


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
    versions = {"python": platform.python_version()}
    for name in MANIFEST_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def git_revision() -> str:
    """The workbook's git commit (with ``-dirty`` if modified), or ``unknown``."""
    try:
        rev = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=PROJECT_DIR, capture_output=True,
                             text=True, timeout=10)
        return rev.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def write_manifest(profile_name: str, runs: dict[str, dict]) -> Path:
    """Write ``outputs/<profile>/manifest.json``: parameters, versions, data checksums, notebook runs."""
    profile = load_profile(profile_name)
    path = OUTPUTS_DIR / profile_name / "manifest.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(path.read_text()).get("notebooks", {}) if path.is_file() else {}
    manifest = {
        "profile": profile_name,
        "profile_hash": profile_hash(profile),
        "parameters": profile,
        "git_revision": git_revision(),
        "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "platform": platform.platform(),
        "packages": package_versions(),
        "data_sha256": data_checksums(),
        "notebooks": {**previous, **runs},
    }
    path.write_text(json.dumps(manifest, indent=2, default=str))
    return path


def reproduce(profile_name: str = "quick", only: list[str] | None = None) -> int:
    """Execute the notebooks in order under a profile; stop at the first failure. Returns an exit code."""
    import papermill
    from tqdm import tqdm

    load_profile(profile_name)
    books = notebook_paths(only)
    paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    os.environ["PYTHONPATH"] = os.pathsep.join([str(PROJECT_DIR), *paths])  # kernels import this lnss_lib
    if not books:
        raise ValueError(f"no notebooks found in {NOTEBOOKS_DIR}")
    target = output_dir(profile_name, "notebooks")
    runs: dict[str, dict] = {}
    status = 0
    bar = tqdm(books, desc=f"reproduce [{profile_name}]", unit="notebook", file=sys.stderr)
    for book in bar:
        bar.set_postfix_str(book.stem)
        start = time.perf_counter()
        try:
            papermill.execute_notebook(str(book), str(target / book.name), parameters={"profile_name": profile_name},
                                       cwd=str(NOTEBOOKS_DIR), progress_bar=False, kernel_name="python3")
            runs[book.stem] = {"status": "ok", "wall_s": round(time.perf_counter() - start, 2)}
        except papermill.PapermillExecutionError as error:
            runs[book.stem] = {"status": "failed", "wall_s": round(time.perf_counter() - start, 2),
                               "error": f"{error.ename}: {error.evalue}"}
            bar.close()
            print(f"\nnotebook {book.name} failed in cell {error.cell_index}: {error.ename}: {error.evalue}\n"
                  f"the executed copy with the traceback is {target / book.name}; "
                  f"outputs of the notebooks before it are kept", file=sys.stderr)
            status = 1
            break
    manifest = write_manifest(profile_name, runs)
    if status == 0:
        total = sum(r["wall_s"] for r in runs.values())
        print(f"{len(runs)} notebook(s) ran in {total:.0f} s; manifest: {manifest}", file=sys.stderr)
    return status
