"""``python -m lnss_lib bench campaign [--before-after] [--scaling]``: a short NSGA-II campaign, its throughput and
time shares, and the projected wall time of the profile's 120 x 1000 campaign on this machine (minutes: the
projection alone). ``--before-after`` adds the historical comparisons, each of which compiles or re-runs old code
(tens of minutes on a loaded machine): the operational profile's projection beside the profile's (when
``params/operational.toml`` exists), the force model before and after its speed work side by side
(:func:`lnss_lib.bench.force_before.kernel_comparison`, the model before run from its commit): CPU time per
right-hand side and per design over the points an RK45
integration of each satellite of the run's first :data:`~lnss_lib.bench.force_before.KERNEL_DESIGNS`
valid designs evaluates, and the largest relative difference of the two accelerations (round-off,
~1e-15). Before the force model, the campaign's whole design evaluation before and after the
evaluation-path work (:mod:`lnss_lib.bench.evaluation_path`: Datasets, every Delta-V model, kernel
paths per design; the path before run from its commit), on the same designs alternating, with the
per-generation time and 120 x 1000 projection of each. After the force model, with ``--history`` as well,
that run's own pace of its last generations before and with this change (:func:`history_after`), and
one of its late generations sent to a local Dask cluster as before (a task per design) and as the
campaign sends it now (guided batches, designs that break a bound stopped early once the population
is all feasible), alternating (:func:`dispatch_comparison`).

When the profile has shipped results (``outputs/reference/<profile>/``) the short run takes the profile's population,
so that its generations are the shipped run's first ones (the same designs, bit for bit), and the 120 x 1000
projection scales that run's recorded history (its designs, journal hits and converged designs) by this machine's
pace on the generations both ran (:func:`shipped_projection`): the short run's own rate, from the first generations'
designs and with no hits, is the other projection printed.

``--history RUN_DIR`` projects the same 120 x 1000 campaign with the designs a real run actually evaluated per
generation (its checkpoint history: a converging search repeats designs, which the journal answers): the
run's own generations as recorded, the rest at the mean of its last :data:`HISTORY_TAIL` generations; the
projection is printed as a range, from no cache hits to the run's hits. The evaluation before/after then times
designs of the run's last :data:`HISTORY_TAIL` generations (the mix a converged search evaluates).

``--scaling`` adds: designs/s with 1 and 2 local workers (scaling efficiency); the campaign's own
overhead per design on loopback Dask clusters (127.0.0.1, one thread per worker process) of 8, 32 and 64
workers running the synthetic evaluation with a fixed sleep (no CPU); and, from those numbers and the
measured spread of real evaluation times, the largest worker count that keeps workers 90% busy on a
generation of 120 designs, with designs as tasks and with satellites as tasks.
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from .. import kernel_cpu
from ..campaign import load_checkpoint, read_cache_records, run_campaign
from ..campaign.grid import DesignGrid
from ..campaign.reference import REFERENCE_DIR, load_reference
from ..campaign.timing import campaign_timing, concurrent_workers, steady_rate
from ..config import PARAMS_DIR, deep_merge
from ..constellation import WalkerDesign
from ..errors import ConfigError
from ..evaluator import context_for
from ..keys import TIMING_KEYS
from ..paper import EVALUATIONS, TABLE_5
from ..settings import load_settings
from .evaluation_path import WHAT, PreviousEvaluation, compare_evaluations
from .force_before import kernel_comparison

EVALUATION_DESIGNS = 30  # designs whose whole campaign evaluation is timed before and after
HISTORY_TAIL = (
    20  # generations of a run whose mean evaluated count stands for its unrun generations
)
ROUNDOFF_RTOL = (
    1e-6  # hypervolume agreement that marks the same designs where the kernels are compiled for
)
# another processor model: its round-off moved metrics by up to 2e-7 relative (docs/NOTES.md,
# Notes for developers); a different design moves the hypervolume by far more
SHORT_GENERATIONS = 8  # generations of the short run when the profile has no shipped results
PACE_GENERATIONS = (
    30  # generations of the short run when it repeats a shipped run: the pace is measured on 2-30
)
SCALING_WORKERS = (8, 32, 64)
SCALING_DELAY_S = 0.5


def _short_campaign(
    profile_name: str,
    population: int,
    generations: int,
    workers: int | None,
    overrides: dict | None = None,
) -> dict:
    """Run a campaign in a temporary directory; its timing, history and records."""
    size = {"campaign": {"population": population, "generations": generations, "ftol": 0.0}}
    merged = deep_merge(size, overrides or {})
    with tempfile.TemporaryDirectory(prefix="lnss_bench_campaign_") as tmp:
        start = time.perf_counter()
        result = run_campaign(
            profile_name,
            overrides=merged,
            workers=workers,
            run_dir=Path(tmp) / "run",
            progress=False,
        )
        wall = time.perf_counter() - start
        records = read_cache_records(result.run_dir)
        n_workers = concurrent_workers(records)
        timing = campaign_timing(result.run_dir, n_workers, wall)
        history = load_checkpoint(result.run_dir)["history"]
    return {
        "result": result,
        "wall_s": wall,
        "records": records,
        "n_workers": n_workers,
        "timing": timing,
        "history": history,
    }


def _projection(
    profile_name: str,
    population: int,
    generations: int,
    workers: int | None,
    overrides: dict | None = None,
) -> dict:
    """Short campaign at ``profile_name``'s fidelity and its 120 x 1000 projection; prints the numbers."""
    profile = load_settings(profile_name, overrides=overrides)
    run = _short_campaign(profile_name, population, generations, workers, overrides)
    timing, history, wall = run["timing"], run["history"], run["wall_s"]
    n = timing["n_evaluations"]
    rate = steady_rate(history, n, wall)
    first_gen_s = history[0]["wall_s"]
    startup_s = wall - sum(h["wall_s"] for h in history)
    hits = sum(h["n_cache_hits"] for h in history) / max(1, sum(h["n_designs"] for h in history))
    projected_h = (startup_s + first_gen_s + EVALUATIONS / rate) / 3600.0
    budget = timing["worker_budget_s"]
    print(
        f"campaign [{profile_name}] {population} x {generations} generations, {profile.epoch.duration_days:g} "
        f"days, degree {profile.gravity.degree} (truncation {profile.gravity.truncation_kms2:g} "
        f"km/s^2), integrator {profile.integrator.setting}, {run['n_workers']} worker(s): {n} unique designs "
        f"({run['result'].n_feasible} feasible), cache hits {100 * hits:.1f}% of requests"
    )
    print(
        f"  wall {wall:.1f} s (start-up {startup_s:.1f} s, generation 1 {first_gen_s:.1f} s incl. worker warm-up)"
    )
    print(
        f"  throughput {n / wall:.2f} designs/s overall, {rate:.2f} designs/s from generation 2 on"
    )
    print(
        f"  worker time {budget:.1f} s: propagation {100 * timing['propagation_s'] / budget:.1f}%, metrics "
        f"(DOP, Delta-V, GPS) {100 * timing['metrics_s'] / budget:.1f}%, in-task overhead "
        f"{100 * timing['in_task_overhead_s'] / budget:.1f}%, campaign overhead "
        f"{100 * timing['campaign_overhead_s'] / budget:.1f}%"
    )
    parts = {
        k: sum(r["timing_s"].get(k, 0.0) for r in run["records"]) / max(n, 1)
        for k in ("propagation", "dop", "deltav", "gps")
    }
    print("  mean per evaluation: " + ", ".join(f"{k} {v:.3f} s" for k, v in parts.items()))
    print(
        f"  projected 120 x 1000 campaign ({EVALUATIONS} designs, all eq. 45 objectives, no cache hits, this design "
        f"mix): {projected_h:.1f} h on this machine; with this run's hit rate {projected_h * (1 - hits):.1f} h"
    )
    return {
        "profile": profile_name,
        "wall_s": wall,
        "n_evaluations": n,
        "n_workers": run["n_workers"],
        "designs_per_s": n / wall,
        "steady_designs_per_s": rate,
        "projected_paper_h": projected_h,
        "fixed_s": startup_s + first_gen_s,
        "startup_s": startup_s,
        "records": run["records"],
        "history": history,
        **timing,
    }


