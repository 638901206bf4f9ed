"""Replay: what a cluster of N workers would make of recorded campaigns, measured with sleeping tasks.

A run's journal (``evaluations.jsonl``) holds what each design cost where it ran (``task_wall_s``) and the
generation that asked for it. :func:`replay` sends those costs, generation after generation, through the campaign's
own Dask backend (:class:`~lnss_lib.campaign.backends.DaskBackend`: largest constellations first, guided batches,
two in flight per worker) to a local cluster of ``n_workers`` threads, where each task sleeps its design's cost
(times ``time_scale``); every campaign waits for its whole generation before the next, as NSGA-II does, and the
campaigns of a study run side by side. What it measures is the wall time the cluster takes, scheduling and
dispatch included, and the share of it the workers spent busy. It leaves out the campaign's own work between
generations (NSGA-II, the checkpoint): a few milliseconds per generation against its designs' seconds.
"""

from __future__ import annotations

import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from .backends import DaskBackend
from .journal import read_cache_records
from .rundir import RUN_FILE
from .study import STUDY_FILE

__all__ = ["journal_costs", "recorded_costs", "replay", "Replay", "sleep_task"]


def journal_costs(run_dir) -> list[list[dict]]:
    """Per generation of the run in ``run_dir`` (first to last), one item per design first evaluated in it:
    ``{"n_planes", "sats_per_plane", "cost_s"}`` (the task's wall time on its worker; the grid's scaled
    ``n_planes`` and ``sats_per_plane``, which order the designs as the campaign does)."""
    records = read_cache_records(Path(run_dir))
    generations: dict[int, list[dict]] = {}
    for record in sorted(records, key=lambda r: (r["generation"], r["order"])):
        key = record["key"]
        generations.setdefault(int(record["generation"]), []).append(
            {
                "n_planes": int(key[4]),
                "sats_per_plane": int(key[5]),
                "cost_s": float(record["task_wall_s"]),
            }
        )
    return [generations[g] for g in sorted(generations)]


def recorded_costs(folder) -> dict[str, list[list[dict]]]:
    """:func:`journal_costs` of a campaign's run folder (``{its name: costs}``) or of every campaign of a study's
    folder (``{campaign: costs}``, those started so far); ConfigError for any other folder."""
    folder = Path(folder)
    if (folder / RUN_FILE).is_file():
        return {folder.name: journal_costs(folder)}
    if (folder / STUDY_FILE).is_file():
        return {
            run.parent.name: journal_costs(run.parent)
            for run in sorted(folder.glob(f"*/{RUN_FILE}"))
        }
    raise ConfigError(
        f"--replay {folder}: neither a campaign run folder ({RUN_FILE}) nor a study folder "
        f"({STUDY_FILE})",
        key="--replay",
    )


def sleep_task(time_scale: float, item: dict, numba_threads: int = 0) -> float:
    """A replayed design: sleep its cost times ``time_scale``; returns the cost slept (s, unscaled)."""
    time.sleep(item["cost_s"] * time_scale)
    return item["cost_s"]


@dataclass(frozen=True)
class Replay:
    """A replay's result at ``n_workers``: the projected wall time (s, the replay's divided by its time scale), the
    designs' total cost (s of worker time) and the busy fraction, cost over workers times wall time."""

    n_workers: int
    n_campaigns: int
    n_designs: int
    wall_s: float
    cost_s: float

    @property
    def busy_fraction(self) -> float:
        return self.cost_s / (self.n_workers * self.wall_s) if self.wall_s > 0 else 0.0


def replay(campaigns: list[list[list[dict]]], n_workers: int, time_scale: float = 1.0) -> Replay:
    """Replay ``campaigns`` (each a list of generations of :func:`journal_costs` items) side by side on a local
    cluster of ``n_workers`` single-thread workers (this process), each task sleeping its cost times ``time_scale``
    (0 < scale; below 1 the replay runs faster than the run and the dispatch weighs more)."""
    from dask.distributed import LocalCluster

    if not (isinstance(n_workers, int) and n_workers >= 1):
        raise ValueError(f"n_workers must be an integer >= 1; got {n_workers!r}")
    if not time_scale > 0.0:
        raise ValueError(f"time_scale must be > 0; got {time_scale!r}")
    with (
        warnings.catch_warnings()
    ):  # the scheduler's HTTP port moves aside when another cluster holds 8787
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        cluster = LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=False,
            protocol="tcp",
            host="127.0.0.1",
            dashboard_address=None,
        )
    errors: list[BaseException] = []
    backends = []

    def one(backend: DaskBackend, generations: list[list[dict]]) -> None:
        try:
            for items in generations:
                for _ in backend.run(items, guided=True):
                    pass
        except BaseException as error:
            errors.append(error)

    try:
        for _ in campaigns:  # connected (and the workers checked) before the clock starts
            backends.append(
                DaskBackend(
                    time_scale,
                    sleep_task,
                    max_resubmits=0,
                    scheduler_address=cluster.scheduler_address,
                )
            )
        threads = [threading.Thread(target=one, args=pair) for pair in zip(backends, campaigns)]
        start = time.perf_counter()
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        wall_s = time.perf_counter() - start
    finally:
        for backend in backends:
            backend.close()
        cluster.close()
    if errors:
        raise errors[0]
    items = [item for generations in campaigns for generation in generations for item in generation]
    return Replay(
        n_workers=n_workers,
        n_campaigns=len(campaigns),
        n_designs=len(items),
        wall_s=wall_s / time_scale,
        cost_s=sum(item["cost_s"] for item in items),
    )
