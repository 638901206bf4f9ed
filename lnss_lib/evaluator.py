"""The design evaluator: every quantity of eq. 45 for a Walker design or an explicit constellation.

An :class:`EvaluationContext` holds what a run shares across designs (ephemeris tables and force
model, the Moon-fixed rotation at every epoch, the surface grid, the GPS states); it is built once
per process. :func:`evaluate_design` propagates a design, then computes the south-pole DOP
statistics (eq. 9-14, all satellites), the station-keeping Delta-V (satellite 0, or the mean over
every satellite with ``[deltav] satellites = "all"``) and the GPS-LNSS link (first satellite, as the
paper does, Section 5.3). Infeasible designs (impact, invalid elements) come back flagged with NaN
metrics, never raised, so batch callers can treat them as constraint violations.

A profile may ask for the operational metrics of :data:`~lnss_lib.keys.EXTRA_METRIC_KEYS` in
``[evaluator] extra_metrics`` (none in ``paper``): the station-keeping Delta-V estimate over
every satellite (``[sk_estimate] model``: the 10-day box slope of :mod:`lnss_lib.design_life.estimate` from the
same arc, or the service controller's life of :mod:`lnss_lib.design_life.life_estimate`, which shares the screen),
the design-life stability screen (:mod:`lnss_lib.design_life.screen`, from the initial states; ``stable_screen`` 1.0
or 0.0), the eq. 45 Delta-V's maximum over satellites, the south-pole PDOP/HDOP availability over the life (mean
and worst month) of the life estimate's constellation rebuilt from its averaged elements, restores included
(:data:`~lnss_lib.keys.LIFE_NAVIGATION_KEYS`: what the 10-day figures cannot see, an apolune drifting off the pole),
and the user's position error in metres (:mod:`lnss_lib.navigation_error`: uploads and ephemeris ages, then the
weighted least-squares errors from the DOP grid's own compiled pass, which then also gives the DOP metrics). Only the
requested ones are computed and returned.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from . import deltav, dop, gnss, gps, navigation_error
from .constants import SECONDS_PER_DAY
from .constellation import WalkerDesign
from .design_life import life_estimate, screen
from .elements import vis_viva_sma_km
from .ephemeris import EphemerisTable, ensure_kernels, rotation, tdb_seconds
from .errors import ConfigError, ImpactError, InfeasibleDesignError
from .forces import ForceModel
from .frames import rotate_with
from .gps_states import gps_states_mci
from .keys import (
    GNSS_SYSTEM_METRICS,
    LIFE_NAVIGATION_KEYS,
    METRIC_KEYS,
    NAVIGATION_ERROR_KEYS,
    TIMING_KEYS,
    gnss_metric_keys,
    requested_extra_metrics,
    runs_screen,
    violated_bound,
    wants_life_estimate,
)
from .propagator import (
    check_elements_deg,
    elements_deg_to_states,
    integrate_batch,
    output_times,
    propagate_states,
)
from .surface_grid import SurfaceGrid

if TYPE_CHECKING:
    from .settings import DeltaVSettings, DopSettings, Dynamics, GnssSettings, GpsSettings, Settings


@dataclass
class EvaluationContext:
    """Everything a run shares across design evaluations, built once a process (:meth:`build`): the settings
    sections the evaluation reads, the tables and force model, the Moon-fixed rotations, the grid and the GPS
    states. ``settings`` (the whole tree) stays for the propagator and the extra metrics' modules."""

    settings: Settings
    t0_tdb_s: float
    times: np.ndarray
    model: ForceModel
    rot_to_moon_fixed: np.ndarray
    grid: SurfaceGrid
    gps_states: xr.Dataset
    extra_metrics: tuple[str, ...] = ()
    stations: tuple[np.ndarray, np.ndarray] | None = (
        None  # upload stations when a metre metric is asked for
    )
    gnss_states: xr.Dataset | None = (
        None  # every [gnss] system, when more than GPS or a gnss_* metric is asked
    )
    gnss_tx: gnss.Transmitters | None = None

    dynamics: Dynamics = field(init=False, repr=False)  # the sections each design reads, taken once
    dop: DopSettings = field(init=False, repr=False)
    gps: GpsSettings = field(init=False, repr=False)
    gnss: GnssSettings = field(init=False, repr=False)
    deltav: DeltaVSettings = field(init=False, repr=False)

    def __post_init__(self):
        self.dynamics, self.dop, self.gps, self.gnss, self.deltav = (
            self.settings.dynamics,
            self.settings.dop,
            self.settings.gps,
            self.settings.gnss,
            self.settings.deltav,
        )

    @classmethod
    def build(cls, settings: Settings) -> EvaluationContext:
        """Tables, force model, Moon-fixed rotations, grid and GPS states over the settings' arc (checked at load)."""
        ensure_kernels(settings.ephemeris)
        epoch = settings.epoch
        t0 = tdb_seconds(epoch.start_tdb, "TDB")
        times = output_times(t0, epoch.duration_days * SECONDS_PER_DAY, epoch.step_s)
        table = EphemerisTable.build(settings.dynamics, t0, float(times[-1]))
        model = ForceModel.build(settings.dynamics, table)
        rot = rotation("J2000", settings.frames.moon_fixed, times)
        grid = SurfaceGrid.from_settings(settings.dop, settings.constants.r_moon_mean_km)
        extras = requested_extra_metrics(settings.evaluator)
        stations = (
            navigation_error.station_states(settings.navigation_error, settings.constants, times)
            if set(extras) & set(NAVIGATION_ERROR_KEYS)
            else None
        )
        gnss_states = gnss_tx = None
        if settings.gnss.systems != ("gps",) or any(k.startswith("gnss_") for k in extras):
            gnss_states = gnss.gnss_states_mci(settings.gnss, settings.gps, epoch.start_tdb, times)
            gnss_tx = gnss.system_transmitters(settings.gnss, settings.gps, gnss_states)
        return cls(
            settings,
            t0,
            times,
            model,
            rot,
            grid,
            gps_states_mci(settings.gps, epoch.start_tdb, times),
            extras,
            stations,
            gnss_states,
            gnss_tx,
        )

    def position_errors(
        self, r_mci_km: np.ndarray, r_mf_km: np.ndarray
    ) -> navigation_error.PositionErrors:
        """:func:`lnss_lib.navigation_error.position_errors` of positions (sat, time, 3) on this context's arc and grid
        (the upload stations built here if the profile asks for no metre metric)."""
        stations = self.stations or navigation_error.station_states(
            self.settings.navigation_error, self.settings.constants, self.times
        )
        return navigation_error.position_errors(
            self.settings.navigation_error,
            self.dop,
            self.grid,
            r_mf_km,
            r_mci_km,
            self.times,
            stations,
            self.dynamics.constants.r_moon_mean_km,
        )