def shipped_projection(profile_name: str, projection: dict) -> dict | None:
    """The 120 x 1000 projection from the profile's shipped run (``outputs/reference/<profile>/history.nc``): its
    generations' wall times, which hold its own designs, journal hits and the converged search's cheaper designs,
    scaled by this machine's pace over the generations the short run repeated (2 on; generation 1 is this run's own,
    with the start-up). Only when the short run is the shipped run's beginning: the same evaluated and hit counts
    every generation and the same hypervolume, bit for bit where the kernels are compiled for the processor model of
    the shipped run, else within :data:`ROUNDOFF_RTOL`; otherwise None, saying why."""
    reference = load_reference(profile_name)
    if reference is None:
        print(f"  no shipped results for [{profile_name}]: no projection from a full run")
        return None
    shipped, short = reference.history, projection["history"]
    n = min(len(short), int(shipped.sizes["generation"]))
    shipped_cpu, here = (
        json.loads(shipped.attrs.get("versions", "{}")).get("kernel_cpu"),
        kernel_cpu(),
    )
    rtol = 0.0 if shipped_cpu == here else ROUNDOFF_RTOL
    hv_shipped = shipped["hypervolume"].values[:n]
    hv_short = np.array([h["hypervolume"] for h in short[:n]])
    hv_rel = float(
        np.max(
            np.abs(hv_short - hv_shipped) / np.maximum(np.abs(hv_shipped), np.finfo(float).tiny),
            initial=0.0,
        )
    )
    same = (
        n >= 2
        and hv_rel <= rtol
        and all(
            int(shipped["n_evaluated"].values[g]) == h["n_evaluated"]
            and int(shipped["n_cache_hits"].values[g]) == h["n_cache_hits"]
            for g, h in enumerate(short[:n])
        )
    )
    kernels = (
        f"kernels for {here} here, {shipped_cpu} there: hypervolume within {hv_rel:.1e} relative, "
        f"allowed {rtol:g}"
    )
    if not same:
        print(
            f"  the short run's generations are not the shipped [{profile_name}] run's (another population, seed, "
            f"profile, or more than round-off; {kernels}): no projection from it"
        )
        return None
    shipped_s = shipped["wall_s"].values
    pace = sum(h["wall_s"] for h in short[1:n]) / float(np.sum(shipped_s[1:n]))
    total_s = projection["startup_s"] + short[0]["wall_s"] + pace * float(np.sum(shipped_s[1:]))
    hours = total_s / 3600.0
    print(
        f"  from the shipped run ({shipped.sizes['generation']} generations, {int(shipped['n_evaluated'].sum())} "
        f"designs evaluated, {int(shipped['n_cache_hits'].sum())} journal hits, {float(np.sum(shipped_s)):.0f} s): "
        f"generations 2-{n} here took {pace:.2f} times its time for the same designs ({kernels}); projected "
        f"{hours:.2f} h ({total_s:.0f} s) for its whole campaign on this machine"
    )
    return {
        "pace_vs_shipped": pace,
        "generations_compared": n,
        "projected_s": total_s,
        "projected_h": hours,
        "shipped_wall_s": float(np.sum(shipped_s)),
    }


