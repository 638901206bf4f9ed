"""Regression pins for refactors that must not change any result.

What is pinned (the recorded values live in ``tests/data/pinned_results.json``):

1. ``python -m lnss_lib evaluate --profile paper --json`` for the Table 4 standalone ELFO (``[standalone_elfo]``
   of params/paper.toml: a 6143 km, e 0.6, AOP 90 deg, i 51.7 deg, 2 planes (RAAN 0 and 180 deg by eq. 42) x 8),
   without and with ``--design-life-days 60``; run in-process through :func:`lnss_lib.__main__.main` (the
   command's own code path: argument parsing, ``lnss_lib.cli.evaluate.run``, ``json.dumps``), stdout parsed back.
2. The quick profile's campaign, generations 1-2 (``campaign --profile quick --max-generations 2 --workers 0``,
   in-process through :func:`lnss_lib.campaign.run_campaign`): every journal record (design key, physical
   design, metrics, flags), each evaluated design's objectives F and constraints G as the campaign's pymoo
   problem computes them, the population NSGA-II keeps after each generation (X, F, G), and the data of
   evaluations.nc, front.nc and history.nc.
3. 50 designs drawn with a fixed seed from the paper profile's Table 3 grid (``[campaign.variables]``),
   evaluated as the campaign evaluates them (``evaluation_profile`` and the serial backend, i.e.
   :func:`lnss_lib.campaign.tasks.evaluate_task`), metrics, objectives and constraints.

Fields left out of the comparison, each run-dependent (see :data:`EXCLUDED`): timings (``wall_s``,
``task_wall_s``, ``timing_s``, history's ``time_*_s``, ``designs_per_s``), the worker's ``host:pid``, the
journal line checksum ``crc32`` (it covers the timings), and of the NetCDF attributes the package
``versions``, the ``evaluation_hash`` and the ``parameters`` echo of the profile (inputs, not results: a refactor
may change how settings are hashed and serialised).

Regenerate (only when a change of results is intended and explained in its commit)::

    PYTHONPATH=$PWD python tests/pinned_results.py --write

Each processor model the kernels are compiled for (:func:`lnss_lib.kernel_cpu`) has its own record,
``tests/data/pinned_results/<model>.json`` (``:`` written ``-``): the gravity kernels' bits follow the model, and the
adaptive step control amplifies that round-off beyond the pins' tolerance. ``--write`` records this machine's model
only (the others' records are kept), with the commit it was made on (and whether lnss_lib/ or params/ had
uncommitted edits) in the file's ``meta``. ``tests/test_pinned_results.py`` compares a result with its model's record
within :data:`RTOL` and with every other model's within the cross-model tolerance (:func:`cross_model_rtol`), derived
from the recorded models' own differences; on a model without a record only the latter, so every host checks.
When a stated change moves a pin, the models that can run it re-record it and the others' records drop it; it is
then checked there against the models that hold it (:func:`pin_cross_model_rtol`). Dropped so: the Intel
(``skylake-avx512``) record of ``evaluate_table4_life60``, whose screen perilune moved with the one stability screen.
``python tests/pinned_results.py`` (no ``--write``) recomputes and prints the differences without writing;
``--only NAME`` picks pins and ``--set SECTION.KEY=VALUE`` recomputes under a changed setting (a scratch check
that a pin notices a change; never recorded).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from lnss_lib import kernel_cpu

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = (
    ROOT / "tests" / "data" / "pinned_results"
)  # one record per processor model: <model>.json

TABLE4_ARGV = [
    "evaluate",
    "--profile",
    "paper",
    "--json",
    "--sma-km",
    "6143",
    "--ecc",
    "0.6",
    "--aop-deg",
    "90",
    "--inc-deg",
    "51.7",
    "--planes",
    "2",
    "--sats-per-plane",
    "8",
]
LIFE_DAYS = "60"
CAMPAIGN_PROFILE, CAMPAIGN_GENERATIONS = "quick", 2
RANDOM_PROFILE, RANDOM_SEED, RANDOM_N = "paper", 20250522, 50

RTOL = {
    "evaluate_table4": 1e-12,
    "evaluate_table4_life60": 1e-12,
    "campaign_quick_2gen": 1e-12,
    "random_paper_designs": 1e-9,
}
# The cross-model tolerance of a pin: this factor times the largest relative difference between two models' records
# of it, rounded up to a power of ten (room for a model whose round-off lies beyond both recorded ones).
CROSS_MODEL_FACTOR = 10.0

# Every field left out of the comparison, with the reason (keys are dict keys at any depth of a pin).
EXCLUDED = {
    "wall_s": "wall-clock time of an evaluation or a generation (run-dependent)",
    "task_wall_s": "wall-clock time of a campaign task (run-dependent)",
    "timing_s": "per-stage timings of an evaluation (run-dependent)",
    "worker": "host:pid of the process that evaluated the design (run-dependent)",
    "crc32": "journal line checksum; it covers the timings above (run-dependent)",
    "kernel_cpu": "journal record: the processor model of the kernels (the record's meta names it)",
    "designs_per_s": "history: evaluation rate (timing)",
    "time_campaign_s": "history: timing",
    "time_deltav_s": "history: timing",
    "time_dop_s": "history: timing",
    "time_gps_s": "history: timing",
    "time_operational_s": "history: timing",
    "time_overhead_s": "history: timing",
    "time_propagation_s": "history: timing",
    "versions": "NetCDF attribute: installed package versions",
    "evaluation_hash": "NetCDF attribute / journal header: hash of the settings (a refactor may change the hashing)",
    "parameters": "NetCDF attribute: echo of the profile (input, not a result; a refactor may change its serialisation)",
}


def _clean(value):
    """JSON-ready plain Python (numpy scalars/arrays -> float/int/bool/list); excluded keys dropped."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items() if k not in EXCLUDED}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_clean(v) for v in value.tolist()]
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.str_):
        return str(value)
    return value


