"""A study: many campaigns side by side on one Dask cluster (``python -m lnss_lib study FILE``).

One NSGA-II run cannot keep a large cluster busy (a generation waits for its slowest design), but a study is many
runs: seeds, restricted sizes, another epoch or mask. A study file (TOML, ``params/studies/``; read and checked by
:func:`load_study` before any work) lists them::

    [study]
    description = "what the study asks"

    [[campaigns]]
    name = "seed2"                      # its run folder, RUN_DIR/seed2
    profile = "paper_dv_physical"       # params/NAME.toml
    seed = 2                            # campaign.seed (default: the profile's)
    set = ["campaign.generations=300"]  # --set overrides, checked like the profile
    front_validation = false            # fly the front after NSGA-II ([front_validation] of the profile)

:func:`run_study` runs every campaign through :func:`~lnss_lib.campaign.runner.run_campaign`, each in its own run
folder under ``RUN_DIR`` with its own journal and checkpoint, all at once on one cluster (a local one, or the
scheduler at ``scheduler_address``), with one progress line (campaigns, busy workers, designs per second). A
campaign's results are those of the same campaign run alone, bit for bit: its population, random generator and
journal are its own, and the cluster only decides where a design is evaluated. ``RUN_DIR/study.toml`` keeps the
study file, so a study killed at any moment continues with :func:`run_study` ``resume=True`` (every campaign from its
last checkpoint). With one worker or none the campaigns run one after the other in this process (the SPICE toolkit
behind the evaluator is not thread-safe).
"""

from __future__ import annotations

import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from ..config import PROFILE_NAME, deep_merge, parse_sets, read_toml
from ..errors import ConfigError
from ..settings import load_settings
from .backends import connect_scheduler, start_local_cluster, usable_cores
from .callbacks import Callback, RunState
from .rundir import RUN_FILE, RunLock, check_new_run_dir
from .runner import CampaignResult, run_campaign

__all__ = [
    "StudyCampaign",
    "Study",
    "StudyResult",
    "StudyStopped",
    "load_study",
    "run_study",
    "STUDY_FILE",
    "STUDY_KEYS",
    "CAMPAIGN_KEYS",
]

STUDY_FILE = (
    "study.toml"  # the study file as given, in the study's run folder (what --resume reads)
)
STUDY_KEYS = {"description": str}
CAMPAIGN_KEYS = {"name": str, "profile": str, "seed": int, "set": list, "front_validation": bool}
REQUIRED_CAMPAIGN_KEYS = ("name", "profile")
TYPE_WORDS = {
    str: "a string",
    int: "an integer",
    list: 'a list of "SECTION.KEY=VALUE" strings',
    bool: "true or false",
}


@dataclass(frozen=True)
class StudyCampaign:
    """One campaign of a study: its folder ``name``, ``profile`` and the overrides merged into it (``set``, the
    seed, front validation off unless asked for)."""

    name: str
    profile: str
    overrides: dict


@dataclass(frozen=True)
class Study:
    """A checked study file: ``name`` (the file's stem), ``description``, its campaigns and the file's text."""

    name: str
    description: str
    campaigns: tuple[StudyCampaign, ...]
    text: str


def _type_ok(value, kind) -> bool:
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if kind is list:
        return isinstance(value, list) and all(isinstance(item, str) for item in value)
    return isinstance(value, kind)


def _check_table(table, known: dict, where: str, path: Path) -> None:
    """Every key of ``table`` known and of its type; ConfigError naming the file, the key and the value."""
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: {where} must be a table; got {table!r}", source=str(path))
    for key, value in table.items():
        if key not in known:
            raise ConfigError(
                f"{path}: {where}.{key} is not a study key; allowed: {', '.join(known)}",
                key=f"{where}.{key}",
                source=str(path),
            )
        if not _type_ok(value, known[key]):
            raise ConfigError(
                f"{path}: {where}.{key} = {value!r} is not allowed; allowed: "
                f"{TYPE_WORDS[known[key]]}",
                key=f"{where}.{key}",
                source=str(path),
            )


