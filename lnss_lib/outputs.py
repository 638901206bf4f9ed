"""Outputs of a run: the folders under ``outputs/<profile>/``, table and caption writers, and the manifest.

Figures (:mod:`lnss_lib.figures`) and notebooks write through :func:`output_dir`,
:func:`write_caption` and :func:`save_table`; :mod:`lnss_lib.pipeline` reads the captions back for
the index and calls :func:`write_manifest` after a run.
"""

from __future__ import annotations

import functools
import hashlib
import json
import platform
import time
from pathlib import Path

from .atomicio import atomic_path, write_bytes_atomic, write_text_atomic
from .config import OUTPUTS_DIR, PARAMS_DIR, PROJECT_DIR
from .keys import LABELS, format_value, label
from .provenance import MANIFEST_PACKAGES, git_revision, package_versions
from .settings import load_settings

__all__ = [
    "output_dir",
    "profile_dir",
    "display_path",
    "display_table",
    "quantity_table",
    "reader_html",
    "use_reader_tables",
    "notebook_shell",
    "write_text_atomic",
    "write_bytes_atomic",
    "atomic_path",
    "write_caption",
    "read_caption",
    "markdown_table",
    "save_table",
    "data_checksums",
    "package_versions",
    "git_revision",
    "write_manifest",
    "CAPTION_SUFFIX",
    "OUTPUT_KINDS",
    "MANIFEST_PACKAGES",
]

OUTPUT_KINDS = ("notebooks", "figures", "tables", "data", "campaign")
CAPTION_SUFFIX = ".meta.json"


def profile_dir(profile_name: str) -> Path:
    """``outputs/<profile>/`` (not created)."""
    return OUTPUTS_DIR / profile_name


def display_path(path) -> str:
    """``path`` as a record shows it: relative to the workbook folder (``outputs/quick/campaign``), never the
    machine's absolute prefix; a path outside the workbook by its name alone."""
    path = Path(path).resolve()
    try:
        return path.relative_to(PROJECT_DIR.resolve()).as_posix()
    except ValueError:
        return path.name


def display_table(frame, columns=None):
    """A copy of ``frame`` (its ``columns``) for a notebook's display: headers, index names and row keys by their
    labels with units, each number in the format of its quantity (:func:`lnss_lib.keys.format_value`), NaN as
    ``-``."""
    shown = frame[list(columns)] if columns is not None else frame
    table = shown.apply(lambda col: col.map(lambda v: format_value(str(col.name), v)))
    table = table.rename(
        columns=lambda c: label(str(c)), index=lambda r: label(r) if isinstance(r, str) else r
    )
    table.index = table.index.set_names(
        [None if n is None else label(str(n)) for n in table.index.names]
    )
    table.columns = table.columns.set_names(
        [None if n is None else label(str(n)) for n in table.columns.names]
    )
    return table


def quantity_table(values):
    """Keyed results (a mapping: key -> number, text, list or mapping) as a table for people: one row per key, a
    mapping one row per entry ("key: entry"), with the key's label (:func:`~lnss_lib.keys.label`; a key without
    one in words) and the value in its quantity's format (a list: its values joined); None as ``-``."""
    import pandas as pd

    def words(key: str) -> str:
        return label(key) if key in LABELS or label(key) != key else key.replace("_", " ")

    def text(key: str, value) -> str:
        if value is None:
            return "-"
        if isinstance(value, (list, tuple)):
            return ", ".join(format_value(key, v) for v in value)
        return format_value(key, value)

    rows = []
    for key, value in values.items():
        if isinstance(value, dict):
            rows += [
                {"quantity": f"{words(key)}: {str(entry).replace('_', ' ')}", "value": text(key, v)}
                for entry, v in value.items()
            ]
        else:
            rows.append({"quantity": words(key), "value": text(key, value)})
    return pd.DataFrame(rows, columns=["quantity", "value"])


def reader_html(frame) -> str:
    """A DataFrame as a notebook shows it to people: :func:`display_table` (labelled headers, each number in its
    quantity's format) over the first ``display.max_rows`` rows; pandas' own HTML when the frame cannot be
    labelled (duplicate columns, say)."""
    import pandas as pd

    max_rows = pd.get_option("display.max_rows") or len(frame)
    shown = frame.head(max_rows)
    note = "" if len(shown) == len(frame) else f"<p>first {max_rows} of {len(frame)} rows</p>"
    try:
        return display_table(shown).to_html(notebook=True) + note
    except (ValueError, TypeError):
        return shown.to_html(notebook=True) + note


def notebook_shell():
    """The IPython shell of the notebook kernel this code runs in, or None (a plain interpreter, a terminal IPython)."""
    try:
        from IPython import get_ipython
    except ImportError:
        return None
    shell = get_ipython()
    return shell if shell is not None and hasattr(shell, "kernel") else None


def use_reader_tables() -> bool:
    """In a notebook kernel, show every DataFrame through :func:`reader_html`; True if it did."""
    shell = notebook_shell()
    if shell is None:
        return False
    import pandas as pd

    shell.display_formatter.formatters["text/html"].for_type(pd.DataFrame, reader_html)
    return True