def evaluated_per_generation(run_dir) -> dict:
    """Designs a run evaluated (not answered by its journal) in each generation of a 120 x 1000 campaign.

    From the run's checkpoint history (``n_evaluated``, ``n_cache_hits``): its recorded generations as they
    were, each later one at the mean of the last :data:`HISTORY_TAIL` recorded. ConfigError (naming the
    folder) when ``run_dir`` is not a campaign run folder with at least one checkpointed generation, or its
    population is not Table 5's.
    """
    path = Path(run_dir)
    checkpoint = load_checkpoint(path) if path.is_dir() else None
    history = (checkpoint or {}).get("history") or []
    if not history:
        raise ConfigError(
            f"--history {run_dir}: not a campaign run folder with a checkpointed generation "
            "(expected checkpoint.pkl written by 'python -m lnss_lib campaign')",
            key="--history",
        )
    population, generations = TABLE_5["population"], TABLE_5["generations"]
    sizes = {int(h["n_designs"]) for h in history}
    if sizes != {population}:
        raise ConfigError(
            f"--history {run_dir}: generations of {sorted(sizes)} designs; the projection needs a run "
            f"with Table 5's population of {population}",
            key="--history",
        )
    recorded = np.array([int(h["n_evaluated"]) for h in history[:generations]])
    tail = float(np.mean(recorded[-HISTORY_TAIL:]))
    total = float(recorded.sum() + tail * (generations - recorded.size))
    return {
        "run_dir": str(path),
        "generations_recorded": int(recorded.size),
        "evaluated_recorded": int(recorded.sum()),
        "hits_recorded": int(sum(int(h["n_cache_hits"]) for h in history[:generations])),
        "tail_mean_evaluated": tail,
        "evaluated_total": total,
        "hit_fraction": 1.0 - total / EVALUATIONS,
    }


