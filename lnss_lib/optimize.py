"""NSGA-II search over Walker designs (paper Section 5: eq. 43-45, Tables 3 and 5; Section 6.2).

Decision variables (Table 3) live on the integer grid of eq. 43: ``x_j = (X_j - L_j) / dX_j``
with the bounds ``L_j``, ``U_j`` and step sizes ``dX_j`` of ``[campaign.variables]``; a scaled
design is de-scaled by eq. 44, ``X_j = min(max(L_j + dX_j x_j, L_j), U_j)``, with Np and Ns
rounded to integers (:class:`DesignGrid`). The objectives are the metrics of eq. 45 named in
``campaign.objectives`` (a leading ``-`` marks a maximised metric, negated for pymoo); the
constraints are Table 3's fitness bounds (``[campaign.constraints]``) as pymoo inequality
constraints ``g <= 0``, normalised by their limits. A design without a metric (impact, invalid
elements, no four-satellite coverage: NaN) gets the finite penalty ``nan_objective`` for that
objective and ``nan_violation`` for that constraint, so it is dominated, never an error.

A campaign (:func:`run_campaign`, ``python -m lnss_lib campaign``) runs pymoo's NSGA-II through
ask and tell, one generation at a time, in a run directory:

* ``run.json``: the profile (with every override) and the evaluation hash, written first;
* ``evaluations.jsonl``: the persistent evaluation cache, one JSON line per design evaluated,
  appended (and flushed) as each design finishes; the header line holds the evaluation hash
  (:func:`evaluation_hash`), so a design is never evaluated twice in a run, even across kills;
* ``checkpoint.pkl``: after every generation, the pickled algorithm (population, random
  generator, termination state) and the per-generation history, written to a temporary file
  and moved into place with ``os.replace``; ``--resume`` continues from it. Designs of an
  interrupted generation come back from the cache, so a run killed at any moment and resumed
  ends with the same population as an uninterrupted one;
* ``evaluations.nc``, ``front.nc``, ``history.nc`` (:func:`export_results`), also copied to
  ``outputs/<profile>/campaign/`` when the run directory lies there (the default).

Designs are evaluated in-process (``workers`` 0 or 1) or as tasks on a Dask cluster (a local
one with one worker process per core, or an existing one by address); each worker builds its
:class:`~lnss_lib.evaluator.EvaluationContext` once (:func:`~lnss_lib.evaluator.context_for`)
and reuses it. A design whose worker is lost is resubmitted.
"""

from __future__ import annotations

import copy
import json
import math
import os
import pickle
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr
from pymoo.core.problem import Problem

from .config import OUTPUTS_DIR, deep_merge, load_profile, profile_hash
from .evaluator import DESIGN_KEYS, METRIC_KEYS

INTEGER_VARIABLES = ("n_planes", "sats_per_plane")
EVALUATORS = ("walker", "synthetic")
TIMING_KEYS = ("propagation", "dop", "deltav", "gps")
CAMPAIGN_ONLY_KEYS = ("population", "generations", "crossover_prob", "crossover_eta", "mutation_eta",
                      "mutation_prob_var", "seed", "ftol", "ftol_period", "objectives", "constraints",
                      "nan_objective", "nan_violation", "hypervolume", "max_resubmits",
                      "numba_threads_per_worker", "synthetic_delay_s")
RUN_FILE, JOURNAL_FILE, CHECKPOINT_FILE = "run.json", "evaluations.jsonl", "checkpoint.pkl"
RESULT_FILES = ("evaluations.nc", "front.nc", "history.nc")
FORMAT_VERSION = 1


# ---------------------------------------------------------------------------------------------
# Design grid (eq. 43-44) and settings
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class DesignGrid:
    """Bounds ``lower``, ``upper`` and steps ``step`` (6,) of ``DESIGN_KEYS`` (Table 3, eq. 43-44)."""

    lower: np.ndarray
    upper: np.ndarray
    step: np.ndarray

    @classmethod
    def from_settings(cls, variables: dict) -> "DesignGrid":
        """From ``{name: {lower, upper, step}}`` for every name in ``DESIGN_KEYS``; ValueError if bad."""
        missing = [k for k in DESIGN_KEYS if k not in variables]
        extra = [k for k in variables if k not in DESIGN_KEYS]
        if missing or extra:
            raise ValueError(f"campaign.variables must name exactly {', '.join(DESIGN_KEYS)}; "
                             f"missing {missing}, unknown {extra}")
        rows = []
        for name in DESIGN_KEYS:
            spec = variables[name]
            if not isinstance(spec, dict) or set(spec) != {"lower", "upper", "step"}:
                raise ValueError(f"campaign.variables.{name} must be {{lower, upper, step}}; got {spec!r}")
            lo, hi, step = (float(spec[k]) for k in ("lower", "upper", "step"))
            if not all(map(math.isfinite, (lo, hi, step))) or step <= 0.0 or hi <= lo:
                raise ValueError(f"campaign.variables.{name}: need finite lower < upper and step > 0; got {spec!r}")
            if name in INTEGER_VARIABLES and (lo != round(lo) or hi != round(hi) or lo < 1):
                raise ValueError(f"campaign.variables.{name}: integer bounds >= 1 required; got {spec!r}")
            rows.append((lo, hi, step))
        lower, upper, step = (np.array(col) for col in zip(*rows))
        return cls(lower, upper, step)

    @property
    def n_levels(self) -> np.ndarray:
        """Largest scaled value of each variable (int, 6): ``ceil((U - L) / dX)``; the scaled domain is 0..n."""
        return np.ceil((self.upper - self.lower) / self.step - 1e-9).astype(int)

    def scale(self, designs) -> np.ndarray:
        """Eq. 43: scaled values ``(X - L) / dX`` (float, not rounded) of physical designs (n, 6)."""
        return (np.atleast_2d(np.asarray(designs, dtype=float)) - self.lower) / self.step

    def descale(self, scaled) -> np.ndarray:
        """Eq. 44: physical designs (n, 6) of scaled ones, clipped to [L, U]; Np and Ns rounded.

        Real variables are rounded to 12 decimals so that grid values print cleanly (0.3, not
        0.30000000000000004).
        """
        x = np.atleast_2d(np.asarray(scaled, dtype=float))
        if x.shape[-1] != len(DESIGN_KEYS) or not np.all(np.isfinite(x)):
            raise ValueError(f"scaled designs must be finite with {len(DESIGN_KEYS)} columns; got shape {x.shape}")
        values = np.round(np.minimum(np.maximum(self.lower + self.step * x, self.lower), self.upper), 12)
        for name in INTEGER_VARIABLES:
            j = DESIGN_KEYS.index(name)
            values[:, j] = np.rint(values[:, j])
        return values

    def designs(self, scaled) -> list[dict]:
        """Keyword dicts for :func:`~lnss_lib.evaluator.evaluate_design` (ints for Np and Ns)."""
        return [{k: (int(v) if k in INTEGER_VARIABLES else float(v)) for k, v in zip(DESIGN_KEYS, row)}
                for row in self.descale(scaled)]


