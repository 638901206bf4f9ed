"""The campaign: pymoo's NSGA-II through ask and tell, one generation at a time, in a run directory.

:func:`run_campaign` (``python -m lnss_lib campaign``) is a loop: ask the algorithm for a generation,
evaluate it through the journal and a backend, tell the algorithm, and notify the callbacks
(:mod:`lnss_lib.campaign.callbacks`: error guard, history, checkpoint, progress bars) that do the
rest. A run killed at any moment and resumed ends with the same population as an uninterrupted
one: designs of an interrupted generation come back from the journal, the checkpoint holds the
algorithm and its random generator; designs the checkpoint needs whose journal lines were lost are
evaluated again. Resumed on a machine whose kernels are compiled for another processor model than the run's
(:func:`lnss_lib.kernel_cpu`, recorded in ``run.json`` and in each journal record), the run goes on with a
RuntimeWarning: the journal answers no design from a record of the other model (it is evaluated again here:
:class:`~lnss_lib.campaign.journal.EvaluationCache`), so its later designs differ from an uninterrupted run's by
round-off, which the adaptive step control can carry into the search. When
NSGA-II has finished and ``[front_validation] max_designs`` > 0, the front is flown in closed loop (:mod:`lnss_lib.campaign.validation`, ``validated.nc``; a run killed during it and resumed finishes
it without running NSGA-II again). A session that ends in ``outputs/<profile>/campaign/`` publishes the run when
its settings are the profile's (:mod:`lnss_lib.campaign.publication`).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import kernel_cpu
from ..config import OUTPUTS_DIR, PROFILE_NAME
from ..errors import ConfigError
from ..settings import Settings, load_settings, settings_from_profile
from .backends import BatchEvaluator, check_scheduler_address, early_stop_bounds, open_backend
from .callbacks import (
    Callback,
    CampaignStopped,
    Checkpointer,
    ErrorGuard,
    HistoryRecorder,
    ProgressBars,
    RunState,
)
from .journal import JOURNAL_FILE, EvaluationCache, read_cache_records
from .problem import WalkerDesignProblem, build_algorithm, build_termination
from .publication import publish_run, run_differences
from .rundir import (
    LOCK_FILE,
    RUN_FILE,
    RunLock,
    check_new_run_dir,
    check_resumable,
    default_run_dir,
    load_checkpoint,
    load_run,
    run_kernel_cpu,
    start_run,
    write_results,
)
from .settings import (
    CampaignPlan,
    evaluation_hash,
    evaluation_profile,
    recorded_evaluation_hashes,
)
from .validation import check_validatable, validate_front

__all__ = ["run_campaign", "validate_run", "CampaignResult", "default_callbacks"]


def default_callbacks(progress: bool) -> list[Callback]:
    """Error guard, history, checkpoint and (with ``progress``) the tqdm bars, in the order they act."""
    chain = [ErrorGuard(), HistoryRecorder(), Checkpointer()]
    return chain + [ProgressBars()] if progress else chain


@dataclass
class CampaignResult:
    """What :func:`run_campaign` returns: the run directory, result files, what was published (a sentence,
    empty for a run outside ``outputs/<profile>/campaign/``) and headline numbers."""

    run_dir: Path
    files: list[Path]
    publication: str
    generations: int
    n_evaluations: int
    n_feasible: int
    wall_s: float
    session_evaluations: int
    session_wall_s: float
    resubmitted: int
    n_errors: int = 0


def run_campaign(
    profile_name: str = "quick",
    *,
    overrides: dict | None = None,
    workers: int | None = None,
    scheduler_address: str | None = None,
    run_dir=None,
    resume=None,
    progress: bool = True,
    max_generations: int | None = None,
    callbacks=(),
) -> CampaignResult:
    """Run (or, with ``resume`` = a run directory, continue) an NSGA-II campaign; see the module docstring.

    ``overrides`` is merged into the profile (e.g. ``{"campaign": {"evaluator": "synthetic"}}``);
    ``workers`` 0 or 1 evaluates in this process, None or >= 2 on a local Dask cluster, and
    ``scheduler_address`` uses an existing cluster. ``max_generations`` stops this session after
    that many generations (the run stays resumable). ``callbacks`` (:class:`~lnss_lib.campaign.callbacks.Callback`)
    are notified after the default chain (:func:`default_callbacks`). Returns a :class:`CampaignResult`.

    Everything is checked before the run folder is touched (profile, campaign settings, on resume the
    stored settings against their hashes); a new run folder that ends without a recorded design is
    removed again. The process holds the folder's lock (:class:`~lnss_lib.campaign.rundir.RunLock`)
    while it runs. More evaluation errors than ``campaign.max_errors`` raise
    :class:`~lnss_lib.campaign.callbacks.CampaignStopped` after writing ``evaluations.nc``.
    """
    if scheduler_address is not None:
        check_scheduler_address(scheduler_address)
    if resume is not None:
        if overrides:
            raise ConfigError(
                "a resumed run keeps its parameters: overrides are not allowed with resume"
            )
        run_dir = Path(resume)
        run = load_run(run_dir)
        settings = _stored_settings(run_dir, run)
        eval_hash = run["evaluation_hash"]  # its journal's, also one recorded under an earlier rule
        if eval_hash not in recorded_evaluation_hashes(settings):
            raise ConfigError(
                f"{run_dir}: evaluation hash of the stored profile changed; cannot resume"
            )
        _warn_if_other_kernel_cpu(run_dir, run)
        eval_settings = evaluation_profile(settings)
        lock = RunLock(run_dir)
        created = False
    else:
        settings = load_settings(profile_name, overrides=overrides)
        eval_hash = evaluation_hash(settings)
        eval_settings = evaluation_profile(settings)
        run_dir = _new_run_dir(run_dir, settings.name)
        created = not run_dir.exists()
        run_dir.mkdir(parents=True, exist_ok=True)
        lock = RunLock(run_dir)
    try:
        if resume is None:
            start_run(run_dir, settings, eval_hash)
        return _run_locked(
            run_dir,
            settings,
            eval_settings,
            eval_hash,
            workers,
            scheduler_address,
            progress,
            max_generations,
            callbacks,
        )
    except BaseException:
        if created:
            _remove_if_empty_run(run_dir)
        raise
    finally:
        lock.release()


def _new_run_dir(run_dir, profile_name: str) -> Path:
    """The folder a new run goes into: ``run_dir`` (not blank, outside the shipped results, missing or empty:
    :func:`~lnss_lib.campaign.rundir.check_new_run_dir`) or the profile's default."""
    if run_dir is None:
        return default_run_dir(profile_name)
    if not str(run_dir).strip():
        raise ConfigError(
            f"--run-dir {str(run_dir)!r}: a folder path is needed (a blank one would be the current "
            f"folder); omit --run-dir for outputs/<profile>/campaign/run_<time>",
            key="--run-dir",
        )
    run_dir = Path(run_dir)
    reference_dir = (OUTPUTS_DIR / "reference").resolve()
    if run_dir.resolve() == reference_dir or reference_dir in run_dir.resolve().parents:
        raise ConfigError(
            f"--run-dir {run_dir}: inside {reference_dir}, the shipped results, which exports replace "
            f"whole; choose a folder elsewhere",
            key="--run-dir",
        )
    check_new_run_dir(run_dir)
    return run_dir


