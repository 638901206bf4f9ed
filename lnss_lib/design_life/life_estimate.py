"""Campaign-grade estimate of what the service controller pays over the design life, and the navigation it keeps.

The 10-day estimate of :mod:`lnss_lib.design_life.estimate` prices a fixed-element box from the slope of a
short arc; over a year it misses the Lidov-Kozai growth that decides the cost, and it charges for e, AOP and
i motion the service controller (:mod:`lnss_lib.design_life.service`) lets run. This estimate follows the
controller instead, on the doubly-averaged evolution of every orbit over the life (the stability screen's
integration, :func:`lnss_lib.design_life.screen.screen_states`, shared with the screen), plus the evaluator's
10-day full-model arc for what only the full model sees:

* ``safety``: where the averaged perilune a (1 - e) would cross the floor (``impact.min_altitude_km`` +
  ``[design_life.service] perilune_margin_km`` + the dip of the arc's osculating perilune below its mean, as the
  controller adds the measured dip), a safety burn ``safety_lead_days`` before the crossing lowers e along the
  e vector by the controller's own law (that of :func:`lnss_lib.design_life.service.safety_ecc`: the smallest raise
  of its list that keeps the prediction above the floor for the rest of the life, else the one that delays the
  crossing most), judged on one integration of the candidate raises. An orbit that crosses again (no raise held it)
  pays the rest of its life at that burn's rate (its Delta-V over the time it bought). Cost of a change of e at
  fixed a (a perilune / apolune pair): ``h |de| / (2 p)``.
* ``navigation``: the navigation monitor's restores (:func:`navigation_restores`). Each window of
  ``[design_life.service] nav_window_days`` (closing on the day grid, as the monitor on its daily checks) is rebuilt
  from the averaged elements: e, AOP, i and the node (its common precession, which turns the constellation about the
  element frame's pole, included) at :data:`NAV_SAMPLES_PER_WINDOW` epochs of the window itself
  (:func:`lattice_epochs_s`: spread over the month and over the orbit, so the Moon turns under the constellation as
  it does), the mean anomaly from the slot at the design's mean motion; its south-pole DOP is summarised with
  ``[dop]``. A window at whose close some satellite's averaged e, AOP or i is outside ``[design_life.box]`` is judged
  against the first window's by the monitor's rule (:func:`lnss_lib.design_life.service.navigation_violations`). A
  violation restores e, AOP and i of every satellite outside the box, priced by the closed loop's two-burn plan
  (:func:`lnss_lib.design_life.manoeuvres.plan_impulses`, first order); the restored satellite's e, AOP and i then
  run their averaged history again from the design's elements (shifted in time: the Earth's and Sun's averaged pull
  on an orbit in ``moon_op`` barely depends on the date). The same windows, as flown, give the availability over the
  life that the campaign judges (:data:`LIFE_NAVIGATION_KEYS`: PDOP and HDOP, the life's mean and the worst month).
  A satellite whose averaged history ends (a second crossing of the safety floor, which the estimate prices as kept
  at its raises' rate) stays where its last raise left it.
* ``relative_node``: each satellite's averaged RAAN drift relative to the constellation's circular mean
  (the common precession is free), held within the controller's half-width
  (:func:`lnss_lib.design_life.service.raan_half_width_rad` of the tilt tolerance at the design inclination; the
  tolerances of :func:`lnss_lib.design_life.tolerances.estimate_tolerances_deg` unless given) by
  its overshoot law (:func:`lnss_lib.design_life.control.overshoot_target`); a node change of ``dW`` tilts the
  plane by ``sin i dW``, a normal impulse at the farther antinode: ``h sin i (1 - e |sin AOP|) / p`` per rad.
* ``phase``: the argument of latitude relative to the constellation's mean, drifting at the arc's rate
  (:func:`lnss_lib.design_life.estimate.mean_drift`) taken to the design's mean a (the closed loop's insertion trim
  removes the offset of the osculating elements' mean a) less its averaged AOP rate, plus the averaged AOP history,
  held within the slot tolerance by drift-band changes of a (:func:`lnss_lib.design_life.control.drift_band_rate`,
  no acceleration, as the controller flies them): ``sqrt(1 - e^2) a |d(rate)| / 3`` (a perilune / apolune pair
  changing a by ``2 a d(rate) / (3 n)``).

What it leaves out: the monitor's violations from causes other than the averaged e, AOP and i (the relative node and
slot inside their tolerances, the monthly swing, the sampling: 64 epochs a window where the monitor has about 2900), which in the closed loop keep a degraded window degraded after a
restore, so that it restores monthly, in smaller steps, where the estimate restores when the drift breaks the
requirement again; the closed loop's Delta-V cap (``[design_life] dv_cap_kms_per_year``: the closed loop stops
correcting anything but safety there, the estimate prices the whole life); the effect of the restores on the node
and slot parts (computed on the unrestored histories); the mean-a trims after each burn (a few m/s a year in the
closed loop), the monthly swing of the mean elements (the controller judges on tidal means), and what the averaged
model does not see of the relative node (a few degrees a year on some high orbits). The relative drifts after a
safety raise come from the raised orbit; after a second crossing they go on at their mean rates. Cost: a few
milliseconds for a design whose perilune stays clear and whose e, AOP and i stay in the box (the screen's
integration is shared), one averaged integration of nine candidate orbits per distinct orbit that needs a safety
raise, a DOP pass over 64 epochs per navigation window (every window: the availability over the life) plus one
restore plan per distinct orbit and restore.
"""

