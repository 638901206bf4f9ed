"""One design's evaluation as a task (in-process or on a Dask worker), and the synthetic stand-in."""

from __future__ import annotations

import math
import os
import socket
import time

from .. import kernel_cpu
from ..keys import CAMPAIGN_METRIC_KEYS, METRIC_KEYS, TIMING_KEYS, violated_bound
from ..settings import Settings

__all__ = [
    "evaluate_task",
    "synthetic_evaluation",
    "cap_numba_threads",
    "worker_name",
    "worker_fields",
]


def synthetic_evaluation(
    settings: Settings,
    sma_km: float,
    ecc: float,
    aop_deg: float,
    inc_deg: float,
    n_planes: int,
    sats_per_plane: int,
    delay_s: float = 0.0,
    stop_bounds=None,
) -> dict:
    """A closed-form stand-in for :func:`~lnss_lib.evaluator.evaluate_design` (tests and debugging; no physics).

    Same keys and conventions (an orbit whose perilune ``a (1 - e)`` is below the mean lunar
    radius plus the minimum altitude is an impact with NaN metrics); smooth, deterministic
    trade-offs between satellite count, apolune over the south pole (AOP near 90 deg, high
    inclination) and a perilune-driven Delta-V. ``delay_s`` sleeps to mimic an evaluation's cost.
    Chosen with ``campaign.evaluator = "synthetic"`` (or ``--evaluator synthetic``).

    The settings' ``[evaluator] extra_metrics`` get closed-form stand-ins too (no physics either):
    a geometry-keeping Delta-V that grows with a (the Earth's tide) and away from the frozen
    inclination near 60 deg, its maximum 10 % above the mean, the eq. 45 Delta-V maxima 5 % above
    their values, and a "screen" that calls a design unstable when the Lidov-Kozai bound
    ``a (1 - e_max)`` with ``e_max = sqrt(1 - 5/3 cos^2 i)`` (i above 39.2 deg) for a > 8000 km
    falls below the surface; availabilities over the life that fall with that Delta-V (the worst month
    more than the life's mean); the metre metrics are a 4 m range error times the stand-in HDOP (vertical twice
    that), the requirement met as often as the PDOP availability, every satellite uploaded hourly.
    ``stop_bounds``: a design that breaks one comes back not evaluated, as the
    evaluator's (:func:`~lnss_lib.evaluator.campaign_metrics`).
    """
    start = time.perf_counter()
    if delay_s > 0.0:
        time.sleep(delay_s)
    n_sat = int(n_planes) * int(sats_per_plane)
    r_min = settings.dynamics.r_impact_km
    extras = settings.evaluator.extra_metrics
    result = {"deltav_model": "synthetic", "timing_s": dict.fromkeys(TIMING_KEYS, 0.0)}
    if sma_km * (1.0 - ecc) < r_min:
        result.update(
            {k: math.nan for k in METRIC_KEYS + extras},
            n_sat=n_sat,
            evaluated=False,
            impact=True,
            reason=f"impact: perilune {sma_km * (1.0 - ecc):.1f} km below {r_min:.1f} km",
        )
    else:
        pole = 0.5 * (1.0 + math.sin(math.radians(aop_deg))) * math.sin(math.radians(inc_deg))
        visible = n_sat * (0.2 + 0.6 * pole * (0.3 + ecc) + 0.2 * sma_km / 24000.0)
        pdop = 1.2 + 12.0 / max(visible, 0.3) ** 1.2
        avail = 100.0 * min(1.0, visible / 5.0)
        dv_total = (
            0.1
            + 4.0 * (r_min / (sma_km * (1.0 - ecc))) ** 4
            + 0.3 * ecc * math.cos(math.radians(inc_deg))
        )
        gps_visible = 12.0 * sma_km / 24000.0 * (0.5 + 0.5 * math.cos(math.radians(aop_deg)))
        result.update(
            n_sat=n_sat,
            mean_visible_sats=visible,
            pdop_mean_3sigma=pdop,
            pdop_avail_pct=avail,
            hdop_mean_3sigma=0.45 * pdop,
            hdop_avail_pct=min(100.0, 1.1 * avail),
            dv_total_kms_per_year=dv_total,
            dv_opt_kms_per_year=0.75 * dv_total,
            gps_visible_mean=gps_visible,
            gps_pdop_mean=500.0 / gps_visible if gps_visible >= 1.0 else math.nan,
            evaluated=True,
            impact=False,
            reason="",
        )
        result.update(
            _synthetic_extras(
                sma_km, ecc, inc_deg, r_min, dv_total, 0.45 * pdop, avail, gps_visible, extras
            )
        )
        broken = violated_bound(result, stop_bounds or ())
        if broken:
            result.update(
                evaluated=False, reason=f"stopped early: {broken}; the rest not evaluated"
            )
    result["wall_s"] = time.perf_counter() - start
    return result


