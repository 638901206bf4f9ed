"""Navigation over the life in the life estimate: the navigation monitor's restores and the availability they
leave, on the constellation rebuilt from its averaged mean elements, window by window (:func:`navigation_restores`).
Read by :func:`lnss_lib.design_life.life_estimate.life_estimate`."""

from __future__ import annotations

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..dop import metrics_for_settings
from ..elements import TWO_PI, elements_to_state
from ..ephemeris import rotation
from ..frames import element_frame_to_j2000, rotate_with
from ..settings import DesignLifeSettings, DopSettings, Dynamics
from ..surface_grid import SurfaceGrid
from .manoeuvres import plan_impulses
from .mean_elements import wrap_pi
from .service import navigation_violations, restore_target

__all__ = [
    "NAV_SAMPLES_PER_WINDOW",
    "AVAILABILITY_KEYS",
    "LIFE_NAVIGATION_KEYS",
    "navigation_windows",
    "lattice_epochs_s",
    "rebuilt_positions_j2000",
    "navigation_restores",
]

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
    and its south-pole DOP summarised with ``[dop]`` (:func:`lnss_lib.dop.metrics_for_settings`, as the monitor's). A window in which some satellite's e, AOP or i is outside
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
