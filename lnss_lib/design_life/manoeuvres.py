"""Impulsive manoeuvres from the Gauss variational equations: element changes and burn planning.

An impulse Delta-v (km/s, RTN: R along r, T = N x R, N along r x v) applied at a point of an orbit
changes the osculating elements by ``B(state) dv`` to first order, with B the impulsive form of the
GVEs (paper eq. 25-29; Vallado, *Fundamentals of Astrodynamics*, Gauss form; the mean-anomaly row
from Schaub & Junkins). :func:`impulsive_gve_matrix` gives B for the classical elements
``[a, e, i, raan, aop, M]``; :func:`control_gve_matrix` gives it for the control set
``[a, e cos(aop), e sin(aop), i, raan, u]`` (u = aop + M, the mean argument of latitude), which has
no 1/e: the station keeping plans in that set.

:func:`plan_impulses` picks the burn points of the next orbit among apsides and nodes/antinodes
(:func:`candidate_true_anomalies`), accounts for the along-track drift that a change of a causes
until a common target epoch, and keeps the one- or two-burn combination with the least total
Delta-v that reaches the requested changes (least squares, minimum norm within the combination),
then refines the impulses of that combination by Newton steps on the two-body flight of the burns
(:func:`kepler_achieved`), so that the second-order part of a large correction (a 40 m/s e-vector pair
moves a by several km to second order) does not leak into the rows that were to be held.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..elements import (
    TWO_PI,
    elements_to_state,
    kepler_states,
    mean_anomaly_from_true,
    state_to_elements,
    true_anomaly_from_mean,
)
from ..frames import rtn_basis
from ..gve import gve_matrix, orbit_quantities

CONTROL_ROWS = ("a_km", "ex", "ey", "inc_rad", "raan_rad", "u_rad")
"""Rows of the control element set: a, the eccentricity vector in the orbit's nodal axes, i, RAAN and
the mean argument of latitude u = aop + M."""


def apply_impulse(state: np.ndarray, dv_rtn_kms: np.ndarray) -> np.ndarray:
    """State (6,) after an impulse given in RTN (km/s): the velocity jumps, the position does not."""
    s = np.array(state, dtype=float)
    s[3:6] += np.asarray(dv_rtn_kms, dtype=float) @ rtn_basis(s)
    return s


def _with_true_anomaly(elements: np.ndarray) -> np.ndarray:
    """Elements (..., 6) ``[a, e, i, raan, aop, nu]`` of ``[a, e, i, raan, aop, M]``: the set :mod:`lnss_lib.gve` takes."""
    el = np.array(elements, dtype=float)
    el[..., 5] = true_anomaly_from_mean(el[..., 5], el[..., 1])
    return el


def mean_anomaly(true_anomaly_rad, e):
    """Mean anomaly (rad, in [0, 2 pi)) of a true anomaly (rad) and eccentricity."""
    return np.mod(mean_anomaly_from_true(true_anomaly_rad, e), TWO_PI)


def impulsive_gve_matrix(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """B (..., 6, 3): change of ``[a, e, i, raan, aop, M]`` (km, rad) per RTN impulse (km/s) at elements
    (..., 6) ``[a, e, i, raan, aop, M]``.

    Rows (Vallado's Gauss form of eq. 25-29 times dt; M from Schaub & Junkins, without the n dt of the
    coast): da = 2 a^2/h (e sin(nu) dv_R + p/r dv_T); de = (p sin(nu) dv_R + ((p + r) cos(nu) + r e) dv_T)/h;
    di = r cos(theta) dv_N/h; draan = r sin(theta) dv_N/(h sin i); daop = (-p cos(nu) dv_R + (p + r) sin(nu) dv_T)/(h e)
    - cos(i) draan; dM = b/(a h e) ((p cos(nu) - 2 r e) dv_R - (p + r) sin(nu) dv_T). Singular at e = 0 and
    sin(i) = 0; :func:`control_gve_matrix` is not.
    """
    el = _with_true_anomaly(elements)
    a, e, inc, nu, theta, p, h, r = orbit_quantities(el, gm_km3_s2)
    sn, cn = np.sin(nu), np.cos(nu)
    beta = np.sqrt(1.0 - e * e)
    row_m = np.stack(
        [beta / (h * e) * (p * cn - 2.0 * r * e), -beta / (h * e) * (p + r) * sn, np.zeros_like(a)],
        axis=-1,
    )
    return np.concatenate([gve_matrix(el, gm_km3_s2), row_m[..., None, :]], axis=-2)


def control_gve_matrix(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """B (..., 6, 3) for :data:`CONTROL_ROWS` ``[a, e cos(aop), e sin(aop), i, raan, u]`` (km, -, -, rad, rad, rad).

    Combines the rows of :func:`impulsive_gve_matrix` so that 1/e cancels: e d(aop) and
    d(aop) + dM are finite as e -> 0 (with (beta - 1)/e = -e/(1 + beta), beta = sqrt(1 - e^2)).
    Only the RAAN row (and the N column of the aop-bearing rows) keeps 1/sin(i).
    """
    el = _with_true_anomaly(elements)
    a, e, inc, nu, theta, p, h, r = orbit_quantities(el, gm_km3_s2)
    st = np.sin(theta)
    beta = np.sqrt(1.0 - e * e)
    cot_i = np.cos(inc) / np.sin(inc)
    b = gve_matrix(el, gm_km3_s2, e_times_aop=True)  # rows a, e, i, raan, e aop-dot
    row_e, row_e_daop = b[..., 1, :], b[..., 4, :]
    ca, sa = np.cos(el[..., 4])[..., None], np.sin(el[..., 4])[..., None]
    k = e / (1.0 + beta)
    row_u = np.stack(
        [row_e_daop[..., 0] * k - 2.0 * r * beta / h, row_e_daop[..., 1] * k, -r * st * cot_i / h],
        axis=-1,
    )
    rows = [
        b[..., 0, :],
        ca * row_e - sa * row_e_daop,
        sa * row_e + ca * row_e_daop,
        b[..., 2, :],
        b[..., 3, :],
        row_u,
    ]
    return np.stack(rows, axis=-2)


def control_elements(elements: np.ndarray) -> np.ndarray:
    """Control set (..., 6) ``[a, e cos(aop), e sin(aop), i, raan, aop + M]`` of classical elements (..., 6)."""
    el = np.asarray(elements, dtype=float)
    return np.stack(
        [
            el[..., 0],
            el[..., 1] * np.cos(el[..., 4]),
            el[..., 1] * np.sin(el[..., 4]),
            el[..., 2],
            el[..., 3],
            el[..., 4] + el[..., 5],
        ],
        axis=-1,
    )


def candidate_true_anomalies(e: float, aop_rad: float) -> np.ndarray:
    """Burn points (true anomaly, rad, in [0, 2 pi)): perilune and apolune (a, e, aop), the nodes (i)
    and the antinodes (raan): argument of latitude 0, 90, 180 and 270 deg. Duplicates removed."""
    nus = np.mod(np.concatenate([[0.0, np.pi], np.arange(4) * np.pi / 2.0 - aop_rad]), TWO_PI)
    keep = []
    for nu in nus:
        if all(abs(np.angle(np.exp(1j * (nu - k)))) > 1e-6 for k in keep):
            keep.append(nu)
    return np.array(keep)


@dataclass(frozen=True)
class ImpulsePlan:
    """Burns planned by :func:`plan_impulses`: times after the planning epoch (s), RTN impulses (km/s),
    the control-set change they give at the target epoch, and the residual of the requested change."""

    dt_s: np.ndarray
    dv_rtn_kms: np.ndarray
    achieved: np.ndarray
    residual: np.ndarray

    @property
    def dv_total_kms(self) -> float:
        return float(np.sum(np.linalg.norm(self.dv_rtn_kms, axis=-1)))


def kepler_achieved(
    elements: np.ndarray, gm_km3_s2: float, dt_s, dv_rtn_kms, horizon_s: float
) -> np.ndarray:
    """Change (6,) of the control set (:data:`CONTROL_ROWS`, angles wrapped) at ``horizon_s`` after the epoch
    of ``elements`` when the impulses ``dv_rtn_kms`` (k, 3) are flown at ``dt_s`` (k,) in two-body motion,
    against the same coast without them. Impulses that open the orbit (e >= 1) give NaN, without a warning:
    a plan with a non-finite impulse is never flown (:func:`lnss_lib.design_life.fleet.enqueue`)."""
    el = np.asarray(elements, dtype=float)
    state, t = elements_to_state(el, gm_km3_s2), 0.0
    with np.errstate(invalid="ignore"):
        for dt, dv in zip(dt_s, dv_rtn_kms):
            state = apply_impulse(
                kepler_states(state_to_elements(state, gm_km3_s2), [dt - t], gm_km3_s2)[0, 0], dv
            )
            t = float(dt)
        final = kepler_states(state_to_elements(state, gm_km3_s2), [horizon_s - t], gm_km3_s2)[0, 0]
    nominal = kepler_states(el, [horizon_s], gm_km3_s2)[0, 0]
    diff = control_elements(state_to_elements(final, gm_km3_s2)) - control_elements(
        state_to_elements(nominal, gm_km3_s2)
    )
    diff[3:] = np.mod(diff[3:] + np.pi, TWO_PI) - np.pi
    return diff


def lowest_perilune_km(elements: np.ndarray, gm_km3_s2: float, dt_s, dv_rtn_kms) -> float:
    """Lowest osculating perilune radius a (1 - e) (km) of the orbits that the impulses ``dv_rtn_kms`` (k, 3), flown at
    ``dt_s`` (k,) (s after the epoch of ``elements`` (6,), ascending) in two-body motion, leave behind: each one between
    two burns and the last; -inf where an impulse opens the orbit (e >= 1), inf without impulses."""
    state, t, low = elements_to_state(np.asarray(elements, dtype=float), gm_km3_s2), 0.0, np.inf
    with np.errstate(invalid="ignore"):
        for dt, dv in zip(dt_s, dv_rtn_kms):
            state = apply_impulse(
                kepler_states(state_to_elements(state, gm_km3_s2), [dt - t], gm_km3_s2)[0, 0], dv
            )
            t = float(dt)
            a, e = state_to_elements(state, gm_km3_s2)[:2]
            if not (np.isfinite(a) and np.isfinite(e) and a > 0.0 and e < 1.0):
                return -np.inf
            low = min(low, float(a * (1.0 - e)))
    return low


def plan_impulses(
    elements: np.ndarray,
    gm_km3_s2: float,
    target: dict,
    *,
    horizon_s: float | None = None,
    max_burns: int = 2,
    true_anomalies=None,
    min_dv_kms: float = 0.0,
    newton_steps: int = 3,
) -> ImpulsePlan:
    """One or two impulses on the next orbit that change the control set (:data:`CONTROL_ROWS`) by ``target``.

    ``elements`` (6,) ``[a, e, i, raan, aop, M]`` (km, rad) are the osculating (or mean) elements now;
    ``target`` maps row names of :data:`CONTROL_ROWS` to the wanted change at the target epoch (now +
    ``horizon_s``, default one orbital period); rows not named are free. The u row includes the drift
    -1.5 n da/a (t_target - t_burn) that a change of a causes before the target epoch. Burn points are
    ``true_anomalies`` (default :func:`candidate_true_anomalies`), reached by Keplerian motion; every
    combination of up to ``max_burns`` points is solved by minimum-norm least squares on rows scaled to
    comparable units, and the combination with the smallest residual (then the least total Delta-v)
    is kept; ``newton_steps`` Newton steps on :func:`kepler_achieved` (same burn points and Jacobian) then
    remove the linearisation error. ``achieved`` is the two-body change. Burns below ``min_dv_kms`` are dropped.
    """
    el = np.asarray(elements, dtype=float)
    if el.shape != (6,) or not np.all(np.isfinite(el)):
        raise ValueError(
            f"elements must be 6 finite values [sma_km, e, i, raan, aop, M] (rad); got {el!r}"
        )
    unknown = set(target) - set(CONTROL_ROWS)
    if unknown or not target:
        raise ValueError(f"target must name rows of {CONTROL_ROWS}; got {sorted(target)}")
    a, e = el[0], el[1]
    n = np.sqrt(gm_km3_s2 / a**3)
    period = TWO_PI / n
    horizon = period if horizon_s is None else float(horizon_s)
    nus = (
        candidate_true_anomalies(e, el[4])
        if true_anomalies is None
        else np.mod(np.asarray(true_anomalies), TWO_PI)
    )
    m_now = np.mod(el[5], TWO_PI)
    dts = np.mod(mean_anomaly(nus, e) - m_now, TWO_PI) / n
    if np.any(dts > horizon):
        raise ValueError(
            f"horizon {horizon:.0f} s ends before burn point(s) at {dts[dts > horizon]} s"
        )
    rows = [CONTROL_ROWS.index(k) for k in target]
    # scale: angles and e-vector in units of 1e-3; a by the along-track drift it causes in one orbit
    # (3 pi da/a rad), so that holding a weighs as much as holding u
    scale = np.array([3e3 * np.pi / a, 1e3, 1e3, 1e3, 1e3 * np.sin(el[2]), 1e3])[rows]
    want = np.array([target[k] for k in target]) * scale
    columns = []
    for nu, dt in zip(nus, dts):
        el_k = el.copy()
        el_k[5] = mean_anomaly(nu, e)
        b = control_gve_matrix(el_k, gm_km3_s2)
        b[5] += -1.5 * n / a * (horizon - dt) * b[0]
        columns.append(b[rows] * scale[:, None])
    best = None
    for k in range(1, max_burns + 1):
        for combo in combinations(range(len(nus)), k):
            mat = np.concatenate([columns[c] for c in combo], axis=1)
            sol = np.linalg.lstsq(mat, want, rcond=None)[0]
            resid = float(np.linalg.norm(mat @ sol - want))
            cost = float(np.sum(np.linalg.norm(sol.reshape(k, 3), axis=1)))
            key = (round(resid / max(np.linalg.norm(want), 1e-300), 6), cost)
            if best is None or key < best[0]:
                best = (key, combo, sol.reshape(k, 3))
    _, combo, dv = best
    order = np.argsort(dts[list(combo)])
    dt_sel, dv = dts[list(combo)][order], dv[order]
    mat = np.concatenate([columns[combo[j]] for j in order], axis=1)
    for _ in range(int(newton_steps)):
        got = kepler_achieved(el, gm_km3_s2, dt_sel, dv, horizon)[rows] * scale
        dv = dv + np.linalg.lstsq(mat, want - got, rcond=None)[0].reshape(dv.shape)
    keep = np.linalg.norm(dv, axis=1) >= min_dv_kms
    dt_sel, dv = dt_sel[keep], dv[keep]
    achieved = kepler_achieved(el, gm_km3_s2, dt_sel, dv, horizon)[rows]
    return ImpulsePlan(dt_sel, dv, achieved, achieved - np.array([target[k] for k in target]))