@dataclass(frozen=True)
class CampaignSettings:
    """``profile["campaign"]`` checked (see ``params/paper.toml``); ValueError names a bad entry."""

    grid: DesignGrid
    population: int
    generations: int
    crossover_prob: float
    crossover_eta: float
    mutation_eta: float
    mutation_prob_var: float
    seed: int
    ftol: float
    ftol_period: int
    objectives: tuple[str, ...]
    constraints: tuple[tuple[str, str, float], ...]
    nan_objective: float
    nan_violation: float
    hypervolume: tuple[tuple[str, float], ...]
    evaluator: str
    synthetic_delay_s: float
    max_resubmits: int
    numba_threads_per_worker: int
    overrides: dict = field(default_factory=dict)

    @classmethod
    def from_profile(cls, profile: dict) -> "CampaignSettings":
        if "campaign" not in profile:
            raise ValueError(f"profile {profile.get('profile', {}).get('name')!r} has no [campaign] section")
        c = profile["campaign"]

        def number(key, kind=float, low=None, high=None):
            if key not in c:
                raise ValueError(f"campaign.{key} is missing")
            value = c[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or (kind is int and value != int(value)):
                raise ValueError(f"campaign.{key} must be a finite {kind.__name__}; got {value!r}")
            if (low is not None and value < low) or (high is not None and value > high):
                raise ValueError(f"campaign.{key} = {value!r} is outside [{low}, {high}]")
            return kind(value)

        objectives = tuple(c.get("objectives", ()))
        bad = [o for o in objectives if not isinstance(o, str) or o.lstrip("-") not in METRIC_KEYS]
        if not objectives or bad or len({o.lstrip("-") for o in objectives}) != len(objectives):
            raise ValueError(f"campaign.objectives must be distinct metric names (optionally '-' = maximise) "
                             f"from {', '.join(METRIC_KEYS)}; bad: {bad or objectives!r}")
        constraints = []
        for metric, spec in c.get("constraints", {}).items():
            if metric not in METRIC_KEYS or not isinstance(spec, dict) or len(spec) != 1 \
                    or next(iter(spec)) not in ("min", "max"):
                raise ValueError(f"campaign.constraints.{metric}: need a metric of {', '.join(METRIC_KEYS)} "
                                 f"and exactly one of {{min = value}} or {{max = value}}; got {spec!r}")
            kind, limit = next(iter(spec.items()))
            if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not math.isfinite(limit):
                raise ValueError(f"campaign.constraints.{metric}.{kind} must be a finite number; got {limit!r}")
            constraints.append((metric, kind, float(limit)))
        hv = []
        for metric, ref in c.get("hypervolume", {}).items():
            if metric not in METRIC_KEYS or isinstance(ref, bool) or not isinstance(ref, (int, float)) or ref <= 0:
                raise ValueError(f"campaign.hypervolume.{metric}: need a metric of {', '.join(METRIC_KEYS)} "
                                 f"and a positive reference value; got {ref!r}")
            hv.append((metric, float(ref)))
        evaluator = c.get("evaluator", "walker")
        if evaluator not in EVALUATORS:
            raise ValueError(f"campaign.evaluator {evaluator!r} unknown; allowed: {', '.join(EVALUATORS)}")
        overrides = c.get("overrides", {})
        if not isinstance(overrides, dict) or "campaign" in overrides:
            raise ValueError(f"campaign.overrides must be a table of profile sections other than campaign; "
                             f"got {overrides!r}")
        return cls(
            grid=DesignGrid.from_settings(c.get("variables", {})),
            population=number("population", int, 2),
            generations=number("generations", int, 1),
            crossover_prob=number("crossover_prob", float, 0.0, 1.0),
            crossover_eta=number("crossover_eta", float, 0.0),
            mutation_eta=number("mutation_eta", float, 0.0),
            mutation_prob_var=number("mutation_prob_var", float, 0.0, 1.0),
            seed=number("seed", int, 0),
            ftol=number("ftol", float, 0.0),
            ftol_period=number("ftol_period", int, 1),
            objectives=objectives,
            constraints=tuple(constraints),
            nan_objective=number("nan_objective", float, 0.0),
            nan_violation=number("nan_violation", float, 0.0),
            hypervolume=tuple(hv),
            evaluator=evaluator,
            synthetic_delay_s=number("synthetic_delay_s", float, 0.0),
            max_resubmits=number("max_resubmits", int, 0),
            numba_threads_per_worker=number("numba_threads_per_worker", int, 0),
            overrides=overrides,
        )


def evaluation_profile(profile: dict) -> dict:
    """The profile an evaluation runs under: ``campaign.overrides`` merged in, no campaign section."""
    settings = CampaignSettings.from_profile(profile)
    base = {k: v for k, v in profile.items() if k != "campaign"}
    return deep_merge(base, settings.overrides)


def evaluation_hash(profile: dict) -> str:
    """Hash of every parameter that can change an evaluation of a scaled design.

    :func:`~lnss_lib.config.profile_hash` of the profile without the campaign-only keys
    (``CAMPAIGN_ONLY_KEYS``: population, objectives, constraints, seed, ...); the grid
    (``campaign.variables``), ``campaign.overrides`` and ``campaign.evaluator`` stay in.
    """
    CampaignSettings.from_profile(profile)
    content = copy.deepcopy(profile)
    for key in CAMPAIGN_ONLY_KEYS:
        content["campaign"].pop(key, None)
    return profile_hash(content)


# ---------------------------------------------------------------------------------------------
# Objectives, constraints, dominance, hypervolume (pure functions on arrays)
# ---------------------------------------------------------------------------------------------

def objective_matrix(metrics: dict, objectives, nan_objective: float) -> np.ndarray:
    """F (n, k) for pymoo (minimised): metric, or -metric for a ``-name`` objective; NaN -> ``nan_objective``."""
    columns = []
    for name in objectives:
        values = np.asarray(metrics[name.lstrip("-")], dtype=float)
        signed = -values if name.startswith("-") else values
        columns.append(np.where(np.isfinite(signed), signed, nan_objective))
    return np.column_stack(columns)


def constraint_matrix(metrics: dict, constraints, nan_violation: float) -> np.ndarray:
    """G (n, m), feasible where <= 0: ``value / limit - 1`` for a max bound, ``1 - value / limit`` for a min
    bound (divided by ``|limit|``, or 1 for a zero limit); a NaN metric violates by ``nan_violation``."""
    n = len(np.asarray(metrics[METRIC_KEYS[0]]))
    if not constraints:
        return np.zeros((n, 0))
    columns = []
    for metric, kind, limit in constraints:
        values = np.asarray(metrics[metric], dtype=float)
        scale = abs(limit) if limit != 0.0 else 1.0
        g = (values - limit) / scale if kind == "max" else (limit - values) / scale
        columns.append(np.where(np.isfinite(g), g, nan_violation))
    return np.column_stack(columns)


def constraint_violation(g: np.ndarray) -> np.ndarray:
    """Total violation (n,) >= 0: the sum of the positive parts of G (pymoo's CV)."""
    return np.sum(np.maximum(np.asarray(g, dtype=float), 0.0), axis=1)


def non_dominated_mask(f: np.ndarray, chunk: int = 512) -> np.ndarray:
    """True for the rows of F (n, k) that no other row dominates (<= everywhere, < somewhere); minimisation.

    Identical rows do not dominate each other, so duplicates are all kept.
    """
    f = np.asarray(f, dtype=float)
    n = f.shape[0]
    keep = np.ones(n, dtype=bool)
    for start in range(0, n, chunk):
        block = f[start:start + chunk]
        less_eq = np.all(f[None, :, :] <= block[:, None, :], axis=2)
        less = np.any(f[None, :, :] < block[:, None, :], axis=2)
        keep[start:start + chunk] = ~np.any(less_eq & less, axis=1)
    return keep


def hypervolume(metrics: dict, feasible: np.ndarray, reference) -> float:
    """Hypervolume of the feasible designs in the space of ``reference`` metrics, normalised per metric
    by the reference value (ideal at 0, reference point at 1), so 1 is the whole box [0, ref]."""
    if not reference or not np.any(feasible):
        return 0.0
    from pymoo.indicators.hv import HV

    points = np.column_stack([np.asarray(metrics[m], dtype=float)[feasible] / ref for m, ref in reference])
    points = points[np.all(points < 1.0, axis=1)]
    if points.shape[0] == 0:
        return 0.0
    points = points[non_dominated_mask(points)]
    return float(HV(ref_point=np.ones(points.shape[1])).do(points))


# ---------------------------------------------------------------------------------------------
# Evaluations: the real evaluator, the synthetic stand-in, worker task
# ---------------------------------------------------------------------------------------------

def synthetic_evaluation(profile: dict, sma_km: float, ecc: float, aop_deg: float, inc_deg: float,
                         n_planes: int, sats_per_plane: int, delay_s: float = 0.0) -> dict:
    """A closed-form stand-in for :func:`~lnss_lib.evaluator.evaluate_design` (tests and debugging; no physics).

    Same keys and conventions (an orbit whose perilune ``a (1 - e)`` is below the mean lunar
    radius plus the minimum altitude is an impact with NaN metrics); smooth, deterministic
    trade-offs between satellite count, apolune over the south pole (AOP near 90 deg, high
    inclination) and a perilune-driven Delta-V. ``delay_s`` sleeps to mimic an evaluation's cost.
    Chosen with ``campaign.evaluator = "synthetic"`` (or ``--evaluator synthetic``).
    """
    start = time.perf_counter()
    if delay_s > 0.0:
        time.sleep(delay_s)
    n_sat = int(n_planes) * int(sats_per_plane)
    r_min = float(profile["constants"]["r_moon_mean_km"]) + float(profile["impact"]["min_altitude_km"])
    result = {"deltav_model": "synthetic", "timing_s": dict.fromkeys(TIMING_KEYS, 0.0)}
    if sma_km * (1.0 - ecc) < r_min:
        result.update({k: math.nan for k in METRIC_KEYS}, n_sat=n_sat, feasible=False, impact=True,
                      reason=f"impact: perilune {sma_km * (1.0 - ecc):.1f} km below {r_min:.1f} km")
    else:
        pole = 0.5 * (1.0 + math.sin(math.radians(aop_deg))) * math.sin(math.radians(inc_deg))
        visible = n_sat * (0.2 + 0.6 * pole * (0.3 + ecc) + 0.2 * sma_km / 24000.0)
        pdop = 1.2 + 12.0 / max(visible, 0.3) ** 1.2
        avail = 100.0 * min(1.0, visible / 5.0)
        dv_total = 0.1 + 4.0 * (r_min / (sma_km * (1.0 - ecc))) ** 4 + 0.3 * ecc * math.cos(math.radians(inc_deg))
        gps_visible = 12.0 * sma_km / 24000.0 * (0.5 + 0.5 * math.cos(math.radians(aop_deg)))
        result.update(n_sat=n_sat, mean_visible_sats=visible, pdop_mean_3sigma=pdop, pdop_avail_pct=avail,
                      hdop_mean_3sigma=0.45 * pdop, hdop_avail_pct=min(100.0, 1.1 * avail),
                      dv_total_kms_per_year=dv_total, dv_opt_kms_per_year=0.75 * dv_total,
                      gps_visible_mean=gps_visible,
                      gps_pdop_mean=500.0 / gps_visible if gps_visible >= 1.0 else math.nan,
                      feasible=True, impact=False, reason="")
    result["wall_s"] = time.perf_counter() - start
    return result


def evaluate_task(eval_profile: dict, design: dict, evaluator: str = "walker", synthetic_delay_s: float = 0.0,
                  numba_threads: int = 0) -> dict:
    """Evaluate one design where this runs (in-process or a Dask worker); a JSON-ready record.

    The walker evaluator uses the process-wide context (:func:`~lnss_lib.evaluator.context_for`:
    kernels, tables and compiled code are loaded once per process). ``numba_threads`` > 0 caps the
    propagator's threads (one per worker process on a shared machine). An exception inside the
    evaluator is recorded as an infeasible design with ``reason`` "error: ..." and ``error`` True.
    """
    start = time.perf_counter()
    if numba_threads > 0:
        import numba

        numba.set_num_threads(min(numba_threads, numba.config.NUMBA_NUM_THREADS))
    try:
        if evaluator == "walker":
            from .evaluator import context_for, evaluate_design

            result = evaluate_design(context_for(eval_profile), **design)
        else:
            result = synthetic_evaluation(eval_profile, **design, delay_s=synthetic_delay_s)
        error = False
    except Exception as exc:  # recorded, counted and reported; one failed design must not stop a campaign
        result = {k: math.nan for k in METRIC_KEYS}
        result.update(n_sat=int(design["n_planes"]) * int(design["sats_per_plane"]), feasible=False,
                      impact=False, reason=f"error: {type(exc).__name__}: {exc}", wall_s=0.0, deltav_model="")
        error = True
    metrics = {k: (int(result[k]) if k == "n_sat" else float(result[k])) for k in METRIC_KEYS}
    return {
        "metrics": metrics,
        "ok": bool(result["feasible"]),
        "impact": bool(result.get("impact", False)),
        "error": error,
        "reason": str(result.get("reason", "")),
        "deltav_model": str(result.get("deltav_model", "")),
        "timing_s": {k: float(v) for k, v in result.get("timing_s", {}).items()},
        "wall_s": float(result.get("wall_s", 0.0)),
        "task_wall_s": time.perf_counter() - start,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }


# ---------------------------------------------------------------------------------------------
# Persistent cache (journal), backends, batch evaluator
# ---------------------------------------------------------------------------------------------

def _atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with tmp.open("wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


class EvaluationCache:
    """The run's evaluations, keyed by scaled design (tuple of 6 ints), backed by an append-only JSON-lines file.

    The first line records the evaluation hash; each further line is one record
    ``{"key", "generation", "order", "metrics", "ok", "impact", "error", "reason", ...}``. A line cut
    short by a kill is dropped (and the file truncated to the last complete line) on opening.
    Opening a file written under another evaluation hash raises ValueError.
    """

    def __init__(self, path: Path, eval_hash: str):
        self.path = Path(path)
        self.eval_hash = eval_hash
        self.records: dict[tuple, dict] = {}
        if self.path.exists():
            self._load()
        else:
            self.path.write_text(json.dumps({"evaluation_hash": eval_hash, "format": FORMAT_VERSION}) + "\n")
        self._handle = self.path.open("a")

    def _load(self) -> None:
        data = self.path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end < len(data):
            with self.path.open("r+b") as handle:
                handle.truncate(end)
        lines = data[:end].decode().splitlines()
        header = json.loads(lines[0]) if lines else {}
        if header.get("evaluation_hash") != self.eval_hash:
            raise ValueError(f"{self.path} holds evaluations for evaluation hash {header.get('evaluation_hash')!r}, "
                             f"not {self.eval_hash!r}: the parameters that change an evaluation differ")
        for line in lines[1:]:
            record = json.loads(line)
            self.records[tuple(record["key"])] = record

    def __contains__(self, key: tuple) -> bool:
        return key in self.records

    def __len__(self) -> int:
        return len(self.records)

    def add(self, key: tuple, record: dict) -> None:
        """Store ``record`` under ``key`` and append it to the file (flushed)."""
        record = {"key": list(key), **record}
        self.records[key] = record
        self._handle.write(json.dumps(record) + "\n")
        self._handle.flush()

    def close(self) -> None:
        self._handle.close()


class SerialBackend:
    """Evaluates designs one after the other in this process."""

    n_workers = 1
    resubmitted = 0

    def __init__(self, eval_profile: dict, settings: CampaignSettings):
        self.args = (eval_profile, settings.evaluator, settings.synthetic_delay_s, 0)

    def run(self, designs: list[dict]):
        """Yield ``(index, record)`` for each design as it finishes."""
        profile, evaluator, delay, threads = self.args
        for index, design in enumerate(designs):
            yield index, evaluate_task(profile, design, evaluator, delay, threads)

    def close(self) -> None:
        return None


class DaskBackend:
    """Evaluates designs as tasks on a Dask cluster: a new local one (``n_workers`` processes, one thread
    each, on 127.0.0.1) or an existing one at ``scheduler_address``. A task lost with its worker
    (KilledWorker, closed connection, cancelled) is resubmitted up to ``max_resubmits`` times."""

    def __init__(self, eval_profile: dict, settings: CampaignSettings, n_workers: int | None = None,
                 scheduler_address: str | None = None):
        import logging

        from dask.distributed import Client, LocalCluster

        self.cluster = None
        if scheduler_address:
            self.client = Client(scheduler_address, timeout=60)
        else:
            self.cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                        host="127.0.0.1", dashboard_address=None, silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        self.n_workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        self.profile = eval_profile
        self.settings = settings
        self.resubmitted = 0

    def _submit(self, design: dict):
        s = self.settings
        return self.client.submit(evaluate_task, self.profile, design, s.evaluator, s.synthetic_delay_s,
                                  s.numba_threads_per_worker, pure=False)

    def run(self, designs: list[dict]):
        """Yield ``(index, record)`` for each design as it finishes (completion order)."""
        from dask.distributed import as_completed

        if not designs:
            return
        futures = {}
        for index, design in enumerate(designs):
            futures[self._submit(design)] = index
        attempts = dict.fromkeys(range(len(designs)), 0)
        queue = as_completed(list(futures))
        for future in queue:
            index = futures.pop(future)
            try:
                record = future.result()
            except Exception as exc:  # worker lost or task cancelled: resubmit (evaluate_task itself never raises)
                attempts[index] += 1
                if attempts[index] > self.settings.max_resubmits:
                    raise RuntimeError(f"design {designs[index]} failed {attempts[index]} times on the cluster; "
                                       f"last error: {type(exc).__name__}: {exc}") from exc
                retry = self._submit(designs[index])
                self.resubmitted += 1
                futures[retry] = index
                queue.add(retry)
                continue
            yield index, record

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def open_backend(eval_profile: dict, settings: CampaignSettings, workers: int | None = None,
                 scheduler_address: str | None = None):
    """Serial for ``workers`` 0 or 1 (and no address), else Dask (``workers`` None: one per core)."""
    if scheduler_address:
        return DaskBackend(eval_profile, settings, scheduler_address=scheduler_address)
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if workers < 0:
        raise ValueError(f"workers must be >= 0 (0 or 1 = serial in this process); got {workers}")
    if workers <= 1:
        return SerialBackend(eval_profile, settings)
    return DaskBackend(eval_profile, settings, n_workers=workers)


class BatchEvaluator:
    """Scaled designs (n, 6) -> metric columns, through the cache; new designs go to the backend.

    ``generation`` must be set before each call; records carry the generation in which a design was
    first evaluated and its row in that generation's batch (``order``). ``progress`` is an optional
    callable ``(n_done, n_total, n_hits)`` called as designs finish.
    """

    def __init__(self, settings: CampaignSettings, cache: EvaluationCache, backend):
        self.settings = settings
        self.cache = cache
        self.backend = backend
        self.generation = 1
        self.progress = None
        self.last = {"evaluated": 0, "hits": 0, "errors": 0, "wall_s": 0.0}
        self.n_backend = 0

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
        designs = self.settings.grid.designs(np.array(todo)) if todo else []
        errors, done = 0, 0
        if self.progress:
            self.progress(0, len(todo), hits)
        for index, record in self.backend.run(designs):
            record.update(generation=self.generation, order=order[index])
            self.cache.add(todo[index], record)
            errors += record["error"]
            done += 1
            if self.progress:
                self.progress(done, len(todo), hits)
        self.last = {"evaluated": fresh, "hits": hits, "errors": errors, "wall_s": time.perf_counter() - start}
        self.n_backend += done
        return metric_columns([self.cache.records[k] for k in keys])


def metric_columns(records: list[dict]) -> dict:
    """Metric arrays (n,) keyed by ``METRIC_KEYS`` from cache records, plus ``ok`` (evaluated without impact)."""
    columns = {k: np.array([r["metrics"][k] for r in records], dtype=int if k == "n_sat" else float)
               for k in METRIC_KEYS}
    columns["ok"] = np.array([r["ok"] for r in records], dtype=bool)
    return columns


# ---------------------------------------------------------------------------------------------
# pymoo problem and algorithm
# ---------------------------------------------------------------------------------------------

class WalkerDesignProblem(Problem):
    """pymoo problem over the scaled grid (integers 0..``grid.n_levels``) of eq. 43.

    ``metrics_source(scaled (n, 6)) -> metric columns`` (a :class:`BatchEvaluator`) supplies the
    metrics; it is not pickled with the problem (attach it again after loading a checkpoint).
    """

    def __init__(self, settings: CampaignSettings, metrics_source=None):
        super().__init__(n_var=len(DESIGN_KEYS), n_obj=len(settings.objectives),
                         n_ieq_constr=len(settings.constraints), xl=np.zeros(len(DESIGN_KEYS), dtype=int),
                         xu=settings.grid.n_levels, vtype=int)
        self.settings = settings
        self.metrics_source = metrics_source

    def _evaluate(self, x, out, *args, **kwargs):
        if self.metrics_source is None:
            raise ValueError("WalkerDesignProblem has no metrics source: set problem.metrics_source first")
        metrics = self.metrics_source(x)
        s = self.settings
        out["F"] = objective_matrix(metrics, s.objectives, s.nan_objective)
        if s.constraints:
            out["G"] = constraint_matrix(metrics, s.constraints, s.nan_violation)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["metrics_source"] = None
        return state


def build_algorithm(settings: CampaignSettings):
    """NSGA-II of Table 5 on the integer grid: integer random sampling, SBX crossover applied with
    probability ``crossover_prob`` (Table 5's crossover fraction) and polynomial mutation, both
    rounded back to the grid; duplicates in a generation eliminated."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.operators.sampling.rnd import IntegerRandomSampling

    prob_var = settings.mutation_prob_var if settings.mutation_prob_var > 0.0 else None
    return NSGA2(pop_size=settings.population, sampling=IntegerRandomSampling(),
                 crossover=SBX(prob=settings.crossover_prob, eta=settings.crossover_eta, vtype=float,
                               repair=RoundingRepair()),
                 mutation=PM(eta=settings.mutation_eta, prob_var=prob_var, vtype=float, repair=RoundingRepair()),
                 eliminate_duplicates=True)


def build_termination(settings: CampaignSettings):
    """``generations`` generations; with ``ftol`` > 0 also pymoo's objective-space tolerance (feasible
    designs, movement of ideal, nadir and front below ``ftol`` over ``ftol_period`` generations)."""
    from pymoo.termination.max_gen import MaximumGenerationTermination

    max_gen = MaximumGenerationTermination(settings.generations)
    if settings.ftol <= 0.0:
        return max_gen
    from pymoo.termination.collection import TerminationCollection
    from pymoo.termination.ftol import MultiObjectiveSpaceTermination
    from pymoo.termination.robust import RobustTermination

    tol = RobustTermination(MultiObjectiveSpaceTermination(settings.ftol, only_feas=True), period=settings.ftol_period)
    return TerminationCollection(max_gen, tol)


# ---------------------------------------------------------------------------------------------
# Run directory: run.json, checkpoint, results
# ---------------------------------------------------------------------------------------------

def load_run(run_dir) -> dict:
    """``run.json`` of a run directory (profile, evaluation hash, creation time); ValueError if absent."""
    path = Path(run_dir) / RUN_FILE
    if not path.is_file():
        raise ValueError(f"{run_dir} is not a campaign run directory (no {RUN_FILE})")
    return json.loads(path.read_text())


def load_checkpoint(run_dir) -> dict | None:
    """The last checkpoint of a run (keys generation, algorithm, history, finished), or None before the first."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.is_file():
        return None
    with path.open("rb") as handle:
        return pickle.load(handle)


def final_population(run_dir) -> tuple[np.ndarray, np.ndarray]:
    """(scaled X (n, 6) int, F (n, k)) of the population in a run's last checkpoint."""
    checkpoint = load_checkpoint(run_dir)
    if checkpoint is None:
        raise ValueError(f"{run_dir} has no checkpoint yet")
    pop = checkpoint["algorithm"].pop
    return np.asarray(pop.get("X")).astype(int), np.asarray(pop.get("F"), dtype=float)


def read_cache_records(run_dir) -> list[dict]:
    """Every record of a run's evaluation cache, in file order (complete lines only)."""
    path = Path(run_dir) / JOURNAL_FILE
    if not path.is_file():
        return []
    data = path.read_bytes()
    lines = data[:data.rfind(b"\n") + 1].decode().splitlines()
    return [json.loads(line) for line in lines[1:]]


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


def _dataset_from_records(records: list[dict], settings: CampaignSettings, attrs: dict) -> xr.Dataset:
    records = sorted(records, key=lambda r: (r["generation"], r["order"]))
    keys = np.array([r["key"] for r in records], dtype=float).reshape(-1, len(DESIGN_KEYS))
    designs = settings.grid.descale(keys) if len(records) else np.zeros((0, len(DESIGN_KEYS)))
    columns = metric_columns(records) if records else {k: np.zeros(0) for k in (*METRIC_KEYS, "ok")}
    cv = constraint_violation(constraint_matrix(columns, settings.constraints, settings.nan_violation)) \
        if records else np.zeros(0)
    data = {}
    for j, name in enumerate(DESIGN_KEYS):
        data[name] = ("design", designs[:, j].astype(np.int64 if name in INTEGER_VARIABLES else np.float64))
    for name in METRIC_KEYS:
        data[name] = ("design", np.asarray(columns[name]).astype(np.int64 if name == "n_sat" else np.float64))
    data["feasible"] = ("design", np.asarray(columns["ok"], dtype=bool) & (cv == 0.0))
    data["impact"] = ("design", np.array([r["impact"] for r in records], dtype=bool))
    data["constraint_violation"] = ("design", cv.astype(np.float64))
    data["generation"] = ("design", np.array([r["generation"] for r in records], dtype=np.int64))
    ds = xr.Dataset(data, attrs=attrs)
    units = {"sma_km": "km", "aop_deg": "deg", "inc_deg": "deg", "dv_total_kms_per_year": "km/s per satellite per year",
             "dv_opt_kms_per_year": "km/s per satellite per year", "pdop_avail_pct": "%", "hdop_avail_pct": "%"}
    for name, unit in units.items():
        ds[name].attrs["units"] = unit
    ds["feasible"].attrs["description"] = "evaluated without impact and every campaign constraint met (Table 3)"
    ds["constraint_violation"].attrs["description"] = ("sum of positive normalised constraint values "
                                                       "(value/limit - 1 for max, 1 - value/limit for min)")
    ds["generation"].attrs["description"] = "generation in which the design was first evaluated"
    return ds


def export_results(run_dir) -> tuple[xr.Dataset, xr.Dataset, xr.Dataset]:
    """(evaluations, front, history) Datasets of a run directory, finished or not.

    evaluations: every unique design evaluated (dim ``design``, in order of first evaluation);
    front: the feasible designs that no other feasible design dominates in the campaign's
    objectives; history: per generation (dim ``generation``) the counts, best values,
    hypervolume, minimum population violation and wall time.
    """
    from .pipeline import package_versions

    run = load_run(run_dir)
    profile = run["profile"]
    settings = CampaignSettings.from_profile(profile)
    checkpoint = load_checkpoint(run_dir)
    history = checkpoint["history"] if checkpoint else []
    attrs = {
        "profile": profile["profile"]["name"],
        "objectives": ",".join(settings.objectives),
        "constraints": ",".join(f"{m} {'<=' if k == 'max' else '>='} {v:g}" for m, k, v in settings.constraints),
        "parameters": json.dumps(profile, sort_keys=True),
        "versions": json.dumps(package_versions(), sort_keys=True),
        "evaluation_hash": run["evaluation_hash"],
        "evaluator": settings.evaluator,
        "seed": settings.seed,
        "generations_done": len(history),
        "finished": int(bool(checkpoint and checkpoint.get("finished"))),
    }
    records = read_cache_records(run_dir)
    evaluations = _dataset_from_records(records, settings, attrs)
    feasible = evaluations["feasible"].values
    columns = {k: evaluations[k].values for k in METRIC_KEYS}
    f = objective_matrix(columns, settings.objectives, settings.nan_objective)
    front_index = np.flatnonzero(feasible)[non_dominated_mask(f[feasible])] if feasible.any() else np.zeros(0, int)
    front = evaluations.isel(design=front_index)
    front.attrs = {**attrs, "description": "feasible designs not dominated by any other feasible design in the "
                                           "campaign objectives"}
    names = sorted({k for h in history for k in h if k != "generation"})
    hist = xr.Dataset({k: ("generation", np.array([h[k] for h in history])) for k in names},
                      coords={"generation": np.array([h["generation"] for h in history], dtype=np.int64)},
                      attrs={**attrs, "hypervolume_reference": json.dumps(dict(settings.hypervolume))})
    return evaluations, front, hist


def write_results(run_dir, publish_dir=None) -> list[Path]:
    """Write evaluations.nc, front.nc and history.nc (h5netcdf, atomically) into the run directory and,
    if given, ``publish_dir``; returns the paths written."""
    datasets = export_results(run_dir)
    written = []
    for folder in [Path(run_dir)] + ([Path(publish_dir)] if publish_dir else []):
        for name, ds in zip(RESULT_FILES, datasets):
            target = folder / name
            tmp = folder / f".{name}.tmp{os.getpid()}"
            ds.to_netcdf(tmp, engine="h5netcdf")
            os.replace(tmp, target)
            written.append(target)
    return written


# ---------------------------------------------------------------------------------------------
# The campaign
# ---------------------------------------------------------------------------------------------

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


def _default_run_dir(profile_name: str) -> Path:
    from .pipeline import output_dir

    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = output_dir(profile_name, "campaign")
    candidate, n = base / f"run_{stamp}", 1
    while candidate.exists():
        n += 1
        candidate = base / f"run_{stamp}_{n}"
    return candidate


def _start_run(run_dir: Path, profile: dict) -> None:
    from .pipeline import package_versions

    run_dir.mkdir(parents=True, exist_ok=True)
    if (run_dir / RUN_FILE).exists():
        raise ValueError(f"{run_dir} already holds a campaign; continue it with --resume {run_dir}")
    run = {"profile": profile, "evaluation_hash": evaluation_hash(profile),
           "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "versions": package_versions()}
    _atomic_write_bytes(run_dir / RUN_FILE, json.dumps(run, indent=1, default=str).encode())


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
        run_dir = Path(run_dir) if run_dir is not None else _default_run_dir(profile_name)
        _start_run(run_dir, profile)
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
            _atomic_write_bytes(run_dir / CHECKPOINT_FILE, pickle.dumps(
                {"format": FORMAT_VERSION, "generation": generation, "algorithm": algorithm, "history": history,
                 "finished": not algorithm.has_next()}))
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


# ---------------------------------------------------------------------------------------------
# Campaign tables for notebook 06 (Table 5, Table 3 grid, binding constraints, throughput)
# ---------------------------------------------------------------------------------------------

PAPER_FEASIBLE_DESIGNS = 5622       # Section 6.2: unique feasible configurations
PAPER_EVALUATIONS = 120 * 1000      # Table 5: population 120 x 1000 generations
CONSTRAINT_LABELS = {"pdop_mean_3sigma": ("PDOP_3sigma", ""), "pdop_avail_pct": ("PDOP availability", " %"),
                     "hdop_mean_3sigma": ("HDOP_3sigma", ""), "hdop_avail_pct": ("HDOP availability", " %"),
                     "dv_total_kms_per_year": ("Delta-V_total", " km/s/yr"),
                     "dv_opt_kms_per_year": ("Delta-V_opt", " km/s/yr")}


def settings_table(settings: CampaignSettings):
    """Table 5 (NSGA-II settings of the paper) next to this profile's pymoo counterparts, with notes."""
    import pandas as pd

    s = settings
    return pd.DataFrame([
        ("Population size", 120, s.population, "same"),
        ("No. of generations", 1000, s.generations, "generation 1 is the initial population"),
        ("Total evaluations", 120000, s.population * s.generations,
         "upper bound; duplicates are evaluated once (cache)"),
        ("Crossover fraction", 0.65, s.crossover_prob, f"SBX (eta {s.crossover_eta:g}) applied to a mating pair "
         "with this probability, rounded to the grid"),
        ("Mutation function", "adaptive", f"polynomial, eta {s.mutation_eta:g}",
         "rounded to the integer grid; per-variable probability "
         + (f"{s.mutation_prob_var:g}" if s.mutation_prob_var else "1/6")),
        ("Pareto fraction", 0.30, "-", "no counterpart in pymoo: rank-and-crowding survival keeps the whole first fronts"),
        ("Function tolerance", 1e-6, s.ftol if s.ftol else "off",
         f"pymoo objective-space tolerance over {s.ftol_period} generations" if s.ftol else "fixed generations"),
        ("Seed", "fixed", s.seed, "same seed, same run (also after kill and resume)"),
    ], columns=["parameter", "paper", "this profile", "note"]).set_index("parameter")


def design_grid_table(settings: CampaignSettings):
    """Table 3 design-variable bounds with the eq. 43-44 step sizes and the number of grid values."""
    import pandas as pd

    grid = settings.grid
    return pd.DataFrame({"lower": grid.lower, "upper": grid.upper, "step": grid.step, "levels": grid.n_levels + 1},
                        index=pd.Index(["a (km)", "e", "AOP (deg)", "i (deg)", "Np", "Ns"], name="variable"))


def latest_run_dir(campaign_dir, profile_name: str) -> Path:
    """The newest ``run_*`` directory with a checkpoint under ``campaign_dir``; FileNotFoundError naming
    the command that makes one for ``profile_name``."""
    runs = sorted(p for p in Path(campaign_dir).glob("run_*") if (p / CHECKPOINT_FILE).is_file())
    if not runs:
        raise FileNotFoundError(
            f"no campaign in {campaign_dir}. Run it first (hours on 2 cores for paper, checkpointed every "
            f"generation):\n    python -m lnss_lib campaign --profile {profile_name}\n"
            "continue an interrupted run with --resume <run dir>, or use a Dask cluster with "
            "--scheduler-address tcp://HOST:8786; then execute the notebook again")
    return runs[-1]


def load_or_run(profile_name: str) -> tuple[Path, xr.Dataset, xr.Dataset, xr.Dataset, list[dict]]:
    """(run_dir, evaluations, front, history, cache records) of the profile's campaign.

    ``paper`` loads the latest run in ``outputs/paper/campaign/`` (publishing its last checkpoint,
    so a run still going is covered); any other profile runs its campaign here (:func:`run_campaign`).
    """
    from .pipeline import output_dir

    campaign_dir = output_dir(profile_name, "campaign")
    if profile_name == "paper":
        run_dir = latest_run_dir(campaign_dir, profile_name)
        write_results(run_dir, campaign_dir)
        print(f"loaded {run_dir}")
    else:
        result = run_campaign(profile_name, progress=False)
        run_dir = result.run_dir
        print(f"ran {run_dir}: {result.generations} generations, {result.n_evaluations} unique designs in "
              f"{result.session_wall_s:.1f} s")
    evaluations, front, history = (xr.open_dataset(campaign_dir / name, engine="h5netcdf").load()
                                   for name in RESULT_FILES)
    return run_dir, evaluations, front, history, read_cache_records(run_dir)


def constraint_label(metric: str, kind: str, limit: float) -> str:
    """Readable bound, e.g. ``("pdop_avail_pct", "min", 70.0)`` -> ``"PDOP availability >= 70 %"``."""
    name, unit = CONSTRAINT_LABELS.get(metric, (metric, ""))
    return f"{name} {'<=' if kind == 'max' else '>='} {limit:g}{unit}"


def constraint_table(evaluations: xr.Dataset, constraints):
    """Designs meeting each campaign bound (Table 3) separately, with count and share of all designs.

    Rows: evaluated without impact (PDOP availability defined), each (metric, kind, limit) of
    ``constraints`` (CampaignSettings.constraints; NaN fails), all bounds except those on Delta-V
    ("navigation bounds only"), and the campaign's own ``feasible`` flag.
    """
    import pandas as pd

    checks = {"evaluated without impact": ~np.isnan(evaluations["pdop_avail_pct"].values.astype(float))}
    navigation = np.ones(evaluations.sizes["design"], dtype=bool)
    for metric, kind, limit in constraints:
        if kind not in ("min", "max"):
            raise ValueError(f"constraint kind {kind!r} for {metric!r} unknown; allowed: min, max")
        values = evaluations[metric].values.astype(float)
        with np.errstate(invalid="ignore"):
            met = values <= limit if kind == "max" else values >= limit
        checks[constraint_label(metric, kind, limit)] = met
        if not metric.startswith("dv_"):
            navigation &= met
    checks["navigation bounds only (no Delta-V bound)"] = navigation
    checks["all Table 3 bounds (feasible)"] = evaluations["feasible"].values.astype(bool)
    n = evaluations.sizes["design"]
    table = pd.DataFrame({"designs": {k: int(v.sum()) for k, v in checks.items()},
                          "share (%)": {k: 100.0 * v.sum() / max(n, 1) for k, v in checks.items()}})
    table.index.name = "bound"
    return table


def steady_designs_per_s(history: xr.Dataset, n_evaluations: int) -> float:
    """Designs evaluated per second of generation wall time from generation 2 on (generation 1 holds the
    worker warm-up); the overall rate when the run has one generation."""
    later = history.where(history.generation > 1, drop=True)
    if later.sizes["generation"]:
        return float(later.n_evaluated.sum() / later.wall_s.sum())
    return n_evaluations / float(history.wall_s.sum())


def throughput_table(history: xr.Dataset, n_feasible: int, timing: dict, workers: int):
    """Campaign counts, throughput and worker-time shares, with the projection of the paper's
    120 x 1000 campaign at the steady rate (no cache hits).

    ``timing`` is :func:`lnss_lib.bench.campaign.campaign_timing` of the run (keys n_evaluations,
    worker_budget_s, propagation_s, metrics_s, in_task_overhead_s, campaign_overhead_s); wall time
    is the sum of ``history.wall_s`` (generations only).
    """
    import pandas as pd

    if workers < 1:
        raise ValueError(f"workers must be >= 1; got {workers!r}")
    wall = float(history.wall_s.sum())
    steady = steady_designs_per_s(history, timing["n_evaluations"])
    budget = timing["worker_budget_s"]
    return pd.DataFrame({
        "value": [timing["n_evaluations"], n_feasible, PAPER_FEASIBLE_DESIGNS, wall, timing["n_evaluations"] / wall,
                  steady, workers, 100 * timing["propagation_s"] / budget, 100 * timing["metrics_s"] / budget,
                  100 * timing["in_task_overhead_s"] / budget, 100 * timing["campaign_overhead_s"] / budget,
                  100 * float(history.n_cache_hits.sum() / history.n_designs.sum()),
                  PAPER_EVALUATIONS / steady / 3600.0]},
        index=pd.Index(["unique designs evaluated", "unique feasible designs", "unique feasible designs (paper)",
                        "campaign wall time (s, generations)", "designs per second (overall)",
                        "designs per second (generation 2 on)", "worker processes", "propagation (% of worker time)",
                        "DOP, Delta-V, GPS (% of worker time)", "in-task overhead (%)", "campaign overhead (%)",
                        "cache hits (% of requested designs)",
                        "projected 120 x 1000 campaign at this profile's fidelity (h, this machine)"], name="quantity"))


def run_throughput_table(run_dir, history: xr.Dataset, evaluations: xr.Dataset, records: list[dict]):
    """:func:`throughput_table` of a run directory: worker processes counted from the cache records,
    time shares from :func:`lnss_lib.bench.campaign.campaign_timing`."""
    from .bench.campaign import campaign_timing

    workers = len({r["worker"] for r in records}) or 1
    timing = campaign_timing(run_dir, workers, float(history.wall_s.sum()))
    return throughput_table(history, int(evaluations["feasible"].sum()), timing, workers)
