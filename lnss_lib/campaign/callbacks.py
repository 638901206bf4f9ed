"""Observers of a campaign run (pymoo's ``core/callback.py`` pattern): the runner loops, callbacks act.

:func:`~lnss_lib.campaign.runner.run_campaign` notifies each callback, in order, at the start of the
session, at the start of each generation, as designs finish and at the end of each generation; the
default chain is :class:`ErrorGuard`, :class:`HistoryRecorder`, :class:`Checkpointer` and (with
``progress``) :class:`ProgressBars`; extra callbacks passed to ``run_campaign`` (the notebooks'
:class:`CellProgressBar`) follow them and see the generation's finished history entry (``state.history[-1]``).
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..progress import CellProgress
from .fitness import (
    constraint_matrix,
    constraint_violation,
    front_of,
    hypervolume_of_front,
    hypervolume_points,
    metric_columns,
)
from .rundir import write_checkpoint
from .settings import CampaignPlan
from .timing import generation_timing

__all__ = [
    "Callback",
    "RunState",
    "CampaignStopped",
    "ErrorGuard",
    "HistoryRecorder",
    "Checkpointer",
    "ProgressBars",
    "CellProgressBar",
    "session_rate",
    "generation_stats",
    "RunningStats",
    "progress_text",
]


@dataclass
class RunState:
    """What a callback sees: the run, the algorithm and journal, and the current generation.

    ``generation`` (1-based), ``n_designs`` (population asked) and ``wall_s`` (the generation's wall
    time, set before :meth:`Callback.on_generation_end`) describe the generation in progress;
    ``history`` holds one dict per finished generation (checkpointed).
    """

    run_dir: Path
    name: str
    plan: CampaignPlan
    algorithm: object
    cache: object
    batch: object
    history: list[dict] = field(default_factory=list)
    generation: int = 0
    n_designs: int = 0
    wall_s: float = 0.0
    profile_hash: str | None = None
    asked_keys: list = field(default_factory=list)
    session_start: float = (
        0.0  # time.perf_counter() when this session started (before the backend opened)
    )


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


class RunningStats:
    """The per-generation statistics of a run (:func:`generation_stats`), kept up to date with the designs the journal
    gained since the last generation: counts, each design's constraint violation, the best value of each objective and
    the non-dominated feasible points of the hypervolume, so a generation costs its new designs, not every design so
    far (at generation 300 of a 120 x 1000 campaign, 35,000 designs: 17 s a generation before). Within a session the
    journal only grows (the batch evaluates designs it does not hold); a session starts from the whole journal."""

    def __init__(self, plan: CampaignPlan):
        self.plan = plan
        self.n_seen = 0
        self.n_feasible = 0
        self.violation: dict[tuple, tuple[float, bool]] = {}
        self.best: dict[str, float] = {}
        self.front = np.zeros((0, len(plan.hypervolume)))

    def update(self, records: list[dict]) -> None:
        """Take the records after the first ``n_seen`` of the journal's (insertion order)."""
        new = records[self.n_seen :]
        if not new:
            return
        plan = self.plan
        columns = metric_columns(new, plan.extra_metrics)
        cv = constraint_violation(constraint_matrix(columns, plan.constraints, plan.nan_violation))
        feasible = columns["ok"] & (cv == 0.0)
        self.violation.update(
            (tuple(r["key"]), (float(c), bool(f))) for r, c, f in zip(new, cv, feasible)
        )
        self.n_seen, self.n_feasible = len(records), self.n_feasible + int(feasible.sum())
        for name in plan.objectives:
            metric, larger = name.lstrip("-"), name.startswith("-")
            values = columns[metric][feasible].astype(float)
            values = values[np.isfinite(values)]
            if values.size:
                best = values.max() if larger else values.min()
                old = self.best.get(metric, math.nan)
                self.best[metric] = float(
                    best if math.isnan(old) else (max(old, best) if larger else min(old, best))
                )
        if plan.hypervolume and feasible.any():
            points = hypervolume_points(columns, feasible, plan.hypervolume)
            self.front = front_of(np.concatenate([self.front, points]))

    def stats(self, pop_keys: list[tuple]) -> dict:
        """The numbers of the history entry, for the population ``pop_keys``."""
        pop = [self.violation[k] for k in pop_keys]
        stats = {
            "n_evaluations_cum": self.n_seen,
            "n_feasible_cum": self.n_feasible,
            "n_feasible_pop": sum(f for _, f in pop),
            "min_cv_pop": min(c for c, _ in pop) if pop else math.nan,
            "hypervolume": hypervolume_of_front(self.front),
        }
        for name in self.plan.objectives:
            metric = name.lstrip("-")
            stats[f"best_{metric}"] = self.best.get(metric, math.nan)
        return stats


