"""The test session's notebooks: `python -m pytest` runs every notebook in notebooks/ through nbval (lax mode,
`pyproject.toml`) under the `ci` profile, before the tests, and records which ran and which failed;
tests/test_notebooks.py checks what they wrote (its docstring says why nbval runs them, not papermill)."""

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

NOTEBOOK_PROFILE = "ci"
NOTEBOOK_GROUP = "notebooks"
ROOT = Path(__file__).resolve().parent
_FAILED_CELLS: dict[Path, list[str]] = {}
_STARTED = pytest.StashKey[float]()

PROPAGATE_TWO_DESIGNS = """
import hashlib, json, sys
import numba
from lnss_lib.constellation import WalkerDesign
from lnss_lib.propagator import integrate_many, propagate_elements
from lnss_lib.settings import load_settings
paper = load_settings("paper")
digests = []
for design in (WalkerDesign(2100.0, 0.1, 10.0, 30.0, 2, 2), WalkerDesign(7500.0, 0.71, 136.0, 90.0, 3, 4)):
    ds = propagate_elements(paper.dynamics, paper.epoch, design.elements_deg(), batch=True)
    digests.append(hashlib.sha256(ds["r_mci_km"].values.tobytes()).hexdigest())
kernels = {id(k): k for name, module in list(sys.modules.items()) if name.startswith("lnss_lib")
           for k in vars(module).values() if isinstance(k, numba.core.registry.CPUDispatcher)}.values()
print(json.dumps({
    "digests": digests,
    "loaded": sum(sum(k.stats.cache_hits.values()) for k in kernels),
    "compiled": sum(sum(k.stats.cache_misses.values()) for k in kernels),
    "propagator_loaded": sum(integrate_many.stats.cache_hits.values()),
}))
"""
"""Sixteen satellites (two Table 3 designs, where fastmath once showed) propagated over the paper profile's epoch;
prints the digests of their positions and how many kernels this process took from numba's cache (``loaded``) and
compiled (``compiled``): on an empty cache it compiles the propagator from source, on a filled one it loads it."""

KERNEL_WARM_UP = (
    "from lnss_lib.evaluator import context_for, evaluate_design\n"
    "from lnss_lib.settings import load_settings\n"
    "evaluate_design(context_for(load_settings('ci')), 6143.0, 0.6, 90.0, 51.7, 2, 2)\n",
    "from lnss_lib.design_life.closed_loop import simulate_life\n"
    "from lnss_lib.design_life.screen import screen_elements\n"
    "from lnss_lib.ephemeris import ensure_kernels, tdb_seconds\n"
    "from lnss_lib.settings import load_settings\n"
    "s = load_settings('ci_operational')\n"
    "ensure_kernels(s.ephemeris)\n"
    "elfo = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]]\n"
    "screen_elements(s.stability, s.dynamics, s.epoch, elfo)\n"
    "t0 = tdb_seconds(s.epoch.start_tdb, 'TDB')\n"
    "simulate_life(s.design_life, s.dynamics, elfo, t0, stability=s.stability, dop=s.dop, life_days=2.0)\n",
)
"""What compiles the other kernels most tests and notebooks share, once the propagator is in the cache, in two
processes side by side: a design's evaluation (DOP grid, GPS link, Delta-V) and the design life's (stability screen,
closed loop)."""
FRESH_COMPILE_ENV = "LNSS_TEST_FRESH_COMPILE"


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


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist starts its workers
def pytest_sessionstart(session):
    session.config.stash[_STARTED] = time.time()
    _warm_kernels(session.config)


def propagate_two_designs(cache_parent: str | None = None) -> dict:
    """:data:`PROPAGATE_TWO_DESIGNS` in a fresh interpreter, on numba's cache under ``cache_parent`` (default: this
    session's, :func:`lnss_lib.kernel_cache_dir`); its record, with ``cache_parent``."""
    env = {**os.environ}
    if cache_parent is not None:
        env["LNSS_NUMBA_CACHE_PARENT"] = cache_parent
    run = subprocess.run(
        [sys.executable, "-c", PROPAGATE_TWO_DESIGNS],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,  # a guard against a hang: a minute on a quiet machine, minutes under load
    )
    assert run.returncode == 0, run.stderr[-2000:]
    return {
        **json.loads(run.stdout.splitlines()[-1]),
        "cache_parent": env["LNSS_NUMBA_CACHE_PARENT"],
    }