def _warn_if_other_kernel_cpu(run_dir: Path, run: dict) -> None:
    """RuntimeWarning when ``run``'s recorded kernel processor model is not this machine's (see the module docstring)."""
    recorded, here = run_kernel_cpu(run), kernel_cpu()
    if recorded is not None and recorded != here:
        warnings.warn(
            f"{run_dir} started with kernels compiled for {recorded}; here they are compiled for "
            f"{here}: the designs evaluated from now on (and those of its journal asked for again) differ "
            "from an uninterrupted run's by round-off (docs/NOTES.md, Notes for developers)",
            RuntimeWarning,
            stacklevel=3,
        )


def _stored_settings(run_dir: Path, run: dict) -> Settings:
    """The settings a run folder recorded (``run.json``), checked again; ConfigError naming the file."""
    try:
        settings = settings_from_profile(run["profile"])
    except ConfigError as error:
        raise ConfigError(f"{run_dir / RUN_FILE}: {error}", key=error.key) from None
    stored_name = settings.name
    if not isinstance(stored_name, str) or not PROFILE_NAME.fullmatch(stored_name):
        raise ConfigError(
            f"{run_dir / RUN_FILE}: profile.name = {stored_name!r} is not a profile name "
            f"(letters, digits, '_' and '-'); the run folder is damaged or forged",
            key="profile.name",
        )
    return settings