def _history_range(projection: dict, run_dir) -> dict:
    """Print the 120 x 1000 projection from no cache hits to ``run_dir``'s measured hits (same design rate)."""
    hist = evaluated_per_generation(run_dir)
    rate, fixed_s = projection["steady_designs_per_s"], projection["fixed_s"]
    no_hits_h = (fixed_s + EVALUATIONS / rate) / 3600.0
    with_hits_h = (fixed_s + hist["evaluated_total"] / rate) / 3600.0
    print(
        f"  with {hist['run_dir']}'s cache hits: generations 1-{hist['generations_recorded']} evaluated "
        f"{hist['evaluated_recorded']} designs ({hist['hits_recorded']} journal hits), the other "
        f"{TABLE_5['generations'] - hist['generations_recorded']} at its last {HISTORY_TAIL} generations' mean of "
        f"{hist['tail_mean_evaluated']:.1f}: {hist['evaluated_total']:.0f} evaluations ({100 * hist['hit_fraction']:.1f}% "
        f"hits)"
    )
    print(
        f"  projected 120 x 1000 [{projection['profile']}] at {rate:.2f} designs/s: {with_hits_h:.2f} h with the "
        f"measured hits .. {no_hits_h:.2f} h with none"
    )
    return {**hist, "projected_h_with_hits": with_hits_h, "projected_h_no_hits": no_hits_h}


def _late_designs(records: list[dict], n: int, tail: int = HISTORY_TAIL) -> list[dict]:
    """Up to ``n`` evaluated records (seeded draw) of the last ``tail`` generations in ``records``."""
    last = max((int(r.get("generation", 0)) for r in records), default=0)
    late = [r for r in records if r["ok"] and int(r.get("generation", 0)) > last - tail]
    rng = np.random.default_rng(23)
    return [late[i] for i in sorted(rng.choice(len(late), min(n, len(late)), replace=False))]


