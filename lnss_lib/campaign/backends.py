"""Where tasks run: in this process or on a Dask cluster; the batch evaluator of the campaign.

A backend runs one task function over a list of items (design dicts): ``task(shared, item, numba_threads=n)``,
``shared`` sent once to every worker (the evaluation settings). The campaign's task is
:func:`~lnss_lib.campaign.tasks.evaluate_task` (:func:`campaign_task`), the front validation's
:func:`~lnss_lib.campaign.validation.validation_task`. Each worker builds its
:class:`~lnss_lib.evaluator.EvaluationContext` once (:func:`~lnss_lib.evaluator.context_for`) and reuses it. A task
whose worker is lost is resubmitted.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import signal
import threading
import time
import warnings
from collections.abc import Callable

import numpy as np

from ..errors import ConfigError, WorkerMismatchError
from .fitness import metric_columns
from .journal import EvaluationCache
from .settings import CampaignPlan
from .tasks import evaluate_task

__all__ = [
    "SerialBackend",
    "DaskBackend",
    "open_backend",
    "usable_cores",
    "check_scheduler_address",
    "start_local_cluster",
    "connect_scheduler",
    "check_workers",
    "worker_fingerprint",
    "SCHEDULER_TIMEOUT_S",
    "campaign_task",
    "BatchEvaluator",
    "guided_batches",
    "early_stop_bounds",
]


def campaign_task(plan: CampaignPlan) -> Callable:
    """The campaign's task: :func:`~lnss_lib.campaign.tasks.evaluate_task` with the plan's evaluator."""
    return functools.partial(
        evaluate_task, evaluator=plan.evaluator, synthetic_delay_s=plan.synthetic_delay_s
    )


# Guided batches on the campaign's backend: each batch the remaining cost over twice the workers, two batches per
# worker in flight (a worker never waits for the next one to be sent). Measured on 111 designs of a late generation
# of the paper_dv_physical campaign, 2 workers on 2 cores (one Dask task per design, all sent at once: 4.98 s; these
# batches: 4.59 s; four times the workers: 4.69 s; one batch in flight per worker: 4.73 s).
GUIDED_SHARE = 2
IN_FLIGHT_PER_WORKER = 2


def run_batch(task: Callable, shared, items: list[dict], numba_threads: int = 0) -> list:
    """``task(shared, item, numba_threads=numba_threads)`` for each item, in order: one Dask task."""
    return [task(shared, item, numba_threads=numba_threads) for item in items]


def guided_batches(
    costs: list[float], n_workers: int, share: int = GUIDED_SHARE
) -> list[list[int]]:
    """Indices of ``costs`` (in that order) cut into consecutive batches of guided self-scheduling (Polychronopoulos
    & Kuck 1987), weighted by cost: each batch takes items until it holds the remaining cost over ``share`` times
    ``n_workers`` (at least one item), so batches shrink to single items at the end and the last to finish are
    small."""
    batches, start = [], 0
    remaining = float(sum(costs))
    while start < len(costs):
        target, end, held = remaining / (share * max(1, n_workers)), start, 0.0
        while end < len(costs) and (end == start or held + costs[end] <= target):
            held += costs[end]
            end += 1
        batches.append(list(range(start, end)))
        remaining -= held
        start = end
    return batches


class SerialBackend:
    """Runs ``task(shared, item, numba_threads=0)`` for one item after the other in this process."""

    n_workers = 1
    resubmitted = 0

    def __init__(self, shared, task: Callable):
        self.shared, self.task = shared, task

    def run(self, items: list[dict], guided: bool = False):
        """Yield ``(index, result)`` for each item as it finishes (``guided``: as :meth:`DaskBackend.run`; here
        there is nothing to batch)."""
        for index, item in enumerate(items):
            yield index, self.task(self.shared, item, numba_threads=0)

    def close(self) -> None:
        return None


def dask_setup(worker) -> None:
    """Dask preload hook (``LocalCluster(preload=[__name__])``), run in each local worker process as it starts, the
    first ones and any its nanny restarts: ignore SIGINT, so that Ctrl-C in a terminal (sent to the whole process
    group) stops only the campaign's process, which then closes the cluster, instead of printing a KeyboardInterrupt
    traceback from every worker."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _sigint_deferred():
    """Hold a Ctrl-C (SIGINT) back while local workers start and raise it (KeyboardInterrupt) once they are up, so that
    the caller closes a whole cluster rather than leave one half started; before, SIGINT was ignored meanwhile and
    the Ctrl-C lost."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def start_local_cluster(n_workers: int | None):
    """A Dask cluster on this machine: ``n_workers`` processes (None: one per core), one thread each, on
    127.0.0.1, without a dashboard; Ctrl-C reaches only this process (every worker, a restarted one too, ignores it:
    :func:`dask_setup`), and one pressed while the workers start is raised once they are up, the cluster closed
    (:func:`_sigint_deferred`)."""
    import logging

    from dask.distributed import LocalCluster

    cluster = None
    try:
        with _sigint_deferred(), warnings.catch_warnings():
            # the scheduler's HTTP port (no dashboard here) moves aside when another cluster holds 8787
            warnings.filterwarnings(
                "ignore", message="Port .* is already in use", category=UserWarning
            )
            cluster = LocalCluster(
                n_workers=n_workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                preload=[__name__],
                silence_logs=logging.CRITICAL,
            )  # task errors come back through the futures
    except KeyboardInterrupt:
        if cluster is not None:
            cluster.close()
        raise
    return cluster


def connect_scheduler(scheduler_address: str):
    """A Dask client of the scheduler at ``scheduler_address`` whose workers all compute what this process computes
    (:func:`check_workers`); RuntimeError when none answers within :data:`SCHEDULER_TIMEOUT_S`. Not the default
    client: xarray would then write NetCDF files under the cluster's locks (campaigns of a study share a process)."""
    from dask.distributed import Client

    try:
        client = Client(
            check_scheduler_address(scheduler_address),
            timeout=SCHEDULER_TIMEOUT_S,
            set_as_default=False,
        )
    except OSError as error:  # TimeoutError included: nothing answers at the address
        raise RuntimeError(
            f"--scheduler-address {scheduler_address}: no Dask scheduler answered within "
            f"{SCHEDULER_TIMEOUT_S} s ({type(error).__name__}); start one (dask scheduler) or "
            f"drop --scheduler-address for a local cluster"
        ) from None
    try:
        check_workers(client)
    except BaseException:
        client.close()
        raise
    return client