_CONTEXTS: dict[str, EvaluationContext] = {}


def context_for(settings: Settings) -> EvaluationContext:
    """The process-wide :class:`EvaluationContext` of some settings (built on first use, keyed by their hash)."""
    key = settings.hash
    if key not in _CONTEXTS:
        _CONTEXTS[key] = EvaluationContext.build(settings)
    return _CONTEXTS[key]


def _infeasible(
    n_sat: int, reason: str, model: str, start: float, extras: tuple[str, ...] = ()
) -> dict:
    result = {k: math.nan for k in METRIC_KEYS + extras}
    result.update(
        n_sat=int(n_sat),
        deltav_model=model,
        evaluated=False,
        reason=reason,
        impact=reason.startswith("impact"),
        wall_s=time.perf_counter() - start,
    )
    return result


def analyse_constellation(context: EvaluationContext, elements_deg) -> dict:
    """Propagate a constellation and keep every intermediate result, for study notebooks.

    Returns ``{"propagation", "dop", "deltav", "gps_link": xarray.Dataset, "metrics": dict}`` with
    the metrics of :func:`evaluate_constellation`. Raises ``ValueError`` for invalid elements and
    :class:`~lnss_lib.propagator.ImpactError` for an orbit that hits the Moon.
    """
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    return analyse_states(
        context,
        elements,
        elements_deg_to_states(context.settings.dynamics, elements, context.t0_tdb_s),
    )