def evaluation_comparison(
    profile_name: str, projection: dict, overrides: dict | None = None, history: str | None = None
) -> dict:
    """Print and return the campaign evaluation before and after the evaluation-path work
    (:mod:`lnss_lib.bench.evaluation_path`, the path before run from its commit; without git or the
    commit today's alone) on :data:`EVALUATION_DESIGNS` designs: the last :data:`HISTORY_TAIL`
    generations' of ``history`` (the mix a converged search evaluates) or else the short run's; and
    the per-generation time and 120 x 1000 projection of both from the short run's rate."""
    settings = load_settings(profile_name, overrides=overrides)
    context = context_for(settings)
    grid = DesignGrid.from_variables(settings.campaign.variables)
    source = read_cache_records(history) if history is not None else projection["records"]
    records = _late_designs(source, EVALUATION_DESIGNS)
    designs = []
    for record in records:
        design = grid.descale(record["key"])[0]
        designs.append(
            WalkerDesign(
                *(float(x) for x in design[:4]), int(design[4]), int(design[5])
            ).elements_deg()
        )
    where = (
        f"{history}'s last {HISTORY_TAIL} generations" if history is not None else "the short run"
    )
    try:
        with PreviousEvaluation(profile_name, overrides) as before:
            got = compare_evaluations(context, designs, before)
    except RuntimeError as error:
        print(f"{WHAT}: not available here ({error}); today's path alone")
        got = compare_evaluations(context, designs)
        print(
            f"campaign evaluation now, {got['n_designs']} designs of {where}, 1 thread, median "
            f"of 3 runs: {1e3 * got['now_s']:.1f} ms per design"
        )
        return {**got, "records": source}
    before, now = got["before_s"], got["now_s"]
    print(
        f"campaign evaluation before -> now (evaluation path), {got['n_designs']} designs of {where}, 1 thread, "
        f"median of 3 alternating runs: {1e3 * before:.1f} ms -> {1e3 * now:.1f} ms per design "
        f"({100 * (1 - now / before):.1f}% less); "
        + ", ".join(
            f"{k} {1e3 * got[f'before_{k}_s']:.1f} -> {1e3 * got[f'now_{k}_s']:.1f}"
            for k in TIMING_KEYS
        )
        + f" ms; metrics differing: {got['n_differing']}"
    )
    rate, fixed_s, workers = (
        projection["steady_designs_per_s"],
        projection["fixed_s"],
        max(projection["n_workers"], 1),
    )
    per_design = {"now": 1.0 / rate, "before": 1.0 / rate + (before - now) / workers}
    evaluated = (
        evaluated_per_generation(history)["evaluated_total"] if history is not None else EVALUATIONS
    )
    hours = {k: (fixed_s + evaluated * v) / 3600.0 for k, v in per_design.items()}
    per_generation = {k: evaluated / TABLE_5["generations"] * v for k, v in per_design.items()}
    print(
        f"  at the short run's rate ({rate:.2f} designs/s, {workers} worker(s)) with "
        + (f"{history}'s cache hits" if history is not None else "no cache hits")
        + f": {per_generation['before']:.2f} s -> {per_generation['now']:.2f} s a generation, 120 x 1000 "
        f"{hours['before']:.2f} h -> {hours['now']:.2f} h"
    )
    return {**got, "generation_s": per_generation, "projected_h": hours, "records": source}


def history_after(run_dir, evaluation: dict, kernels: dict) -> dict:
    """Print and return the pace of ``run_dir``'s last :data:`HISTORY_TAIL` generations as recorded (the code before)
    and with this change: its evaluation time (the mean task time of those generations' designs over its workers)
    less the share :func:`evaluation_comparison` measured and, of its propagation share, the right-hand side's share
    the conical shadow saved (:func:`kernel_comparison`; both evaluation paths use the current force model); and
    120 x 1000 at each pace."""
    tail = load_checkpoint(Path(run_dir))["history"][-HISTORY_TAIL:]
    records = [
        r
        for r in read_cache_records(run_dir)
        if int(r.get("generation", 0)) > tail[0]["generation"] - 1
    ]
    workers = concurrent_workers(records)
    generation_s = float(np.mean([h["wall_s"] for h in tail]))
    evaluated = float(np.mean([h["n_evaluated"] for h in tail]))
    evaluating_s = sum(r["task_wall_s"] for r in records) / len(tail) / workers
    shadow_saved = kernels["shadow_before_s"] - kernels["shadow_new_s"]
    shadow_share = (
        shadow_saved
        / (kernels["new_s"] + shadow_saved)
        * evaluation["now_propagation_s"]
        / evaluation["before_s"]
    )
    saved_s = evaluating_s * (1.0 - evaluation["now_s"] / evaluation["before_s"] + shadow_share)
    after_s = generation_s - saved_s
    generations = TABLE_5["generations"]
    print(
        f"  {run_dir}'s last {HISTORY_TAIL} generations as run (before): {generation_s:.2f} s a generation ({evaluated:.1f} "
        f"evaluated, {evaluating_s:.2f} s of tasks per worker, {workers} workers) = {generations * generation_s / 3600:.2f} h "
        f"for {generations}; with this change: {after_s:.2f} s ({100 * saved_s / generation_s:.1f}% less, of which the "
        f"shadow {100 * evaluating_s * shadow_share / generation_s:.1f}%) = {generations * after_s / 3600:.2f} h"
    )
    return {
        "generation_before_s": generation_s,
        "generation_after_s": after_s,
        "saved_fraction": saved_s / generation_s,
    }


def _greedy_makespan(durations: np.ndarray, n_workers: int, dispatch_s: float) -> float:
    """Wall time of tasks handed out in order to the first free worker, one every ``dispatch_s`` seconds."""
    free = np.zeros(n_workers)
    for k, d in enumerate(durations):
        w = int(np.argmin(free))
        free[w] = max(free[w], k * dispatch_s) + d
    return float(free.max())


