"""The requirement-driven ("service") station-keeping decisions: safety, navigation, where a burn goes.

The service controller (``[design_life] controller = "service"``, :func:`lnss_lib.design_life.closed_loop.simulate_life`)
holds what the service needs and lets every other motion run:

* safety: the perilune stays above ``impact.min_altitude_km + perilune_margin_km`` plus the measured
  short-period amplitude (one-orbit mean perilune minus the lowest osculating perilune of the orbit).
  Every ``safety_check_days`` the doubly-averaged model (:mod:`lnss_lib.design_life.screen`, lunar J2 + Earth and
  Sun quadrupole) predicts the mean perilune (:func:`predicted_crossing_day`) over ``safety_lead_days`` plus
  one ``safety_check_days`` (the next check looks again: integrating the rest of the life at every check finds
  the same crossings within the lead, at a cost that grows with the life); only a crossing within
  ``safety_lead_days`` is acted on, by lowering e along the e vector (a perilune / apolune pair, a unchanged)
  by the smallest step that keeps the prediction above the floor for the rest of the life (:func:`safety_ecc`);
* navigation: the south-pole DOP of each ``nav_window_days`` of sampled positions must keep the first
  window's availability within ``nav_avail_drop_pct`` points and its 3-sigma PDOP/HDOP within
  ``nav_dop_rise_fraction`` (:func:`navigation_violations`); a violation restores e, AOP and i of every
  satellite to the design's values;
* relative geometry: relative node and slot within their tolerances (the drift-band and overshoot laws of
  :mod:`lnss_lib.design_life.control`), derived per design from its navigation sensitivity at the start of the life
  (:mod:`lnss_lib.design_life.tolerances`) or fixed (``raan_rel_deg``, ``u_rel_deg``). The node tolerance bounds
  the angle between the orbit plane and its slot's plane, 2 asin(sin i sin(dRAAN/2)) at equal inclinations, not
  the RAAN difference itself: the RAAN
  half-width is :func:`raan_half_width_rad` of the satellite's design inclination (about raan_rel / sin i; no
  bound at all below i = raan_rel / 2, where no node difference tilts the plane that far), so a near-equatorial
  orbit's node, which barely moves its plane, is left free. The relative node is judged on its mean over a sidereal
  month (two tidal periods): on high orbits a check spans several days and the one-orbit means swing with
  the month, which a shorter mean chases at up to 1 km/s/yr (and, at apolunes beyond about half the Hill
  radius, into escape). A node correction leaves the argument of latitude free.

Burns are planned by :func:`lnss_lib.design_life.manoeuvres.plan_impulses` at the cheapest of the apses, nodes and
antinodes; :func:`burn_location` names the point each one was flown at.
"""

from __future__ import annotations

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..dop import metrics_for_settings
from ..elements import TWO_PI
from ..ephemeris import EphemerisTable
from ..frames import fixed_offset, moon_fixed_rotations, rotate_to_moon_fixed, rotate_with
from ..settings import DopSettings, Dynamics, ServiceSettings
from ..surface_grid import SurfaceGrid
from .secular import SecularField, integrate_secular

__all__ = [
    "PURPOSES",
    "LOCATIONS",
    "predicted_crossing_day",
    "safety_ecc",
    "burn_location",
    "navigation_violations",
    "requirement_fractions",
    "restore_target",
    "mean_vectors_j2000",
    "raan_half_width_rad",
    "safety_targets",
    "raised_history",
    "NavigationMonitor",
]

PURPOSES = ("safety", "navigation", "relative_node", "phase", "a_trim")
"""What a burn is paid for (the Delta-V split of :func:`lnss_lib.design_life.closed_loop.simulate_life`)."""

LOCATIONS = ("perilune", "apolune", "node", "antinode", "other")
"""Where a burn is flown: the apses, the nodes (u = 0, 180 deg), their quadrature (u = 90, 270 deg)."""

SAFETY_RAISE_KM = (5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0)
"""Candidate perilune raises of a safety burn, smallest first (km)."""


