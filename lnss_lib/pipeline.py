"""Running the workbook: headless notebook execution (papermill) and the outputs index page."""

from __future__ import annotations

import csv
import html
import json
import os
import re
import sys
import time
import uuid
from pathlib import Path

from .config import PROJECT_DIR, available_profiles
from .errors import ConfigError
from .findings import write_findings
from .keys import format_value, label
from .outputs import (
    CAPTION_SUFFIX,
    atomic_path,
    output_dir,
    profile_dir,
    read_caption,
    write_manifest,
    write_text_atomic,
)
from .settings import load_settings

__all__ = [
    "NOTEBOOKS_DIR",
    "PROFILE_ENV",
    "notebook_paths",
    "notebook_profile",
    "kernel_environment",
    "reproduce",
    "write_index",
    "ipc_kernel_manager_class",
]

NOTEBOOKS_DIR = PROJECT_DIR / "notebooks"
KERNEL_LOG = "kernels.log"  # in outputs/<profile>/notebooks/: the kernel processes' own stderr
PROFILE_ENV = "LNSS_PROFILE"
"""Environment variable naming the profile of a notebook run without papermill parameters (nbval, jupyter lab)."""
DEFAULT_PROFILE = "quick"
INDEX_TABLE_MAX_ROWS = 200  # rows of a table shown inline in the index; the CSV has them all


def notebook_paths(only: list[str] | None = None) -> list[Path]:
    """The workbook's notebooks in order; ``only`` selects by name, stem or number prefix."""
    books = sorted(NOTEBOOKS_DIR.glob("[0-9][0-9]_*.ipynb"))
    if not only:
        return books
    chosen = []
    for key in only:
        key = key.removesuffix(".ipynb")
        matches = [
            b
            for b in books
            if b.stem == key or b.stem.split("_", 1)[0] == key or b.stem.startswith(key)
        ]
        if not matches:
            raise ValueError(
                f"no notebook matches {key!r}; available: {', '.join(b.stem for b in books)}"
            )
        chosen.extend(m for m in matches if m not in chosen)
    return sorted(chosen)


def notebook_profile() -> str:
    """The profile a notebook's parameters cell defaults to: ``$LNSS_PROFILE`` (the test suite sets ``ci`` for
    nbval), else ``quick``; :func:`reproduce` passes its own as a papermill parameter. Raises
    :class:`ConfigError` for a name that is not a profile in ``params/``."""
    name = os.environ.get(PROFILE_ENV, DEFAULT_PROFILE)
    if name not in available_profiles():
        raise ConfigError(
            f"{PROFILE_ENV} = {name!r} is not a profile; available: {', '.join(available_profiles())}",
            key=PROFILE_ENV,
        )
    return name


def kernel_environment(profile_name: str) -> None:
    """Notebook kernels started from this process (papermill, nbval, voila) import this checkout's lnss_lib and
    default to ``profile_name`` (:func:`notebook_profile`)."""
    paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    os.environ["PYTHONPATH"] = os.pathsep.join(
        [str(PROJECT_DIR), *(p for p in paths if p != str(PROJECT_DIR))]
    )
    os.environ[PROFILE_ENV] = profile_name


def ipc_kernel_manager_class(log_path: Path | None = None):
    """A jupyter_client kernel manager whose kernels talk over local IPC sockets instead of TCP.

    The sockets are files in the Jupyter runtime folder, readable only by this user, so nothing
    listens on a port and the kernel has no reason to warn about unencrypted TCP traffic. With
    ``log_path`` the kernel process's own stderr (its log, not the cells' output) is appended there,
    so an interrupted run does not print the kernel's socket errors on the terminal.
    """
    from jupyter_client import AsyncKernelManager
    from jupyter_core.paths import jupyter_runtime_dir

    class IpcKernelManager(AsyncKernelManager):
        def __init__(self, **kwargs):
            kwargs.setdefault("transport", "ipc")
            super().__init__(**kwargs)
            runtime = Path(jupyter_runtime_dir())
            runtime.mkdir(parents=True, exist_ok=True)
            self.ip = str(runtime / f"lnss-kernel-{uuid.uuid4().hex[:12]}-ipc")

        async def start_kernel(self, **kwargs):
            if log_path is None:
                return await super().start_kernel(**kwargs)
            with open(log_path, "a") as log:
                return await super().start_kernel(**{"stderr": log, **kwargs})

    return IpcKernelManager