def _busy_fraction(
    durations: np.ndarray, n_workers: int, dispatch_s: float, fixed_s: float
) -> float:
    """Share of worker time spent in tasks when ``durations`` run as one generation (list scheduling)."""
    return float(
        durations.sum()
        / (n_workers * (_greedy_makespan(durations, n_workers, dispatch_s) + fixed_s))
    )


def busy_model(records: list[dict], overhead: dict) -> dict:
    """Largest worker count keeping workers >= 90% busy on a generation of 120 designs drawn from ``records``
    (task times of a real campaign), with designs as tasks and with satellites as tasks, each handed out
    longest first, for a dispatch cost per task equal to the smallest and to the largest measured campaign
    overhead per design."""
    records = [r for r in records if r["task_wall_s"] > 0.0 and r["timing_s"]]
    durations = np.array([r["task_wall_s"] for r in records])
    n_sat = np.array([max(int(r["metrics"]["n_sat"]), 1) for r in records])
    propagation = np.array([r["timing_s"].get("propagation", 0.0) for r in records])
    rng = np.random.default_rng(0)
    picks = [rng.integers(0, len(records), 120) for _ in range(10)]
    counts = [w for w in range(2, 2401) if w <= 128 or w % 32 == 0]

    def designs_as_tasks(w, dispatch):
        return float(
            np.mean([_busy_fraction(np.sort(durations[i])[::-1], w, dispatch, 0.0) for i in picks])
        )

    def satellites_as_tasks(w, dispatch):
        """Propagation split into one task per satellite, then one metrics task per design (two phases)."""
        fractions = []
        for i in picks:
            sat_tasks = np.sort(np.repeat(propagation[i] / n_sat[i], n_sat[i]))[::-1]
            wall = _greedy_makespan(sat_tasks, w, dispatch) + _greedy_makespan(
                np.sort(durations[i] - propagation[i])[::-1], w, dispatch
            )
            fractions.append(durations[i].sum() / (w * wall))
        return float(np.mean(fractions))

    print(
        f"  real evaluations here: mean {durations.mean():.2f} s, 95th percentile {np.percentile(durations, 95):.2f} s, "
        f"max {durations.max():.2f} s per design, propagation {100 * propagation.sum() / durations.sum():.0f}% of "
        f"task time"
    )
    out = {}
    for dispatch in sorted({min(overhead.values()), max(overhead.values())}):
        for label, model in (
            ("designs as tasks", designs_as_tasks),
            ("satellites as tasks", satellites_as_tasks),
        ):
            busy = {w: model(w, dispatch) for w in counts}
            best = max((w for w in counts if busy[w] >= 0.9), default=1)
            out[f"max_workers_90pct_{label.split()[0]}_{1e3 * dispatch:.1f}ms"] = best
            print(
                f"  {label:19s}, {1e3 * dispatch:5.1f} ms per task: >= 90% busy up to {best} workers (busy at 8: "
                f"{100 * busy[8]:.0f}%, 32: {100 * busy[32]:.0f}%, 64: {100 * busy[64]:.0f}%, 128: {100 * busy[128]:.0f}%)"
            )
    return out