def _campaign(entry: dict, index: int, path: Path) -> StudyCampaign:
    """One ``[[campaigns]]`` entry, checked: its profile loads with its overrides (every value checked as
    ``--set`` is), its name is a folder name, and front validation has designs to fly when asked for."""
    where = f"campaigns[{index}]"
    _check_table(entry, CAMPAIGN_KEYS, where, path)
    missing = [key for key in REQUIRED_CAMPAIGN_KEYS if key not in entry]
    if missing:
        raise ConfigError(
            f"{path}: {where} lacks {', '.join(missing)} (required: {', '.join(REQUIRED_CAMPAIGN_KEYS)})",
            key=f"{where}.{missing[0]}",
            source=str(path),
        )
    name = entry["name"]
    if not PROFILE_NAME.fullmatch(name):
        raise ConfigError(
            f"{path}: {where}.name = {name!r} is not allowed; allowed: a folder name of letters, "
            f"digits, '_' and '-' (at most 64, starting with a letter or digit)",
            key=f"{where}.name",
            source=str(path),
        )
    try:
        overrides = parse_sets(entry.get("set", []))
        if "seed" in entry:
            overrides = deep_merge(overrides, {"campaign": {"seed": entry["seed"]}})
        settings = load_settings(entry["profile"], overrides=overrides or None)
        validate = entry.get("front_validation", False)
        if validate and settings.front_validation.max_designs == 0:
            raise ConfigError(
                "front_validation = true, but [front_validation] max_designs = 0 in its profile: no "
                "design would be flown; set front_validation.max_designs",
                key="front_validation",
            )
        if not validate and settings.front_validation.max_designs > 0:
            overrides = deep_merge(overrides, {"front_validation": {"max_designs": 0}})
    except ConfigError as error:
        raise ConfigError(
            f"{path}: campaign {name!r}: {error}", key=error.key, source=str(path)
        ) from None
    return StudyCampaign(name=name, profile=entry["profile"], overrides=overrides)


def load_study(path, name: str | None = None) -> Study:
    """The study file at ``path``, every value checked before any work (see the module docstring); ConfigError
    naming the file, the entry and the value. ``name``: the study's (default: the file's stem)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(
            f"study file {path}: no such file (a TOML file, e.g. params/studies/ci_pair.toml)",
            source=str(path),
        )
    data = read_toml(path)
    for key in data:
        if key not in ("study", "campaigns"):
            raise ConfigError(
                f"{path}: [{key}] is not a study table; allowed: [study], [[campaigns]]",
                key=key,
                source=str(path),
            )
    study = data.get("study", {})
    _check_table(study, STUDY_KEYS, "study", path)
    entries = data.get("campaigns")
    if not isinstance(entries, list) or not entries:
        raise ConfigError(
            f"{path}: a study needs at least one [[campaigns]] entry",
            key="campaigns",
            source=str(path),
        )
    campaigns = tuple(_campaign(entry, i, path) for i, entry in enumerate(entries))
    names = [c.name for c in campaigns]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ConfigError(
            f"{path}: campaign names {', '.join(map(repr, repeated))} are used twice; each campaign "
            f"needs its own run folder",
            key="campaigns.name",
            source=str(path),
        )
    return Study(
        name=name or path.stem,
        description=study.get("description", ""),
        campaigns=campaigns,
        text=path.read_text(),
    )


class StudyStopped(KeyboardInterrupt):
    """A campaign of a study stopped because the study was interrupted (its run folder stays resumable)."""


@dataclass
class StudyProgress:
    """What the study's progress line shows, updated by each campaign's :class:`_Reporter` (thread-safe)."""

    campaigns: tuple[str, ...]
    generations_total: int
    start: float = field(default_factory=time.perf_counter)
    designs: dict = field(default_factory=dict)  # campaign -> designs evaluated this session
    generations: dict = field(default_factory=dict)  # campaign -> generations done
    running: set = field(default_factory=set)
    done: set = field(default_factory=set)
    stop: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def designs_per_s(self) -> float:
        elapsed = time.perf_counter() - self.start
        return sum(self.designs.values()) / elapsed if elapsed > 0 else 0.0

    def text(self, busy: int, workers: int) -> str:
        """``campaigns 1 done, 2 running, 0 waiting; workers 2/2 busy; 12.3 designs/s``."""
        with self.lock:
            waiting = len(self.campaigns) - len(self.done) - len(self.running)
            return (
                f"campaigns {len(self.done)} done, {len(self.running)} running, {waiting} waiting; workers "
                f"{busy}/{workers} busy; {self.designs_per_s():.2f} designs/s"
            )


class _Reporter(Callback):
    """Reports one campaign's designs and generations to the study's :class:`StudyProgress`; stops the campaign
    (:class:`StudyStopped`, between two designs) once the study is interrupted."""

    def __init__(self, progress: StudyProgress, name: str):
        self.progress, self.name = progress, name

    def _check(self) -> None:
        if self.progress.stop.is_set():
            raise StudyStopped(f"campaign {self.name} stopped with the study")

    def on_session_start(self, state: RunState) -> None:
        with self.progress.lock:
            self.progress.running.add(self.name)
            self.progress.generations[self.name] = len(state.history)
        self._check()

    def on_designs(self, state: RunState, n_done: int, n_total: int, n_hits: int) -> None:
        with self.progress.lock:
            self.progress.designs[self.name] = state.batch.n_backend + n_done
        self._check()

    def on_generation_end(self, state: RunState) -> None:
        with self.progress.lock:
            self.progress.generations[self.name] = len(state.history)


@dataclass
class StudyResult:
    """What :func:`run_study` returns: the study's folder, each campaign's :class:`CampaignResult` (by name), the
    session's wall time and designs per second."""

    run_dir: Path
    campaigns: dict[str, CampaignResult]
    wall_s: float
    designs_per_s: float


