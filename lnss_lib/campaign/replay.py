"""Replay: what a cluster of N workers would make of recorded campaigns, measured with sleeping tasks.

A run's journal (``evaluations.jsonl``) holds what each design cost where it ran (``task_wall_s``) and the
generation that asked for it. :func:`replay` sends those costs, generation after generation, through the campaign's
own Dask backend (:class:`~lnss_lib.campaign.backends.DaskBackend`: largest constellations first, guided batches,
two in flight per worker) to a local cluster of ``n_workers`` threads, where each task sleeps its design's cost
(times ``time_scale``); every campaign waits for its whole generation before the next, as NSGA-II does, and the
campaigns of a study run side by side. What it measures is the wall time the cluster takes, scheduling and
dispatch included, and the share of it the workers spent busy. It leaves out the campaign's own work between
generations (NSGA-II, the checkpoint): a few milliseconds per generation against its designs' seconds.

The replay's one process hands out every task, so where tasks are short and workers many it measures its own
dispatch: on 16 idle cores, 40 generations of a ``paper_dv_physical`` campaign that ran in 49 s on 16 worker
processes did not replay at 16 workers within 75 s. :func:`simulate` schedules the same batches in the same order on
``n_workers`` without running anything (a worker pays ``dispatch_s`` per batch, nothing else): where the replay is a
lower bound on the busy fraction, the simulation is an upper one.
"""

from __future__ import annotations

import collections
import heapq
import itertools
import math
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from .backends import DaskBackend, guided_batches
from .costs import COSTS_FILE, journal_costs, read_costs
from .rundir import RUN_FILE
from .study import STUDY_FILE

__all__ = [
    "journal_costs",
    "recorded_costs",
    "replay",
    "Replay",
    "simulate",
    "sleep_task",
    "time_scale_for",
]

# A task the cluster drops (on a machine whose cores are busy, a client's heartbeat can come late and the scheduler
# releases what it sent) is sent again, as the campaign does; its time lost counts in the replay's wall time.
REPLAY_RESUBMITS = 3


def recorded_costs(source) -> dict[str, list[list[dict]]]:
    """:func:`journal_costs` of a campaign's run folder (``{its name: costs}``), of every campaign of a study's
    folder (``{campaign: costs}``, those started so far), or the campaigns of a shipped ``costs.nc``
    (:func:`~lnss_lib.campaign.costs.read_costs`); ConfigError for anything else."""
    source = Path(source)
    if source.is_file() and source.name.endswith(".nc"):
        return read_costs(source)
    if (source / RUN_FILE).is_file():
        return {source.name: journal_costs(source)}
    if (source / STUDY_FILE).is_file():
        return {
            run.parent.name: journal_costs(run.parent)
            for run in sorted(source.glob(f"*/{RUN_FILE}"))
        }
    raise ConfigError(
        f"--replay {source}: neither a campaign run folder ({RUN_FILE}), a study folder ({STUDY_FILE}) nor a "
        f"costs file ({COSTS_FILE})",
        key="--replay",
    )


