"""The design evaluator: every quantity of eq. 45 for a Walker design or an explicit constellation.

An :class:`EvaluationContext` holds what a run shares across designs (ephemeris tables and force
model, the Moon-fixed rotation at every epoch, the surface grid, the GPS states); it is built once
per process. :func:`evaluate_design` propagates a design, then computes the south-pole DOP
statistics (eq. 9-14, all satellites), the station-keeping Delta-V and the GPS-LNSS link (first
satellite, as the paper does, Section 5.3). Infeasible designs (impact, invalid elements) come back
flagged with NaN metrics, never raised, so batch callers can treat them as constraint violations.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import xarray as xr

from . import deltav, dop, gps
from .config import load_profile, profile_hash
from .constellation import WalkerDesign
from .ephemeris import EphemerisTable, ensure_kernels, rotation, tdb_seconds
from .constants import SECONDS_PER_DAY
from .forces import ForceModel
from .frames import rotate_with
from .errors import ImpactError
from .keys import DESIGN_KEYS, METRIC_KEYS, RESULT_KEYS
from .propagator import elements_deg_to_states, output_times, propagate_states



@dataclass
class EvaluationContext:
    """Everything a run shares across design evaluations (build with :meth:`from_profile`)."""

    profile: dict
    t0_tdb_s: float
    times: np.ndarray
    model: ForceModel
    rot_to_moon_fixed: np.ndarray
    grid: dop.SurfaceGrid
    gps_states: xr.Dataset

    @classmethod
    def from_profile(cls, profile: dict) -> "EvaluationContext":
        """Tables, force model, Moon-fixed rotations, grid and GPS states over the profile's arc."""
        ensure_kernels(profile)
        epoch = profile["epoch"]
        t0 = tdb_seconds(epoch["start_tdb"], "TDB")
        times = output_times(t0, epoch["duration_days"] * SECONDS_PER_DAY, epoch["step_s"])
        table = EphemerisTable.build(profile, t0, float(times[-1]))
        model = ForceModel.from_profile(profile, table)
        rot = rotation("J2000", profile["frames"]["moon_fixed"], times)
        return cls(profile, t0, times, model, rot, dop.grid_from_profile(profile), gps.gps_states_mci(profile, times))


_CONTEXTS: dict[str, EvaluationContext] = {}


def context_for(profile: dict) -> EvaluationContext:
    """The process-wide :class:`EvaluationContext` of a profile (built on first use)."""
    key = profile_hash(profile)
    if key not in _CONTEXTS:
        _CONTEXTS[key] = EvaluationContext.from_profile(profile)
    return _CONTEXTS[key]


def _infeasible(n_sat: int, reason: str, model: str, start: float) -> dict:
    result = {k: math.nan for k in METRIC_KEYS}
    result.update(n_sat=int(n_sat), deltav_model=model, feasible=False, reason=reason,
                  impact=reason.startswith("impact"), wall_s=time.perf_counter() - start)
    return result


def analyse_constellation(context: EvaluationContext, elements_deg) -> dict:
    """Propagate a constellation and keep every intermediate result, for study notebooks.

    Returns ``{"propagation", "dop", "deltav", "gps_link": xarray.Dataset, "metrics": dict}`` with
    the metrics of :func:`evaluate_constellation`. Raises ``ValueError`` for invalid elements and
    :class:`~lnss_lib.propagator.ImpactError` for an orbit that hits the Moon.
    """
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    return _analyse_states(context, elements, elements_deg_to_states(context.profile, elements, context.t0_tdb_s))


