"""A design judged over its design life: station keeping, drift and navigation.

:func:`evaluate_design_life` flies the constellation for the design life twice with the full force
model (:func:`lnss_lib.design_life.closed_loop.simulate_life`, one force model shared by both runs): with
closed-loop station keeping (``[design_life] controller``: ``"service"`` or ``"box"``) and with none
(natural drift). From the controlled run it reports the Delta-V per satellite and year (mean and max)
and what it pays for (``sk_dv_split`` by purpose, ``sk_dv_split_by_location``), the manoeuvres, whether
every held quantity stayed within its tolerance, the first impact, the lowest perilune and the lost
satellites (day, cause); from the natural run the same for the uncontrolled constellation. Navigation
over the life (:func:`life_navigation`) is the south-pole DOP of eq. 3-14 on positions sampled
every ``[life_evaluation] sample_step_s`` over the life, with the profile's grid, mask, threshold
and 3-sigma filter (:func:`lnss_lib.dop.dop_for_settings`, :func:`lnss_lib.dop.summary_for_settings`),
evaluated one month at a time so memory stays bounded. Beside them, the two cheap predictors of the
campaign: the geometry-keeping estimate from the 10-day arc (:mod:`lnss_lib.design_life.estimate`) and the
doubly-averaged stability screen for the same life (:mod:`lnss_lib.design_life.screen`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping

import numpy as np
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..dop import dop_for_settings, summary_for_settings
from ..ephemeris import ensure_kernels, tdb_seconds
from ..forces import ForceModel
from ..frames import rotate_to_moon_fixed
from ..progress import steps
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import (
    DesignLifeSettings,
    DopSettings,
    Dynamics,
    EpochSettings,
    Settings,
    SkEstimateSettings,
    StabilitySettings,
)
from ..surface_grid import SurfaceGrid
from .closed_loop import life_force_model, simulate_life
from .life_estimate import campaign_estimate
from .life_report import impact_day
from .screen import screen_states

__all__ = [
    "LIFE_KEYS",
    "NAVIGATION_KEYS",
    "STUDY_KEYS",
    "run_design_life",
    "life_metrics",
    "life_navigation",
    "life_availability",
    "lost_satellites",
    "short_arc_predictors",
    "evaluate_design_life",
    "json_ready",
    "elements_deg_in_frame",
]

LIFE_KEYS = (
    "life_days",
    "impact_day",
    "natural_impact_day",
    "sk_dv_kms_per_year",
    "sk_dv_max_kms_per_year",
    "n_maneuvers",
    "box_held",
    "pdop_avail_pct_life",
    "hdop_avail_pct_life",
    "sk_dv_estimate_kms_per_year",
    "stable_screen",
    "screen_min_perilune_alt_km",
    "controller",
    "element_frame",
    "sk_dv_split",
    "sk_dv_split_by_location",
    "min_perilune_alt_km",
    "natural_min_perilune_alt_km",
    "lost_satellites",
    "natural_lost_satellites",
    "pdop_avail_pct_monthly",
    "hdop_avail_pct_monthly",
    "relative_tolerances_deg",
)
"""Keys :func:`evaluate_design_life` adds to an evaluation (the evaluate CLI's ``--design-life-days``)."""

NAVIGATION_KEYS = (
    "pdop_avail_pct",
    "hdop_avail_pct",
    "pdop_mean_3sigma",
    "hdop_mean_3sigma",
    "mean_visible_sats",
    "fewer_than_4_pct",
)
"""Per-month statistics of :func:`life_navigation` (eq. 9-14)."""

STUDY_KEYS = (
    "notebook_life_days",
    "convergence_life_days",
    "convergence_sats",
    "validation_life_days",
    "validation_max_sats_per_plane",
    "validation_front_designs",
    "validation_designs",
    "anchor_life_days",
    "validation_frames",
    "frame_rerun_designs",
)
"""``[life_evaluation]`` keys read by notebook 08 and :mod:`lnss_lib.studies.design_life` only."""


def run_design_life(
    settings: Settings,
    elements_deg,
    life_days: float | None = None,
    *,
    natural: bool = True,
    sample_step_s: float | None = None,
    sample: bool = True,
    insertion_errors_deg=None,
) -> dict[str, xr.Dataset]:
    """The controlled (and, with ``natural``, the natural-drift) life of elements (n, 6) in the element frame.

    Takes the whole settings: it reads ``[design_life]``, ``[stability]`` and ``[dop]`` (the service
    controller), the dynamics, the epoch and ``[life_evaluation]``. ``life_days`` replaces ``[design_life]
    life_days``. Both runs share one force model and sample positions every ``sample_step_s`` (default
    ``[life_evaluation] sample_step_s``; none with ``sample=False``) and insert the satellites with
    ``insertion_errors_deg`` (:func:`~lnss_lib.design_life.closed_loop.simulate_life`). Returns ``{"controlled": ds[, "natural": ds]}`` of
    :func:`lnss_lib.design_life.closed_loop.simulate_life` Datasets.
    """
    dynamics = settings.dynamics
    ensure_kernels(dynamics.ephemeris)
    design_life = (
        settings.design_life
        if life_days is None
        else dataclasses.replace(settings.design_life, life_days=float(life_days))
    )
    step = settings.life_evaluation.sample_step_s if sample_step_s is None else float(sample_step_s)
    step = step if sample else None
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB")
    model = life_force_model(dynamics, t0, design_life.life_days)
    runs = {}
    for name in steps(
        ("controlled", "natural") if natural else ("controlled",), "design life", "runs"
    ):
        runs[name] = simulate_life(
            design_life,
            dynamics,
            elements_deg,
            t0,
            stability=settings.stability,
            dop=settings.dop,
            natural=name == "natural",
            model=model,
            sample_step_s=step,
            insertion_errors_deg=insertion_errors_deg,
        )
    return runs


def _month_index(sample_day: np.ndarray, month_days: float) -> np.ndarray:
    """Month (0, 1, ...) of each sample; the last sample (the end of the life) joins the month it closes."""
    month = np.floor(sample_day / month_days + 1e-9).astype(int)
    last = max(int(np.ceil(sample_day[-1] / month_days - 1e-9)) - 1, 0)
    return np.minimum(month, last)


def life_navigation(
    dop: DopSettings, dynamics: Dynamics, life_ds, *, month_days: float
) -> xr.Dataset:
    """Month-by-month PDOP/HDOP statistics (eq. 9-14) over the design life, dims (run, month).

    ``life_ds``: one :func:`simulate_life` Dataset sampled with ``sample_step_s`` or a mapping
    run name -> Dataset (e.g. :func:`run_design_life`'s controlled and natural runs). Every month
    (``month_days``, e.g. ``[life_evaluation] month_days``) is one :func:`lnss_lib.dop.dop_for_settings` call
    on that month's samples. Variables :data:`NAVIGATION_KEYS` and ``n_epochs`` (run, month);
    coordinates ``month_start_day``, ``month_end_day``.
    """
    runs = {"life": life_ds} if isinstance(life_ds, xr.Dataset) else dict(life_ds)
    month_days = float(month_days)
    if not (math.isfinite(month_days) and month_days > 0):
        raise ValueError(f"month_days = {month_days!r} must be positive")
    grid = SurfaceGrid.from_settings(dop, dynamics.constants.r_moon_mean_km)
    first = next(iter(runs.values()))
    for name, ds in runs.items():
        if "r_mci_km" not in ds:
            raise ValueError(
                f"run {name!r} holds no sampled positions: simulate_life(..., sample_step_s=...)"
            )
        if not np.array_equal(ds["sample_day"].values, first["sample_day"].values):
            raise ValueError(f"run {name!r} is sampled on another grid than {next(iter(runs))!r}")
    day = first["sample_day"].values
    month = _month_index(day, month_days)
    n_month = int(month.max()) + 1
    stats = {key: np.full((len(runs), n_month), np.nan) for key in NAVIGATION_KEYS}
    n_epochs = np.zeros((len(runs), n_month), dtype=int)
    t = first["sample_t_tdb_s"].values
    for m in range(n_month):
        idx = np.flatnonzero(month == m)
        for k, ds in enumerate(runs.values()):
            r_mci = ds["r_mci_km"].transpose("sat", "sample", "xyz").values[:, idx]
            summary = summary_for_settings(
                dop,
                dop_for_settings(dop, rotate_to_moon_fixed(dynamics, r_mci, t[idx]), t[idx], grid),
            )
            for key in NAVIGATION_KEYS:
                stats[key][k, m] = summary[key]
            n_epochs[k, m] = idx.size
    starts = np.array([day[month == m][0] for m in range(n_month)])
    ends = np.array([day[month == m][-1] for m in range(n_month)])
    out = xr.Dataset(
        {key: (("run", "month"), value) for key, value in stats.items()},
        coords={
            "run": list(runs),
            "month": np.arange(n_month),
            "month_start_day": ("month", starts),
            "month_end_day": ("month", ends),
        },
        attrs={
            "month_days": month_days,
            "los_axes": dop.los_axes,
            "elevation_mask_deg": dop.elevation_mask_deg,
            "availability_threshold": dop.availability_threshold,
            "filter_sigma": dop.filter_sigma,
            "sample_step_s": float(np.median(np.diff(t))) if t.size > 1 else float("nan"),
        },
    )
    out["n_epochs"] = (("run", "month"), n_epochs)
    return out


def life_availability(nav: xr.Dataset, run: str, key: str) -> float:
    """Availability (%) over the whole life from :func:`life_navigation`: the month values weighted by epochs.

    Exact for eq. 13-14: every epoch carries the same grid weights, so the whole-life weighted
    fraction is the epoch-weighted mean of the monthly fractions.
    """
    if key not in ("pdop_avail_pct", "hdop_avail_pct", "fewer_than_4_pct"):
        raise ValueError(f"life_availability combines availability fractions only; got {key!r}")
    n = nav["n_epochs"].sel(run=run).values
    return float(np.sum(nav[key].sel(run=run).values * n) / np.sum(n))


def satellite_loss(
    dop: DopSettings, dynamics: Dynamics, flight: xr.Dataset, *, month_days: float
) -> list[dict]:
    """Availability over the life of a closed-loop ``flight`` (sampled positions, every satellite) with all satellites
    (``lost_sat`` -1) and with each one removed in turn (the others flown as they flew: an operator does not
    re-phase), worst loss first (the lowest worst-month PDOP availability, then over the life): the second row is
    the N-1 case. Each row: ``lost_sat`` and ``<key>_life``, ``<key>_worst_month`` (%) of PDOP and HDOP."""
    n_sat = flight.sizes["sat"]
    runs = {"all": flight} | {str(i): flight.isel(sat=np.arange(n_sat) != i) for i in range(n_sat)}
    nav = life_navigation(dop, dynamics, runs, month_days=month_days)
    rows = [
        {
            "lost_sat": -1 if run == "all" else int(run),
            **{
                f"{key}_{span}": value
                for key in ("pdop_avail_pct", "hdop_avail_pct")
                for span, value in (
                    ("life", life_availability(nav, run, key)),
                    ("worst_month", float(nav[key].sel(run=run).min())),
                )
            },
        }
        for run in runs
    ]
    return rows[:1] + sorted(
        rows[1:], key=lambda r: (r["pdop_avail_pct_worst_month"], r["pdop_avail_pct_life"])
    )


def _day_or_none(value: float):
    return None if not np.isfinite(value) else float(value)


def lost_satellites(ds: xr.Dataset) -> list[dict]:
    """``[{"sat", "day", "cause"}]`` of the satellites a :func:`simulate_life` run lost (impact, escape, failed propagation)."""
    return [
        {
            "sat": int(i),
            "day": float(ds["loss_day"].values[i]),
            "cause": str(ds["loss_cause"].values[i]),
        }
        for i in np.flatnonzero(np.isfinite(ds["loss_day"].values))
    ]


def life_metrics(runs: Mapping[str, xr.Dataset], nav: xr.Dataset | None = None) -> dict:
    """Closed-loop and natural-drift summary of :func:`run_design_life` (and :func:`life_navigation`).

    ``sk_dv_split`` (purpose -> km/s/yr) and ``sk_dv_split_by_location`` are means over the satellites, so each
    sums to ``sk_dv_kms_per_year``; ``min_perilune_alt_km`` is the lowest osculating perilune altitude of any
    satellite over the life (controlled; ``natural_`` for the natural drift); the monthly availabilities are
    ``{"controlled": [...], "natural": [...]}`` per month of :func:`life_navigation`; ``relative_tolerances_deg``
    ``{"raan_rel": plane tilt, "u_rel": slot}`` the service controller held (derived for the design or fixed:
    :mod:`lnss_lib.design_life.tolerances`; None under the box controller)."""
    ctl = runs["controlled"]
    nat = runs.get("natural")
    out = {
        "life_days": float(ctl.attrs["life_days"]),
        "impact_day": _day_or_none(impact_day(ctl)),
        "natural_impact_day": _day_or_none(impact_day(nat)) if nat is not None else None,
        "sk_dv_kms_per_year": float(ctl["dv_kms_per_year"].mean()),
        "sk_dv_max_kms_per_year": float(ctl["dv_kms_per_year"].max()),
        "n_maneuvers": int(ctl["n_maneuvers"].sum()),
        "box_held": bool(ctl["box_held"].all()),
        "controller": str(ctl.attrs["controller"]),
        "element_frame": str(ctl.attrs["element_frame"]),
        "sk_dv_split": {
            str(k): float(v)
            for k, v in ctl["dv_purpose_kms_per_year"].mean("sat").to_series().items()
        },
        "sk_dv_split_by_location": {
            str(k): float(v)
            for k, v in ctl["dv_location_kms_per_year"].mean("sat").to_series().items()
        },
        "min_perilune_alt_km": float(np.nanmin(ctl["min_perilune_alt_km"].values)),
        "natural_min_perilune_alt_km": float(np.nanmin(nat["min_perilune_alt_km"].values))
        if nat is not None
        else None,
        "lost_satellites": lost_satellites(ctl),
        "natural_lost_satellites": lost_satellites(nat) if nat is not None else None,
        "relative_tolerances_deg": (
            None
            if ctl.attrs.get("relative_tolerances", "none") == "none"
            else {
                "raan_rel": float(ctl.attrs["raan_rel_tolerance_deg"]),
                "u_rel": float(ctl.attrs["u_rel_tolerance_deg"]),
            }
        ),
    }
    if nav is not None:
        out["pdop_avail_pct_life"] = life_availability(nav, "controlled", "pdop_avail_pct")
        out["hdop_avail_pct_life"] = life_availability(nav, "controlled", "hdop_avail_pct")
        for key in ("pdop_avail_pct", "hdop_avail_pct"):
            out[f"{key}_monthly"] = {
                str(run): [float(v) for v in nav[key].sel(run=run).values]
                for run in nav["run"].values
            }
    return out


def short_arc_predictors(
    epoch: EpochSettings,
    dynamics: Dynamics,
    sk_estimate: SkEstimateSettings,
    stability: StabilitySettings,
    design_life: DesignLifeSettings,
    dop: DopSettings,
    elements: np.ndarray,
    life_days: float,
    *,
    model: ForceModel | None = None,
) -> dict:
    """The campaign-grade estimate on the epoch's short arc (``[sk_estimate] model``; NaN if a satellite hits the Moon
    on it; ``model``: a force model over that arc to reuse, e.g. the evaluation context's) and the stability screen
    for ``life_days``, which the ``"life"`` estimate also covers: ``sk_dv_estimate_kms_per_year``, ``stable_screen``,
    ``screen_min_perilune_alt_km``, ``screen_impact_day`` (None when none)."""
    t0 = tdb_seconds(epoch.start_tdb, "TDB")
    states = elements_deg_to_states(dynamics, elements, t0)
    arc = propagate_states(
        dynamics,
        states,
        t0,
        epoch.duration_days * SECONDS_PER_DAY,
        epoch.step_s,
        batch=True,
        model=model,
    )
    screen = screen_states(stability, dynamics, states, t0, life_days=life_days)
    estimate = (
        float("nan")
        if bool(arc["impact"].any())
        else campaign_estimate(sk_estimate, stability, design_life, dynamics, dop, arc, screen)[
            "sk_dv_estimate_kms_per_year"
        ]
    )
    return {
        "sk_dv_estimate_kms_per_year": estimate,
        "stable_screen": bool(screen.attrs["stable"]),
        "screen_min_perilune_alt_km": float(screen.attrs["min_perilune_alt_km"]),
        "screen_impact_day": _day_or_none(screen.attrs["impact_day"]),
    }


def evaluate_design_life(
    context_or_settings, elements_deg, life_days: float | None = None, *, keep: bool = False
) -> dict:
    """:data:`LIFE_KEYS` for elements (n, 6) ``[sma_km, e, i, RAAN, AOP, M]`` (deg, the settings' element frame).

    ``context_or_settings``: an :class:`lnss_lib.evaluator.EvaluationContext` (its force model is
    reused for the short arc) or :class:`lnss_lib.settings.Settings`; the whole settings because the
    verdict reads most of them (``[design_life]``, ``[stability]``, ``[sk_estimate]``, ``[dop]``,
    ``[life_evaluation]``, the epoch and the dynamics). ``life_days`` defaults to ``[design_life]``.
    Availabilities are over the whole life with station keeping; ``impact_day`` is the controlled
    run's first impact, ``natural_impact_day`` the natural drift's (None when none). Also returns
    ``screen_impact_day`` and ``design_life_wall_s``; with ``keep`` the runs (``"runs"``) and the
    month-by-month navigation (``"navigation"``) too. Raises ``ValueError`` for invalid elements.
    """
    start = time.perf_counter()
    is_settings = isinstance(context_or_settings, Settings)
    settings = context_or_settings if is_settings else context_or_settings.settings
    model = None if is_settings else context_or_settings.model
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    life = settings.design_life.life_days if life_days is None else float(life_days)
    runs = run_design_life(settings, elements, life)
    nav = life_navigation(
        settings.dop, settings.dynamics, runs, month_days=settings.life_evaluation.month_days
    )
    result = life_metrics(runs, nav)
    result.update(
        short_arc_predictors(
            settings.epoch,
            settings.dynamics,
            settings.sk_estimate,
            settings.stability,
            settings.design_life,
            settings.dop,
            elements,
            life,
            model=model,
        )
    )
    result = {
        **{k: result[k] for k in LIFE_KEYS},
        "screen_impact_day": result["screen_impact_day"],
        "design_life_wall_s": time.perf_counter() - start,
    }
    if keep:
        result.update(runs=runs, navigation=nav)
    return result


def json_ready(result: dict) -> dict:
    """``result`` with NaN floats as None and numpy scalars as Python ones, in nested dicts and lists too
    (for ``json.dumps``)."""
    return {key: _json_value(value) for key, value in result.items()}


def _json_value(value):
    if isinstance(value, Mapping):
        return json_ready(value)
    if isinstance(value, (list, tuple)):
        return [_json_value(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    return value


def elements_deg_in_frame(dynamics: Dynamics, states_mci, t0_tdb_s: float) -> np.ndarray:
    """Osculating ``[sma_km, e, i, RAAN, AOP, M]`` (n, 6) (km, deg) of Moon-centred J2000 states in the element frame of
    ``dynamics.frames``."""
    from ..elements import state_to_elements
    from ..frames import element_frame_to_j2000

    rot = element_frame_to_j2000(dynamics, float(t0_tdb_s))
    s = np.atleast_2d(np.asarray(states_mci, dtype=float))
    el = state_to_elements(
        np.concatenate([s[:, :3] @ rot, s[:, 3:] @ rot], axis=1), dynamics.gravity.gm_km3_s2
    )
    return np.column_stack([el[:, :2], np.degrees(el[:, 2:])])
