"""The layering of lnss_lib, read from the source: a module imports only its own layer or lower.

1 foundations (``config``, ``profile_rules``, ``dates``, ``sections``, ``setting_rule``, ``legacy_keys``, ``settings``, ``constants``, ``paper``, ``keys``, ``errors``, ``atomicio``, ``progress``, ``provenance``); 2 physics
kernels (every other top-level module: a new physics module is a kernel without editing this file; and the
``design_life/`` package, named in :data:`KERNEL_PACKAGES`); 3 the campaign
engine (``campaign/``); 4 presentation and studies (``outputs``, ``pipeline``, ``figures/``,
``studies/``, ``explorer``); 5 the command line and benchmarks (``__main__``, ``cli``, ``bench/``).
Every ``import`` counts, including those inside functions. Also: no import cycles, kernels stay free
of pandas/plotly/pymoo/Dask/papermill, only the top layer imports ``studies`` and ``figures``, figures
read only foundations and ``outputs``, and each module imports on its own in a fresh interpreter
(as skyfield's ``design/test_import_loops.py``).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

PACKAGE = "lnss_lib"
PACKAGE_DIR = Path(__file__).resolve().parents[1] / PACKAGE
FOUNDATIONS = {
    "config",
    "profile_rules",
    "dates",
    "sections",
    "setting_rule",
    "legacy_keys",
    "settings",
    "constants",
    "paper",
    "keys",
    "errors",
    "atomicio",
    "progress",
    "provenance",
}
CAMPAIGN = {"campaign"}
PRESENTATION = {"outputs", "pipeline", "findings", "figures", "studies", "explorer"}
TOP = {"__main__", "cli", "bench"}
KERNEL_PACKAGES = {"design_life"}  # layer-2 packages (a subject spread over several modules)
DESIGN_LIFE_MODULES = (
    "screen",
    "estimate",
    "manoeuvres",
    "mean_elements",
    "control",
    "service",
    "propagation",
    "closed_loop",
    "controllers",
    "fleet",
    "life_report",
    "life_estimate",
    "life_safety",
    "life_relative",
    "life_navigation",
    "evaluation",
    "frozen",
)
LAYER_NAMES = {
    1: "foundations",
    2: "kernels",
    3: "campaign",
    4: "presentation/studies",
    5: "command line/bench",
}
HEAVY_FOR_KERNELS = {"pandas", "plotly", "pymoo", "dask", "distributed", "papermill"}
FRONT_ENDS = {"studies", "figures"}  # imported only by the top layer (and notebooks, tests)
FRONT_END_CONSUMERS = TOP | {
    "explorer"
}  # explorer: notebook 09's widgets, a notebook in module form


def layer_of(module: str) -> int:
    """Layer of a dotted module name, from its first component under ``lnss_lib`` alone."""
    parts = module.split(".")
    if parts[0] != PACKAGE:
        raise ValueError(f"{module!r} is not in {PACKAGE}")
    if len(parts) == 1:
        return 1  # lnss_lib/__init__.py: metadata only
    top = parts[1]
    if top in FOUNDATIONS:
        return 1
    if top in CAMPAIGN:
        return 3
    if top in PRESENTATION:
        return 4
    if top in TOP:
        return 5
    return 2


def module_files(package_dir: Path = PACKAGE_DIR) -> dict[str, Path]:
    """Dotted name -> file of every module of the package (``__init__`` gives the package's name)."""
    modules = {}
    for path in sorted(package_dir.rglob("*.py")):
        relative = path.relative_to(package_dir.parent).with_suffix("")
        parts = list(relative.parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def imports_of(module: str, path: Path, known: set[str]) -> dict[str, set[str]]:
    """``{"internal": lnss_lib modules imported, "external": top-level third-party names}``, from every
    ``import`` statement in the file (inside functions and classes too)."""
    is_package = path.name == "__init__.py"
    package = module if is_package else module.rpartition(".")[0]
    internal, external = set(), set()

    def add(name: str) -> None:
        if name.split(".")[0] == PACKAGE:
            while name not in known and "." in name:  # an attribute imported from a module
                name = name.rpartition(".")[0]
            internal.add(name)
        else:
            external.add(name.split(".")[0])

    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            for alias in node.names:
                submodule = f"{target}.{alias.name}"
                add(submodule if submodule in known else target)
    internal.discard(module)
    return {"internal": internal, "external": external}


def import_graph(
    package_dir: Path = PACKAGE_DIR,
) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """(internal imports, third-party top-level imports) of every module."""
    files = module_files(package_dir)
    parsed = {m: imports_of(m, p, set(files)) for m, p in files.items()}
    return {m: d["internal"] for m, d in parsed.items()}, {
        m: d["external"] for m, d in parsed.items()
    }


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Imports from a higher layer, as readable lines."""
    return [
        f"{m} (layer {layer_of(m)}, {LAYER_NAMES[layer_of(m)]}) imports {t} (layer {layer_of(t)}, "
        f"{LAYER_NAMES[layer_of(t)]})"
        for m in sorted(graph)
        for t in sorted(graph[m])
        if layer_of(t) > layer_of(m)
    ]


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of two or more modules (Tarjan), each sorted."""
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                cycles.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(cycles)


def heavy_kernel_imports(external: dict[str, set[str]]) -> list[str]:
    """Foundations and kernels that import pandas, plotly, pymoo, Dask or papermill."""
    return [
        f"{m} (layer {layer_of(m)}) imports {', '.join(sorted(external[m] & HEAVY_FOR_KERNELS))}"
        for m in sorted(external)
        if layer_of(m) <= 2 and external[m] & HEAVY_FOR_KERNELS
    ]


def _top(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def front_end_imports(graph: dict[str, set[str]]) -> list[str]:
    """Modules other than the top layer that import ``studies`` or ``figures`` (each package may use itself)."""
    return [
        f"{m} imports {t}"
        for m in sorted(graph)
        for t in sorted(graph[m])
        if _top(t) in FRONT_ENDS and _top(m) != _top(t) and _top(m) not in FRONT_END_CONSUMERS
    ]


def figure_inputs(graph: dict[str, set[str]]) -> list[str]:
    """Figure modules that read anything but foundations, ``outputs`` and other figure modules."""
    return [
        f"{m} imports {t}"
        for m in sorted(graph)
        if _top(m) == "figures"
        for t in sorted(graph[m])
        if not (layer_of(t) == 1 or _top(t) in ("outputs", "figures"))
    ]


GRAPH, EXTERNAL = import_graph()


def test_every_module_is_seen_and_classified():
    assert {
        "lnss_lib.config",
        "lnss_lib.propagator",
        "lnss_lib.figures",
        "lnss_lib.figures.export",
        "lnss_lib.outputs",
        "lnss_lib.pipeline",
        "lnss_lib.__main__",
    } <= set(GRAPH)
    assert (
        layer_of("lnss_lib.design_life.closed_loop") == 2
        and layer_of("lnss_lib.campaign.runner") == 3
    )
    assert (
        layer_of("lnss_lib.design_life") == 2 and layer_of("lnss_lib.design_life.evaluation") == 2
    )
    assert {f"lnss_lib.design_life.{m}" for m in DESIGN_LIFE_MODULES} <= set(GRAPH)
    assert (
        "lnss_lib.design_life.secular" in GRAPH["lnss_lib.design_life.service"]
    )  # relative import in the package
    assert layer_of("lnss_lib.figures.dop") == 4 and layer_of("lnss_lib.bench.dop") == 5
    assert "lnss_lib.outputs" in GRAPH["lnss_lib.figures.export"]  # relative import two levels up
    assert "lnss_lib.figures.charts" in GRAPH["lnss_lib.figures.dop"]
    assert "lnss_lib.ephemeris" in GRAPH["lnss_lib.outputs"]  # an import inside a function


def test_every_subpackage_is_named_in_its_layer():
    """A new top-level module is a kernel by default; a new subpackage must be placed in a layer by name."""
    subpackages = {m.split(".")[1] for m in GRAPH if m.count(".") >= 2}
    assert subpackages - (CAMPAIGN | PRESENTATION | TOP | KERNEL_PACKAGES) == set()
    assert KERNEL_PACKAGES <= subpackages


def test_no_module_imports_a_higher_layer():
    assert upward_imports(GRAPH) == []


def test_no_import_cycles():
    assert import_cycles(GRAPH) == []


def test_kernels_import_no_dataframe_plotting_optimiser_or_cluster_library():
    assert heavy_kernel_imports(EXTERNAL) == []


def test_only_the_top_layer_imports_studies_and_figures():
    assert front_end_imports(GRAPH) == []


def test_figures_read_only_foundations_and_outputs():
    assert figure_inputs(GRAPH) == []


def test_checks_catch_synthetic_violations(tmp_path):
    graph = {
        "lnss_lib.gps": {"lnss_lib.config", "lnss_lib.campaign.grid"},  # kernel -> campaign: upward
        "lnss_lib.campaign.grid": {
            "lnss_lib.gps",
            "lnss_lib.outputs",
        },  # cycle; campaign -> outputs
        "lnss_lib.outputs": {"lnss_lib.figures"},  # outputs -> figures
        "lnss_lib.figures": {"lnss_lib.dop", "lnss_lib.figures.charts"},  # figures read a kernel
        "lnss_lib.figures.charts": set(),
        "lnss_lib.config": set(),
        "lnss_lib.dop": set(),
        "lnss_lib.studies.dop": {"lnss_lib.figures.charts"},
        "lnss_lib.__main__": {"lnss_lib.studies.dop"},
    }
    assert upward_imports(graph) == [
        "lnss_lib.campaign.grid (layer 3, campaign) imports lnss_lib.outputs (layer 4, presentation/studies)",
        "lnss_lib.gps (layer 2, kernels) imports lnss_lib.campaign.grid (layer 3, campaign)",
    ]
    assert import_cycles(graph) == [["lnss_lib.campaign.grid", "lnss_lib.gps"]]
    assert import_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert front_end_imports(graph) == [
        "lnss_lib.outputs imports lnss_lib.figures",
        "lnss_lib.studies.dop imports lnss_lib.figures.charts",
    ]
    assert figure_inputs(graph) == ["lnss_lib.figures imports lnss_lib.dop"]
    assert heavy_kernel_imports(
        {"lnss_lib.dop": {"numpy", "pandas"}, "lnss_lib.outputs": {"pandas"}}
    ) == ["lnss_lib.dop (layer 2) imports pandas"]
    # the parser on a synthetic package: function-level, relative, absolute and attribute imports
    root = tmp_path / "lnss_lib"
    (root / "figures").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "config.py").write_text("")
    (root / "gps.py").write_text(
        "import numpy as np\n\ndef f():\n    from .figures import charts\n"
        "    import pandas.io\n    from lnss_lib.config import PARAMS_DIR\n"
    )
    (root / "figures" / "__init__.py").write_text("from .charts import line\n")
    (root / "figures" / "charts.py").write_text("from .. import gps\nfrom ..config import X\n")
    graph, external = import_graph(root)
    assert graph["lnss_lib.gps"] == {"lnss_lib.figures.charts", "lnss_lib.config"}
    assert external["lnss_lib.gps"] == {"numpy", "pandas"}
    assert graph["lnss_lib.figures.charts"] == {"lnss_lib.gps", "lnss_lib.config"}
    assert graph["lnss_lib.figures"] == {"lnss_lib.figures.charts"}
    assert import_cycles(graph) == [["lnss_lib.figures.charts", "lnss_lib.gps"]]
    assert upward_imports(graph) == [
        "lnss_lib.gps (layer 2, kernels) imports lnss_lib.figures.charts (layer 4, presentation/studies)"
    ]


# Third-party libraries are loaded once in a parent interpreter that then forks one child per module:
# each child starts with no lnss_lib module imported (a fresh interpreter for the package, which is what
# import-order bugs need), without paying numba's, xarray's, scipy's and plotly's start-up per module (with
# scipy's optimize, integrate, interpolate and stats imported in each child, the 136 children took 54 CPU s
# on a loaded two-core machine; loaded here first, 31).
_FORK_IMPORTS = """
import importlib, os, sys
for name in ("numpy", "scipy", "scipy.integrate", "scipy.interpolate", "scipy.optimize", "scipy.stats", "numba",
             "xarray", "pandas", "spiceypy", "sgp4.api", "sgp4.io", "h5netcdf", "plotly.graph_objects", "plotly.io",
             "plotly.subplots", "pymoo.core.problem", "pymoo.algorithms.moo.nsga2", "dask", "distributed",
             "dask.distributed", "papermill", "tqdm", "ipywidgets", "kaleido"):
    try:
        importlib.import_module(name)
    except ImportError:
        pass
assert not any(m == "lnss_lib" or m.startswith("lnss_lib.") for m in sys.modules)
running = {}
def reap():
    pid, status = os.wait()
    module = running.pop(pid)
    if status != 0:
        print(f"{module}: exit status {status}", flush=True)
for module in sys.argv[1:]:
    if len(running) >= 4:
        reap()
    pid = os.fork()
    if pid == 0:
        try:
            importlib.import_module(module)
        except BaseException as error:
            print(f"{module}: {type(error).__name__}: {error}", flush=True)
            os._exit(1)
        os._exit(0)
    running[pid] = module
while running:
    reap()
"""


def test_each_module_imports_in_a_fresh_interpreter():
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(PACKAGE_DIR.parent), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [sys.executable, "-c", _FORK_IMPORTS, *sorted(GRAPH)],
        capture_output=True,
        text=True,
        timeout=900,  # a guard against a hang: seconds on a quiet machine, minutes under load
        cwd=PACKAGE_DIR.parent,
        env=env,
    )
    failures = [line for line in done.stdout.splitlines() if line.strip()]
    assert done.returncode == 0 and failures == [], (failures, done.stderr[-2000:])