def generation_stats(plan: CampaignPlan, records: list[dict], pop_keys: list[tuple]) -> dict:
    """Deterministic per-generation numbers from the cache so far and the population's keys (:class:`RunningStats`
    over every record at once)."""
    running = RunningStats(plan)
    running.update(records)
    return running.stats(pop_keys)


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
        n_errors, limit = state.cache.n_errors, state.plan.max_errors
        if n_errors > limit:
            first = state.cache.first_error()
            design = dict(
                zip(
                    ("sma_km", "ecc", "aop_deg", "inc_deg", "n_planes", "sats_per_plane"),
                    state.plan.grid.descale(np.array([first["key"]], dtype=float))[0].tolist(),
                )
            )
            raise CampaignStopped(
                f"campaign stopped: {n_errors} evaluation error(s), more than campaign.max_errors = {limit}; first, "
                f"design {design}: {first['reason']}; every error is in {state.run_dir / 'evaluations.jsonl'}",
                errors=n_errors,
                first=first,
            )


class HistoryRecorder(Callback):
    """Appends the generation's counts, cache hits, errors, best values, hypervolume, throughput and
    per-design time split (:func:`~lnss_lib.campaign.timing.generation_timing`) to ``state.history``. Its
    ``wall_s`` is the generation's evaluation wall time plus these statistics over every design so far, which grow
    with the run (a 1000-generation run's numbers are its wall time, not the evaluations' alone)."""

    def on_session_start(self, state: RunState) -> None:
        self.running = RunningStats(state.plan)  # from the whole journal at the first generation

    def on_generation_end(self, state: RunState) -> None:
        start = time.perf_counter()
        records = list(state.cache.records.values())
        pop_keys = [tuple(int(v) for v in row) for row in np.rint(state.algorithm.pop.get("X"))]
        self.running.update(records)
        stats = self.running.stats(pop_keys)
        wall = state.wall_s + (time.perf_counter() - start)
        last = state.batch.last
        state.history.append(
            {
                "generation": state.generation,
                "n_designs": state.n_designs,
                "n_evaluated": last["evaluated"],
                "n_cache_hits": last["hits"],
                "n_errors": last["errors"],
                "n_errors_cum": state.cache.n_errors,
                **stats,
                "wall_s": wall,
                "designs_per_s": last["evaluated"] / wall if wall > 0 else 0.0,
                **generation_timing(
                    records, state.generation, getattr(state.batch.backend, "n_workers", 1), wall
                ),
            }
        )


class Checkpointer(Callback):
    """Writes ``checkpoint.pkl`` (algorithm and history) after every generation, atomically."""

    def on_generation_end(self, state: RunState) -> None:
        write_checkpoint(
            state.run_dir,
            state.generation,
            state.algorithm,
            state.history,
            not state.algorithm.has_next(),
            state.profile_hash,
            state.asked_keys,
        )


BAR_COLUMNS = 80  # the widest a progress line gets (narrower terminals: their width)
OUTER_FORMAT = "{desc} {n_fmt}/{total_fmt} gen {percentage:3.0f}% {elapsed}<{remaining}{postfix}"
INNER_FORMAT = "  generation {desc}: {n_fmt}/{total_fmt} designs |{bar:10}| {elapsed}{postfix}"


