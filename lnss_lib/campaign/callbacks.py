"""Observers of a campaign run (pymoo's ``core/callback.py`` pattern): the runner loops, callbacks act.

:func:`~lnss_lib.campaign.runner.run_campaign` notifies each callback, in order, at the start of the
session, at the start of each generation, as designs finish and at the end of each generation; the
default chain is :class:`ErrorGuard`, :class:`HistoryRecorder`, :class:`Checkpointer` and (with
``progress``) :class:`ProgressBars`; extra callbacks passed to ``run_campaign`` follow them and see
the generation's finished history entry (``state.history[-1]``).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .fitness import constraint_matrix, constraint_violation, hypervolume, metric_columns
from .rundir import write_checkpoint
from .settings import CampaignSettings
from .timing import generation_timing, timing_text

__all__ = ["Callback", "RunState", "CampaignStopped", "ErrorGuard", "HistoryRecorder", "Checkpointer", "ProgressBars",
           "generation_stats", "progress_text"]


@dataclass
class RunState:
    """What a callback sees: the run, the algorithm and journal, and the current generation.

    ``generation`` (1-based), ``n_designs`` (population asked) and ``wall_s`` (the generation's wall
    time, set before :meth:`Callback.on_generation_end`) describe the generation in progress;
    ``history`` holds one dict per finished generation (checkpointed).
    """

    run_dir: Path
    name: str
    settings: CampaignSettings
    algorithm: object
    cache: object
    batch: object
    history: list[dict] = field(default_factory=list)
    generation: int = 0
    n_designs: int = 0
    wall_s: float = 0.0
    profile_hash: str | None = None
    asked_keys: list = field(default_factory=list)


class Callback:
    """Base observer: every hook is optional and does nothing here."""

    def on_session_start(self, state: RunState) -> None:
        """Before the first generation of this session (also when resuming)."""

    def on_generation_start(self, state: RunState) -> None:
        """After the algorithm asked for ``state.n_designs`` designs of ``state.generation``."""

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        """As designs finish: ``n_done`` of ``n_total`` new designs, ``n_hits`` served by the journal."""

    def on_generation_end(self, state: RunState) -> None:
        """After the algorithm was told the generation's fitness; ``state.wall_s`` is set."""

    def on_session_end(self, state: RunState) -> None:
        """After the last generation of this session."""


def generation_stats(settings: CampaignSettings, records: list[dict], pop_keys: list[tuple]) -> dict:
    """Deterministic per-generation numbers from the cache so far and the population's keys."""
    columns = metric_columns(records, settings.extra_metrics)
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


class CampaignStopped(RuntimeError):
    """The run stopped because evaluations raised (``errors`` of them; ``first`` their first record)."""

    def __init__(self, message: str, *, errors: int, first: dict | None):
        super().__init__(message)
        self.errors = errors
        self.first = first


class ErrorGuard(Callback):
    """Stops the run (:class:`CampaignStopped`) as soon as more evaluations raised than
    ``campaign.max_errors`` allows (default 0: the first error, in generation 1 or later, stops it).

    An evaluation that raises is an error, never an infeasible design: it points at the evaluator or
    the settings (a bad gain file, a NaN constant), so the run stops instead of optimising around it.
    """

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        self._check(state)

    def on_generation_end(self, state: RunState) -> None:
        self._check(state)

    @staticmethod
    def _check(state: RunState) -> None:
        n_errors, limit = state.cache.n_errors, state.settings.max_errors
        if n_errors > limit:
            first = state.cache.first_error()
            design = dict(zip(("sma_km", "ecc", "aop_deg", "inc_deg", "n_planes", "sats_per_plane"),
                              state.settings.grid.descale(np.array([first["key"]], dtype=float))[0].tolist()))
            raise CampaignStopped(
                f"campaign stopped: {n_errors} evaluation error(s), more than campaign.max_errors = {limit}; first, "
                f"design {design}: {first['reason']}; every error is in {state.run_dir / 'evaluations.jsonl'}",
                errors=n_errors, first=first)


