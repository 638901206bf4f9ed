"""The campaign: pymoo's NSGA-II through ask and tell, one generation at a time, in a run directory.

A run killed at any moment and resumed ends with the same population as an uninterrupted one:
designs of an interrupted generation come back from the journal, the checkpoint holds the
algorithm and its random generator.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import OUTPUTS_DIR, load_profile
from .backends import BatchEvaluator, open_backend
from .fitness import constraint_matrix, constraint_violation, hypervolume, metric_columns
from .journal import JOURNAL_FILE, EvaluationCache
from .problem import WalkerDesignProblem, build_algorithm, build_termination
from .rundir import default_run_dir, load_checkpoint, load_run, start_run, write_checkpoint, write_results
from .settings import CampaignSettings, evaluation_hash, evaluation_profile

__all__ = ["run_campaign", "CampaignResult"]


def _generation_stats(settings: CampaignSettings, records: list[dict], pop_keys: list[tuple]) -> dict:
    """Deterministic per-generation numbers from the cache so far and the population's keys."""
    columns = metric_columns(records)
    cv = constraint_violation(constraint_matrix(columns, settings.constraints, settings.nan_violation))
    feasible = columns["ok"] & (cv == 0.0)
    by_key = {tuple(r["key"]): i for i, r in enumerate(records)}
    pop_idx = np.array([by_key[k] for k in pop_keys], dtype=int)
    stats = {
        "n_evaluations_cum": len(records),
        "n_feasible_cum": int(feasible.sum()),
        "n_feasible_pop": int(feasible[pop_idx].sum()),
        "min_cv_pop": float(cv[pop_idx].min()) if pop_idx.size else math.nan,
        "hypervolume": hypervolume(columns, feasible, settings.hypervolume),
    }
    for name in settings.objectives:
        metric = name.lstrip("-")
        values = columns[metric][feasible].astype(float)
        values = values[np.isfinite(values)]
        best = (values.max() if name.startswith("-") else values.min()) if values.size else math.nan
        stats[f"best_{metric}"] = float(best)
    return stats


@dataclass
class CampaignResult:
    """What :func:`run_campaign` returns: the run directory, result files and headline numbers."""

    run_dir: Path
    files: list[Path]
    generations: int
    n_evaluations: int
    n_feasible: int
    wall_s: float
    session_evaluations: int
    session_wall_s: float
    resubmitted: int


def _progress_text(entry: dict) -> str:
    """Progress-bar summary of one history entry: throughput, cache hits, feasibility, best values."""
    text = (f"{entry['designs_per_s']:.2f} designs/s, hits {entry['n_cache_hits']}, feasible "
            f"{entry['n_feasible_pop']}/{entry['n_designs']} (all {entry['n_feasible_cum']}), "
            f"min cv {entry['min_cv_pop']:.3g}" + (f", errors {entry['n_errors']}" if entry["n_errors"] else ""))
    best = [f"{key[5:]} {entry[key]:.3g}" for key in ("best_n_sat", "best_pdop_mean_3sigma", "best_dv_opt_kms_per_year")
            if key in entry and math.isfinite(entry[key])]
    return text + (f", best {', '.join(best)}" if best else "")