def _analyse_states(context: EvaluationContext, elements: np.ndarray, states: np.ndarray,
                    datasets: bool = True) -> dict:
    """Propagation and metrics; without ``datasets`` the campaign's path: no grid or link Dataset, the DOP
    grid compiled (:func:`lnss_lib.dop.metrics_from_profile`, same metrics to ~1e-12 relative) and the
    GPS link from arrays (:func:`lnss_lib.gps.gps_link_metrics`, bit for bit)."""
    start = time.perf_counter()
    profile = context.profile
    times = context.times
    clock = [time.perf_counter()]
    ds = propagate_states(profile, states, context.t0_tdb_s, float(times[-1] - times[0]), profile["epoch"]["step_s"],
                          batch=True, model=context.model)
    if bool(ds.impact.any()):
        first = int(np.argmax(ds.impact.values))
        t_impact = float(ds.impact_t_tdb_s.values[first])
        days = (t_impact - context.t0_tdb_s) / SECONDS_PER_DAY
        raise ImpactError(f"impact: satellite {first} hits the Moon after {days:.2f} days", sat=first,
                          t_tdb_s=t_impact, days=days)
    ds["elements_deg"] = (("sat", "element"), elements)
    clock.append(time.perf_counter())
    r_mf = rotate_with(context.rot_to_moon_fixed, ds.r_mci_km.values)
    if datasets:
        grid_ds = dop.dop_for_profile(profile, r_mf, times, grid=context.grid)
        dop_stats = dop.summary_from_profile(profile, grid_ds)
    else:
        grid_ds, dop_stats = None, dop.metrics_from_profile(profile, r_mf, context.grid)
    clock.append(time.perf_counter())
    dv = deltav.deltav_from_propagation(profile, ds, sat=0)
    clock.append(time.perf_counter())
    if datasets:
        link = gps.gps_link(profile, context.gps_states, ds, sats="first")
        link_stats = gps.gps_link_summary(link)
    else:
        link, link_stats = None, gps.gps_link_metrics(profile, context.gps_states, ds["r_mci_km"].values)
    clock.append(time.perf_counter())
    metrics = {
        "n_sat": int(elements.shape[0]),
        "mean_visible_sats": dop_stats["mean_visible_sats"],
        "pdop_mean_3sigma": dop_stats["pdop_mean_3sigma"],
        "pdop_avail_pct": dop_stats["pdop_avail_pct"],
        "hdop_mean_3sigma": dop_stats["hdop_mean_3sigma"],
        "hdop_avail_pct": dop_stats["hdop_avail_pct"],
        "dv_total_kms_per_year": float(dv.attrs["dv_total_kms_per_year"]),
        "dv_opt_kms_per_year": float(dv.attrs["dv_opt_kms_per_year"]),
        "gps_visible_mean": link_stats["gps_visible_mean"],
        "gps_pdop_mean": link_stats["gps_pdop_mean"],
        "deltav_model": dv.attrs["deltav_model"],
        "feasible": True,
        "reason": "",
        "impact": False,
        "timing_s": dict(zip(("propagation", "dop", "deltav", "gps"), np.diff(clock).tolist())),
        "wall_s": time.perf_counter() - start,
    }
    return {"propagation": ds, "dop": grid_ds, "deltav": dv, "gps_link": link, "metrics": metrics}


def evaluate_constellation(context: EvaluationContext, elements_deg) -> dict:
    """Every quantity of eq. 45 for satellites given by elements (n, 6) [a_km, e, i, RAAN, AOP, M] (deg).

    Returns a dict with :data:`RESULT_KEYS` plus ``reason`` ("" when feasible), ``impact`` and
    ``timing_s`` (seconds spent in propagation, DOP, Delta-V and GPS link). ``feasible`` is False
    (metrics NaN) for invalid elements or an orbit that hits the Moon; the Table 3 bounds are the
    optimiser's business, not checked here.
    """
    start = time.perf_counter()
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    n_sat = elements.shape[0]
    model_name = deltav.deltav_settings(context.profile)["model"]
    try:
        states = elements_deg_to_states(context.profile, elements, context.t0_tdb_s)
    except ValueError as error:
        return _infeasible(n_sat, f"invalid elements: {error}", model_name, start)
    try:
        return _analyse_states(context, elements, states, datasets=False)["metrics"]
    except ImpactError as error:
        return _infeasible(n_sat, str(error), model_name, start)


def evaluate_design(context: EvaluationContext, sma_km: float, ecc: float, aop_deg: float, inc_deg: float,
                    n_planes: int, sats_per_plane: int) -> dict:
    """Eq. 45 for the Walker design of Table 3's variables (RAAN by eq. 42, M equally spaced).

    Invalid designs (e outside [0, 1), perilune inside the Moon, non-positive counts) come back
    flagged, not raised.
    """
    start = time.perf_counter()
    try:
        design = WalkerDesign(sma_km, ecc, inc_deg, aop_deg, n_planes, sats_per_plane)
        elements = design.elements_deg()
    except ValueError as error:
        n_sat = int(n_planes) * int(sats_per_plane) if float(n_planes) > 0 and float(sats_per_plane) > 0 else 0
        return _infeasible(n_sat, f"invalid design: {error}", deltav.deltav_settings(context.profile)["model"], start)
    return evaluate_constellation(context, elements)


def evaluate_cli(profile_name: str, sma_km: float, ecc: float, aop_deg: float, inc_deg: float, n_planes: int,
                 sats_per_plane: int) -> dict:
    """:func:`evaluate_design` under a named profile with exactly the CLI's JSON keys."""
    context = context_for(load_profile(profile_name))
    result = evaluate_design(context, sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)
    return {key: (None if isinstance(result[key], float) and math.isnan(result[key]) else result[key])
            for key in RESULT_KEYS}