# ---------------------------------------------------------------- the pins' computations


def evaluate_json(extra_argv=(), overrides=()) -> dict:
    """``python -m lnss_lib evaluate ... --json`` for the Table 4 ELFO, in-process; ``overrides`` are ``--set`` texts."""
    from lnss_lib.__main__ import main

    argv = TABLE4_ARGV + list(extra_argv) + [a for text in overrides for a in ("--set", text)]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    if code != 0:
        raise RuntimeError(f"evaluate exited {code}: {err.getvalue()}")
    return _clean(json.loads(out.getvalue()))


def _problem_fg(settings, records: list[dict], keys: list[tuple]) -> tuple[np.ndarray, np.ndarray]:
    """Objectives F and constraints G of the designs ``keys`` as the campaign's pymoo problem computes them."""
    from lnss_lib.campaign.fitness import metric_columns
    from lnss_lib.campaign.problem import WalkerDesignProblem

    by_key = {tuple(r["key"]): r for r in records}
    problem = WalkerDesignProblem(
        settings,
        lambda x: metric_columns(
            [by_key[tuple(int(v) for v in row)] for row in np.rint(x)], settings.extra_metrics
        ),
    )
    out = problem.evaluate(np.array(keys), return_as_dictionary=True)
    g = out.get("G")
    return out["F"], (g if g is not None else np.zeros((len(keys), 0)))


def _netcdf(path: Path) -> dict:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return {
            "attrs": {k: v for k, v in ds.attrs.items()},
            "variables": {name: ds[name].values for name in ds.variables},
        }


