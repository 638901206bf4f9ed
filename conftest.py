"""The test session's notebooks: `python -m pytest` runs every notebook in notebooks/ through nbval (lax mode,
`pyproject.toml`) under the `ci` profile, before the tests, and records which ran and which failed;
tests/test_notebooks.py checks what they wrote (its docstring says why nbval runs them, not papermill)."""

import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

NOTEBOOK_PROFILE = "ci"
ROOT = Path(__file__).resolve().parent
_FAILED_CELLS: dict[Path, list[str]] = {}
_STARTED = pytest.StashKey[float]()


def _notebook_cell(item) -> bool:
    return item.path.suffix == ".ipynb"


def pytest_configure(config):
    """Notebook kernels (nbval, papermill) import lnss_lib from this checkout and run under the ci profile; an
    nbval cell may take as long as the profile gives a papermill cell (unless --nbval-cell-timeout says)."""
    from lnss_lib.pipeline import kernel_environment
    from lnss_lib.settings import load_settings

    kernel_environment(NOTEBOOK_PROFILE)
    if hasattr(config.option, "nbval_cell_timeout") and not any(
        arg.startswith("--nbval-cell-timeout") for arg in config.invocation_params.args
    ):
        config.option.nbval_cell_timeout = float(
            load_settings(NOTEBOOK_PROFILE).notebooks.timeout_s
        )


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    session.config.stash[_STARTED] = time.time()


def pytest_collection_modifyitems(items):
    """Notebook cells first (in their order), then the tests: the notebooks' output checks read what they wrote."""
    items.sort(key=lambda item: not _notebook_cell(item))


def pytest_runtest_logreport(report):
    if report.failed and ".ipynb::" in report.nodeid:
        path, cell = report.nodeid.split("::", 1)
        _FAILED_CELLS.setdefault((ROOT / path).resolve(), []).append(cell)


@dataclass
class NotebookRuns:
    """Which notebooks ran in this session, how (``nbval`` or ``papermill``), and the failed cells of each."""

    profile: str
    started: float
    runner: dict[Path, str] = field(default_factory=dict)
    failed: dict[Path, list[str]] = field(default_factory=dict)


@pytest.fixture(scope="session")
def notebook_runs(request) -> NotebookRuns:
    """Every notebook run once in this session: by nbval when the session collected all its code cells (they
    ran first), otherwise by ``reproduce`` (papermill) here, e.g. for ``pytest tests/test_notebooks.py``."""
    import json

    import nbformat

    from lnss_lib.config import OUTPUTS_DIR
    from lnss_lib.pipeline import notebook_paths, reproduce

    collected: dict[Path, int] = {}
    for item in request.session.items:
        if _notebook_cell(item):
            collected[item.path.resolve()] = collected.get(item.path.resolve(), 0) + 1
    runs = NotebookRuns(NOTEBOOK_PROFILE, request.config.stash[_STARTED])
    missing = []
    for book in notebook_paths():
        n_code = sum(cell.cell_type == "code" for cell in nbformat.read(book, as_version=4).cells)
        if collected.get(book.resolve()) == n_code:
            runs.runner[book], runs.failed[book] = "nbval", _FAILED_CELLS.get(book.resolve(), [])
        else:
            missing.append(book)
    if missing:
        reproduce(NOTEBOOK_PROFILE, only=[book.stem for book in missing])
        ran = json.loads((OUTPUTS_DIR / NOTEBOOK_PROFILE / "manifest.json").read_text())[
            "notebooks"
        ]
        for book in missing:
            run = ran.get(book.stem, {"status": "not run (an earlier notebook failed)"})
            runs.runner[book] = "papermill"
            runs.failed[book] = [] if run["status"] == "ok" else [run.get("error", run["status"])]
    return runs