def worker_fingerprint() -> dict[str, str]:
    """What fixes a process's results: Python's and the packages' versions, the processor model the kernels are
    compiled for (:func:`~lnss_lib.provenance.package_versions`) and the digest of the workbook's sources
    (:func:`~lnss_lib.source_digest`, the key of the compiled-kernel cache)."""
    from .. import source_digest
    from ..config import PACKAGE_DIR
    from ..provenance import package_versions

    return {**package_versions(), "lnss_lib sources": source_digest(PACKAGE_DIR)}


def check_workers(client) -> None:
    """Refuse (:class:`~lnss_lib.errors.WorkerMismatchError`) a cluster with a worker whose
    :func:`worker_fingerprint` is not this process's: its designs would differ from a serial run's (other
    round-off, other code), or it cannot import the workbook at all."""
    here = worker_fingerprint()
    for worker, theirs in sorted(client.run(worker_fingerprint, on_error="return").items()):
        if isinstance(theirs, BaseException):
            differences = {"lnss_lib": (f"{type(theirs).__name__}: {theirs}", "importable")}
        else:
            differences = {
                k: (theirs.get(k, "absent"), v) for k, v in here.items() if theirs.get(k) != v
            }
        if differences:
            listed = "; ".join(
                f"{k} {mine} (here {ours})" for k, (mine, ours) in differences.items()
            )
            raise WorkerMismatchError(
                f"Dask worker {worker} is refused: it differs from this process in {listed}; "
                f"its designs would not be those of a serial run. Start every worker from this "
                f"environment (same packages, same workbook, same NUMBA_CPU_NAME)",
                worker=worker,
                differences=differences,
            )