def raan_half_width_rad(plane_tol_rad: float, inc_rad):
    """RAAN difference (rad) that tilts an orbit of inclination ``inc_rad`` by ``plane_tol_rad`` against a plane of
    the same inclination: 2 asin(sin(tol / 2) / |sin i|); pi (every node) where |sin i| <= sin(tol / 2)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sin(0.5 * plane_tol_rad) / np.abs(np.sin(np.asarray(inc_rad, dtype=float)))
        return np.where(ratio < 1.0, 2.0 * np.arcsin(np.minimum(ratio, 1.0)), np.pi)


def mean_vectors_j2000(
    mean_el: np.ndarray, rot_el_to_j2000: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(e vector, j = sqrt(1 - e^2) h_hat), each (n, 3) in Moon-centred J2000, of mean elements (n, 6)
    ``[a, e, i, raan, aop, u]`` (km, rad) in the element frame."""
    el = np.atleast_2d(mean_el)
    e, inc, raan, aop = el[:, 1], el[:, 2], el[:, 3], el[:, 4]
    node = np.stack([np.cos(raan), np.sin(raan), np.zeros_like(raan)], axis=1)
    h_hat = np.stack([np.sin(inc) * np.sin(raan), -np.sin(inc) * np.cos(raan), np.cos(inc)], axis=1)
    across = np.cross(h_hat, node)
    e_vec = e[:, None] * (np.cos(aop)[:, None] * node + np.sin(aop)[:, None] * across)
    rot = np.asarray(rot_el_to_j2000, dtype=float)
    return e_vec @ rot.T, (np.sqrt(1.0 - e * e)[:, None] * h_hat) @ rot.T


def predicted_crossing_day(
    field: SecularField, t_now_days: float, sma_km, e_vec, j_vec, floor_km, horizon_days: float
) -> np.ndarray:
    """Days from ``t_now_days`` (days since the field's epoch) until the averaged model's perilune a (1 - e) of
    each orbit (n,) reaches ``floor_km`` (radius, (n,) or scalar) within ``horizon_days``; NaN when it does not."""
    if horizon_days <= 0.0:
        return np.full(np.atleast_1d(sma_km).size, np.nan)
    res = integrate_secular(
        sma_km,
        e_vec,
        j_vec,
        field.shifted(t_now_days),
        horizon_days,
        floor_km=floor_km,
        output_step_days=max(horizon_days, 1.0),
    )
    return res["impact_day"]


def safety_ecc(
    field: SecularField,
    t_now_days: float,
    sma_km: float,
    e_vec,
    j_vec,
    floor_km: float,
    horizon_days: float,
) -> float:
    """Mean e after a safety burn: the e vector shortened (direction kept) by the smallest perilune raise of
    :data:`SAFETY_RAISE_KM` whose predicted perilune stays above ``floor_km`` (radius) for ``horizon_days``;
    where none does, the raise that delays the crossing most."""
    e_vec = np.asarray(e_vec, dtype=float)
    h_hat = np.asarray(j_vec, dtype=float) / np.linalg.norm(j_vec)
    e0 = float(np.linalg.norm(e_vec))
    e_new = np.array([max(e0 - dr / sma_km, 0.0) for dr in SAFETY_RAISE_KM])
    e_new = np.unique(e_new)[::-1]  # largest e (smallest raise) first
    direction = e_vec / e0 if e0 > 0.0 else np.zeros(3)
    ev = e_new[:, None] * direction[None, :]
    jv = np.sqrt(1.0 - e_new**2)[:, None] * h_hat[None, :]
    day = predicted_crossing_day(
        field, t_now_days, np.full(e_new.size, sma_km), ev, jv, floor_km, horizon_days
    )
    safe = np.flatnonzero(~np.isfinite(day))
    if safe.size:
        return float(e_new[safe[0]])
    return float(e_new[int(np.argmax(day))])