def analyse_states(
    context: EvaluationContext, elements: np.ndarray, states: np.ndarray, datasets: bool = True
) -> dict:
    """Propagation and metrics; without ``datasets`` the campaign's path: no grid or link Dataset, the DOP
    grid compiled (:func:`lnss_lib.dop.metrics_for_settings`, same metrics to ~1e-12 relative) and the
    GPS link from arrays (:func:`lnss_lib.gps.gps_link_metrics`, bit for bit)."""
    laps = Laps()
    settings = context.settings
    times = context.times
    ds = propagate_states(
        settings.dynamics,
        states,
        context.t0_tdb_s,
        float(times[-1] - times[0]),
        settings.epoch.step_s,
        batch=True,
        model=context.model,
    )
    _raise_first_impact(context, ds.impact.values, ds.impact_t_tdb_s.values)
    ds["elements_deg"] = (("sat", "element"), elements)
    laps.lap("propagation")
    r_mf = rotate_with(context.rot_to_moon_fixed, ds.r_mci_km.values)
    metres = {}
    if datasets:
        grid_ds = dop.dop_for_settings(context.dop, r_mf, times, context.grid)
        dop_stats = dop.summary_for_settings(context.dop, grid_ds)
        if context.stations is not None:
            metres = context.position_errors(ds.r_mci_km.values, r_mf).metrics(
                context.settings.navigation_error, context.grid
            )
    else:
        grid_ds = None
        dop_stats, metres = _navigation(context, ds.r_mci_km.values, r_mf)
    laps.lap("dop")
    dv = deltav.deltav_from_propagation(context.deltav, context.dynamics, ds, sat=0)
    dv_budget = _design_deltav(context.deltav, context.dynamics, ds, dv)
    laps.lap("deltav")
    if datasets:
        link = gps.gps_link(
            context.gps, context.dynamics.constants, context.gps_states, ds, sats="first"
        )
        link_stats = gps.gps_link_summary(link)
    else:
        link, link_stats = (
            None,
            gps.gps_link_metrics(
                context.gps, context.dynamics.constants, context.gps_states, ds["r_mci_km"].values
            ),
        )
    link_stats = {**link_stats, **_gnss_metrics(context, ds["r_mci_km"].values)}
    laps.lap("gps")
    extras = _operational_metrics(context, ds, states, {**dv_budget, **metres, **link_stats})
    laps.lap("operational")
    metrics = _metrics(
        elements.shape[0], dop_stats, dv_budget, link_stats, dv.attrs["deltav_model"], extras, laps
    )
    return {"propagation": ds, "dop": grid_ds, "deltav": dv, "gps_link": link, "metrics": metrics}


def _raise_first_impact(
    context: EvaluationContext, impact: np.ndarray, t_impact_tdb_s: np.ndarray
) -> None:
    """ImpactError naming the first satellite of ``impact`` (mask) and when it hits the Moon; nothing when none."""
    if bool(np.any(impact)):
        first = int(np.argmax(impact))
        t_impact = float(t_impact_tdb_s[first])
        days = (t_impact - context.t0_tdb_s) / SECONDS_PER_DAY
        raise ImpactError(
            f"impact: satellite {first} hits the Moon after {days:.2f} days",
            sat=first,
            t_tdb_s=t_impact,
            days=days,
        )


class Laps:
    """Seconds spent in each part of an evaluation (:data:`~lnss_lib.keys.TIMING_KEYS`), read off one clock as each
    part ends (:meth:`lap`); ``start`` is when the evaluation began."""

    def __init__(self):
        self.start = self.last = time.perf_counter()
        self.seconds = dict.fromkeys(TIMING_KEYS, 0.0)

    def lap(self, part: str) -> None:
        now = time.perf_counter()
        self.seconds[part] += now - self.last
        self.last = now


def _metrics(
    n_sat: int,
    dop_stats: dict,
    dv_budget: dict,
    link_stats: dict,
    deltav_model: str,
    extras: dict,
    laps: Laps,
) -> dict:
    """An evaluation's metrics dict from its parts' results and their times."""
    return {
        "n_sat": int(n_sat),
        "mean_visible_sats": dop_stats["mean_visible_sats"],
        "pdop_mean_3sigma": dop_stats["pdop_mean_3sigma"],
        "pdop_avail_pct": dop_stats["pdop_avail_pct"],
        "hdop_mean_3sigma": dop_stats["hdop_mean_3sigma"],
        "hdop_avail_pct": dop_stats["hdop_avail_pct"],
        "dv_total_kms_per_year": dv_budget["dv_total_kms_per_year"],
        "dv_opt_kms_per_year": dv_budget["dv_opt_kms_per_year"],
        "gps_visible_mean": link_stats["gps_visible_mean"],
        "gps_pdop_mean": link_stats["gps_pdop_mean"],
        **{k: v for k, v in link_stats.items() if k.startswith("gnss_")},
        "deltav_model": deltav_model,
        "evaluated": True,
        "reason": "",
        "impact": False,
        **extras,
        "timing_s": dict(laps.seconds),
        "wall_s": time.perf_counter() - laps.start,
    }