def campaign_pin(overrides: dict | None = None) -> dict:
    """The quick campaign's generations 1-2 in a temporary run folder, serial, no progress bars."""
    from lnss_lib.campaign import run_campaign
    from lnss_lib.campaign.callbacks import Callback
    from lnss_lib.campaign.journal import read_cache_records
    from lnss_lib.campaign.settings import CampaignPlan
    from lnss_lib.settings import load_settings

    populations = []

    class KeptPopulation(Callback):
        def on_generation_end(self, state):
            pop = state.algorithm.pop
            populations.append(
                {
                    "generation": state.generation,
                    "X": pop.get("X"),
                    "F": pop.get("F"),
                    "G": pop.get("G"),
                }
            )

    settings = CampaignPlan.of(load_settings(CAMPAIGN_PROFILE, overrides=overrides))
    with tempfile.TemporaryDirectory(prefix="lnss_pin_campaign_") as tmp:
        run_dir = Path(tmp) / "run"
        result = run_campaign(
            CAMPAIGN_PROFILE,
            overrides=overrides,
            workers=0,
            run_dir=run_dir,
            progress=False,
            max_generations=CAMPAIGN_GENERATIONS,
            callbacks=[KeptPopulation()],
        )
        records = sorted(read_cache_records(run_dir), key=lambda r: (r["generation"], r["order"]))
        files = {
            name: _netcdf(run_dir / f"{name}.nc") for name in ("evaluations", "front", "history")
        }
    keys = [tuple(r["key"]) for r in records]
    f, g = _problem_fg(settings, records, keys)
    designs = settings.grid.designs(np.array(keys))
    evaluations = [
        {**r, "design": d, "objectives": fi, "constraints": gi}
        for r, d, fi, gi in zip(records, designs, f, g)
    ]
    return _clean(
        {
            "generations": result.generations,
            "n_evaluations": result.n_evaluations,
            "n_feasible": result.n_feasible,
            "evaluations": evaluations,
            "populations": populations,
            **files,
        }
    )


def random_designs_pin(overrides: dict | None = None) -> dict:
    """``RANDOM_N`` designs drawn with ``RANDOM_SEED`` from the paper grid, evaluated as the campaign does."""
    from lnss_lib.campaign.backends import SerialBackend, campaign_task
    from lnss_lib.campaign.settings import CampaignPlan, evaluation_profile
    from lnss_lib.settings import load_settings

    profile = load_settings(RANDOM_PROFILE, overrides=overrides)
    settings = CampaignPlan.of(profile)
    rng = np.random.default_rng(RANDOM_SEED)
    keys = [
        tuple(int(v) for v in row)
        for row in rng.integers(0, settings.grid.n_levels + 1, size=(RANDOM_N, 6))
    ]
    designs = settings.grid.designs(np.array(keys))
    backend = SerialBackend(evaluation_profile(profile), campaign_task(settings))
    try:
        records = [None] * len(designs)
        for index, record in backend.run(designs):
            records[index] = {**record, "key": list(keys[index])}
    finally:
        backend.close()
    f, g = _problem_fg(settings, records, keys)
    return _clean(
        {
            "seed": RANDOM_SEED,
            "profile": RANDOM_PROFILE,
            "evaluations": [
                {**r, "design": d, "objectives": fi, "constraints": gi}
                for r, d, fi, gi in zip(records, designs, f, g)
            ],
        }
    )


def _overrides(sets) -> dict | None:
    from lnss_lib.config import parse_sets

    return parse_sets(sets) or None


# name -> recompute(sets): ``sets`` are ``--set SECTION.KEY=VALUE`` texts (scratch checks that a pin can fail)
PINS = {
    "evaluate_table4": lambda sets=(): evaluate_json(overrides=sets),
    "evaluate_table4_life60": lambda sets=(): evaluate_json(
        ["--design-life-days", LIFE_DAYS], overrides=sets
    ),
    "campaign_quick_2gen": lambda sets=(): campaign_pin(_overrides(sets)),
    "random_paper_designs": lambda sets=(): random_designs_pin(_overrides(sets)),
}


# ---------------------------------------------------------------- comparison