class DaskBackend:
    """Runs ``task(shared, item, numba_threads=numba_threads)`` as tasks on a Dask cluster: a new local one
    (``n_workers`` processes, one thread each, on 127.0.0.1) or an existing one at ``scheduler_address``. A task
    lost with its worker (KilledWorker, closed connection, cancelled) is resubmitted up to ``max_resubmits`` times."""

    def __init__(
        self,
        shared,
        task: Callable,
        *,
        max_resubmits: int,
        numba_threads: int = 0,
        n_workers: int | None = None,
        scheduler_address: str | None = None,
    ):
        from dask.distributed import Client

        self.cluster = None
        if scheduler_address:
            self.client = connect_scheduler(scheduler_address)
        else:
            self.cluster = start_local_cluster(n_workers)
            self.client = Client(self.cluster, set_as_default=False)
        self.n_workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        self.shared, self.task = shared, task
        self.max_resubmits, self.numba_threads = max_resubmits, numba_threads
        self.resubmitted = 0
        self._scatter()

    def _scatter(self) -> None:
        """Send the shared settings to every worker once (tasks then carry a reference, not 14 kB each);
        again after a task is lost, since the copies may have gone with its worker."""
        self.shared_future = self.client.scatter(self.shared, broadcast=True, hash=False)

    def _submit(self, items: list[dict]):
        return self.client.submit(
            run_batch,
            self.task,
            self.shared_future,
            items,
            numba_threads=self.numba_threads,
            pure=False,
        )

    def run(self, designs: list[dict], guided: bool = False):
        """Yield ``(index, result)`` for each design as it finishes (completion order), largest constellations
        first. ``guided``: designs go in :func:`guided_batches` weighted by satellite count, each batch one task,
        :data:`IN_FLIGHT_PER_WORKER` per worker sent at a time and the next as one returns (so the scheduler places
        each where a worker is free); a Dask task costs its scheduler and worker milliseconds of CPU that a short
        evaluation on a machine without a spare core pays in full. Otherwise one task per design, all sent."""
        from dask.distributed import as_completed

        if not designs:
            return
        by_cost = sorted(
            range(len(designs)),
            key=lambda i: -designs[i]["n_planes"] * designs[i]["sats_per_plane"],
        )
        if guided:
            cuts = guided_batches(
                [designs[i]["n_planes"] * designs[i]["sats_per_plane"] for i in by_cost],
                self.n_workers,
            )
            batches = [[by_cost[j] for j in cut] for cut in cuts]
            in_flight = IN_FLIGHT_PER_WORKER * self.n_workers
        else:
            batches, in_flight = [[i] for i in by_cost], len(by_cost)
        futures = {
            self._submit([designs[i] for i in batches[b]]): b
            for b in range(min(in_flight, len(batches)))
        }
        waiting = iter(range(len(futures), len(batches)))
        attempts = [0] * len(batches)
        queue = as_completed(list(futures), loop=self.client.loop)
        for future in queue:
            b = futures.pop(future)
            batch = batches[b]
            try:
                records = future.result()
            except (
                Exception
            ) as exc:  # worker lost or task cancelled: resubmit (the tasks themselves never raise)
                attempts[b] += 1
                if attempts[b] > self.max_resubmits:
                    raise RuntimeError(
                        f"designs {[designs[i] for i in batch]} failed {attempts[b]} times on the "
                        f"cluster; last error: {type(exc).__name__}: {exc}"
                    ) from exc
                self._scatter()
                retry = self._submit([designs[i] for i in batch])
                self.resubmitted += 1
                futures[retry] = b
                queue.add(retry)
                continue
            following = next(waiting, None)
            if following is not None:
                successor = self._submit([designs[i] for i in batches[following]])
                futures[successor] = following
                queue.add(successor)
            yield from zip(batch, records)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


SCHEDULER_TIMEOUT_S = 15  # a scheduler answers in well under a second, a loaded machine in seconds; none there waited 60 s
_ADDRESS = re.compile(
    r"(?:(?:tcp|tls)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?):(\d{1,5})"
)


