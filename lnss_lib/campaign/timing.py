"""Where a campaign's worker time went, from its journal: propagation, metrics, overheads.

Used by ``python -m lnss_lib bench campaign`` and notebook 06's throughput table; the campaign
package never imports :mod:`lnss_lib.bench`.
"""

from __future__ import annotations

from ..keys import TIMING_KEYS
from .journal import read_cache_records

__all__ = ["campaign_timing", "concurrent_workers", "steady_rate", "generation_timing"]


def concurrent_workers(records: list[dict]) -> int:
    """Worker processes that ran at once: the most common number of distinct workers in a generation of the cache
    records (a run resumed in another session has new worker names, and the generation it was stopped in mixes both
    sessions'; counting every name would multiply its worker time)."""
    by_generation: dict = {}
    for record in records:
        by_generation.setdefault(record.get("generation"), set()).add(record.get("worker"))
    counts = [len(names) for names in by_generation.values()]
    return max(set(counts), key=lambda c: (counts.count(c), c)) if counts else 1


def campaign_timing(run_dir, n_workers: int, wall_s: float) -> dict:
    """Time shares of a finished run from its cache records (``timing_s`` of every evaluation).

    Worker time available = ``n_workers * wall_s``; propagation and metrics (DOP, Delta-V, GPS
    link, operational extras) are summed over the evaluations; in-task overhead is the rest of each task (context
    build, compiled-code loading, glue); campaign overhead is what is left (start-up, scheduling,
    idle workers at the end of a generation, pymoo, checkpoints).
    """
    records = read_cache_records(run_dir)
    propagation = sum(r["timing_s"].get("propagation", 0.0) for r in records)
    metrics = sum(
        r["timing_s"].get(k, 0.0) for r in records for k in ("dop", "deltav", "gps", "operational")
    )
    task = sum(r["task_wall_s"] for r in records)
    budget = n_workers * wall_s
    return {
        "n_evaluations": len(records),
        "propagation_s": propagation,
        "metrics_s": metrics,
        "in_task_overhead_s": task - propagation - metrics,
        "campaign_overhead_s": budget - task,
        "worker_budget_s": budget,
        "task_s": task,
    }


def steady_rate(history: list[dict], n_evaluations: int, wall_s: float) -> float:
    """Designs evaluated per second of generation wall time from generation 2 on (generation 1 holds the
    worker warm-up); ``n_evaluations / wall_s`` when the run has one generation."""
    later = [h for h in history if h["generation"] > 1]
    if later:
        return sum(h["n_evaluated"] for h in later) / sum(h["wall_s"] for h in later)
    return n_evaluations / wall_s


def generation_timing(records, generation: int, n_workers: int, wall_s: float) -> dict:
    """Mean seconds per design evaluated in ``generation``: ``time_<part>_s`` for propagation, DOP,
    Delta-V and GPS (the evaluator's ``timing_s``), ``time_overhead_s`` (the rest of each task) and
    ``time_campaign_s`` (worker time not spent in tasks: scheduling, idle workers, pymoo, checkpoint).

    NaN-free: zeros for a generation that evaluated nothing. Written to ``history.nc`` every generation.
    """
    mine = [r for r in records if r.get("generation") == generation]
    n = max(len(mine), 1)
    out = {f"time_{k}_s": sum(r["timing_s"].get(k, 0.0) for r in mine) / n for k in TIMING_KEYS}
    task = sum(r.get("task_wall_s", 0.0) for r in mine)
    out["time_overhead_s"] = task / n - sum(out[f"time_{k}_s"] for k in TIMING_KEYS)
    out["time_campaign_s"] = max(n_workers * wall_s - task, 0.0) / n if mine else 0.0
    return out