def scaling(
    profile_name: str = "paper", reference: dict | None = None, overrides: dict | None = None
) -> dict:
    """Print local scaling, loopback-cluster overhead per design and the 90%-busy worker count."""
    out = {}
    rates = {}
    threads = numba.get_num_threads()
    for workers in (1, 2):
        numba.set_num_threads(1)  # one core per worker, as in a Dask worker process
        try:
            run = _short_campaign(profile_name, 16, 4, workers, overrides)
        finally:
            numba.set_num_threads(threads)
        rates[workers] = steady_rate(run["history"], run["timing"]["n_evaluations"], run["wall_s"])
    out["designs_per_s"] = rates
    print(
        f"scaling [{profile_name}], 16 x 4 generations: {rates[1]:.2f} designs/s on 1 worker (in-process, 1 thread), "
        f"{rates[2]:.2f} on 2 (Dask): efficiency {100 * rates[2] / (2 * rates[1]):.0f}%"
    )
    overhead = {}
    for workers in SCALING_WORKERS:
        start = time.perf_counter()
        synthetic = {"campaign": {"evaluator": "synthetic", "synthetic_delay_s": SCALING_DELAY_S}}
        run = _short_campaign(profile_name, 120, 2, workers, deep_merge(overrides or {}, synthetic))
        later = [h for h in run["history"] if h["generation"] > 1]
        n = sum(h["n_evaluated"] for h in later)
        gen_wall = sum(h["wall_s"] for h in later)
        rounds = sum(math.ceil(h["n_evaluated"] / workers) for h in later)
        excess = (gen_wall - rounds * SCALING_DELAY_S) / max(n, 1)
        busy = n * SCALING_DELAY_S / (workers * gen_wall)
        overhead[workers] = excess
        print(
            f"  loopback cluster, {workers:2d} workers, {SCALING_DELAY_S} s sleep per design: generation wall "
            f"{gen_wall / len(later):.2f} s (ideal {rounds * SCALING_DELAY_S / len(later):.2f} s), campaign overhead "
            f"{1e3 * excess:.1f} ms per design, workers busy {100 * busy:.0f}% (run incl. start-up "
            f"{time.perf_counter() - start:.0f} s)"
        )
    out["overhead_s_per_design"] = overhead
    records = (reference or {}).get("records") or _short_campaign(
        profile_name, 32, 2, None, overrides
    )["records"]
    out.update(busy_model(records, overhead))
    return out


def dispatch_comparison(
    profile_name: str, run_dir, overrides: dict | None = None, workers: int = 2, repeats: int = 3
) -> dict:
    """Print and return one late generation of ``run_dir`` (its last :data:`HISTORY_TAIL` generations' mean count
    of evaluated designs, drawn from them) on a local Dask cluster, sent as before (one task per design, all at
    once) and as the campaign now sends it (:func:`~lnss_lib.campaign.backends.guided_batches`, and a design that
    breaks a bound stopped early when the run's last population was all feasible,
    :func:`~lnss_lib.campaign.backends.early_stop_bounds`), alternating, best of ``repeats``; and 120 x 1000 at each
    pace with the run's evaluated counts."""
    from ..campaign.backends import DaskBackend, campaign_task
    from ..campaign.settings import CampaignPlan, evaluation_profile

    settings = load_settings(profile_name, overrides=overrides)
    plan = CampaignPlan.of(settings)
    hist = evaluated_per_generation(run_dir)
    checkpoint = load_checkpoint(Path(run_dir))
    last = checkpoint["history"][-1]
    bounds = plan.constraints if int(last["n_feasible_pop"]) >= plan.population else None
    records = _late_designs(read_cache_records(run_dir), round(hist["tail_mean_evaluated"]))
    designs = plan.grid.designs(np.array([r["key"] for r in records]))
    capped = [{**d, "stop_bounds": bounds} for d in designs] if bounds is not None else designs
    backend = DaskBackend(
        evaluation_profile(settings),
        campaign_task(plan),
        max_resubmits=plan.max_resubmits,
        numba_threads=plan.numba_threads_per_worker,
        n_workers=workers,
    )
    best = {"before": math.inf, "now": math.inf}
    try:
        for _ in backend.run(designs[: 2 * workers]):  # workers' contexts and compiled code
            pass
        for _ in range(repeats):
            for name, items, guided in (("before", designs, False), ("now", capped, True)):
                start = time.perf_counter()
                for _ in backend.run(items, guided=guided):
                    pass
                best[name] = min(best[name], time.perf_counter() - start)
    finally:
        backend.close()
    evaluated = hist["evaluated_total"] / TABLE_5["generations"]
    scale = evaluated / len(designs)
    hours = {k: TABLE_5["generations"] * v * scale / 3600.0 for k, v in best.items()}
    print(
        f"generation dispatch before -> now, {len(designs)} designs of {run_dir}'s last {HISTORY_TAIL} "
        f"generations, {workers} workers, best of {repeats} alternating: {best['before']:.2f} s -> {best['now']:.2f} s "
        f"({100 * (1 - best['now'] / best['before']):.1f}% less; early stop "
        + (
            "at the bounds"
            if bounds is not None
            else "off: the run's population was not all feasible"
        )
        + f"); 120 x 1000 at {evaluated:.1f} evaluated a generation: {hours['before']:.2f} h -> {hours['now']:.2f} h "
        "(evaluations and dispatch; NSGA-II, the journal and the checkpoint add about 0.05 s a generation)"
    )
    return {
        "before_s": best["before"],
        "now_s": best["now"],
        "early_stop": bounds is not None,
        "n_designs": len(designs),
        "projected_h": hours,
    }