def _synthetic_extras(
    sma_km: float,
    ecc: float,
    inc_deg: float,
    r_min: float,
    dv_total: float,
    hdop: float,
    avail: float,
    gps_visible: float,
    extras,
) -> dict:
    """Closed-form stand-ins for the extra metrics (see :func:`synthetic_evaluation`; no physics)."""
    cos_i = math.cos(math.radians(inc_deg))
    sk = 0.05 + 0.6 * (sma_km / 24000.0) ** 3 + 0.8 * abs(math.sin(math.radians(inc_deg - 60.0)))
    e_max = (
        max(ecc, math.sqrt(max(0.0, 1.0 - 5.0 / 3.0 * cos_i * cos_i))) if sma_km > 8000.0 else ecc
    )
    perilune_alt = sma_km * (1.0 - e_max) - r_min
    values = {
        "sk_dv_estimate_kms_per_year": sk,
        "sk_dv_estimate_max_kms_per_year": 1.1 * sk,
        "stable_screen": 1.0 if perilune_alt > 0.0 else 0.0,
        "screen_min_perilune_alt_km": perilune_alt,
        "dv_total_max_kms_per_year": 1.05 * dv_total,
        "dv_opt_max_kms_per_year": 0.75 * 1.05 * dv_total,
        "horizontal_error_95_m": 2.0 * 4.0 * hdop,
        "vertical_error_95_m": 1.96 * 4.0 * 2.0 * hdop,
        "position_error_avail_pct": avail,
        "ephemeris_age_max_h": 1.0,
        "satellites_never_uploaded": 0,
        "gnss_visible_mean": 3.0 * gps_visible,
        "gnss_pdop_mean": 300.0 / (3.0 * gps_visible) if gps_visible >= 1.0 / 3.0 else math.nan,
    }
    drift = min(1.0, 0.5 * sk)  # the drift the Delta-V stand-in pays against
    for name, value in (("pdop", avail), ("hdop", min(100.0, 1.1 * avail))):
        values[f"{name}_avail_pct_life_estimate"] = value * (1.0 - 0.05 * drift)
        values[f"{name}_avail_pct_worst_month_estimate"] = value * (1.0 - 0.1 * drift)
    return {k: values[k] for k in extras}


def cap_numba_threads(numba_threads: int) -> None:
    """Cap the compiled kernels' threads in this process at ``numba_threads`` (0: leave numba's default)."""
    if numba_threads > 0:
        import numba

        numba.set_num_threads(min(numba_threads, numba.config.NUMBA_NUM_THREADS))


def worker_name() -> str:
    """``host:pid`` of the process a task runs in."""
    return f"{socket.gethostname()}:{os.getpid()}"


def worker_fields() -> dict:
    """Where a task ran, for its journal record: ``worker`` (:func:`worker_name`) and ``kernel_cpu``, the processor
    model its kernels were compiled for (:func:`lnss_lib.kernel_cpu`, which fixes their round-off; the journal answers
    a design from its record only on that model: :class:`~lnss_lib.campaign.journal.EvaluationCache`)."""
    return {"worker": worker_name(), "kernel_cpu": kernel_cpu()}


def evaluate_task(
    eval_profile: Settings,
    design: dict,
    evaluator: str = "walker",
    synthetic_delay_s: float = 0.0,
    numba_threads: int = 0,
) -> dict:
    """Evaluate one design under the evaluation settings ``eval_profile`` (checked once, at the campaign's start:
    nothing is validated or hashed here) where this runs (in-process or a Dask worker); a JSON-ready record.
    ``design``: Table 3's six variables, and ``stop_bounds`` when the campaign stops designs that break a bound
    early (:class:`~lnss_lib.campaign.backends.BatchEvaluator`).

    The walker evaluator uses the process-wide context (:func:`~lnss_lib.evaluator.context_for`:
    kernels, tables and compiled code are loaded once per process). ``numba_threads`` > 0 caps the
    propagator's threads (one per worker process on a shared machine). An exception inside the
    evaluator is recorded as an infeasible design with ``reason`` "error: ..." and ``error`` True.
    """
    start = time.perf_counter()
    cap_numba_threads(numba_threads)
    try:
        if evaluator == "walker":
            from ..evaluator import context_for, evaluate_design

            result = evaluate_design(context_for(eval_profile), **design)
        else:
            result = synthetic_evaluation(eval_profile, **design, delay_s=synthetic_delay_s)
        error = False
    except (
        Exception
    ) as exc:  # recorded, counted and reported; one failed design must not stop a campaign
        result = {k: math.nan for k in CAMPAIGN_METRIC_KEYS}
        result.update(
            n_sat=int(design["n_planes"]) * int(design["sats_per_plane"]),
            evaluated=False,
            impact=False,
            reason=f"error: {type(exc).__name__}: {exc}",
            wall_s=0.0,
            deltav_model="",
        )
        error = True
    metrics = {k: (int(result[k]) if k == "n_sat" else float(result[k])) for k in METRIC_KEYS}
    metrics.update(
        {k: float(result[k]) for k in CAMPAIGN_METRIC_KEYS if k in result and k not in METRIC_KEYS}
    )
    return {
        "metrics": metrics,
        "ok": bool(result["evaluated"]),
        "impact": bool(result.get("impact", False)),
        "error": error,
        "reason": str(result.get("reason", "")),
        "deltav_model": str(result.get("deltav_model", "")),
        "timing_s": {k: float(v) for k, v in result.get("timing_s", {}).items()},
        "wall_s": float(result.get("wall_s", 0.0)),
        "task_wall_s": time.perf_counter() - start,
        **worker_fields(),
    }