def _stopped(elements: np.ndarray, broken: str, model: str, laps: Laps, metrics: dict) -> dict:
    """A design stopped at a bound: not evaluated, with the metrics and the part times computed so far."""
    result = _infeasible(
        elements.shape[0], f"stopped early: {broken}; the rest not evaluated", model, laps.start
    )
    return {
        **result,
        **{k: v for k, v in metrics.items() if k in result},
        "timing_s": dict(laps.seconds),
    }


def campaign_metrics(
    context: EvaluationContext, elements: np.ndarray, states: np.ndarray, stop_bounds=None
) -> dict:
    """The metrics of :func:`analyse_states` without a Dataset (``datasets=False``), bit for bit: propagation
    to arrays (:func:`lnss_lib.propagator.integrate_batch`), the compiled DOP grid and GPS link, and the
    Delta-V of satellite 0 with ``[deltav] model`` alone computed (:func:`lnss_lib.deltav.chosen_budget`). A
    profile with extra metrics other than the metre ones (which this path computes in the DOP grid's pass) or
    ``[deltav] satellites = "all"`` (which read the propagation Dataset) takes
    :func:`analyse_states`. ImpactError as there.

    ``stop_bounds`` ``(metric, kind, limit)``: a design that breaks one (:func:`violated_bound`) stops at the first
    part that shows it, not evaluated, with the metrics computed so far (``reason`` names the bound): the satellite
    count before anything, then satellite 0 propagated first (each satellite is integrated on its own, so its states are the same bits) for the Delta-V,
    then the others for the DOP, then the GPS link (an impact of a later satellite is not looked for).
    """
    if (
        set(context.extra_metrics) - set(NAVIGATION_ERROR_KEYS)
        or context.deltav.satellites != "first"
    ):
        return analyse_states(context, elements, states, datasets=False)["metrics"]
    laps = Laps()
    times = context.times
    model = context.deltav.model
    if not stop_bounds:
        out, _, t_stop, _, impact = integrate_batch(
            context.dynamics, states, context.t0_tdb_s, times, context.model
        )
        dv_budget = None
    else:
        if broken := violated_bound({"n_sat": elements.shape[0]}, stop_bounds):
            return _stopped(elements, broken, model, laps, {})
        first, _, t_stop, _, impact = integrate_batch(
            context.dynamics, states[:1], context.t0_tdb_s, times, context.model
        )
        _raise_first_impact(context, impact, t_stop)
        laps.lap("propagation")
        dv_budget = deltav.chosen_budget(context.deltav, context.dynamics, times, first[0])
        laps.lap("deltav")
        if broken := violated_bound(dv_budget, stop_bounds):
            return _stopped(elements, broken, model, laps, dv_budget)
        rest, _, t_rest, _, impact_rest = integrate_batch(
            context.dynamics, states[1:], context.t0_tdb_s, times, context.model
        )
        out = np.concatenate([first, rest])
        t_stop, impact = np.concatenate([t_stop, t_rest]), np.concatenate([impact, impact_rest])
    _raise_first_impact(context, impact, t_stop)
    r_mci = out[:, :, :3]
    laps.lap("propagation")
    dop_stats, metres = _navigation(context, r_mci, rotate_with(context.rot_to_moon_fixed, r_mci))
    laps.lap("dop")
    if dv_budget is None:
        dv_budget = deltav.chosen_budget(context.deltav, context.dynamics, times, out[0])
        laps.lap("deltav")
    elif broken := violated_bound({**dop_stats, **metres}, stop_bounds):
        return _stopped(elements, broken, model, laps, {**dop_stats, **metres, **dv_budget})
    link_stats = gps.gps_link_metrics(
        context.gps, context.dynamics.constants, context.gps_states, r_mci
    )
    link_stats = {**link_stats, **_gnss_metrics(context, r_mci)}
    laps.lap("gps")
    return _metrics(elements.shape[0], dop_stats, dv_budget, link_stats, model, metres, laps)