def reproduce(
    profile_name: str = DEFAULT_PROFILE,
    only: list[str] | None = None,
    overrides: dict | None = None,
) -> int:
    """Execute the notebooks in order under a profile; stop at the first failure. Returns an exit code.

    ``overrides`` (a nested dict, e.g. from ``--set``) is checked here, before any notebook runs, and
    reaches each notebook as the papermill parameter ``overrides_json`` for its ``load_settings``.
    Kernels run over IPC sockets (:func:`ipc_kernel_manager_class`) with their own log in
    ``notebooks/kernels.log``, so the progress bar is the only output unless a notebook fails; Ctrl-C
    ends the run with one line (exit 130). Each executed notebook is written to a temporary file and moved
    into place, so a failed write leaves the previous copy.
    """
    import papermill
    from tqdm import tqdm

    timeout_s = load_settings(profile_name, overrides=overrides).notebooks.timeout_s
    parameters = {"profile_name": profile_name, "overrides_json": json.dumps(overrides or {})}
    books = notebook_paths(only)
    kernel_environment(profile_name)
    if not books:
        raise ValueError(f"no notebooks found in {NOTEBOOKS_DIR}")
    target = output_dir(profile_name, "notebooks")
    manager = ipc_kernel_manager_class(target / KERNEL_LOG)
    runs: dict[str, dict] = {}
    status = 0
    bar = tqdm(books, desc=f"reproduce [{profile_name}]", unit="notebook", file=sys.stderr)
    for book in bar:
        bar.set_postfix_str(book.stem)
        start = time.perf_counter()
        failure = None
        try:
            with atomic_path(target / book.name, suffix=".ipynb") as temporary:
                declared = {
                    k: v
                    for k, v in parameters.items()
                    if k in papermill.inspect_notebook(str(book))
                }
                try:
                    papermill.execute_notebook(
                        str(book),
                        str(temporary),
                        parameters=declared,
                        cwd=str(NOTEBOOKS_DIR),
                        progress_bar=False,
                        kernel_name="python3",
                        execution_timeout=timeout_s,
                        kernel_manager_class=manager,
                    )
                except papermill.PapermillExecutionError as error:
                    failure = error  # the complete notebook, holding the failing cell's traceback, is kept
        except BaseException:
            bar.close()
            raise
        wall_s = round(time.perf_counter() - start, 2)
        if failure is None:
            runs[book.stem] = {"status": "ok", "wall_s": wall_s}
            continue
        runs[book.stem] = {
            "status": "failed",
            "wall_s": wall_s,
            "error": f"{failure.ename}: {failure.evalue}",
        }
        bar.close()
        print(
            f"\nnotebook {book.name} failed in cell {failure.cell_index}: {failure.ename}: {failure.evalue}\n"
            f"the executed copy with the traceback is {target / book.name}; "
            f"outputs of the notebooks before it are kept",
            file=sys.stderr,
        )
        status = 1
        break
    manifest = write_manifest(profile_name, runs)
    index = write_index(profile_name)
    print(f"index of figures and tables: {index}", file=sys.stderr)
    if status == 0:
        total = sum(r["wall_s"] for r in runs.values())
        print(
            f"{len(runs)} notebook(s) ran in {total:.0f} s; manifest: {manifest}", file=sys.stderr
        )
    return status