class HistoryRecorder(Callback):
    """Appends the generation's counts, cache hits, errors, best values, hypervolume, throughput and
    per-design time split (:func:`~lnss_lib.campaign.timing.generation_timing`) to ``state.history``."""

    def on_generation_end(self, state: RunState) -> None:
        records = list(state.cache.records.values())
        pop_keys = [tuple(int(v) for v in row) for row in np.rint(state.algorithm.pop.get("X"))]
        stats = generation_stats(state.settings, records, pop_keys)
        last = state.batch.last
        state.history.append({"generation": state.generation, "n_designs": state.n_designs,
                              "n_evaluated": last["evaluated"], "n_cache_hits": last["hits"],
                              "n_errors": last["errors"], "n_errors_cum": state.cache.n_errors, **stats, "wall_s": state.wall_s,
                              "designs_per_s": last["evaluated"] / state.wall_s if state.wall_s > 0 else 0.0,
                              **generation_timing(records, state.generation,
                                                  getattr(state.batch.backend, "n_workers", 1), state.wall_s)})


class Checkpointer(Callback):
    """Writes ``checkpoint.pkl`` (algorithm and history) after every generation, atomically."""

    def on_generation_end(self, state: RunState) -> None:
        write_checkpoint(state.run_dir, state.generation, state.algorithm, state.history,
                         not state.algorithm.has_next(), state.profile_hash, state.asked_keys)


class ProgressBars(Callback):
    """tqdm bars on stderr: generations of the run, and designs of the generation in progress."""

    def __init__(self):
        self.outer = None
        self.inner = None
        self.t0 = 0.0

    def on_session_start(self, state: RunState) -> None:
        from tqdm import tqdm

        self.outer = tqdm(total=state.settings.generations, initial=len(state.history),
                          desc=f"campaign [{state.name}]", unit="gen", file=sys.stderr, dynamic_ncols=True)

    def on_generation_start(self, state: RunState) -> None:
        from tqdm import tqdm

        self.inner = tqdm(total=state.n_designs, desc=f"gen {state.generation}", unit="design", leave=False,
                          file=sys.stderr, dynamic_ncols=True)
        self.t0 = time.perf_counter()

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        self.inner.total = n_total + n_hits
        self.inner.n = n_done + n_hits
        rate = n_done / max(time.perf_counter() - self.t0, 1e-9)
        errors = state.cache.n_errors
        self.inner.set_postfix_str(f"{rate:.2f} designs/s, cache hits {n_hits}"
                                   + (f", evaluation errors {errors}" if errors else ""), refresh=True)

    def on_generation_end(self, state: RunState) -> None:
        self.inner.close()
        self.outer.update(1)
        self.outer.set_postfix_str(progress_text(state.history[-1]))

    def on_session_end(self, state: RunState) -> None:
        self.outer.close()

    def close(self) -> None:
        """Close the bars after an error (the runner calls this when the session ends early)."""
        for bar in (self.inner, self.outer):
            if bar is not None:
                bar.close()


def progress_text(entry: dict) -> str:
    """Progress-bar summary of one history entry: throughput, cache hits, feasibility, best values."""
    text = (f"{entry['designs_per_s']:.2f} designs/s, hits {entry['n_cache_hits']}, feasible "
            f"{entry['n_feasible_pop']}/{entry['n_designs']} (all {entry['n_feasible_cum']}), "
            f"min cv {entry['min_cv_pop']:.3g}" + (f", errors {entry['n_errors']}" if entry["n_errors"] else ""))
    best = [f"{key[5:]} {entry[key]:.3g}" for key in ("best_n_sat", "best_pdop_mean_3sigma", "best_dv_opt_kms_per_year")
            if key in entry and math.isfinite(entry[key])]
    timing = timing_text(entry)
    return text + (f", best {', '.join(best)}" if best else "") + (f", {timing}" if timing else "")