def burn_location(nu_rad: float, aop_rad: float, tol_rad: float = 1e-3) -> str:
    """:data:`LOCATIONS` name of a burn at true anomaly ``nu_rad`` on an orbit of argument of perilune ``aop_rad``."""

    def near(angle, target):
        return abs(np.mod(angle - target + np.pi, TWO_PI) - np.pi) < tol_rad

    u = nu_rad + aop_rad
    if near(nu_rad, 0.0):
        return "perilune"
    if near(nu_rad, np.pi):
        return "apolune"
    if near(u, 0.0) or near(u, np.pi):
        return "node"
    if near(u, 0.5 * np.pi) or near(u, 1.5 * np.pi):
        return "antinode"
    return "other"


def requirement_fractions(
    summary: dict, baseline: dict, service: ServiceSettings
) -> dict[str, float]:
    """Each navigation statistic's degradation in ``summary`` (a :func:`lnss_lib.dop.metrics_for_settings` dict)
    against ``baseline`` (the first window's) as a fraction of what the requirement allows: availability points lost
    over ``nav_avail_drop_pct``, the relative rise of a 3-sigma PDOP/HDOP over ``nav_dop_rise_fraction`` (infinite
    for a DOP lost altogether, or any loss where nothing is allowed; a DOP without a baseline is not judged)."""
    out = {
        key: _fraction(baseline[key] - summary[key], service.nav_avail_drop_pct)
        for key in ("pdop_avail_pct", "hdop_avail_pct")
    }
    for key in ("pdop_mean_3sigma", "hdop_mean_3sigma"):
        ref, now = baseline[key], summary[key]
        if np.isfinite(ref):
            out[key] = (
                _fraction(now / ref - 1.0, service.nav_dop_rise_fraction)
                if np.isfinite(now)
                else np.inf
            )
    return out


def _fraction(excess: float, allowed: float) -> float:
    if allowed > 0.0:
        return excess / allowed
    return np.inf if excess > 0.0 else 0.0


def restore_target(
    ecc: float, aop_rad: float, d_inc_rad: float, ref_ecc: float, ref_aop_rad: float
) -> dict:
    """The navigation restore's change of the control set (:func:`lnss_lib.design_life.manoeuvres.plan_impulses`):
    the e vector back to the design's (``ref_ecc``, ``ref_aop_rad``), the inclination by ``-d_inc_rad`` (its offset
    from the design's), a held."""
    return {
        "a_km": 0.0,
        "ex": ref_ecc * np.cos(ref_aop_rad) - ecc * np.cos(aop_rad),
        "ey": ref_ecc * np.sin(ref_aop_rad) - ecc * np.sin(aop_rad),
        "inc_rad": -d_inc_rad,
    }


def navigation_violations(summary: dict, baseline: dict, service: ServiceSettings) -> list[str]:
    """Names of the navigation statistics outside the requirement (:func:`requirement_fractions` above 1)."""
    return [
        key
        for key, fraction in requirement_fractions(summary, baseline, service).items()
        if fraction > 1.0
    ]


def safety_targets(
    field, safe_hist, mel, active, t_days, life_days, floor_base_km, service, tide_period_days
):
    """Change of mean e (n_sat,) of each satellite whose perilune the averaged model predicts below the floor
    within ``safety_lead_days`` (NaN for the others; the prediction is integrated over the lead and one
    ``safety_check_days`` only: a crossing further off is not acted on at this check).

    Each prediction starts from the e and j vectors averaged over the last tidal period (the monthly swing of
    the one-orbit means averaged out); the floor is ``floor_base_km`` plus the largest amount by which the
    osculating perilune dipped below that averaged perilune over the last two tidal periods."""
    d_ecc = np.full(mel.shape[0], np.nan)
    idx = [i for i in np.flatnonzero(active) if safe_hist[i]]
    if not idx:
        return d_ecc
    e_avg, j_avg, floor = [], [], []
    for i in idx:
        t_k = np.array([h[0] for h in safe_hist[i]])
        recent = t_k >= t_k[-1] - tide_period_days * SECONDS_PER_DAY
        e_avg.append(np.mean([h[1] for h, keep in zip(safe_hist[i], recent) if keep], axis=0))
        j_avg.append(np.mean([h[2] for h, keep in zip(safe_hist[i], recent) if keep], axis=0))
        rp_avg = mel[i, 0] * (1.0 - np.linalg.norm(e_avg[-1]))
        floor.append(floor_base_km + max(0.0, max(rp_avg - h[3] for h in safe_hist[i])))
    e_avg, j_avg, floor, a = np.array(e_avg), np.array(j_avg), np.array(floor), mel[idx, 0]
    j_avg *= (np.sqrt(1.0 - np.sum(e_avg**2, axis=1)) / np.linalg.norm(j_avg, axis=1))[:, None]
    remaining = life_days - t_days
    horizon = min(remaining, service.safety_lead_days + service.safety_check_days)
    day = predicted_crossing_day(field, t_days, a, e_avg, j_avg, floor, horizon)
    day = np.where(a * (1.0 - np.linalg.norm(e_avg, axis=1)) <= floor, 0.0, day)
    for q in np.flatnonzero(day <= service.safety_lead_days):
        e_now = float(np.linalg.norm(e_avg[q]))
        d_ecc[idx[q]] = (
            safety_ecc(field, t_days, a[q], e_avg[q], j_avg[q], floor[q], remaining) - e_now
        )
    return d_ecc