def check_scheduler_address(address: str) -> str:
    """``address`` when it is a Dask scheduler address, ``[tcp://|tls://]HOST:PORT`` with a port in 1-65535, else
    ConfigError saying the expected form (``nonsense`` was an internal error; port 99999 waited 60 s)."""
    match = _ADDRESS.fullmatch(address) if isinstance(address, str) else None
    if match is None or not 1 <= int(match.group(2)) <= 65535:
        raise ConfigError(
            f"--scheduler-address {address!r} is not a Dask scheduler address; expected "
            f"[tcp://|tls://]HOST:PORT with PORT in 1-65535, e.g. tcp://127.0.0.1:8786",
            key="--scheduler-address",
        )
    return address


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system has one): the default worker
    count."""
    return (
        len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    )


def open_backend(
    shared,
    plan: CampaignPlan,
    workers: int | None = None,
    scheduler_address: str | None = None,
    task: Callable | None = None,
):
    """Serial for ``workers`` 0 or 1 (and no address), else Dask (``workers`` None: one per core), running ``task``
    (default :func:`campaign_task` of ``plan``) on ``shared``; the plan's resubmit and numba-thread limits."""
    task = campaign_task(plan) if task is None else task
    if workers is None and not scheduler_address:
        workers = usable_cores()
    if workers is not None and workers < 0:
        raise ValueError(f"workers must be >= 0 (0 or 1 = serial in this process); got {workers}")
    if not scheduler_address and workers <= 1:
        return SerialBackend(shared, task)
    return DaskBackend(
        shared,
        task,
        max_resubmits=plan.max_resubmits,
        numba_threads=plan.numba_threads_per_worker,
        n_workers=None if scheduler_address else workers,
        scheduler_address=scheduler_address,
    )


def early_stop_bounds(plan: CampaignPlan, algorithm) -> tuple | None:
    """The bounds at which this generation's offspring may stop early (:func:`~lnss_lib.keys.violated_bound`): the
    plan's constraints once NSGA-II's population is ``plan.population`` designs, all feasible, else None.

    Exact: pymoo's survival (``Survival.do``) ranks the feasible designs of parents and offspring first and takes
    infeasible ones only to fill up, so with ``population`` feasible parents no infeasible offspring survives,
    whatever its violation; the search, its population and every feasible design's metrics are those of the full
    evaluation. A design stopped early breaks a bound (by the sign of
    :func:`~lnss_lib.campaign.fitness.constraint_matrix`), so it is infeasible in both. Never while any parent is
    infeasible (the paper campaign under its own bounds: there violations rank the population), nor with
    ``nan_violation`` 0 (an undefined metric would then not violate).
    """
    pop = getattr(algorithm, "pop", None)
    if (
        not plan.constraints
        or plan.nan_violation <= 0.0
        or pop is None
        or len(pop) < plan.population
        or not bool(np.all(pop.get("FEAS")))
    ):
        return None
    return plan.constraints


class BatchEvaluator:
    """Scaled designs (n, 6) -> metric columns, through the cache; new designs go to the backend.

    ``generation`` must be set before each call; records carry the generation in which a design was
    first evaluated and its row in that generation's batch (``order``). ``progress`` is an optional
    callable ``(n_done, n_total, n_hits)`` called as designs finish. ``stop_bounds`` (None: off), set per
    generation by :func:`early_stop_bounds`, goes with each design to the task.
    """

    def __init__(self, plan: CampaignPlan, cache: EvaluationCache, backend):
        self.plan = plan
        self.cache = cache
        self.backend = backend
        self.generation = 1
        self.progress = None
        self.last = {"evaluated": 0, "hits": 0, "errors": 0, "wall_s": 0.0}
        self.n_backend = 0
        self.stop_bounds = None

    def __call__(self, scaled: np.ndarray) -> dict:
        start = time.perf_counter()
        keys = [tuple(int(v) for v in row) for row in np.rint(np.atleast_2d(scaled))]
        todo, order, seen = [], [], set()
        fresh = 0
        for i, key in enumerate(keys):
            if key in seen:
                continue
            seen.add(key)
            if key not in self.cache:
                todo.append(key)
                order.append(i)
                fresh += 1
            elif self.cache.records[key]["generation"] == self.generation:
                fresh += 1  # evaluated in this generation before an interruption: still new to it
        hits = len(keys) - fresh
        designs = self.plan.grid.designs(np.array(todo)) if todo else []
        if self.stop_bounds is not None:
            designs = [{**design, "stop_bounds": self.stop_bounds} for design in designs]
        errors, done = 0, 0
        if self.progress:
            self.progress(0, len(todo), hits)
        for index, record in self.backend.run(designs, guided=True):
            record.update(generation=self.generation, order=order[index])
            self.cache.add(todo[index], record)
            errors += record["error"]
            done += 1
            if self.progress:
                self.progress(done, len(todo), hits)
        self.last = {
            "evaluated": fresh,
            "hits": hits,
            "errors": errors,
            "wall_s": time.perf_counter() - start,
        }
        self.n_backend += done
        return metric_columns([self.cache.records[k] for k in keys], self.plan.extra_metrics)