def _before_after(
    profile_name: str, projection: dict, overrides: dict | None, history: str | None
) -> dict:
    """The historical comparisons: the evaluation path and the force model before and after their speed work, and
    with ``history`` that run's pace before and with them and its dispatch as before and now."""
    out = {"evaluation": evaluation_comparison(profile_name, projection, overrides, history)}
    out["evaluation"].pop("records")
    out["kernels"] = kernel_comparison(profile_name, projection["records"], overrides)
    if history is not None:
        if math.isfinite(out["evaluation"]["before_s"]):
            out["history_after"] = history_after(history, out["evaluation"], out["kernels"])
        out["dispatch"] = dispatch_comparison(profile_name, history, overrides)
    return out


def run(
    profile_name: str = "paper",
    generations: int | None = None,
    population: int | None = None,
    workers: int | None = None,
    scaling_run: bool = False,
    overrides: dict | None = None,
    history: str | None = None,
    before_after: bool = False,
) -> dict:
    """Short campaign(s) with the profile's evaluations; throughput, shares and 120 x 1000 projections.

    Defaults: at most :data:`SHORT_GENERATIONS` generations of the profile's population, at most 32, unless the
    profile has shipped results: then :data:`PACE_GENERATIONS` of the profile's population, so that the short run
    repeats the shipped run's first generations and :func:`shipped_projection` scales that run's whole history by the
    pace on them. Generations 2-8 are half a minute in all, at the host's pace of that half minute: for the paper
    campaign the AMD run's pace on them was 0.83 of the Intel run's where the whole run's was 0.62 (a projection 34 %
    high), on generations 2-30 0.66 (7 % high). ``overrides`` (``--set``) apply to every campaign run here.
    ``history``: a run folder whose per-generation evaluated counts give the projection's range (checked before
    anything runs). ``before_after``: the historical comparisons too (the module docstring), and when
    ``params/operational.toml`` exists the operational projection beside the profile's.
    """
    if history is not None:
        evaluated_per_generation(history)
    settings = load_settings(profile_name, overrides=overrides).campaign
    short_population = population or min(settings.population, 32)
    shipped = (REFERENCE_DIR / profile_name).is_dir()
    population = population or (settings.population if shipped else short_population)
    short_generations = generations or min(settings.generations, SHORT_GENERATIONS)
    generations = generations or min(
        settings.generations, PACE_GENERATIONS if shipped else SHORT_GENERATIONS
    )
    out = {profile_name: _projection(profile_name, population, generations, workers, overrides)}
    out["shipped"] = shipped_projection(profile_name, out[profile_name])
    if history is not None:
        out["history"] = _history_range(out[profile_name], history)
    operational = (
        before_after
        and (PARAMS_DIR / "operational.toml").is_file()
        and profile_name != "operational"
    )
    if operational:
        out["operational"] = _projection(
            "operational", short_population, short_generations, workers, overrides
        )
        print(
            f"projected 120 x 1000: [{profile_name}] {out[profile_name]['projected_paper_h']:.1f} h, [operational] "
            f"{out['operational']['projected_paper_h']:.1f} h (target <= 3 h on 2 workers)"
        )
    else:
        print(
            f"projected 120 x 1000: [{profile_name}] {out[profile_name]['projected_paper_h']:.1f} h (target <= 3 h on "
            "2 workers)"
        )
    if before_after:
        out.update(_before_after(profile_name, out[profile_name], overrides, history))
    if scaling_run:
        out["scaling"] = scaling(profile_name, out[profile_name], overrides)
    for value in out.values():
        value.pop("records", None) if isinstance(value, dict) else None
    return out
