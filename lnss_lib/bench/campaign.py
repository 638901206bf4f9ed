"""``python -m lnss_lib bench campaign``: a short NSGA-II campaign, its throughput and time shares, and the
projected wall time of the paper's 120 x 1000 campaign on this machine."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from ..config import load_profile
from ..campaign import CampaignSettings, load_checkpoint, read_cache_records, run_campaign
from ..campaign.timing import campaign_timing, steady_rate
from ..paper import EVALUATIONS


def run(profile_name: str = "quick", generations: int | None = None, population: int | None = None,
        workers: int | None = None) -> dict:
    """Run a short campaign with the profile's evaluations and print throughput, shares and projections.

    Defaults: the profile's population (at most 32) for at most 8 generations; for ``quick`` that
    is its whole campaign. Returns the printed numbers.
    """
    profile = load_profile(profile_name)
    settings = CampaignSettings.from_profile(profile)
    population = population or min(settings.population, 32)
    generations = generations or min(settings.generations, 8)
    full = population == settings.population and generations == settings.generations
    with tempfile.TemporaryDirectory(prefix="lnss_bench_campaign_") as tmp:
        start = time.perf_counter()
        result = run_campaign(profile_name, overrides={"campaign": {"population": population,
                                                                    "generations": generations, "ftol": 0.0}},
                              workers=workers, run_dir=Path(tmp) / "run", progress=False)
        wall = time.perf_counter() - start
        records = read_cache_records(result.run_dir)
        n_workers = len({r["worker"] for r in records}) or 1
        timing = campaign_timing(result.run_dir, n_workers, wall)
        history = load_checkpoint(result.run_dir)["history"]
    n = timing["n_evaluations"]
    rate = steady_rate(history, n, wall)
    first_gen_s = history[0]["wall_s"]
    startup_s = wall - sum(h["wall_s"] for h in history)
    hits = sum(h["n_cache_hits"] for h in history) / max(1, sum(h["n_designs"] for h in history))
    projected_h = (startup_s + first_gen_s + EVALUATIONS / rate) / 3600.0
    budget = timing["worker_budget_s"]
    print(f"campaign [{profile_name}] {population} x {generations} generations, {profile['epoch']['duration_days']:g} "
          f"days, degree {profile['gravity']['degree']}, {n_workers} worker(s): {n} unique designs "
          f"({result.n_feasible} feasible), cache hits {100 * hits:.1f}% of requests")
    print(f"  wall {wall:.1f} s (start-up {startup_s:.1f} s, generation 1 {first_gen_s:.1f} s incl. worker warm-up)"
          + ("  <- the whole quick campaign" if full and profile_name == "quick" else ""))
    print(f"  throughput {n / wall:.2f} designs/s overall, {rate:.2f} designs/s from generation 2 on")
    print(f"  worker time {budget:.1f} s: propagation {100 * timing['propagation_s'] / budget:.1f}%, metrics "
          f"(DOP, Delta-V, GPS) {100 * timing['metrics_s'] / budget:.1f}%, in-task overhead "
          f"{100 * timing['in_task_overhead_s'] / budget:.1f}%, campaign overhead "
          f"{100 * timing['campaign_overhead_s'] / budget:.1f}%")
    print(f"  mean per evaluation: propagation {timing['propagation_s'] / max(n, 1):.3f} s, metrics "
          f"{timing['metrics_s'] / max(n, 1):.3f} s")
    print(f"  projected paper campaign (120 x 1000 = {EVALUATIONS} designs, no cache hits, this design mix): "
          f"{projected_h:.1f} h on this machine; with this run's hit rate {projected_h * (1 - hits):.1f} h")
    return {"wall_s": wall, "n_evaluations": n, "designs_per_s": n / wall, "steady_designs_per_s": rate,
            "projected_paper_h": projected_h, **timing}