def _navigation(
    context: EvaluationContext, r_mci_km: np.ndarray, r_mf_km: np.ndarray
) -> tuple[dict, dict]:
    """(DOP metrics, requested metre metrics) of positions (sat, time, 3) from the compiled grid pass; the metre
    metrics (:data:`~lnss_lib.keys.NAVIGATION_ERROR_KEYS`) come from the same pass when the profile asks for one."""
    if context.stations is None:
        return dop.metrics_for_settings(context.dop, r_mf_km, context.grid), {}
    errors = context.position_errors(r_mci_km, r_mf_km)
    metres = errors.metrics(context.settings.navigation_error, context.grid)
    return errors.dop_stats, {k: metres[k] for k in context.extra_metrics if k in metres}


def _gnss_metrics(context: EvaluationContext, r_lnss_mci_km: np.ndarray) -> dict:
    """The multi-GNSS link of the first LNSS satellite (:mod:`lnss_lib.gnss`): ``gnss_visible_mean`` and
    ``gnss_pdop_mean`` over every ``[gnss]`` system (one clock each) and, when they name more than GPS, each
    system's own (:data:`~lnss_lib.keys.GNSS_SYSTEM_METRICS`); nothing for the GPS link alone."""
    if context.gnss_states is None:
        return {}
    systems = context.gnss.systems
    counts, scatter = gnss.gnss_link_arrays(
        context.gps,
        context.dynamics.constants,
        context.gnss_states,
        context.gnss_tx,
        r_lnss_mci_km[0],
    )
    summary = gnss.gnss_link_summary(
        counts,
        scatter,
        systems,
        {"combined": systems},
        context.gps.pdop_filter,
        context.gps.clock_column,
    )
    out = {
        "gnss_visible_mean": summary["combined"]["visible_mean"],
        "gnss_pdop_mean": summary["combined"]["pdop_mean"],
    }
    visible, pdop = GNSS_SYSTEM_METRICS
    for name in systems:
        out[visible.format(name)] = summary[name]["visible_mean"]
        out[pdop.format(name)] = summary[name]["pdop_mean"]
    return {
        k: out[k] for k in (gnss_metric_keys(systems) or ("gnss_visible_mean", "gnss_pdop_mean"))
    }


def _design_deltav(
    settings: DeltaVSettings, dynamics: Dynamics, ds: xr.Dataset, dv_first: xr.Dataset
) -> dict:
    """The design's eq. 45 Delta-V budgets: satellite 0's (``[deltav] satellites = "first"``, the paper's
    Section 5.3 practice) or the mean over every satellite (``"all"``), then also the maxima."""
    if settings.satellites == "first":
        return {
            k: float(dv_first.attrs[k]) for k in ("dv_total_kms_per_year", "dv_opt_kms_per_year")
        }
    per_sat = deltav.deltav_per_satellite(settings, dynamics, ds).sel(
        model_all=dv_first.attrs["deltav_model"]
    )
    out = {}
    for key in ("dv_total", "dv_opt"):
        values = per_sat[f"{key}_kms_per_year"].values
        out[f"{key}_kms_per_year"] = float(np.mean(values))
        out[f"{key}_max_kms_per_year"] = float(np.max(values))
    return out


def _operational_metrics(
    context: EvaluationContext, ds: xr.Dataset, states: np.ndarray, computed: dict
) -> dict:
    """The requested extra metrics (``context.extra_metrics``), those already ``computed`` (the Delta-V budget's
    maxima, the metre metrics, the GNSS link) taken from there; NaN for an estimate the arc cannot give."""
    settings, wanted = context.settings, context.extra_metrics
    out = {k: computed[k] for k in wanted if k in computed}
    want_nav = any(k in LIFE_NAVIGATION_KEYS for k in wanted)
    want_sk = wants_life_estimate(wanted)
    screened = None
    if runs_screen(wanted, settings.sk_estimate.model):
        screened = screen.screen_states(
            settings.stability, context.dynamics, states, context.t0_tdb_s
        )
    if want_sk:
        min_periods = settings.sk_estimate.min_periods
        gm = context.dynamics.gravity.gm_km3_s2
        r = np.linalg.norm(ds["r_mci_km"].values, axis=-1)
        v2 = np.sum(ds["v_mci_kms"].values ** 2, axis=-1)
        a_mean = np.mean(vis_viva_sma_km(r, v2, gm), axis=1)  # vis-viva, as the estimate's arc test
        arc_s = float(ds["time"].values[-1] - ds["time"].values[0])
        if arc_s >= min_periods * 2.0 * np.pi * np.sqrt(np.max(a_mean) ** 3 / gm) * (1.0 + 1e-9):
            estimate = life_estimate.campaign_estimate(
                settings.sk_estimate,
                settings.stability,
                settings.design_life,
                context.dynamics,
                settings.dop,
                ds,
                screened,
                availability=want_nav,
            )
        else:
            estimate = dict.fromkeys(
                (
                    "sk_dv_estimate_kms_per_year",
                    "sk_dv_estimate_max_kms_per_year",
                    *LIFE_NAVIGATION_KEYS,
                ),
                math.nan,
            )
        out.update(
            {
                k: float(estimate[k])
                for k in wanted
                if k.startswith("sk_dv_estimate") or k in LIFE_NAVIGATION_KEYS
            }
        )
    if screened is not None:
        values = {
            "stable_screen": 1.0 if screened.attrs["stable"] else 0.0,
            "screen_min_perilune_alt_km": float(screened.attrs["min_perilune_alt_km"]),
        }
        out.update({k: values[k] for k in wanted if k in values})
    return {k: out[k] for k in wanted}