def _kind(value) -> str:
    if value is None:
        return "null"
    for name, types in (
        ("bool", bool),
        ("int", int),
        ("float", float),
        ("str", str),
        ("list", list),
        ("dict", dict),
    ):
        if isinstance(value, types):
            return name
    return type(value).__name__


def differences(expected, actual, rtol: float, path: str = "") -> list[str]:
    """Every difference between two JSON-like trees: floats within ``rtol`` relative (NaN equals NaN,
    infinities exact), everything else (ints, bools, strings, None, keys, lengths, types) exact. Keys in
    :data:`EXCLUDED` are skipped at any depth."""
    where = path or "<root>"
    ek, ak = _kind(expected), _kind(actual)
    if ek != ak:
        return [f"{where}: type {ak} ({actual!r:.80}), expected {ek} ({expected!r:.80})"]
    if ek == "dict":
        out = []
        e_keys = [k for k in expected if k not in EXCLUDED]
        a_keys = [k for k in actual if k not in EXCLUDED]
        missing, extra = (
            [k for k in e_keys if k not in actual],
            [k for k in a_keys if k not in expected],
        )
        if missing:
            out.append(f"{where}: missing keys {missing}")
        if extra:
            out.append(f"{where}: unexpected keys {extra}")
        for k in e_keys:
            if k in actual:
                out += differences(expected[k], actual[k], rtol, f"{path}.{k}" if path else k)
        return out
    if ek == "list":
        if len(expected) != len(actual):
            return [f"{where}: length {len(actual)}, expected {len(expected)}"]
        out = []
        for i, (e, a) in enumerate(zip(expected, actual)):
            out += differences(e, a, rtol, f"{path}[{i}]")
        return out
    if ek == "float":
        if math.isnan(expected) and math.isnan(actual):
            return []
        if expected == actual:
            return []
        if (
            math.isfinite(expected)
            and math.isfinite(actual)
            and abs(actual - expected) <= rtol * max(abs(expected), abs(actual))
        ):
            return []
        rel = (
            abs(actual - expected) / max(abs(expected), abs(actual))
            if math.isfinite(expected - actual)
            else math.inf
        )
        return [f"{where}: {actual!r}, expected {expected!r} (relative {rel:.3g} > {rtol:g})"]
    return [] if expected == actual else [f"{where}: {actual!r:.120}, expected {expected!r:.120}"]


def largest_relative_difference(expected, actual) -> float:
    """The largest relative difference between the floats at the same place of two JSON-like trees of the same
    shape (:data:`EXCLUDED` keys skipped; 0 when every float is equal, NaN with NaN counting equal)."""
    if isinstance(expected, dict):
        return max(
            (
                largest_relative_difference(expected[k], actual[k])
                for k in expected
                if k not in EXCLUDED and k in actual
            ),
            default=0.0,
        )
    if isinstance(expected, list):
        return max(map(largest_relative_difference, expected, actual), default=0.0)
    if (
        isinstance(expected, float)
        and isinstance(actual, float)
        and expected != actual
        and not (math.isnan(expected) and math.isnan(actual))
    ):
        return abs(actual - expected) / max(abs(expected), abs(actual))
    return 0.0


def cross_model_rtol(name: str, records: list) -> float:
    """The tolerance within which pin ``name`` of one processor model holds another model's record: the
    :data:`CROSS_MODEL_FACTOR` times the largest relative difference between any two of ``records`` (that pin as
    recorded on each model), rounded up to a power of ten, and never below the pin's own :data:`RTOL`."""
    spread = max(
        (
            largest_relative_difference(a, b)
            for i, a in enumerate(records)
            for b in records[i + 1 :]
        ),
        default=0.0,
    )
    if spread == 0.0:
        return RTOL[name]
    return max(RTOL[name], 10.0 ** math.ceil(math.log10(CROSS_MODEL_FACTOR * spread)))


def fixture_path(model: str) -> Path:
    return FIXTURES / f"{model.replace(':', '-')}.json"