def output_dir(profile_name: str, kind: str) -> Path:
    """``outputs/<profile>/<kind>/`` (created): kind is notebooks, figures, tables, data or campaign."""
    if kind not in OUTPUT_KINDS:
        raise ValueError(f"unknown output kind {kind!r}; allowed: {', '.join(OUTPUT_KINDS)}")
    folder = profile_dir(profile_name) / kind
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def write_caption(folder: Path, name: str, caption: str, files: list[Path]) -> Path:
    """Sidecar ``<folder>/<name>.meta.json`` holding the one-line caption of a figure or table and its files."""
    path = folder / f"{name}{CAPTION_SUFFIX}"
    write_text_atomic(
        path,
        json.dumps(
            {
                "name": name,
                "caption": " ".join(str(caption).split()),
                "files": [p.name for p in files],
            },
            indent=1,
        ),
    )
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

    Headers that are workbook keys show their label with unit (:data:`lnss_lib.keys.LABELS`); numbers in
    the format of their column's quantity (:func:`lnss_lib.keys.format_value`: km as integers, DOP to 2
    decimals, Delta-V to 3), other floats with ``digits`` significant digits; NaN and None as empty cells.
    """
    import numbers

    import pandas as pd

    def cell(value, column) -> str:
        if value is None or (isinstance(value, float) and value != value):
            return ""
        if isinstance(value, (bool,)) or not isinstance(value, numbers.Real):
            return str(value).replace("|", "\\|").replace("\n", " ")
        if isinstance(value, numbers.Integral):
            return str(int(value))
        if str(column) in LABELS:
            return format_value(str(column), value)
        return f"{float(value):.{digits}g}"

    show_index = not isinstance(frame.index, pd.RangeIndex)
    columns = ([frame.index.name] if show_index else []) + list(frame.columns)
    header = [label(str(c)) if c is not None else "" for c in columns]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for index, row in zip(frame.index, frame.itertuples(index=False)):
        cells = ([cell(index, frame.index.name)] if show_index else []) + [
            cell(v, c) for v, c in zip(row, frame.columns)
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def save_table(
    frame, profile_name: str, name: str, caption: str, *, digits: int = 4
) -> dict[str, Path]:
    """Write ``outputs/<profile>/tables/<name>.csv`` and ``.md`` (with the caption above the table)
    and the caption sidecar used by :func:`lnss_lib.pipeline.write_index`; return the written paths."""
    folder = output_dir(profile_name, "tables")
    written = {"csv": folder / f"{name}.csv", "md": folder / f"{name}.md"}
    write_text_atomic(written["csv"], frame.to_csv(index=not _plain_index(frame)))
    write_text_atomic(
        written["md"], f"{' '.join(caption.split())}\n\n{markdown_table(frame, digits)}"
    )
    written["meta"] = write_caption(folder, name, caption, [written["csv"], written["md"]])
    return written


def _plain_index(frame) -> bool:
    import pandas as pd

    return isinstance(frame.index, pd.RangeIndex)


def data_checksums() -> dict[str, str]:
    """SHA-256 of every data file in ``params/data`` and of the planetary SPK."""
    from .ephemeris import file_sha256, planetary_spk_path

    sums = {
        str(p.relative_to(PARAMS_DIR)): file_sha256(p)
        for p in sorted((PARAMS_DIR / "data").rglob("*"))
        if p.is_file() and p.name not in ("README.md", "SHA256SUMS")
    }
    sums["skyfield-data:de421.bsp"] = file_sha256(planetary_spk_path())
    return sums


@functools.lru_cache(maxsize=1)
def code_and_data_digest() -> str:
    """Digest (16 hex) of every ``lnss_lib`` source file, every data file (:func:`data_checksums`) and the processor
    model the kernels are compiled for (:func:`lnss_lib.kernel_cpu`, which fixes their round-off): what a cached
    result was computed with, besides its settings (computed once a process)."""
    from . import kernel_cpu, source_digest

    text = json.dumps(
        [source_digest(Path(__file__).resolve().parent), data_checksums(), kernel_cpu()],
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _json_ready(value):
    """numpy scalars as Python numbers, for ``json.dumps``."""
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"not JSON-ready: {value!r} ({type(value).__name__})")


def cached_json(cache_dir: Path | None, name: str, key, compute) -> tuple:
    """``(compute(), False)``, the result kept in ``cache_dir/<name>_<digest>.json``, or ``(kept result, True)`` when
    that file exists: the digest covers ``key`` (the inputs: settings hash, design, life, ...) and
    :func:`code_and_data_digest`, so a change of code, data or inputs computes afresh; a file that does not parse is
    computed again. ``cache_dir`` None: no cache. The result must be JSON-ready (numpy scalars are converted)."""
    if cache_dir is None:
        return compute(), False
    digest = hashlib.sha256(
        json.dumps([key, code_and_data_digest()], sort_keys=True, default=_json_ready).encode()
    ).hexdigest()[:16]
    path = Path(cache_dir) / f"{name}_{digest}.json"
    if path.is_file():
        try:
            return json.loads(path.read_text()), True
        except ValueError:
            pass
    result = compute()
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(result, default=_json_ready))
    return result, False


def write_manifest(profile_name: str, runs: dict[str, dict]) -> Path:
    """Write ``outputs/<profile>/manifest.json``: parameters, versions, data checksums, notebook runs."""
    profile = load_settings(profile_name)
    path = profile_dir(profile_name) / "manifest.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(path.read_text()).get("notebooks", {}) if path.is_file() else {}
    manifest = {
        "profile": profile_name,
        "profile_hash": profile.hash,
        "parameters": profile.as_dict(),
        "git_revision": git_revision(),
        "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "platform": platform.platform(),
        "packages": package_versions(),
        "data_sha256": data_checksums(),
        "notebooks": {**previous, **runs},
    }
    write_text_atomic(path, json.dumps(manifest, indent=2, default=str))
    return path