def session_rate(state: RunState) -> float:
    """Designs evaluated per second in this session so far: the rate the campaign's closing summary prints."""
    elapsed = time.perf_counter() - state.session_start
    return state.batch.n_backend / elapsed if elapsed > 0 else 0.0


class ProgressBars(Callback):
    """tqdm bars on stderr, at most :data:`BAR_COLUMNS` wide: generations of the run and, on a terminal,
    designs of the generation in progress (piped, one line per generation). Both show the session's
    designs per second, the rate the closing summary reports."""

    def __init__(self):
        self.outer = None
        self.inner = None

    @staticmethod
    def _columns() -> int:
        return min(BAR_COLUMNS, shutil.get_terminal_size((BAR_COLUMNS, 24)).columns)

    def on_session_start(self, state: RunState) -> None:
        from tqdm import tqdm

        self.outer = tqdm(
            total=state.plan.generations,
            initial=len(state.history),
            desc=state.name,
            file=sys.stderr,
            ncols=self._columns(),
            bar_format=OUTER_FORMAT,
        )

    def on_generation_start(self, state: RunState) -> None:
        from tqdm import tqdm

        if sys.stderr.isatty():
            self.inner = tqdm(
                total=state.n_designs,
                desc=str(state.generation),
                leave=False,
                file=sys.stderr,
                ncols=self._columns(),
                bar_format=INNER_FORMAT,
            )

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        if self.inner is None:
            return
        self.inner.total = n_total + n_hits
        self.inner.n = n_done + n_hits
        self.inner.set_postfix_str(
            f"{session_rate(state):.2f} designs/s" + (f", {n_hits} cached" if n_hits else ""),
            refresh=True,
        )

    def on_generation_end(self, state: RunState) -> None:
        if self.inner is not None:
            self.inner.close()
            self.inner = None
        self.outer.set_postfix_str(
            progress_text(state.history[-1], session_rate(state)), refresh=False
        )
        self.outer.update(1)

    def on_session_end(self, state: RunState) -> None:
        self.outer.close()

    def close(self) -> None:
        """Close the bars after an error (the runner calls this when the session ends early)."""
        for bar in (self.inner, self.outer):
            if bar is not None:
                bar.close()


class CellProgressBar(Callback):
    """The run below a running notebook cell (:class:`lnss_lib.progress.CellProgress`, nothing outside a
    kernel): generations done, then the generation in progress (designs done, the session's designs per
    second) or the last one's :func:`progress_text`; cleared when the session ends."""

    def __init__(self):
        self.bar = None

    def on_session_start(self, state: RunState) -> None:
        self.bar = CellProgress(
            state.plan.generations,
            f"campaign {state.name}",
            "generations",
            initial=len(state.history),
        )

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        self.bar.update(
            0,
            f"generation {state.generation}: {n_done + n_hits}/{n_total + n_hits} designs, "
            f"{session_rate(state):.2f} designs/s",
        )

    def on_generation_end(self, state: RunState) -> None:
        self.bar.update(1, progress_text(state.history[-1], session_rate(state)))

    def on_session_end(self, state: RunState) -> None:
        self.close()

    def close(self) -> None:
        """Clear the bar (also after an error: the runner calls this when the session ends early)."""
        if self.bar is not None:
            self.bar.close()


def progress_text(entry: dict, designs_per_s: float) -> str:
    """Progress-line summary of one history entry, most telling first (a narrow terminal cuts the tail):
    the session's designs per second, designs meeting every bound so far and, while there is none, the
    population's smallest constraint violation (how far the best design is from feasible), then errors."""
    text = f"{designs_per_s:.2f} designs/s, {entry['n_feasible_cum']} feasible"
    if entry["n_feasible_cum"] == 0:
        text += f", violation {entry['min_cv_pop']:.2g}"
    return text + (f", {entry['n_errors']} errors" if entry["n_errors"] else "")