def load_fixtures() -> dict[str, dict]:
    """Every model's record, ``{kernel_cpu: {"meta": ..., "pins": ...}}``."""
    records = {}
    for path in sorted(FIXTURES.glob("*.json")):
        record = json.loads(path.read_text())
        records[record["meta"]["kernel_cpu"]] = record
    return records


def pin_cross_model_rtol(name: str, recorded: dict[str, dict]) -> float:
    """The cross-model tolerance of pin ``name``: :func:`cross_model_rtol` of the models that recorded it; for a pin
    recorded on one model alone (a change of results re-recorded where it could be), the largest cross-model
    tolerance measured on the pins recorded on several models (the same kernels' round-off through other paths)."""
    holders = [record["pins"][name] for record in recorded.values() if name in record["pins"]]
    if len(holders) >= 2:
        return cross_model_rtol(name, holders)
    measured = [
        cross_model_rtol(other, [record["pins"][other] for record in recorded.values()])
        for other in PINS
        if sum(other in record["pins"] for record in recorded.values()) >= 2
    ]
    return max([RTOL[name], *measured])


def check_pin(name: str, result, recorded: dict[str, dict], here: str) -> list[str]:
    """Every difference of pin ``name``'s ``result`` (computed with kernels of model ``here``) from its model's
    record (within :data:`RTOL`) and from each other model's that recorded it (within
    :func:`pin_cross_model_rtol`), each line naming the record it departs from."""
    cross_rtol = pin_cross_model_rtol(name, recorded)
    found = []
    for model, record in recorded.items():
        if name not in record["pins"]:
            continue
        rtol = RTOL[name] if model == here else cross_rtol
        found += [
            f"{model} (rtol {rtol:g}, recorded at commit {record['meta']['commit'][:12]}): {line}"
            for line in differences(record["pins"][name], result, rtol)
        ]
    return found


# ---------------------------------------------------------------- regeneration


def _git(*args) -> str:
    return subprocess.run(
        ["git", *args], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description="Recompute the pinned results; --write records them."
    )
    parser.add_argument(
        "--write",
        action="store_true",
        help=f"write {fixture_path(kernel_cpu()).relative_to(ROOT)} (this machine's processor model)",
    )
    parser.add_argument(
        "--only", choices=sorted(PINS), action="append", help="recompute only these pins"
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="recompute under a changed setting and show the differences (never with --write)",
    )
    args = parser.parse_args(argv)
    if args.write and (args.only or args.set):
        parser.error(
            "--write records every pin under the unchanged profiles; drop --only and --set"
        )
    names = args.only or list(PINS)
    pins, seconds = {}, {}
    for name in names:
        start = time.perf_counter()
        pins[name] = PINS[name](args.set)
        seconds[name] = round(time.perf_counter() - start, 1)
        print(f"{name}: {seconds[name]} s", file=sys.stderr)
    if not args.write:
        recorded = load_fixtures()
        failed = 0
        for name in names:
            diffs = check_pin(name, pins[name], recorded, kernel_cpu())
            failed += bool(diffs)
            print(f"{name}: {len(diffs)} difference(s)" + "".join(f"\n  {d}" for d in diffs[:20]))
        return 1 if failed else 0
    meta = {
        "commit": _git("rev-parse", "HEAD"),
        "dirty": bool(_git("status", "--porcelain", "--", "lnss_lib", "params")),
        "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "command": "PYTHONPATH=$PWD python tests/pinned_results.py --write",
        "seconds": seconds,
        "kernel_cpu": kernel_cpu(),
        "rtol": RTOL,
        "excluded": EXCLUDED,
    }
    path = fixture_path(meta["kernel_cpu"])
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"meta": meta, "pins": pins}, indent=1) + "\n")
    print(
        f"wrote {path} (commit {meta['commit'][:12]}{', dirty' if meta['dirty'] else ''})",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