def time_scale_for(campaigns: list[list[list[dict]]], n_workers: int, tasks_per_s: float) -> float:
    """The time scale at which a replay of ``campaigns`` on ``n_workers`` sends about ``tasks_per_s`` tasks a second
    (the backend's guided batches of each generation, :func:`~lnss_lib.campaign.backends.guided_batches`): its
    tasks over ``tasks_per_s`` is the replay's wall time. Each task costs the replay's one process milliseconds of
    CPU (scheduler, workers and clients share it), so a replay that sent its tasks faster than that process can hand
    them out would measure itself, not the schedule; short designs on many workers then sleep longer than they ran
    (scale above 1)."""
    tasks, cost_s = 0, 0.0
    for generations in campaigns:
        for items in generations:
            n_sat = sorted(
                (item["n_planes"] * item["sats_per_plane"] for item in items), reverse=True
            )
            tasks += len(guided_batches(n_sat, n_workers))
            cost_s += sum(item["cost_s"] for item in items)
    return tasks * n_workers / (tasks_per_s * cost_s)


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
    import dask
    from dask.distributed import LocalCluster

    if not (isinstance(n_workers, int) and n_workers >= 1):
        raise ValueError(f"n_workers must be an integer >= 1; got {n_workers!r}")
    if not time_scale > 0.0:
        raise ValueError(f"time_scale must be > 0; got {time_scale!r}")
    # The workers share this process: each one's default share of the memory (1/128 of it at 128 workers) is below
    # the process's size, and a worker above its share pauses; their stack profilers (every 10 ms each), system
    # monitors (every 0.5 s each, counting the process's open files, more with every worker) and the GIL monitor
    # would take the CPU the dispatch needs.
    quiet = {
        "distributed.worker.profile.enabled": False,
        "distributed.admin.system-monitor.gil.enabled": False,
        "distributed.admin.system-monitor.interval": "1h",
    }
    with warnings.catch_warnings(), dask.config.set(quiet):
        # the scheduler's HTTP port moves aside when another cluster holds 8787
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        cluster = LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=False,
            protocol="tcp",
            host="127.0.0.1",
            dashboard_address=None,
            memory_limit=0,
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
                    max_resubmits=REPLAY_RESUBMITS,
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


def simulate(campaigns: list[list[list[dict]]], n_workers: int, dispatch_s: float = 0.0) -> Replay:
    """The schedule :func:`replay` measures, computed: each campaign's generation, largest constellations first, in
    :func:`~lnss_lib.campaign.backends.guided_batches` as :meth:`DaskBackend.run` cuts it, queues when the
    campaign's previous generation has finished; a free worker takes the oldest queued batch and is busy for
    ``dispatch_s`` plus its designs' costs. Nothing runs, so 1000 generations of 8 campaigns on 128 workers take
    seconds; what it leaves out (the scheduler's and clients' own time beyond ``dispatch_s``) makes its busy
    fraction an upper bound."""
    if not (isinstance(n_workers, int) and n_workers >= 1):
        raise ValueError(f"n_workers must be an integer >= 1; got {n_workers!r}")
    if not (math.isfinite(dispatch_s) and dispatch_s >= 0.0):
        raise ValueError(f"dispatch_s must be finite and >= 0; got {dispatch_s!r}")
    order = itertools.count()  # ties in time go to the batch queued first
    queue: collections.deque = collections.deque()
    running: list[tuple[float, int, int]] = []
    generation, batches_left = [0] * len(campaigns), [0] * len(campaigns)

    def enqueue(c: int) -> None:
        """Queue campaign ``c``'s next generation that asks for designs (one answered by the journal alone
        costs nothing)."""
        while generation[c] < len(campaigns[c]) and not campaigns[c][generation[c]]:
            generation[c] += 1
        if generation[c] == len(campaigns[c]):
            return
        items = sorted(
            campaigns[c][generation[c]], key=lambda i: -i["n_planes"] * i["sats_per_plane"]
        )
        cuts = guided_batches([i["n_planes"] * i["sats_per_plane"] for i in items], n_workers)
        batches_left[c] = len(cuts)
        queue.extend((c, sum(items[j]["cost_s"] for j in cut)) for cut in cuts)

    for c in range(len(campaigns)):
        enqueue(c)
    now, idle = 0.0, n_workers
    while queue or running:
        while idle and queue:
            c, cost_s = queue.popleft()
            idle -= 1
            heapq.heappush(running, (now + dispatch_s + cost_s, next(order), c))
        now, _, c = heapq.heappop(running)
        idle += 1
        batches_left[c] -= 1
        if batches_left[c] == 0:
            generation[c] += 1
            enqueue(c)
    items = [item for generations in campaigns for generation in generations for item in generation]
    return Replay(
        n_workers=n_workers,
        n_campaigns=len(campaigns),
        n_designs=len(items),
        wall_s=now,
        cost_s=sum(item["cost_s"] for item in items),
    )
