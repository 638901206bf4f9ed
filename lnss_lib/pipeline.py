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

    timeout_s = int(load_profile(profile_name)["notebooks"]["timeout_s"])
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
                                       cwd=str(NOTEBOOKS_DIR), progress_bar=False, kernel_name="python3",
                                       execution_timeout=timeout_s)
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
    index = write_index(profile_name)
    print(f"index of figures and tables: {index}", file=sys.stderr)
    if status == 0:
        total = sum(r["wall_s"] for r in runs.values())
        print(f"{len(runs)} notebook(s) ran in {total:.0f} s; manifest: {manifest}", file=sys.stderr)
    return status


CAPTION_SUFFIX = ".meta.json"


def write_caption(folder: Path, name: str, caption: str, files: list[Path]) -> Path:
    """Sidecar ``<folder>/<name>.meta.json`` holding the one-line caption of a figure or table and its files."""
    path = folder / f"{name}{CAPTION_SUFFIX}"
    path.write_text(json.dumps({"name": name, "caption": " ".join(str(caption).split()),
                                "files": [p.name for p in files]}, indent=1))
    return path


def read_caption(folder: Path, name: str) -> str:
    """The caption of ``name`` from its sidecar, or a readable form of the name when there is none."""
    path = folder / f"{name}{CAPTION_SUFFIX}"
    if path.is_file():
        caption = json.loads(path.read_text()).get("caption", "")
        if caption:
            return caption
    return name.replace("_", " ")


def markdown_table(frame, digits: int = 4) -> str:
    """Pipe-style Markdown table of a DataFrame (index included when it is not a plain range).

    Floats are written with ``digits`` significant digits; NaN and None as empty cells.
    """
    import numbers

    import pandas as pd

    def cell(value) -> str:
        if value is None or (isinstance(value, float) and value != value):
            return ""
        if isinstance(value, (bool,)) or not isinstance(value, numbers.Real):
            return str(value).replace("|", "\\|").replace("\n", " ")
        if isinstance(value, numbers.Integral):
            return str(int(value))
        return f"{float(value):.{digits}g}"

    show_index = not isinstance(frame.index, pd.RangeIndex)
    header = ([str(frame.index.name or "")] if show_index else []) + [str(c) for c in frame.columns]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for index, row in zip(frame.index, frame.itertuples(index=False)):
        cells = ([cell(index)] if show_index else []) + [cell(v) for v in row]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def save_table(frame, profile_name: str, name: str, caption: str, *, digits: int = 4) -> dict[str, Path]:
    """Write ``outputs/<profile>/tables/<name>.csv`` and ``.md`` (with the caption above the table)
    and the caption sidecar used by :func:`write_index`; return the written paths."""
    folder = output_dir(profile_name, "tables")
    written = {"csv": folder / f"{name}.csv", "md": folder / f"{name}.md"}
    frame.to_csv(written["csv"], index=not _plain_index(frame))
    written["md"].write_text(f"{' '.join(caption.split())}\n\n{markdown_table(frame, digits)}")
    written["meta"] = write_caption(folder, name, caption, [written["csv"], written["md"]])
    return written


def _plain_index(frame) -> bool:
    import pandas as pd

    return isinstance(frame.index, pd.RangeIndex)


def write_index(profile_name: str) -> Path:
    """Write ``outputs/<profile>/index.html``: every figure (HTML, PNG) and table (CSV, Markdown) with
    a one-line caption (from the sidecars :func:`lnss_lib.figures.save_figure` and :func:`save_table`
    write), the executed notebooks, the campaign files and the manifest, all as relative links."""
    import html

    root = OUTPUTS_DIR / profile_name
    root.mkdir(parents=True, exist_ok=True)

    def link(path: Path, label: str) -> str:
        return f'<a href="{html.escape(path.relative_to(root).as_posix())}">{html.escape(label)}</a>'

    def rows(folder: Path, kinds: tuple[str, ...]) -> list[str]:
        if not folder.is_dir():
            return []
        stems = sorted({p.name[: -len(p.suffix)] for p in folder.iterdir()
                        if p.suffix in kinds and not p.name.endswith(CAPTION_SUFFIX)})
        out = []
        for stem in stems:
            links = " ".join(link(folder / f"{stem}{k}", k.lstrip(".").upper()) for k in kinds
                             if (folder / f"{stem}{k}").is_file())
            out.append(f"<tr><td>{html.escape(stem)}</td><td>{html.escape(read_caption(folder, stem))}</td>"
                       f"<td>{links}</td></tr>")
        return out

    def section(title: str, body: list[str], empty: str) -> str:
        if not body:
            return f"<h2>{html.escape(title)}</h2><p>{html.escape(empty)}</p>"
        return (f"<h2>{html.escape(title)}</h2><table><tr><th>name</th><th>caption</th><th>files</th></tr>"
                + "".join(body) + "</table>")

    notebooks = sorted((root / "notebooks").glob("*.ipynb")) if (root / "notebooks").is_dir() else []
    campaign = sorted((root / "campaign").glob("*.nc")) if (root / "campaign").is_dir() else []
    extras = [link(p, p.name) for p in notebooks + campaign]
    if (root / "manifest.json").is_file():
        extras.append(link(root / "manifest.json", "manifest.json (parameters, versions, checksums, timings)"))
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>LNSS workbook outputs: {html.escape(profile_name)}</title>"
        "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:4px 8px;text-align:left;vertical-align:top}</style></head><body>"
        f"<h1>LNSS workbook outputs, profile {html.escape(profile_name)}</h1>"
        f"<p>Written {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}.</p>"
        + section("Figures", rows(root / "figures", (".html", ".png")), "no figures yet")
        + section("Tables", rows(root / "tables", (".csv", ".md")), "no tables yet")
        + "<h2>Notebooks, campaign and manifest</h2>"
        + ("<ul>" + "".join(f"<li>{e}</li>" for e in extras) + "</ul>" if extras else "<p>none yet</p>")
        + "</body></html>\n"
    )
    path = root / "index.html"
    path.write_text(page)
    return path