def run_campaign(profile_name: str = "quick", *, overrides: dict | None = None, workers: int | None = None,
                 scheduler_address: str | None = None, run_dir=None, resume=None, progress: bool = True,
                 max_generations: int | None = None) -> CampaignResult:
    """Run (or, with ``resume`` = a run directory, continue) an NSGA-II campaign; see the module docstring.

    ``overrides`` is merged into the profile (e.g. ``{"campaign": {"evaluator": "synthetic"}}``);
    ``workers`` 0 or 1 evaluates in this process, None or >= 2 on a local Dask cluster, and
    ``scheduler_address`` uses an existing cluster. ``max_generations`` stops this session after
    that many generations (the run stays resumable). Returns a :class:`CampaignResult`.
    """
    from tqdm import tqdm

    if resume is not None:
        run_dir = Path(resume)
        run = load_run(run_dir)
        profile = run["profile"]
        if overrides:
            raise ValueError("a resumed run keeps its parameters: overrides are not allowed with resume")
        if evaluation_hash(profile) != run["evaluation_hash"]:
            raise ValueError(f"{run_dir}: evaluation hash of the stored profile changed; cannot resume")
    else:
        profile = load_profile(profile_name, overrides=overrides)
        run_dir = Path(run_dir) if run_dir is not None else default_run_dir(profile_name)
        start_run(run_dir, profile)
    settings = CampaignSettings.from_profile(profile)
    eval_hash = evaluation_hash(profile)
    name = profile["profile"]["name"]
    checkpoint = load_checkpoint(run_dir)
    if checkpoint is not None:
        algorithm, history = checkpoint["algorithm"], checkpoint["history"]
        problem = algorithm.problem
    else:
        algorithm, history = build_algorithm(settings), []
        problem = WalkerDesignProblem(settings)
        algorithm.setup(problem, termination=build_termination(settings), seed=settings.seed, verbose=False)
    cache = EvaluationCache(run_dir / JOURNAL_FILE, eval_hash)
    done_before = len(history)
    session_start = time.perf_counter()
    backend = None
    try:
        if not (checkpoint and checkpoint.get("finished")) and algorithm.has_next():
            backend = open_backend(evaluation_profile(profile), settings, workers, scheduler_address)
        batch = BatchEvaluator(settings, cache, backend)
        problem.metrics_source = batch
        outer = tqdm(total=settings.generations, initial=done_before, desc=f"campaign [{name}]", unit="gen",
                     file=sys.stderr, disable=not progress, dynamic_ncols=True)
        session_gens = 0
        while backend is not None and algorithm.has_next():
            if max_generations is not None and session_gens >= max_generations:
                break
            generation = len(history) + 1
            gen_start = time.perf_counter()
            pop = algorithm.ask()
            batch.generation = generation
            inner = tqdm(total=len(pop), desc=f"gen {generation}", unit="design", leave=False, file=sys.stderr,
                         disable=not progress, dynamic_ncols=True)

            def report(done, total, hits, bar=inner, t0=time.perf_counter()):
                bar.total = total + hits
                bar.n = done + hits
                rate = done / max(time.perf_counter() - t0, 1e-9)
                bar.set_postfix_str(f"{rate:.2f} designs/s, cache hits {hits}", refresh=True)

            batch.progress = report
            algorithm.evaluator.eval(problem, pop)
            algorithm.tell(infills=pop)
            inner.close()
            gen_wall = time.perf_counter() - gen_start
            records = list(cache.records.values())
            pop_keys = [tuple(int(v) for v in row) for row in np.rint(algorithm.pop.get("X"))]
            stats = _generation_stats(settings, records, pop_keys)
            if batch.last["errors"] and stats["n_evaluations_cum"] == sum(r["error"] for r in records):
                first = next(r for r in records if r["error"])
                raise RuntimeError(f"every evaluation so far failed; first: {first['reason']}")
            history.append({"generation": generation, "n_designs": len(pop), "n_evaluated": batch.last["evaluated"],
                            "n_cache_hits": batch.last["hits"], "n_errors": batch.last["errors"], **stats,
                            "wall_s": gen_wall,
                            "designs_per_s": batch.last["evaluated"] / gen_wall if gen_wall > 0 else 0.0})
            write_checkpoint(run_dir, generation, algorithm, history, not algorithm.has_next())
            session_gens += 1
            outer.update(1)
            outer.set_postfix_str(_progress_text(history[-1]))
        outer.close()
    finally:
        cache.close()
        resubmitted = getattr(backend, "resubmitted", 0)
        if backend is not None:
            backend.close()
    published = (OUTPUTS_DIR / name / "campaign").resolve()
    files = write_results(run_dir, published if run_dir.resolve().parent == published else None) if history else []
    return CampaignResult(run_dir=run_dir, files=files, generations=len(history),
                          n_evaluations=history[-1]["n_evaluations_cum"] if history else 0,
                          n_feasible=history[-1]["n_feasible_cum"] if history else 0,
                          wall_s=float(sum(h["wall_s"] for h in history)),
                          session_evaluations=batch.n_backend, session_wall_s=time.perf_counter() - session_start,
                          resubmitted=resubmitted)