INDEX_STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:1400px}"
    "#answer p{max-width:60em;font-size:1.05em}img.headline{max-width:900px;width:100%;border:1px solid #ddd}"
    "table.findings{font-size:0.9em}table.findings th{text-align:left}td.why{max-width:34em;color:#333}"
    "nav{font-size:0.9em;margin:1em 0}nav a{margin-right:1em}"
    ".scroll{max-width:100%;overflow-x:auto}"
    "td.text{max-width:28em;white-space:normal;overflow-wrap:anywhere}"
    ".grid{display:flex;flex-wrap:wrap;gap:16px}"
    "figure{margin:0;width:320px;border:1px solid #ddd;padding:8px;background:#fafafa}"
    "figure img{width:100%;height:auto;display:block;background:#fff}"
    ".noimg{display:flex;align-items:center;justify-content:center;height:180px;background:#eee;color:#555}"
    "figcaption{font-size:0.9em;margin-top:6px}"
    "table{border-collapse:collapse;font-size:0.85em;margin-bottom:0.5em}"
    "td,th{border:1px solid #ccc;padding:3px 6px;text-align:right;vertical-align:top}"
    "th{background:#f0f0f0;max-width:9em;font-weight:600;overflow-wrap:anywhere}td.text{text-align:left}"
    ".files{font-size:0.85em;color:#555}"
)