def _remove_if_empty_run(run_dir: Path) -> None:
    """Remove a run folder this call created when no design was recorded (a rejected or failed start)."""
    if read_cache_records(run_dir):
        return
    for name in (RUN_FILE, JOURNAL_FILE, LOCK_FILE):
        (run_dir / name).unlink(missing_ok=True)
    try:
        run_dir.rmdir()
    except OSError:
        pass


def _lost_designs(checkpoint: dict | None, cache: EvaluationCache) -> list[tuple]:
    """Designs the checkpoint needs (its population and the generation it asked for) that the journal
    lacks: lines torn or damaged, a journal deleted, or an evaluation error to retry."""
    if checkpoint is None:
        return []
    population = checkpoint["algorithm"].pop
    keys = [tuple(k) for k in checkpoint.get("asked_keys", [])]
    if population is not None and len(population):
        keys += [tuple(int(v) for v in row) for row in np.rint(population.get("X"))]
    return [k for k in dict.fromkeys(keys) if k not in cache]


def _run_locked(
    run_dir: Path,
    run_settings: Settings,
    eval_settings: Settings,
    eval_hash: str,
    workers,
    scheduler_address,
    progress: bool,
    max_generations,
    callbacks,
) -> CampaignResult:
    """The generation loop of :func:`run_campaign` in a run folder this process holds the lock of: the run's
    settings, those its evaluations run under (:func:`evaluation_profile`) and their :func:`evaluation_hash`."""
    plan = CampaignPlan.of(run_settings)
    name = run_settings.name
    checkpoint = load_checkpoint(run_dir)
    run = load_run(run_dir)
    check_resumable(run_dir, run, checkpoint)
    if checkpoint is not None:
        algorithm, history = checkpoint["algorithm"], checkpoint["history"]
        problem = algorithm.problem
    else:
        algorithm, history = build_algorithm(plan), []
        problem = WalkerDesignProblem(plan)
        algorithm.setup(problem, termination=build_termination(plan), seed=plan.seed, verbose=False)
    cache = EvaluationCache(
        run_dir / JOURNAL_FILE, eval_hash, kernel_cpu=kernel_cpu(), run_cpu=run_kernel_cpu(run)
    )
    session_start = time.perf_counter()
    session_wall_s = None
    backend = None
    observers: list = []
    try:
        lost = _lost_designs(checkpoint, cache)
        if lost or (not (checkpoint and checkpoint.get("finished")) and algorithm.has_next()):
            backend = open_backend(eval_settings, plan, workers, scheduler_address)
        batch = BatchEvaluator(plan, cache, backend)
        if lost:  # designs of the checkpoint whose journal lines were torn, damaged or lost: evaluate them again
            batch.generation = len(history)
            batch(np.array(lost))
        problem.metrics_source = batch
        state = RunState(
            run_dir=run_dir,
            name=name,
            plan=plan,
            algorithm=algorithm,
            cache=cache,
            batch=batch,
            history=history,
            profile_hash=run_settings.hash,
            session_start=session_start,
        )
        observers = default_callbacks(progress) + list(callbacks)

        def notify(hook: str, *args) -> None:
            for observer in observers:
                getattr(observer, hook)(state, *args)

        batch.progress = lambda done, total, hits: notify("on_designs", done, total, hits)
        notify("on_session_start")
        session_gens = 0
        while backend is not None and algorithm.has_next():
            if max_generations is not None and session_gens >= max_generations:
                break
            gen_start = time.perf_counter()
            pop = algorithm.ask()
            state.generation, state.n_designs = len(history) + 1, len(pop)
            state.asked_keys = [[int(v) for v in row] for row in np.rint(pop.get("X"))]
            batch.generation = state.generation
            batch.stop_bounds = early_stop_bounds(plan, algorithm)
            notify("on_generation_start")
            algorithm.evaluator.eval(problem, pop)
            algorithm.tell(infills=pop)
            state.wall_s = time.perf_counter() - gen_start
            notify("on_generation_end")
            session_gens += 1
        session_wall_s = (
            time.perf_counter() - session_start
        )  # evaluation time: writing the results is not in it
        notify("on_session_end")
    except CampaignStopped:
        for observer in observers:
            if hasattr(observer, "close"):
                observer.close()
        cache.close()
        write_results(
            run_dir
        )  # evaluations.nc holds every design so far, errors with their messages
        raise
    finally:
        cache.close()
        resubmitted = getattr(backend, "resubmitted", 0)
        if backend is not None:
            backend.close()
    files = write_results(run_dir) if history else []
    if run_settings.front_validation.max_designs > 0 and bool(
        (load_checkpoint(run_dir) or {}).get("finished")
    ):
        files.append(
            validate_front(
                run_dir, workers=workers, scheduler_address=scheduler_address, progress=progress
            ).path
        )
    note = _publish(run_dir, run_settings) if history else ""
    return CampaignResult(
        run_dir=run_dir,
        files=files,
        publication=note,
        generations=len(history),
        n_evaluations=history[-1]["n_evaluations_cum"] if history else 0,
        n_feasible=history[-1]["n_feasible_cum"] if history else 0,
        wall_s=float(sum(h["wall_s"] for h in history)),
        session_evaluations=batch.n_backend,
        session_wall_s=session_wall_s
        if session_wall_s is not None
        else time.perf_counter() - session_start,
        resubmitted=resubmitted,
        n_errors=sum(bool(r.get("error")) for r in read_cache_records(run_dir)),
    )