from __future__ import annotations

import time

import numba as nb
import numpy as np
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..dop import SurfaceGrid, metrics_for_settings
from ..elements import (
    TWO_PI,
    eccentricity_vector,
    elements_to_state,
    state_to_elements,
    vis_viva_sma_km,
)
from ..ephemeris import rotation
from ..frames import element_frame_to_j2000, rotate_with
from ..settings import (
    DesignLifeSettings,
    DopSettings,
    Dynamics,
    SkEstimateSettings,
    StabilitySettings,
)
from .control import drift_band_rate, overshoot_target
from .estimate import mean_drift, sk_estimate_from_propagation
from .manoeuvres import plan_impulses
from .mean_elements import to_element_frame, wrap_pi
from .screen import (
    SecularField,
    cached_field,
    elements_from_vectors,
    integrate_secular,
    screen_states,
)
from .service import (
    SAFETY_RAISE_KM,
    mean_vectors_j2000,
    navigation_violations,
    raan_half_width_rad,
    restore_target,
)
from .tolerances import estimate_tolerances_deg

__all__ = [
    "PARTS",
    "NAV_SAMPLES_PER_WINDOW",
    "AVAILABILITY_KEYS",
    "LIFE_NAVIGATION_KEYS",
    "perilune_dip_km",
    "safety_dv_kms",
    "node_corrections",
    "phase_corrections",
    "navigation_windows",
    "lattice_epochs_s",
    "rebuilt_positions_j2000",
    "navigation_restores",
    "life_estimate",
    "campaign_estimate",
]

PARTS = ("safety", "navigation", "relative_node", "phase")
"""What the estimate charges for (a subset of :data:`lnss_lib.design_life.service.PURPOSES`)."""

FOLLOWED_SAFETY_BURNS = 1
"""Safety raises of one orbit followed through the averaged model; an orbit that crosses the floor again (no raise
held it for the rest of the life) pays the rest of its life at their rate: their Delta-V over the time they bought."""

SEARCH_WINDOW = 64
"""Checks (history samples) searched at once for the next node or slot decision."""

NAV_SAMPLES_PER_WINDOW = 64
"""Epochs of each navigation window at which the estimate computes the south-pole DOP, on a lattice in time and
orbital phase (:func:`lattice_epochs_s`; the monitor samples every ``[life_evaluation] sample_step_s``, 900 s: about
2900 a window). 128 changed the quick operational validation's worst months by up to 2 points on designs the
closed loop keeps, at twice the DOP cost."""

GOLDEN_FRACTION = (np.sqrt(5.0) - 1.0) / 2.0
"""The phase step of :func:`lattice_epochs_s`: the most irrational number spreads any run of phases most evenly."""

AVAILABILITY_KEYS = ("pdop_avail_pct", "hdop_avail_pct")
"""The availabilities (eq. 14) the estimate follows over the life, window by window."""

LIFE_NAVIGATION_KEYS = tuple(
    f"{key}_{span}_estimate" for key in AVAILABILITY_KEYS for span in ("life", "worst_month")
)
"""What the estimate reports of the navigation over the life: each availability's mean over the life and its worst
window (a navigation window is ``[design_life.service] nav_window_days``, a month in every profile)."""

SEARCH_RTOL, SEARCH_ATOL = 1e-4, 1e-6
"""Tolerances of the averaged integration of the candidate raises (the screen's are tighter): a few hundred metres of
perilune; the same ranking and costs on the validation designs as 1e-6, at half the cost over five years."""