def _warm_kernels(config) -> None:
    """For the whole suite (``python -m pytest``: pyproject.toml's ``testpaths``), before any test or notebook and
    before the pytest-xdist workers start: fill numba's cache (one folder per source state, which every process of
    the session shares), so that the workers, the notebook kernels and their Dask workers load the kernels instead
    of each compiling them, two or three at a time. First :data:`PROPAGATE_TWO_DESIGNS` alone (the propagator, the
    longest compile; its record, in ``LNSS_TEST_FRESH_COMPILE``, is the fresh compile ``fresh_compile`` gives when
    it found the cache empty), then :data:`KERNEL_WARM_UP`'s two processes side by side. Checks nothing (the tests
    check what the kernels compute); a warm-up that fails says so in one line and the session goes on. A run of a
    few files (or a selection, ``-k``, ``-m``) compiles what it uses as it goes."""
    whole_suite = (
        config.args_source == pytest.Config.ArgsSource.TESTPATHS
        and not config.option.keyword
        and not config.option.markexpr
    )
    if hasattr(config, "workerinput") or config.option.collectonly or not whole_suite:
        return
    say = config.get_terminal_writer().line
    try:
        os.environ[FRESH_COMPILE_ENV] = json.dumps(propagate_two_designs())
    except (AssertionError, subprocess.TimeoutExpired, ValueError) as error:
        say(f"kernel warm-up (propagator) failed: {str(error).strip().splitlines()[-1:]}")
        return
    children = [
        subprocess.Popen(
            [sys.executable, "-c", code],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for code in KERNEL_WARM_UP
    ]
    for child in children:
        error = child.communicate()[1].strip()
        if child.returncode:
            say(f"kernel warm-up exited {child.returncode}: {error.splitlines()[-1:]}")


@dataclass
class FreshCompile:
    """:data:`PROPAGATE_TWO_DESIGNS`'s record from a process that compiled every kernel it ran from source, and the
    cache that compile filled."""

    record: dict

    def loaded(self) -> dict:
        """The record of a second process on the same cache."""
        return propagate_two_designs(self.record["cache_parent"])


@pytest.fixture(scope="session")
def fresh_compile(tmp_path_factory) -> FreshCompile:
    """The whole suite's warm-up when it found the cache empty (it compiled every kernel it ran), else a run here
    on a cache folder of its own (a run of a few files, a second run of the suite)."""
    record = json.loads(os.environ.get(FRESH_COMPILE_ENV, "{}"))
    if not record.get("compiled") or record.get("loaded"):
        record = propagate_two_designs(str(tmp_path_factory.mktemp("numba")))
    return FreshCompile(record)


def _reads_notebook_outputs(item) -> bool:
    """A notebook cell, or a test that reads what this session's notebooks wrote (fixture ``notebook_runs`` or
    marker ``notebook_outputs``)."""
    return (
        _notebook_cell(item)
        or "notebook_runs" in getattr(item, "fixturenames", ())
        or item.get_closest_marker("notebook_outputs") is not None
    )


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(items):
    """Notebook cells first (in their order), then the tests: the notebooks' output checks read what they wrote.
    Under pytest-xdist (``--dist loadgroup``, pyproject.toml) the cells and the tests that read their outputs are
    one group, :data:`NOTEBOOK_GROUP`, which one worker runs in this order; the other tests share the workers."""
    items.sort(key=lambda item: not _notebook_cell(item))
    for item in items:
        if _reads_notebook_outputs(item):
            item.add_marker(pytest.mark.xdist_group(NOTEBOOK_GROUP))


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
