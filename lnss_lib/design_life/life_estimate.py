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
* ``navigation``: the navigation monitor's restores (:func:`lnss_lib.design_life.life_navigation.navigation_restores`). Each window of
  ``[design_life.service] nav_window_days`` (closing on the day grid, as the monitor on its daily checks) is rebuilt
  from the averaged elements: e, AOP, i and the node (its common precession, which turns the constellation about the
  element frame's pole, included) at :data:`~lnss_lib.design_life.life_navigation.NAV_SAMPLES_PER_WINDOW` epochs of the window itself
  (:func:`~lnss_lib.design_life.life_navigation.lattice_epochs_s`: spread over the month and over the orbit, so the Moon turns under the constellation as
  it does), the mean anomaly from the slot at the design's mean motion; its south-pole DOP is summarised with
  ``[dop]``. A window at whose close some satellite's averaged e, AOP or i is outside ``[design_life.box]`` is judged
  against the first window's by the monitor's rule (:func:`lnss_lib.design_life.service.navigation_violations`). A
  violation restores e, AOP and i of every satellite outside the box, priced by the closed loop's two-burn plan
  (:func:`lnss_lib.design_life.manoeuvres.plan_impulses`, first order); the restored satellite's e, AOP and i then
  run their averaged history again from the design's elements (shifted in time: the Earth's and Sun's averaged pull
  on an orbit in ``moon_op`` barely depends on the date). The same windows, as flown, give the availability over the
  life that the campaign judges (:data:`~lnss_lib.design_life.life_navigation.LIFE_NAVIGATION_KEYS`: PDOP and HDOP, the life's mean and the worst month).
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

import numpy as np
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..elements import state_to_elements
from ..frames import element_frame_to_j2000
from ..settings import (
    DesignLifeSettings,
    DopSettings,
    Dynamics,
    SkEstimateSettings,
    StabilitySettings,
)
from .estimate import mean_drift, sk_estimate_from_propagation
from .life_navigation import LIFE_NAVIGATION_KEYS, navigation_restores
from .life_relative import node_corrections, phase_corrections
from .life_safety import first_below, perilune_dip_km, safety_dv_kms
from .mean_elements import to_element_frame
from .screen import cached_field, screen_states
from .secular import SecularField, elements_from_vectors
from .service import mean_vectors_j2000, raan_half_width_rad
from .tolerances import estimate_tolerances_deg

__all__ = ["PARTS", "life_estimate", "campaign_estimate"]

PARTS = ("safety", "navigation", "relative_node", "phase")
"""What the estimate charges for (a subset of :data:`lnss_lib.design_life.service.PURPOSES`)."""


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
    (:data:`~lnss_lib.design_life.life_navigation.LIFE_NAVIGATION_KEYS`, %, NaN unless ``availability``, and ``navigation_windows``, all of
    :func:`~lnss_lib.design_life.life_navigation.navigation_restores`) and ``wall_s``.
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
        if np.isnan(first_below(t_days, a[i] * (1.0 - ecc[i])[None], floor_q)[0]):
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
    :func:`~lnss_lib.design_life.life_navigation.navigation_restores`). Returns at least ``sk_dv_estimate_kms_per_year``,
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