def perilune_dip_km(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Mean minus lowest osculating perilune radius (km) over an arc of states (n_sat, n_time, 6)."""
    r, v = states[..., :3], states[..., 3:]
    rn = np.linalg.norm(r, axis=-1)
    e = np.linalg.norm(eccentricity_vector(r, v, gm_km3_s2, r_km=rn), axis=-1)
    rp = vis_viva_sma_km(rn, np.sum(v * v, axis=-1), gm_km3_s2) * (1.0 - e)
    return np.mean(rp, axis=1) - np.min(rp, axis=1)


def _distinct_rows(*columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the side-by-side arrays (n, ...) that are bit for bit distinct: (their indices (k,), the index into
    them of every row (n,)); the work done per satellite is then done once per distinct history."""
    rows = np.ascontiguousarray(np.concatenate(columns, axis=1))
    _, first, back = np.unique(
        rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel(),
        return_index=True,
        return_inverse=True,
    )
    return first, np.asarray(back).ravel()


def _ecc_cost_kms(sma_km: float, ecc: float, d_ecc: float, gm_km3_s2: float) -> float:
    """Delta-V (km/s) of a change ``d_ecc`` of e at fixed a: h |de| / (2 p)."""
    p = sma_km * (1.0 - ecc * ecc)
    return float(np.sqrt(gm_km3_s2 * p) * abs(d_ecc) / (2.0 * p))


def _first_below(t_days: np.ndarray, perilune_km: np.ndarray, floor_km: float) -> np.ndarray:
    """First day (n,) each perilune radius history (n, m) is at or below the floor (NaN counts); NaN if never."""
    below = ~(perilune_km > floor_km)
    return np.where(below.any(axis=1), t_days[np.argmax(below, axis=1)], np.nan)


def _raise(
    field: SecularField,
    t_burn: float,
    sma_km: float,
    e_vec: np.ndarray,
    j_vec: np.ndarray,
    floor_km: float,
    t_rest: np.ndarray,
) -> tuple[float, np.ndarray, np.ndarray, float]:
    """The controller's safety raise (:func:`lnss_lib.design_life.service.safety_ecc`'s law: the smallest raise of
    :data:`lnss_lib.design_life.service.SAFETY_RAISE_KM` whose averaged perilune stays above ``floor_km`` for the rest
    of the life, else the one that delays the crossing most), from one integration of the candidates that stops
    each at its crossing: the new e, the raised orbit's e and j histories on ``t_rest`` (days from the burn; NaN
    after its crossing) and that crossing (days from the burn, NaN when none)."""
    ecc = float(np.linalg.norm(e_vec))
    e_new = np.unique(np.maximum(ecc - np.asarray(SAFETY_RAISE_KM) / sma_km, 0.0))[::-1]
    direction = e_vec / ecc if ecc > 0.0 else np.zeros(3)
    h_hat = j_vec / np.linalg.norm(j_vec)
    shifted = field.shifted(t_burn)
    res = integrate_secular(
        np.full(e_new.size, sma_km),
        e_new[:, None] * direction,
        np.sqrt(1.0 - e_new**2)[:, None] * h_hat,
        shifted,
        float(t_rest[-1]),
        floor_km=floor_km,
        rtol=SEARCH_RTOL,
        atol=SEARCH_ATOL,
        output_step_days=float(t_rest[1] - t_rest[0]) if t_rest.size > 1 else 1.0,
    )
    cross = res["impact_day"]
    safe = np.flatnonzero(np.isnan(cross))
    k = int(safe[0]) if safe.size else int(np.argmax(cross))
    return float(e_new[k]), res["e"][k], res["j"][k], float(cross[k])


def safety_dv_kms(
    field: SecularField,
    t_days: np.ndarray,
    sma_km: float,
    e_hist: np.ndarray,
    j_hist: np.ndarray,
    floor_km: float,
    lead_days: float,
    check_days: float,
) -> tuple[float, int, np.ndarray, np.ndarray]:
    """Safety burns of one orbit over the life ``t_days`` (m,) (a uniform grid from 0): Delta-V (km/s), number of
    burns, and the controlled e and j histories (m, 3).

    ``e_hist``, ``j_hist`` (m, 3): the orbit's averaged e and j vectors (J2000; NaN after its impact, which comes
    after its crossing of the higher floor ``floor_km``, the perilune radius to hold). A burn is placed
    ``lead_days`` before each predicted crossing (at least ``check_days`` after the previous one) and sized by the
    controller's law (:func:`_raise`); after
    :data:`FOLLOWED_SAFETY_BURNS` burns the rest of the life is charged at their rate (the histories from there
    on are NaN: the relative drifts go on at their mean rates).
    """
    gm = field.gm_km3_s2
    e_ctl, j_ctl = e_hist.copy(), j_hist.copy()
    t_cross = float(
        _first_below(t_days, sma_km * (1.0 - np.linalg.norm(e_ctl, axis=-1))[None], floor_km)[0]
    )
    dv, n_burns, t_first, t_last = 0.0, 0, np.nan, -np.inf
    while np.isfinite(t_cross):
        k = int(np.searchsorted(t_days, max(t_cross - lead_days, t_last + check_days, 0.0) - 1e-9))
        if k >= t_days.size - 1:
            break
        if n_burns == FOLLOWED_SAFETY_BURNS:
            e_ctl[k:], j_ctl[k:] = np.nan, np.nan
            return dv * (t_days[-1] - t_first) / (t_days[k] - t_first), n_burns, e_ctl, j_ctl
        ecc = float(np.linalg.norm(e_ctl[k]))
        ecc_new, e_ctl[k:], j_ctl[k:], t_next = _raise(
            field, float(t_days[k]), sma_km, e_ctl[k], j_ctl[k], floor_km, t_days[k:] - t_days[k]
        )
        dv += _ecc_cost_kms(sma_km, ecc, ecc_new - ecc, gm)
        n_burns += 1
        t_first = float(t_days[k]) if n_burns == 1 else t_first
        t_last, t_cross = float(t_days[k]), float(t_days[k]) + t_next
    return dv, n_burns, e_ctl, j_ctl


@nb.njit(cache=True)
def _wrapped_sums(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compiled first half of :func:`_relative`, bit for bit that of :func:`~lnss_lib.design_life.mean_elements.wrap_pi`
    and the sums of :func:`~lnss_lib.design_life.mean_elements.circular_mean` (NaN as 0, satellites in order): the
    wrapped angles (n, m) and the sums of their sines and cosines (m,)."""
    n, m = x.shape
    diff = np.empty((n, m))
    sin_sum, cos_sum = np.zeros(m), np.zeros(m)
    for i in range(n):
        for k in range(m):
            d = np.mod(x[i, k] + np.pi, TWO_PI) - np.pi
            diff[i, k] = d
            s, c = (0.0, 0.0) if np.isnan(d) else (np.sin(d), np.cos(d))
            sin_sum[k], cos_sum[k] = (s, c) if i == 0 else (sin_sum[k] + s, cos_sum[k] + c)
    return diff, sin_sum, cos_sum


def _relative(x: np.ndarray) -> np.ndarray:
    """Angles (n_sat, m) relative to their circular mean over the satellites at each time, wrapped to [-pi, pi)
    (numpy's arctan2: the compiled one differs in the last bit)."""
    diff, sin_sum, cos_sum = _wrapped_sums(np.ascontiguousarray(x, dtype=float))
    return wrap_pi(diff - np.arctan2(sin_sum, cos_sum)[None, :])


def _decisions(m: int, window):
    """The checks 0..m-1 at which a correction fires, one decision per check: ``window(k, end)`` gives the drifts
    (n, end - k) and where they fire (bool, same shape) over checks k..end-1 under the corrections made so far (it
    is called again after each decision); yields (check, drifts there (n,), firing satellites (n,))."""
    k = 0
    while k < m:
        end = min(k + SEARCH_WINDOW, m)
        rel, fire = window(k, end)
        hit = np.flatnonzero(fire.any(axis=0))
        if not hit.size:
            k = end
            continue
        k += int(hit[0])
        yield k, rel[:, hit[0]], fire[:, hit[0]]
        k += 1


def node_corrections(
    t_days: np.ndarray,
    raan_rad: np.ndarray,
    half_rad: np.ndarray,
    target_fraction: float,
    spacing_days: float,
) -> list[list[tuple[int, float]]]:
    """Relative-node corrections of each satellite: lists of (time index, RAAN change rad).

    ``raan_rad`` (n_sat, m): RAAN drift of each satellite from its design value; the relative node (against the
    circular mean over the satellites) is held within ``half_rad`` (n_sat,) by
    :func:`lnss_lib.design_life.control.overshoot_target`, at most one correction per satellite each ``spacing_days``.
    """
    n, m = raan_rad.shape
    offset = np.zeros(n)
    last = np.full(n, -np.inf)
    out = [[] for _ in range(n)]

    def window(k, end):
        rel = _relative(raan_rad[:, k:end] + offset[:, None])
        return rel, (np.abs(rel) > half_rad[:, None]) & (
            t_days[None, k:end] - last[:, None] >= spacing_days
        )

    for k, rel, fire in _decisions(m, window):
        for i in np.flatnonzero(fire):
            change = overshoot_target(float(rel[i]), float(half_rad[i]), target_fraction)
            offset[i] += change
            last[i] = t_days[k]
            out[i].append((k, change))
    return out


def phase_corrections(
    t_days: np.ndarray,
    u_rad: np.ndarray,
    half_rad: float,
    target_fraction: float,
    coast_days: float,
    lookahead_days: float,
) -> list[list[tuple[int, float]]]:
    """Drift-band slot corrections of each satellite: lists of (time index, change of drift rate rad/s).

    ``u_rad`` (n_sat, m): the argument of latitude's drift from its slot; the slot (against the circular mean)
    is held within ``half_rad``: a satellite found outside, not already commanded back inward over
    ``lookahead_days``, gets the rate of :func:`lnss_lib.design_life.control.drift_band_rate` (no acceleration).
    """
    n, m = u_rad.shape
    day_s = SECONDS_PER_DAY
    rate = np.zeros(n)
    t_ref = np.zeros(n)
    offset = np.zeros(n)
    out = [[] for _ in range(n)]

    def window(k, end):
        own = offset[:, None] + rate[:, None] * (t_days[None, k:end] - t_ref[:, None]) * day_s
        rel = _relative(u_rad[:, k:end] + own)
        ahead = rel + rate[:, None] * lookahead_days * day_s
        return rel, (np.abs(ahead) > half_rad) & (np.sign(rate)[:, None] != -np.sign(ahead))

    for k, rel, fire in _decisions(m, window):
        for i in np.flatnonzero(fire):
            new = drift_band_rate(float(rel[i]), 0.0, half_rad, target_fraction, coast_days * day_s)
            offset[i] += rate[i] * (t_days[k] - t_ref[i]) * day_s
            t_ref[i] = t_days[k]
            out[i].append((k, new - rate[i]))
            rate[i] = new
    return out


def _hold_last(x: np.ndarray) -> np.ndarray:
    """Element histories (n, m) with NaN tails (after an averaged impact or a second safety crossing) held at their
    last value: the estimate keeps such a satellite, charging the rest of its life at its safety raises' rate, so the
    navigation sees it where the last raise left it (a satellite with no value at all stays NaN: lost)."""
    idx = np.where(np.isfinite(x), np.arange(x.shape[1])[None, :], 0)
    return np.take_along_axis(x, np.maximum.accumulate(idx, axis=1), axis=1)


def _fill_forward_rates(x: np.ndarray) -> np.ndarray:
    """Unwrapped angle histories (n, m) with NaN tails (after an averaged impact or a second safety crossing)
    continued at their mean rate over the rest."""
    d = np.diff(x, axis=1)
    for i in np.flatnonzero(~np.all(np.isfinite(d), axis=1)):
        good = np.flatnonzero(np.isfinite(d[i]))
        if not good.size:
            d[i] = 0.0
            continue
        d[i] = np.where(np.isfinite(d[i]), d[i], np.mean(d[i, good]))
    return np.concatenate([x[:, :1], x[:, :1] + np.cumsum(d, axis=1)], axis=1)


def navigation_windows(t_days: np.ndarray, window_days: float) -> np.ndarray:
    """Edges (indices into the uniform day grid ``t_days``, from 0) of the navigation monitor's windows over the
    life: each closes at the first grid time at least ``window_days`` after it opened (the monitor closes a window at
    its first daily check past that length), the last one before the end of the life (the closed loop judges nothing
    at its last check). Window j spans (edge j, edge j + 1]; window 0 is the baseline."""
    edges = [0]
    while True:
        k = int(np.searchsorted(t_days, t_days[edges[-1]] + window_days - 1e-9))
        if k >= t_days.size - 1:
            return np.array(edges)
        edges.append(k)


def lattice_epochs_s(span_s: float, period_s: float, n: int) -> np.ndarray:
    """``n`` epochs (s from the window's start) spread evenly over ``span_s`` whose orbital phases ``t mod period_s``
    are spread evenly too (a rank-1 lattice: the k-th epoch at phase ``k`` times the golden ratio, modulo one, on the
    orbit nearest ``(k + 1/2) span / n``). Availability is a fraction of time over two clocks, the orbit and the Moon's
    turn under it: evenly spaced epochs alias with the orbit (64 of a month of a 6500 km constellation's positions
    gave 78 % where every 900 s gave 89 %), the lattice samples both (85.9 % and 91.2 % for 89.0 % and 88.8 %)."""
    k = np.arange(n)
    phase = (k * GOLDEN_FRACTION) % 1.0
    orbits = np.round((k + 0.5) / n * span_s / period_s - phase)
    return np.clip(period_s * (orbits + phase), 0.0, span_s)


def rebuilt_positions_j2000(
    sma_km: np.ndarray,
    u0_rad: np.ndarray,
    ecc: np.ndarray,
    inc_rad: np.ndarray,
    raan_rad: np.ndarray,
    aop_rad: np.ndarray,
    t_s: np.ndarray,
    rot_el_to_j2000: np.ndarray,
    gm_km3_s2: float,
) -> np.ndarray:
    """Moon-centred J2000 positions (n_sat, n_t, 3) km of a constellation rebuilt from mean elements (n_sat, n_t)
    (element frame, rad) at ``t_s`` (n_t,) s after the epoch: the mean argument of latitude runs from its slot
    ``u0_rad`` (n_sat,) at the design's mean motion (the slot controller holds u against the constellation's), so
    M = u - AOP."""
    mean_motion = np.sqrt(gm_km3_s2 / sma_km**3)
    anomaly = u0_rad[:, None] + mean_motion[:, None] * t_s[None, :] - aop_rad
    el = np.stack(
        [np.broadcast_to(sma_km[:, None], ecc.shape), ecc, inc_rad, raan_rad, aop_rad, anomaly],
        axis=-1,
    )
    return elements_to_state(el, gm_km3_s2)[..., :3] @ np.asarray(rot_el_to_j2000).T


def _restore_dv_kms(el: tuple, ref: tuple, gm_km3_s2: float) -> float:
    """The closed loop's navigation restore (e vector and i back to the design's, two burns of
    :func:`lnss_lib.design_life.manoeuvres.plan_impulses`) of mean elements ``el`` (a, e, i, RAAN, AOP) to ``ref``
    (e, AOP, i), at first order (no Newton refinement: a quarter of the cost; 9 % less Delta-V than the refined plan
    on the 0.42 km/s restore of the quick operational front's cheapest design)."""
    sma, ecc, inc, raan, aop = el
    target = restore_target(ecc, aop, inc - ref[2], ref[0], ref[1])
    return plan_impulses(
        np.array([sma, ecc, inc, raan, aop, 0.0]), gm_km3_s2, target, max_burns=2, newton_steps=0
    ).dv_total_kms


def navigation_restores(
    dop: DopSettings,
    dynamics: Dynamics,
    design_life: DesignLifeSettings,
    t0_tdb_s: float,
    t_days: np.ndarray,
    sma_km: np.ndarray,
    u0_rad: np.ndarray,
    raan_rad: np.ndarray,
    ecc: np.ndarray,
    inc_rad: np.ndarray,
    aop_rad: np.ndarray,
    rot_el_to_j2000: np.ndarray | None = None,
    availability: bool = True,
) -> dict:
    """The navigation monitor's restores over the life, and the availability it leaves, on the constellation rebuilt
    from its mean element histories.

    ``t_days`` (m,): a uniform grid from 0; ``sma_km``, ``u0_rad`` (slots) (n_sat,): the design's; ``raan_rad``,
    ``ecc``, ``inc_rad``, ``aop_rad`` (n_sat, m): each satellite's mean elements (element frame; NaN once lost), its
    design values at index 0. Each window of :func:`navigation_windows`, and the part of the life after the last one,
    is rebuilt (:func:`rebuilt_positions_j2000`) at its own :data:`NAV_SAMPLES_PER_WINDOW` epochs
    (:func:`lattice_epochs_s`), the Moon turned to them and the nodes where their common precession has taken them,
    and its south-pole DOP summarised with ``[dop]`` (:func:`lnss_lib.dop.metrics_for_settings`, the compiled twin of
    the monitor's ``summary_for_settings``). A window in which some satellite's e, AOP or i is outside
    ``[design_life.box]`` at its close is judged against the first window by the monitor's rule
    (:func:`lnss_lib.design_life.service.navigation_violations`); as in the closed loop, a violation restores every
    satellite outside the box (:func:`_restore_dv_kms`), whose e, AOP and i then run their history again from the
    start (the design's elements, shifted in time to the restore; the Earth's and Sun's averaged pull on an orbit in
    ``moon_op`` barely depends on the date).

    Returns ``dv_kms`` and ``n_restores`` (n_sat,), ``violations`` (window -> names of the statistics outside),
    ``n_judged`` (windows judged) and, for each key of :data:`AVAILABILITY_KEYS`, the availability of every window as
    flown (before the restores its close triggers) ``<key>_windows`` (%), with ``window_days`` (their lengths, d),
    ``<key>_life_estimate`` (the mean weighted by length) and ``<key>_worst_month_estimate`` (the lowest window).
    ``rot_el_to_j2000``: :func:`lnss_lib.frames.element_frame_to_j2000` at ``t0_tdb_s`` when the caller has it.
    ``availability`` False: only the first window and those judged are computed (the same restores, a DOP pass per
    judged window where every window costs one), the availabilities are NaN.
    """
    svc, box = design_life.service, design_life.box
    gm = dynamics.gravity.gm_km3_s2
    n_sat = ecc.shape[0]
    out = {
        "dv_kms": np.zeros(n_sat),
        "n_restores": np.zeros(n_sat, dtype=int),
        "violations": {},
        "n_judged": 0,
    }
    edges = navigation_windows(t_days, svc.nav_window_days)
    bounds = np.append(edges, t_days.size - 1) if edges[-1] < t_days.size - 1 else edges
    rot = element_frame_to_j2000(dynamics, t0_tdb_s) if rot_el_to_j2000 is None else rot_el_to_j2000
    grid = SurfaceGrid.from_settings(dop, dynamics.constants.r_moon_mean_km)
    ref = (ecc[:, 0], aop_rad[:, 0], inc_rad[:, 0])
    half = (box.ecc, np.radians(box.aop_deg), np.radians(box.inc_deg))
    step_s = (t_days[1] - t_days[0]) * SECONDS_PER_DAY
    period_s = TWO_PI * np.sqrt(np.mean(sma_km) ** 3 / gm)
    shift = np.zeros(n_sat, dtype=int)  # grid index of each satellite's last restore
    rows = np.arange(n_sat)[:, None]
    costs = {}

    def summary(j):
        """Window j as flown: its own epochs, each satellite's elements since its last restore."""
        t_s = lattice_epochs_s(
            (bounds[j + 1] - bounds[j]) * step_s, period_s, NAV_SAMPLES_PER_WINDOW
        )
        offset = np.rint(t_s / step_s).astype(int)[None, :]
        idx = (bounds[j] - shift)[:, None] + offset
        t_s = t_s + bounds[j] * step_s
        r = rebuilt_positions_j2000(
            sma_km,
            u0_rad,
            ecc[rows, idx],
            inc_rad[rows, idx],
            raan_rad[rows, bounds[j] + offset],
            aop_rad[rows, idx],
            t_s,
            rot,
            gm,
        )
        return metrics_for_settings(
            dop, rotate_with(rotation("J2000", dynamics.frames.moon_fixed, t0_tdb_s + t_s), r), grid
        )

    baseline = summary(0)
    windows = [baseline]
    for j in range(1, bounds.size - 1):
        windows.append(summary(j) if availability else None)
        if j >= edges.size - 1:  # the part after the last window: never judged
            continue
        close = edges[j + 1] - shift
        e, i, w = ecc[rows[:, 0], close], inc_rad[rows[:, 0], close], aop_rad[rows[:, 0], close]
        with np.errstate(invalid="ignore"):
            outside = (
                (np.abs(e - ref[0]) > half[0])
                | (np.abs(wrap_pi(w - ref[1])) > half[1])
                | (np.abs(i - ref[2]) > half[2])
            )
        if not outside.any():
            continue
        windows[j] = windows[j] or summary(j)
        violated = navigation_violations(windows[j], baseline, svc)
        out["n_judged"] += 1
        if not violated:
            continue
        out["violations"][j] = violated
        for s in np.flatnonzero(outside):
            el = (
                float(sma_km[s]),
                float(e[s]),
                float(i[s]),
                float(raan_rad[s, edges[j + 1]]),
                float(w[s]),
            )
            key = tuple(np.round((*el[:3], *el[4:], ref[0][s], ref[1][s], ref[2][s]), 9))
            if key not in costs:
                costs[key] = _restore_dv_kms(el, (ref[0][s], ref[1][s], ref[2][s]), gm)
            out["dv_kms"][s] += costs[key]
            out["n_restores"][s] += 1
            shift[s] = edges[j + 1]
    out["window_days"] = np.diff(bounds) * step_s / SECONDS_PER_DAY
    for key in AVAILABILITY_KEYS:
        values = np.array([w[key] if availability else np.nan for w in windows])
        out[f"{key}_windows"] = values
        out[f"{key}_life_estimate"] = float(
            np.sum(values * out["window_days"]) / np.sum(out["window_days"])
        )
        out[f"{key}_worst_month_estimate"] = float(np.min(values))
    return out


def life_estimate(
    sk_estimate: SkEstimateSettings,
    design_life: DesignLifeSettings,
    dynamics: Dynamics,
    dop: DopSettings,
    arc: xr.Dataset,
    screen: xr.Dataset,
    field: SecularField,
    tolerances_deg: dict | None = None,
    availability: bool = True,
) -> dict:
    """The estimate for the evaluator's arc (every satellite) and the screen of the same states over the life.

    ``arc``: a propagator Dataset; ``screen``: :func:`lnss_lib.design_life.screen.screen_states` of its first
    states (``[stability] margin_km`` below the safety floor, so its history reaches every crossing), ``field`` the
    averaged model it integrated. The life is the screen's. ``tolerances_deg`` ``{"raan_rel", "u_rel"}``: the relative
    node and slot held (default :func:`lnss_lib.design_life.tolerances.estimate_tolerances_deg`; the validation passes
    those the closed loop derived). Returns ``sk_dv_estimate_kms_per_year`` (mean over
    satellites), ``sk_dv_estimate_max_kms_per_year``, ``per_sat`` (part -> (n_sat,) km/s per year and ``total``),
    ``n_safety_burns`` and ``n_navigation_restores`` (n_sat,), the navigation over the life
    (:data:`LIFE_NAVIGATION_KEYS`, %, NaN unless ``availability``, and ``navigation_windows``, all of
    :func:`navigation_restores`) and ``wall_s``.
    """
    start = time.perf_counter()
    svc = design_life.service
    tol_deg = estimate_tolerances_deg(svc) if tolerances_deg is None else tolerances_deg
    gm = dynamics.gravity.gm_km3_s2
    t0 = float(arc["time"].values[0])
    life_days = float(screen.attrs["life_days"])
    years = life_days / sk_estimate.year_days
    t_days = screen["time"].values
    rot = element_frame_to_j2000(dynamics, t0)
    states = np.concatenate([arc["r_mci_km"].values, arc["v_mci_kms"].values], axis=-1)
    a = screen["a_km"].values
    ecc = screen["ecc"].values
    inc, raan, aop = (np.radians(screen[k].values) for k in ("inc_deg", "raan_deg", "aop_deg"))
    n_sat = a.size

    floor = dynamics.r_impact_km + svc.perilune_margin_km + perilune_dip_km(states, gm)
    mel = np.stack(
        [np.broadcast_to(a[:, None], ecc.shape), ecc, inc, raan, aop, np.zeros_like(ecc)], axis=-1
    )
    e_vec, j_vec = mean_vectors_j2000(np.nan_to_num(mel).reshape(-1, 6), rot)
    lost = ~np.isfinite(ecc.ravel())
    e_vec[lost], j_vec[lost] = np.nan, np.nan
    e_vec, j_vec = e_vec.reshape(n_sat, -1, 3), j_vec.reshape(n_sat, -1, 3)
    safety = np.zeros(n_sat)
    n_burns = np.zeros(n_sat, dtype=int)
    key = np.round(np.column_stack([a, ecc[:, 0], inc[:, 0], raan[:, 0], aop[:, 0]]), 9)
    _, first, group = np.unique(key, axis=0, return_index=True, return_inverse=True)
    group = np.asarray(group).ravel()
    for q, i in enumerate(first):
        members = group == q
        floor_q = float(np.max(floor[members]))
        if np.isnan(_first_below(t_days, a[i] * (1.0 - ecc[i])[None], floor_q)[0]):
            continue
        dv, count, e_ctl, j_ctl = safety_dv_kms(
            field,
            t_days,
            float(a[i]),
            e_vec[i],
            j_vec[i],
            floor_q,
            svc.safety_lead_days,
            svc.safety_check_days,
        )
        safety[members], n_burns[members] = dv / years, count
        e_vec[members], j_vec[members] = e_ctl, j_ctl
    u, back = _distinct_rows(
        e_vec.reshape(n_sat, -1), j_vec.reshape(n_sat, -1)
    )  # a raised plane shares one
    controlled = elements_from_vectors(e_vec[u], j_vec[u], rot.T)
    ecc = controlled["ecc"][back]
    inc, raan, aop = (np.radians(controlled[k])[back] for k in ("inc_deg", "raan_deg", "aop_deg"))

    p = a[:, None] * (1.0 - ecc**2)
    h_over_p = np.sqrt(gm / p)
    node_cost = np.nan_to_num(h_over_p * np.abs(np.sin(inc)) * (1.0 - ecc * np.abs(np.sin(aop))))
    raan_drift = _fill_forward_rates(np.unwrap(raan, axis=1)) - raan[:, :1]
    half_node = raan_half_width_rad(np.radians(tol_deg["raan_rel"]), inc[:, 0])
    osc = state_to_elements(to_element_frame(states[:, 0], rot), gm)
    nav = navigation_restores(
        dop,
        dynamics,
        design_life,
        t0,
        t_days,
        a,
        osc[:, 4] + osc[:, 5],
        raan[:, :1] + raan_drift,
        *(_hold_last(x) for x in (ecc, inc, aop)),
        rot,
        availability,
    )
    node = np.zeros(n_sat)
    for i, events in enumerate(
        node_corrections(
            t_days,
            raan_drift,
            half_node,
            design_life.target_fraction,
            design_life.min_maneuver_spacing_days,
        )
    ):
        node[i] = sum(abs(change) * node_cost[i, k] for k, change in events) / years

    aop_drift = _fill_forward_rates(np.unwrap(aop, axis=1)) - aop[:, :1]
    arc_t = arc["time"].values
    drift = mean_drift(
        arc_t,
        np.concatenate([states[..., :3] @ rot, states[..., 3:] @ rot], axis=-1),
        gm,
        sk_estimate.min_periods,
    )
    arc_days = (arc_t[-1] - arc_t[0]) / SECONDS_PER_DAY
    k_arc = min(int(np.searchsorted(t_days, arc_days)), t_days.size - 1)
    aop_rate = aop_drift[:, k_arc] / max(t_days[k_arc], 1e-9) / SECONDS_PER_DAY
    trimmed = (
        drift["u_dot"] + 1.5 * np.sqrt(gm / a**3) * (drift["a_km"] - a) / a
    )  # at the design's mean a
    u_drift = (trimmed - aop_rate)[:, None] * t_days[None, :] * SECONDS_PER_DAY + aop_drift
    phase_cost = np.nan_to_num(np.sqrt(1.0 - ecc**2) * a[:, None] / 3.0)
    phase = np.zeros(n_sat)
    lookahead = design_life.check_interval_days
    events_by_sat = phase_corrections(
        t_days,
        u_drift,
        np.radians(tol_deg["u_rel"]),
        design_life.target_fraction,
        design_life.slot_coast_days,
        lookahead,
    )
    for i, events in enumerate(events_by_sat):
        phase[i] = sum(abs(change) * phase_cost[i, k] for k, change in events) / years

    per_sat = {
        "safety": safety,
        "navigation": nav["dv_kms"] / years,
        "relative_node": node,
        "phase": phase,
    }
    per_sat["total"] = sum(per_sat[k] for k in PARTS)
    total = per_sat["total"]
    return {
        "sk_dv_estimate_kms_per_year": float(np.mean(total)),
        "sk_dv_estimate_max_kms_per_year": float(np.max(total)),
        "per_sat": per_sat,
        "n_safety_burns": n_burns,
        "n_navigation_restores": nav["n_restores"],
        **{key: nav[key] for key in LIFE_NAVIGATION_KEYS},
        "navigation_windows": nav,
        "wall_s": time.perf_counter() - start,
    }


def campaign_estimate(
    sk_estimate: SkEstimateSettings,
    stability: StabilitySettings,
    design_life: DesignLifeSettings,
    dynamics: Dynamics,
    dop: DopSettings,
    arc: xr.Dataset,
    screen: xr.Dataset | None = None,
    availability: bool = True,
) -> dict:
    """``[sk_estimate] model``'s estimate for a propagator Dataset (every satellite; e.g. the evaluator's arc).

    ``"arc"``: :func:`lnss_lib.design_life.estimate.sk_estimate_from_propagation`; ``"life"``: :func:`life_estimate`
    on ``screen`` (:func:`lnss_lib.design_life.screen.screen_states` of the arc's first states over ``[stability]
    life_days``; computed here when not given; ``availability``: the navigation over the life too, see
    :func:`navigation_restores`). Returns at least ``sk_dv_estimate_kms_per_year``,
    ``sk_dv_estimate_max_kms_per_year``, ``per_sat`` and ``wall_s``.
    """
    if sk_estimate.model == "arc":
        return sk_estimate_from_propagation(sk_estimate, dynamics, arc)
    t0 = float(arc["time"].values[0])
    if screen is None:
        first = np.concatenate(
            [arc["r_mci_km"].values[:, 0], arc["v_mci_kms"].values[:, 0]], axis=-1
        )
        screen = screen_states(stability, dynamics, first, t0)
    return life_estimate(
        sk_estimate,
        design_life,
        dynamics,
        dop,
        arc,
        screen,
        cached_field(stability, dynamics, t0)[0],
        availability=availability,
    )