def _new_study_dir(run_dir) -> Path:
    if run_dir is None or not str(run_dir).strip():
        raise ConfigError(
            "a new study needs --run-dir DIR (a missing or empty folder; each campaign runs in "
            "DIR/<name>)",
            key="--run-dir",
        )
    run_dir = Path(run_dir)
    if (run_dir / STUDY_FILE).exists():
        raise ConfigError(
            f"{run_dir} already holds a study; continue it with --resume {run_dir}", key="--run-dir"
        )
    check_new_run_dir(run_dir)
    return run_dir


def run_study(
    study=None,
    *,
    run_dir=None,
    resume: bool = False,
    workers: int | None = None,
    scheduler_address: str | None = None,
    progress: bool = True,
    max_generations: int | None = None,
) -> StudyResult:
    """Run a study (a :class:`Study` or the path of a study file) in the new folder ``run_dir``, or continue the
    one in ``run_dir`` (``resume``: from its ``study.toml``; ``study`` None). ``workers``: local Dask workers
    (None: one per core; 0 or 1: the campaigns one after the other in this process); ``scheduler_address``: an
    existing cluster, whose workers must compute what this process computes
    (:func:`~lnss_lib.campaign.backends.check_workers`). ``max_generations`` ends each campaign's session after
    that many generations (the study stays resumable). Raises RuntimeError naming the campaigns that failed after
    the others finished."""
    if resume:
        if study is not None:
            raise ConfigError(
                "--resume continues a study with the study file it stored: drop FILE",
                key="--resume",
            )
        run_dir = Path(run_dir)
        if not (run_dir / STUDY_FILE).is_file():
            raise ConfigError(
                f"--resume {run_dir}: not a study folder (no {STUDY_FILE})", key="--resume"
            )
        study = load_study(run_dir / STUDY_FILE, name=run_dir.name)
    else:
        study = study if isinstance(study, Study) else load_study(study)
        run_dir = _new_study_dir(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
    lock = RunLock(run_dir)
    try:
        if not resume:
            (run_dir / STUDY_FILE).write_text(study.text)
        return _run_locked(study, run_dir, workers, scheduler_address, progress, max_generations)
    finally:
        lock.release()


def _run_locked(
    study: Study, run_dir: Path, workers, scheduler_address, progress: bool, max_generations
) -> StudyResult:
    if workers is None and not scheduler_address:
        workers = usable_cores()
    if workers is not None and workers < 0:
        raise ConfigError(
            f"--workers {workers} is not allowed; allowed: an integer >= 0", key="--workers"
        )
    generations = sum(
        load_settings(c.profile, overrides=c.overrides or None).campaign.generations
        for c in study.campaigns
    )
    state = StudyProgress(
        campaigns=tuple(c.name for c in study.campaigns), generations_total=generations
    )
    cluster = client = display = None
    serial = not scheduler_address and workers <= 1
    try:
        if not serial:
            if scheduler_address:
                client = connect_scheduler(scheduler_address)
            else:
                from dask.distributed import Client

                cluster = start_local_cluster(workers)
                client = Client(cluster, set_as_default=False)
            scheduler_address = client.scheduler.address
        display = _Display(state, client, study.name) if progress else None
        results, failures = _run_campaigns(
            study, run_dir, state, serial, scheduler_address, max_generations
        )
    finally:
        if display is not None:
            display.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    if failures:
        raise RuntimeError(
            f"study {study.name}: {len(failures)} of {len(study.campaigns)} campaign(s) failed ("
            + "; ".join(
                f"{name}: {type(error).__name__}: {error}" for name, error in failures.items()
            )
            + f"); the others finished; continue with --resume {run_dir}"
        )
    return StudyResult(
        run_dir=run_dir,
        campaigns=results,
        wall_s=time.perf_counter() - state.start,
        designs_per_s=state.designs_per_s(),
    )


def _run_campaigns(
    study: Study,
    run_dir: Path,
    state: StudyProgress,
    serial: bool,
    scheduler_address,
    max_generations,
) -> tuple[dict, dict]:
    """Every campaign of ``study`` to the end of its session: ``(results, failures)`` by campaign name. On the
    cluster at ``scheduler_address`` all at once (one thread each), else one after the other in this process; an
    interrupt stops them all between two designs and is raised again."""

    def one(campaign: StudyCampaign) -> CampaignResult:
        folder = run_dir / campaign.name
        started = (folder / RUN_FILE).is_file()
        try:
            return run_campaign(
                campaign.profile,
                overrides=None if started else campaign.overrides,
                workers=0 if serial else None,
                scheduler_address=scheduler_address,
                run_dir=None if started else folder,
                resume=folder if started else None,
                progress=False,
                max_generations=max_generations,
                callbacks=[_Reporter(state, campaign.name)],
            )
        finally:
            with state.lock:
                state.running.discard(campaign.name)
                state.done.add(campaign.name)

    results, failures = {}, {}
    if serial:
        for campaign in study.campaigns:
            try:
                results[campaign.name] = one(campaign)
            except Exception as error:  # the others still run; reported together at the end
                failures[campaign.name] = error
        return results, failures
    with ThreadPoolExecutor(
        max_workers=len(study.campaigns), thread_name_prefix="campaign"
    ) as pool:
        futures = {campaign.name: pool.submit(one, campaign) for campaign in study.campaigns}
        try:
            for name, future in futures.items():
                try:
                    results[name] = future.result()
                except StudyStopped:
                    raise
                except Exception as error:
                    failures[name] = error
        except BaseException:  # Ctrl-C, SIGTERM: every campaign stops, its folder resumable
            state.stop.set()
            for future in futures.values():
                try:
                    future.result()
                except BaseException:
                    pass
            raise
    return results, failures


class _Display:
    """The study's one progress line (tqdm on stderr): generations done over all campaigns, then
    :meth:`StudyProgress.text`, refreshed by a thread every :data:`REFRESH_S` (piped: :data:`REFRESH_PIPED_S`); busy workers are those the
    scheduler reports processing a task (this process when serial)."""

    REFRESH_S = 1.0  # on a terminal
    REFRESH_PIPED_S = 30.0  # into a log file: a line every half minute

    def __init__(self, state: StudyProgress, client, name: str):
        from tqdm import tqdm

        self.state, self.client = state, client
        self.bar = tqdm(
            total=state.generations_total,
            desc=f"study {name}",
            unit="gen",
            file=sys.stderr,
            bar_format="{desc} {n_fmt}/{total_fmt} gen {elapsed}{postfix}",
        )
        self.refresh_s = self.REFRESH_S if sys.stderr.isatty() else self.REFRESH_PIPED_S
        self.closed = threading.Event()
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _busy(self) -> tuple[int, int]:
        if self.client is None:
            return min(1, len(self.state.running)), 1
        processing = self.client.processing()
        return sum(bool(tasks) for tasks in processing.values()), len(processing)

    def _draw(self) -> None:
        with self.state.lock:
            self.bar.n = sum(self.state.generations.values())
        self.bar.set_postfix_str(self.state.text(*self._busy()), refresh=True)

    def _loop(self) -> None:
        while not self.closed.wait(self.refresh_s):
            try:
                self._draw()
            except Exception:  # a cluster closing under the display: the next draw or close says it
                continue

    def close(self) -> None:
        self.closed.set()
        self.thread.join()
        if self.client is not None and self.client.status == "running":
            self._draw()
        self.bar.close()