def validate_run(
    run_dir,
    *,
    workers: int | None = None,
    scheduler_address: str | None = None,
    progress: bool = True,
    task=None,
) -> tuple:
    """Validate (or continue validating) the front of a finished run (``campaign --validate RUN_DIR``), under its
    lock, then publish it as :func:`run_campaign` would: ``(ValidationResult, publication note)``. ConfigError for a
    folder that is not a run, a run not finished or a profile whose validation is off."""
    run_dir = Path(run_dir)
    if scheduler_address is not None:
        check_scheduler_address(scheduler_address)
    if not run_dir.is_dir():
        raise ConfigError(
            f"--validate {run_dir}: not a folder (a campaign run folder: {RUN_FILE}, checkpoint.pkl, "
            f"{JOURNAL_FILE})",
            key="--validate",
        )
    run = load_run(run_dir)
    settings = _stored_settings(run_dir, run)
    lock = RunLock(run_dir)
    try:
        check_resumable(run_dir, run, load_checkpoint(run_dir))
        check_validatable(run_dir, settings)
        result = validate_front(
            run_dir,
            workers=workers,
            scheduler_address=scheduler_address,
            progress=progress,
            task=task,
        )
        return result, _publish(run_dir, settings)
    finally:
        lock.release()


def _publish(run_dir: Path, settings: Settings) -> str:
    """Publish a run found in ``outputs/<profile>/campaign/`` when it is that profile's campaign; say what was done."""
    name = settings.name
    campaign_dir = OUTPUTS_DIR / name / "campaign"
    if run_dir.resolve().parent != campaign_dir.resolve():
        return ""
    try:
        reasons = run_differences(settings, load_settings(name))
    except (ConfigError, ValueError) as error:
        reasons = [f"profile {name!r} does not load ({error})"]
    if reasons:
        return f"not published as the campaign of profile {name!r}: {'; '.join(reasons)}"
    try:
        return (
            f"published as the campaign of profile {name!r}: {publish_run(run_dir, campaign_dir)}"
        )
    except ConfigError as error:
        return f"not published as the campaign of profile {name!r}: {error}"
