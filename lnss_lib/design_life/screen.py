"""Design-life stability screen: does a satellite's perilune reach the surface within the life?

The doubly-averaged lunar J2 + Earth/Sun quadrupole model of :mod:`lnss_lib.design_life.secular` integrated from
the initial states (satellites that share (a, e, j), the satellites of one Walker plane, integrated once), with
what its verdict adds to that model:

* Monthly terms (kept in the verdict with ``[stability] monthly_terms``, every profile): the tide's oscillation
  about its month-mean swings e at twice the Earth's sidereal rate, by ~ (15/16) (n_month / n) e sqrt(1 - e^2)
  (0.012 at a = 7800 km, e = 0.74: 95 km of perilune; 0.05 at a = 20900 km, e = 0.8: 1000 km), enough to
  take a perilune the mean model keeps at 290 km into the surface within days. :class:`MonthlyTide`
  restores them to first order (near-identity averaging transform): the initial osculating vectors are
  turned into mean ones, and the verdict is on the perilune with the terms put back along the mean
  solution, so the Earth's orbital eccentricity (its monthly term) and the Sun's half-year term come
  with the ephemeris.
* Orbit-period (short-period) terms: within one orbit the tide moves e by at most ~ 4 pi c (1 + e) / n^2
  (:func:`lnss_lib.design_life.frozen.allowances`; a bound: 110 km of perilune at a = 8000 km, e = 0.5);
  ``[stability] margin_km`` raises the floor to allow for them. The averaging also assumes the orbital
  period << one month (0.5 d at a = 6000 km, 3.9 d at a = 24000 km, a / a_Hill = 0.39): at the top of
  Table 3 the model's perilune is good to a few hundred km, not tens
  (:mod:`lnss_lib.studies.screen_validation` measures the agreement with the full model).
* The validity limit (``[stability] validity_period_fraction``, ``validity_ecc``; every profile):
  beyond a tenth of a month's period the tide turns by more than 36 deg during one orbit, and the orbit
  average errs by O(n_month / n) (a singly-averaged run with the instantaneous tide gets the impact days
  right to a median 0.2 d but still keeps those orbits' perilunes up); there, with e >= 0.5, the
  screen does not vouch and judges the orbit unstable.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..elements import eccentricity_vector, vis_viva_sma_km
from ..ephemeris import ensure_kernels, tdb_seconds
from ..frames import element_frame_to_j2000
from ..settings import Dynamics, EpochSettings, StabilitySettings
from .monthly_tide import MonthlyTide, monthly_offsets
from .secular import (
    SIDEREAL_MONTH_DAYS,
    SecularField,
    TideSamples,
    elements_from_vectors,
    integrate_secular,
    orbit_vectors_ej,
)

__all__ = [
    "screen_states",
    "screen_elements",
    "cached_field",
    "propagated_perilune",
]


def screen_states(
    stability: StabilitySettings,
    dynamics: Dynamics,
    states_mci,
    t0_tdb_s: float,
    *,
    field: SecularField | None = None,
    monthly: MonthlyTide | None = None,
    life_days: float | None = None,
) -> xr.Dataset:
    """The screen for osculating Moon-centred J2000 states (n_sat, 6) at TDB ``t0_tdb_s``.

    With ``[stability] monthly_terms`` the states' vectors are taken as orbit-averaged (not month-averaged)
    ones: the monthly terms of :class:`MonthlyTide` are removed before the doubly-averaged integration
    and restored along it, and the verdict is on the restored perilune ``a (1 - |e + de|)``, sampled
    every ``output_step_days``, or the mean one's crossing, whichever comes first. An orbit outside the
    model's validity (:func:`_outside_validity`: ``[stability] validity_period_fraction``, ``validity_ecc``)
    is judged unstable from the start (``impact_day`` 0, ``outside_validity`` True).

    Returns a Dataset: mean ``ecc``, ``inc_deg``, ``raan_deg``, ``aop_deg`` (the element frame of
    ``dynamics.frames``) and ``perilune_alt_km``, the restored ``osc_perilune_alt_km`` (sat, time in days;
    the mean one without monthly terms), per satellite ``min_perilune_alt_km`` (of the restored perilune),
    ``impact`` and ``impact_day`` (NaN when none); attrs ``stable`` (no impact within the life),
    ``min_perilune_alt_km``, ``impact_day`` (first, NaN when none), ``n_orbits`` (distinct orbits
    integrated), ``n_rhs``, ``wall_s``. ``life_days`` replaces the screen's span (``stability.life_days``); an explicit
    ``field`` comes with its ``monthly`` (None: no monthly terms).
    """
    start = time.perf_counter()
    cfg = (
        stability
        if life_days is None
        else dataclasses.replace(stability, life_days=float(life_days))
    )
    gm = dynamics.gravity.gm_km3_s2
    a, e_vec, j_vec = orbit_vectors_ej(states_mci, gm)
    if field is None:
        field, monthly = cached_field(cfg, dynamics, float(t0_tdb_s))
    monthly = monthly if cfg.monthly_terms else None
    key = np.round(np.column_stack([a / 1e4, e_vec, j_vec]), 12)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = np.asarray(inverse).ravel()
    a_u, e0, j0 = a[first], e_vec[first], j_vec[first]
    if monthly is not None:
        de0, dj0 = monthly_offsets(e0, j0, a_u, monthly.at([0.0])[0], gm)
        e0, j0 = e0 - de0, j0 - dj0
    r_moon = dynamics.constants.r_moon_mean_km
    floor = r_moon + dynamics.impact.min_altitude_km + cfg.margin_km
    res = integrate_secular(
        a_u,
        e0,
        j0,
        field,
        cfg.life_days,
        floor_km=floor,
        method=cfg.method,
        rtol=cfg.rtol,
        atol=cfg.atol,
        output_step_days=cfg.output_step_days,
        step_days=cfg.step_days,
    )
    t_days, impact_u = res["t_days"], res["impact_day"]
    e_osc = res["e"]
    if monthly is not None:
        de, _ = monthly_offsets(res["e"], res["j"], a_u[:, None], monthly.at(t_days)[None], gm)
        e_osc = res["e"] + de
    alt_osc_u = a_u[:, None] * (1.0 - np.linalg.norm(e_osc, axis=-1)) - r_moon
    with np.errstate(invalid="ignore"):
        below = alt_osc_u <= floor - r_moon
    first_below = np.where(below.any(axis=1), t_days[np.argmax(below, axis=1)], np.nan)
    impact_u = np.fmin(impact_u, first_below)
    rot = element_frame_to_j2000(dynamics, float(t0_tdb_s)).T
    el = elements_from_vectors(res["e"][inverse], res["j"][inverse], rot)
    alt = a[:, None] * (1.0 - el["ecc"]) - r_moon
    alt_osc = alt_osc_u[inverse]
    outside = _outside_validity(cfg, a, np.linalg.norm(e_vec, axis=1), gm)
    impact_day = np.where(outside, 0.0, impact_u[inverse])
    with np.errstate(invalid="ignore"):
        alt_min = np.where(np.isnan(impact_day), np.nanmin(alt_osc, axis=1), floor - r_moon)
    ds = xr.Dataset(
        {
            **{k: (("sat", "time"), v) for k, v in el.items()},
            "perilune_alt_km": (("sat", "time"), alt),
            "osc_perilune_alt_km": (("sat", "time"), alt_osc),
            "min_perilune_alt_km": ("sat", alt_min),
            "impact": ("sat", ~np.isnan(impact_day)),
            "impact_day": ("sat", impact_day),
            "outside_validity": ("sat", outside),
            "a_km": ("sat", a),
        },
        coords={"sat": np.arange(a.size), "time": t_days},
        attrs={
            "stable": bool(np.all(np.isnan(impact_day))),
            "min_perilune_alt_km": float(np.min(alt_min)),
            "impact_day": float(np.nanmin(impact_day))
            if np.any(~np.isnan(impact_day))
            else float("nan"),
            "life_days": cfg.life_days,
            "floor_alt_km": floor - r_moon,
            "n_orbits": int(first.size),
            "monthly_terms": monthly is not None,
            "n_outside_validity": int(outside.sum()),
            "n_rhs": res["n_rhs"],
            "element_frame": dynamics.frames.element_frame,
            "wall_s": time.perf_counter() - start,
        },
    )
    ds["time"].attrs["units"] = "days since the epoch"
    return ds


def _outside_validity(
    stability: StabilitySettings, sma_km: np.ndarray, ecc: np.ndarray, gm_km3_s2: float
) -> np.ndarray:
    """Orbits (n,) beyond the averaged model's validity: period above ``validity_period_fraction`` of a sidereal
    month (n_month / n; 0.1 at a = 19,060 km, a / a_Hill = 0.31) with e at least ``validity_ecc``."""
    n_month = 2.0 * np.pi / (SIDEREAL_MONTH_DAYS * SECONDS_PER_DAY)
    ratio = n_month / np.sqrt(gm_km3_s2 / np.asarray(sma_km, dtype=float) ** 3)
    return (ratio >= stability.validity_period_fraction) & (
        np.asarray(ecc) >= stability.validity_ecc
    )


def screen_elements(
    stability: StabilitySettings,
    dynamics: Dynamics,
    epoch: EpochSettings,
    elements_deg,
    *,
    t0_tdb_s: float | None = None,
    life_days: float | None = None,
) -> xr.Dataset:
    """:func:`screen_states` for elements (n, 6) [sma_km, e, i, RAAN, AOP, M] (deg) in the element frame of
    ``dynamics.frames`` at ``t0_tdb_s`` (default: the epoch's start)."""
    from ..propagator import elements_deg_to_states

    ensure_kernels(dynamics.ephemeris)
    t0 = tdb_seconds(epoch.start_tdb, "TDB") if t0_tdb_s is None else float(t0_tdb_s)
    return screen_states(
        stability,
        dynamics,
        elements_deg_to_states(dynamics, elements_deg, t0),
        t0,
        life_days=life_days,
    )


_FIELDS: dict = {}


def cached_field(
    stability: StabilitySettings, dynamics: Dynamics, t0_tdb_s: float
) -> tuple[SecularField, MonthlyTide]:
    """The field of :meth:`SecularField.from_settings` and the :class:`MonthlyTide` of the same samples, built once
    per set of the settings they read and epoch."""
    key = (
        dynamics.ephemeris,
        dynamics.constants,
        dynamics.frames.gravity,
        dynamics.gravity,
        t0_tdb_s,
        stability.life_days,
        stability.third_bodies,
        stability.precession,
        stability.average_days,
        stability.table_step_days,
    )
    if key not in _FIELDS:
        samples = TideSamples.from_settings(stability, dynamics, t0_tdb_s, stability.life_days)
        _FIELDS[key] = (
            SecularField.from_samples(stability, dynamics, t0_tdb_s, samples),
            MonthlyTide.from_samples(samples),
        )
    return _FIELDS[key]


def propagated_perilune(
    dynamics: Dynamics,
    epoch: EpochSettings,
    elements_deg,
    life_days: float,
    *,
    setting: str | None = "converged",
    degree: int | None = None,
    step_s: float = 3600.0,
) -> dict:
    """Reference for the screen: the full force model (engine, ``batch=True``, no station keeping).

    Propagates every satellite from the epoch's start for ``life_days`` and returns ``impact_day`` (n,)
    (NaN when none), ``min_perilune_alt_km`` (n,) of the osculating orbit (floor value after an impact),
    ``perilune_alt_km`` (n, m) and ``t_days`` (m,), ``stable``, ``wall_s``. Costs seconds to tens
    of seconds per satellite-year: for notebooks, benches and the slow tests.
    """
    from ..propagator import elements_deg_to_states, propagate_states

    start = time.perf_counter()
    ensure_kernels(dynamics.ephemeris)
    t0 = tdb_seconds(epoch.start_tdb, "TDB")
    states = elements_deg_to_states(dynamics, elements_deg, t0)
    ds = propagate_states(
        dynamics,
        states,
        t0,
        life_days * SECONDS_PER_DAY,
        step_s,
        setting=setting,
        degree=degree,
        batch=True,
    )
    gm = dynamics.gravity.gm_km3_s2
    r_moon = dynamics.constants.r_moon_mean_km
    sv = np.concatenate([ds["r_mci_km"].values, ds["v_mci_kms"].values], axis=-1)
    finite = np.all(np.isfinite(sv), axis=-1)
    safe = np.where(finite[..., None], sv, states[:, None, :])
    r, v = safe[..., :3], safe[..., 3:]
    rn = np.linalg.norm(r, axis=-1)
    a = vis_viva_sma_km(rn, np.sum(v * v, axis=-1), gm)
    e = np.linalg.norm(eccentricity_vector(r, v, gm, r_km=rn), axis=-1)
    alt = np.where(finite, a * (1.0 - e) - r_moon, np.nan)
    impact = ds["impact"].values.astype(bool)
    impact_day = np.where(impact, (ds["impact_t_tdb_s"].values - t0) / SECONDS_PER_DAY, np.nan)
    floor_alt = dynamics.impact.min_altitude_km
    return {
        "t_days": (ds["time"].values - t0) / SECONDS_PER_DAY,
        "perilune_alt_km": alt,
        "min_perilune_alt_km": np.where(impact, floor_alt, np.nanmin(alt, axis=1)),
        "impact_day": impact_day,
        "stable": bool(not impact.any()),
        "wall_s": time.perf_counter() - start,
    }