def raised_history(
    history: list, d_ecc: float, e_vec: np.ndarray, ecc: float, sma_km: float
) -> list:
    """The safety history (t, e vector, j vector, lowest osculating perilune km) after a raise of mean e by ``d_ecc``:
    the e vectors move along ``e_vec`` (of length ``ecc``) and the recorded perilune minima by -``sma_km d_ecc``, so
    the dip below the averaged perilune that sets the floor (:func:`safety_targets`) is what it was before the raise,
    not the raise itself (which, left in, called for a second burn at the next check)."""
    shift = d_ecc * e_vec / max(ecc, 1e-12)
    drop_km = d_ecc * sma_km
    return [(t_k, e_k + shift, j_k, rp_k - drop_km) for t_k, e_k, j_k, rp_k in history]


class NavigationMonitor:
    """South-pole DOP of the sampled positions over windows of ``nav_window_days``: the first window sets the
    requirement (:func:`navigation_violations`); ``violated`` after each closed window.

    The positions turn Moon-fixed with the force model's tabulated rotation (``table``,
    :func:`lnss_lib.frames.moon_fixed_rotations`) where the Moon-fixed frame is fixed to the gravity frame
    (else through SPICE), and the DOP statistics come from the compiled grid pass
    (:func:`lnss_lib.dop.metrics_for_settings`): both agree with SPICE and the Dataset path to rounding
    (``tests/design_life/test_service.py`` checks that the verdicts do not change)."""

    def __init__(
        self,
        dop: DopSettings,
        dynamics: Dynamics,
        sample_t: np.ndarray,
        service: ServiceSettings,
        table: EphemerisTable,
    ):
        self.dop, self.dynamics, self.sample_t, self.service = dop, dynamics, sample_t, service
        self.grid = SurfaceGrid.from_settings(dop, dynamics.constants.r_moon_mean_km)
        self.table = table
        frames = dynamics.frames
        self.offset = fixed_offset(frames.gravity, frames.moon_fixed, sample_t[0], sample_t[-1])
        self.start = sample_t[0]
        self.baseline = None
        self.violated = False
        self.n_violations = 0

    def update(self, t: float, r_sample: np.ndarray) -> None:
        self.violated = False
        if t - self.start < self.service.nav_window_days * SECONDS_PER_DAY:
            return
        idx = np.flatnonzero((self.sample_t > self.start) & (self.sample_t <= t))
        self.start = t
        if idx.size == 0:
            return
        tt = self.sample_t[idx]
        r_mf = (
            rotate_to_moon_fixed(self.dynamics, r_sample[:, idx], tt)
            if self.offset is None
            else rotate_with(moon_fixed_rotations(self.offset, self.table, tt), r_sample[:, idx])
        )
        summary = metrics_for_settings(self.dop, r_mf, self.grid)
        if self.baseline is None:
            self.baseline = summary
            return
        self.violated = bool(navigation_violations(summary, self.baseline, self.service))
        self.n_violations += int(self.violated)