def natural_key(name: str) -> list:
    """Sort key that orders the digits in a name as numbers: ``07_fig8`` before ``07_fig10``."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def _stems(folder: Path, suffixes: tuple[str, ...]) -> list[str]:
    if not folder.is_dir():
        return []
    return sorted(
        {
            p.name[: -len(p.suffix)]
            for p in folder.iterdir()
            if p.suffix in suffixes and not p.name.endswith(CAPTION_SUFFIX)
        },
        key=natural_key,
    )


def _group(stem: str) -> str:
    """The notebook number a figure or table belongs to (its ``NN_`` prefix), or ``""``."""
    prefix = stem.split("_", 1)[0]
    return prefix if len(prefix) == 2 and prefix.isdigit() else ""


def _cell(text: str, column: str = "") -> str:
    """One CSV cell for display: a number in the format of its column's quantity
    (:func:`lnss_lib.keys.format_value`: km as integers, DOP to 2 decimals, Delta-V to 3), a metric key by
    its label, other text escaped."""
    try:
        value = float(text)
    except ValueError:
        return f'<td class="text">{html.escape(label(text))}</td>'
    if text.strip().lstrip("-").isdigit():
        return f"<td>{html.escape(text.strip())}</td>"
    return f"<td>{html.escape(format_value(column, value))}</td>"


def _csv_table(path: Path) -> str:
    """A small CSV as an HTML table (the first :data:`INDEX_TABLE_MAX_ROWS` rows)."""
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    if not rows:
        return "<p>(empty table)</p>"
    header, body = rows[0], rows[1:]
    out = [
        '<div class="scroll"><table><tr>'
        + "".join(f'<th title="{html.escape(h)}">{html.escape(label(h))}</th>' for h in header)
        + "</tr>"
    ]
    out += [
        "<tr>" + "".join(_cell(c, h) for c, h in zip(row, header)) + "</tr>"
        for row in body[:INDEX_TABLE_MAX_ROWS]
    ]
    out.append("</table></div>")
    if len(body) > INDEX_TABLE_MAX_ROWS:
        out.append(f"<p>first {INDEX_TABLE_MAX_ROWS} of {len(body)} rows; all in the CSV.</p>")
    return "".join(out)


def write_index(profile_name: str) -> Path:
    """Write ``outputs/<profile>/index.html``, a page that opens offline, and ``FINDINGS.md`` beside it.

    It opens on the findings (:mod:`lnss_lib.findings`: the run's headline results beside the paper's,
    with links to the figures and sections that show them); then, grouped by notebook (the ``NN_`` prefix of each name): every figure in natural order (Figure 8 before 10) as its PNG
    thumbnail with its caption, linking to the interactive HTML; every table rendered inline with its caption and links to
    the CSV and Markdown; then the executed notebooks, the published campaign's files and the manifest. Captions come
    from the sidecars :func:`lnss_lib.figures.save_figure` and :func:`lnss_lib.outputs.save_table` write.
    """
    from .campaign.publication import published_folder

    root = profile_dir(profile_name)
    root.mkdir(parents=True, exist_ok=True)
    figures_dir, tables_dir, notebooks_dir = root / "figures", root / "tables", root / "notebooks"

    def href(path: Path) -> str:
        return html.escape(path.relative_to(root).as_posix())

    def link(path: Path, label: str) -> str:
        return f'<a href="{href(path)}">{html.escape(label)}</a>'

    def figure(stem: str) -> str:
        caption = html.escape(read_caption(figures_dir, stem))
        page, png = figures_dir / f"{stem}.html", figures_dir / f"{stem}.png"
        target = href(page) if page.is_file() else href(png)
        image = (
            f'<img src="{href(png)}" alt="{caption}" loading="lazy">'
            if png.is_file()
            else '<div class="noimg">interactive figure (no PNG)</div>'
        )
        files = " ".join(link(p, p.suffix.lstrip(".").upper()) for p in (page, png) if p.is_file())
        return (
            f'<figure><a href="{target}">{image}</a><figcaption>{caption}'
            f'<div class="files">{html.escape(stem)}: {files}</div></figcaption></figure>'
        )

    def table(stem: str) -> str:
        files = [tables_dir / f"{stem}{s}" for s in (".csv", ".md")]
        body = _csv_table(files[0]) if files[0].is_file() else ""
        links = " ".join(link(p, p.suffix.lstrip(".").upper()) for p in files if p.is_file())
        return (
            f"<h4>{html.escape(read_caption(tables_dir, stem))}</h4>{body}"
            f'<p class="files">{html.escape(stem)}: {links}</p>'
        )

    figure_stems = _stems(figures_dir, (".html", ".png"))
    table_stems = _stems(tables_dir, (".csv", ".md"))
    executed = (
        {b.stem: b for b in sorted(notebooks_dir.glob("*.ipynb"))} if notebooks_dir.is_dir() else {}
    )
    names = {b.stem.split("_", 1)[0]: b.stem for b in notebook_paths()}
    names.update({stem.split("_", 1)[0]: stem for stem in executed})
    groups = sorted({_group(s) for s in figure_stems + table_stems} | {_group(s) for s in executed})
    sections = []
    for group in sorted(groups, key=lambda g: (g == "", g)):
        title = names.get(group, group).replace("_", " ") if group else "other outputs"
        figs = [figure(s) for s in figure_stems if _group(s) == group]
        tabs = [table(s) for s in table_stems if _group(s) == group]
        notebook = executed.get(names.get(group, ""))
        parts = [f'<h2 id="nb-{group or "other"}">{html.escape(title)}</h2>']
        if notebook is not None:
            parts.append(f"<p>executed notebook: {link(notebook, notebook.name)}</p>")
        if figs:
            parts.append('<div class="grid">' + "".join(figs) + "</div>")
        if tabs:
            parts.append("<h3>Tables</h3>" + "".join(tabs))
        sections.append("".join(parts))
    companion = (
        load_settings(profile_name).campaign.companion_profile or None
        if profile_name in available_profiles()
        else None
    )
    _, findings = write_findings(profile_name, companion)
    contents = "".join(
        f'<a href="#nb-{g or "other"}">{html.escape(g or "other")}</a>'
        for g in sorted(groups, key=lambda g: (g == "", g))
    )
    published = published_folder(root / "campaign") if (root / "campaign").is_dir() else None
    campaign = sorted(published.glob("*.nc")) if published else []
    extras = [link(p, p.name) for p in campaign]
    if (root / "manifest.json").is_file():
        extras.append(
            link(root / "manifest.json", "manifest.json (parameters, versions, checksums, timings)")
        )
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>LNSS workbook outputs: {html.escape(profile_name)}</title>"
        f"<style>{INDEX_STYLE}</style></head><body>"
        f"<h1>LNSS workbook outputs, profile {html.escape(profile_name)}</h1>"
        f"<p>Written {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}. Click a thumbnail for the "
        "interactive figure (works offline).</p>"
        + findings
        + f"<nav>Outputs by notebook: {contents}</nav>"
        + ("".join(sections) if sections else "<p>no figures or tables yet</p>")
        + "<h2>Campaign and manifest</h2>"
        + (
            "<ul>" + "".join(f"<li>{e}</li>" for e in extras) + "</ul>"
            if extras
            else "<p>none yet</p>"
        )
        + "</body></html>\n"
    )
    return write_text_atomic(root / "index.html", page)