def evaluate_constellation(context: EvaluationContext, elements_deg, stop_bounds=None) -> dict:
    """Every quantity of eq. 45 for satellites given by elements (n, 6) [sma_km, e, i, RAAN, AOP, M] (deg).

    Returns a dict with :data:`RESULT_KEYS`, the profile's extra metrics, ``reason`` ("" when evaluated),
    ``impact`` and ``timing_s`` (seconds spent in propagation, DOP, Delta-V, GPS link and operational metrics). ``evaluated`` is False
    (metrics NaN) for elements that are no closed orbit above the surface or an orbit that hits the Moon
    (:class:`~lnss_lib.errors.InfeasibleDesignError`); configuration, ephemeris and other errors propagate.
    The Table 3 bounds are the optimiser's business, not checked here (``stop_bounds``: see
    :func:`campaign_metrics`).
    """
    start = time.perf_counter()
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    n_sat = elements.shape[0]
    model_name = context.deltav.model
    try:
        states = elements_deg_to_states(context.settings.dynamics, elements, context.t0_tdb_s)
    except InfeasibleDesignError as error:
        return _infeasible(
            n_sat, f"invalid elements: {error}", model_name, start, context.extra_metrics
        )
    try:
        return campaign_metrics(context, elements, states, stop_bounds)
    except (
        InfeasibleDesignError
    ) as error:  # only a physically impossible design; any other error propagates
        return _infeasible(n_sat, str(error), model_name, start, context.extra_metrics)


def evaluate_design(
    context: EvaluationContext,
    sma_km: float,
    ecc: float,
    aop_deg: float,
    inc_deg: float,
    n_planes: int,
    sats_per_plane: int,
    stop_bounds=None,
) -> dict:
    """Eq. 45 for the Walker design of Table 3's variables (RAAN by eq. 42, M equally spaced).

    Invalid input (NaN, e outside [0, 1), a <= 0, i outside [0, 180], counts < 1) raises ConfigError
    (:func:`check_design`); a valid design whose perilune is inside the Moon or that impacts comes back
    infeasible with its ``reason``.
    """
    check_design(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)
    design = WalkerDesign(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)
    return evaluate_constellation(context, design.elements_deg(), stop_bounds)


def check_design(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane) -> None:
    """ConfigError naming the first Walker variable that is not a finite value in its domain: a > 0,
    0 <= e < 1, 0 <= i <= 180 deg, AOP finite, Np and Ns integers >= 1 (the same element checks as
    ``propagate --elements``)."""
    for name, value in (("n_planes", n_planes), ("sats_per_plane", sats_per_plane)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, np.integer, float))
            or not math.isfinite(value)
            or value != int(value)
            or value < 1
        ):
            raise ConfigError(
                f"{name} = {value!r} is not allowed; allowed: an integer >= 1", key=name
            )
    for name, value in (
        ("sma_km", sma_km),
        ("ecc", ecc),
        ("aop_deg", aop_deg),
        ("inc_deg", inc_deg),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise ConfigError(f"{name} = {value!r} is not a number", key=name)
    check_elements_deg([[sma_km, ecc, inc_deg, 0.0, aop_deg, 0.0]])
