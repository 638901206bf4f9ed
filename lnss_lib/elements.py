"""Classical Keplerian elements <-> Cartesian states (pure, vectorised numpy kernels).

Elements are ``(sma_km, e, i_rad, raan_rad, aop_rad, M_rad)``, referred to whatever frame the
Cartesian state is in; :func:`lnss_lib.ephemeris.element_frame_to_j2000` supplies the rotation
between the element frame and Moon-centred J2000. Angles are radians here; degree conversion
belongs to the callers that read user input.
"""

from __future__ import annotations

import numpy as np

from .constants import C_M_S, EARTH_MOON_DISTANCE_KM, MOON_HILL_RADIUS_KM
from .errors import ConfigError, InvalidOrbitError

__all__ = [
    "TWO_PI",
    "validate_elements",
    "check_states_km",
    "solve_kepler",
    "eccentric_anomaly_from_true",
    "true_anomaly_from_eccentric",
    "mean_anomaly_from_true",
    "true_anomaly_from_mean",
    "vis_viva_sma_km",
    "eccentricity_vector",
    "elements_to_state",
    "state_to_elements",
    "kepler_states",
    "orbital_period_s",
]

TWO_PI = 2.0 * np.pi


def validate_elements(sma_km, e, r_body_km: float, min_altitude_km: float = 0.0) -> None:
    """Raise :class:`~lnss_lib.errors.InvalidOrbitError` (a ValueError) naming the bad value if elements are not a
    closed orbit above the surface."""
    a = np.atleast_1d(np.asarray(sma_km, dtype=float))
    ecc = np.atleast_1d(np.asarray(e, dtype=float))
    if np.any(~np.isfinite(a)) or np.any(a <= 0.0):
        raise InvalidOrbitError(
            f"semi-major axis must be positive and finite (km); got {a[(a <= 0) | ~np.isfinite(a)][0]!r}"
        )
    if np.any(~np.isfinite(ecc)) or np.any((ecc < 0.0) | (ecc >= 1.0)):
        bad = ecc[(ecc < 0.0) | (ecc >= 1.0) | ~np.isfinite(ecc)][0]
        raise InvalidOrbitError(
            f"eccentricity must be in [0, 1) (closed orbits only); got e = {bad!r}"
        )
    if np.any(a > MOON_HILL_RADIUS_KM):
        raise InvalidOrbitError(
            f"semi-major axis {a[a > MOON_HILL_RADIUS_KM][0]:.1f} km is beyond the Moon's Hill sphere "
            f"({MOON_HILL_RADIUS_KM:,.0f} km): no bound lunar orbit"
        )
    perilune = a * (1.0 - ecc)
    floor = r_body_km + min_altitude_km
    if np.any(perilune < floor):
        k = int(np.argmax(perilune < floor))
        raise InvalidOrbitError(
            f"perilune radius a(1-e) = {perilune[k]:.1f} km (a = {a[k]:.1f} km, e = {ecc[k]:.4f}) is below "
            f"{floor:.1f} km (lunar radius {r_body_km} km + minimum altitude {min_altitude_km} km): the orbit hits the Moon"
        )


def check_states_km(states, gm_km3_s2: float, r_min_km: float | None = None) -> np.ndarray:
    """Moon-centred states (n, 6) [x, y, z, vx, vy, vz] (km, km/s) as floats when each is a lunar orbit's, else
    ConfigError (bad input) naming the state, the value and the limit: finite; above ``r_min_km`` (the surface plus
    the minimum altitude; not checked when None: a batch flags impacts); within the Earth-Moon distance; slower than
    light; below the Moon's escape speed sqrt(2 GM / r); an osculating semi-major axis inside the Hill sphere, the
    bound every element set meets (:func:`validate_elements`)."""
    states = np.atleast_2d(np.asarray(states, dtype=float))
    if states.ndim != 2 or states.shape[1] != 6:
        raise ConfigError(
            f"states must have shape (n_sat, 6) [x, y, z, vx, vy, vz]; got {states.shape}",
            key="state",
        )
    if not np.all(np.isfinite(states)):
        raise ConfigError(
            "states contain non-finite values; allowed: finite km and km/s", key="state"
        )
    r_km, v_kms = np.linalg.norm(states[:, :3], axis=1), np.linalg.norm(states[:, 3:], axis=1)
    c_kms = C_M_S / 1000.0
    v_escape_kms = np.sqrt(2.0 * gm_km3_s2 / np.maximum(r_km, np.finfo(float).tiny))
    with np.errstate(divide="ignore"):
        a_km = 1.0 / (2.0 / r_km - v_kms**2 / gm_km3_s2)
    for k in range(states.shape[0]):
        if r_min_km is not None and r_km[k] < r_min_km:
            problem = (
                f"radius {r_km[k]:.1f} km is inside the Moon (below {r_min_km:.1f} km, the surface plus the "
                f"minimum altitude); allowed: a state above it"
            )
        elif r_km[k] > EARTH_MOON_DISTANCE_KM:
            problem = (
                f"radius {r_km[k]:.6g} km is not allowed; allowed: up to {EARTH_MOON_DISTANCE_KM:,.0f} km (the "
                f"Earth-Moon distance: beyond it the Earth, not the Moon, is the central body)"
            )
        elif v_kms[k] >= c_kms:
            problem = (
                f"speed {v_kms[k]:.6g} km/s is not below the speed of light ({c_kms:,.0f} km/s)"
            )
        elif v_kms[k] >= v_escape_kms[k]:
            problem = (
                f"speed {v_kms[k]:.6g} km/s at radius {r_km[k]:.6g} km is not below the Moon's escape speed "
                f"there ({v_escape_kms[k]:.4g} km/s): no bound lunar orbit"
            )
        elif a_km[k] > MOON_HILL_RADIUS_KM:
            problem = (
                f"osculating semi-major axis {a_km[k]:.6g} km is beyond the Moon's Hill sphere "
                f"({MOON_HILL_RADIUS_KM:,.0f} km): no bound lunar orbit"
            )
        else:
            continue
        raise ConfigError(f"state {k}: {problem}", key="state")
    return states


def solve_kepler(mean_anomaly_rad: np.ndarray, e: np.ndarray, tol: float = 1e-14) -> np.ndarray:
    """Eccentric anomaly E from M = E - e sin E (Newton, vectorised, elliptic orbits)."""
    M = np.mod(np.asarray(mean_anomaly_rad, dtype=float), TWO_PI)
    e = np.asarray(e, dtype=float)
    E = np.where(e < 0.8, M, np.pi * np.ones_like(M))
    for _ in range(50):
        step = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        E = E - step
        if np.all(np.abs(step) < tol):
            break
    return E


def eccentric_anomaly_from_true(true_anomaly_rad, e):
    """Eccentric anomaly E (rad, in [-pi, pi]) of a true anomaly nu (rad), elliptic orbits (0 <= e < 1).

    E = 2 atan2(sqrt(1 - e) sin(nu / 2), sqrt(1 + e) cos(nu / 2)): the half-angle relation
    tan(E / 2) = sqrt((1 - e) / (1 + e)) tan(nu / 2) with the quadrant kept.
    """
    nu = np.asarray(true_anomaly_rad, dtype=float)
    return 2.0 * np.arctan2(
        np.sqrt(1.0 - e) * np.sin(nu / 2.0), np.sqrt(1.0 + e) * np.cos(nu / 2.0)
    )


def true_anomaly_from_eccentric(eccentric_anomaly_rad, e):
    """True anomaly nu (rad, in [-pi, pi]) of an eccentric anomaly E (rad): the inverse of
    :func:`eccentric_anomaly_from_true`, nu = 2 atan2(sqrt(1 + e) sin(E / 2), sqrt(1 - e) cos(E / 2))."""
    E = np.asarray(eccentric_anomaly_rad, dtype=float)
    return 2.0 * np.arctan2(np.sqrt(1.0 + e) * np.sin(E / 2.0), np.sqrt(1.0 - e) * np.cos(E / 2.0))


def mean_anomaly_from_true(true_anomaly_rad, e):
    """Mean anomaly M = E - e sin E (rad, Kepler's equation) of a true anomaly (rad), not wrapped: in
    [-pi, pi] like E (callers wrap to [0, 2 pi) or [0, 360) deg as they need)."""
    E = eccentric_anomaly_from_true(true_anomaly_rad, e)
    return E - e * np.sin(E)


def true_anomaly_from_mean(mean_anomaly_rad, e):
    """True anomaly (rad, in [-pi, pi]) of a mean anomaly (rad): Kepler's equation by :func:`solve_kepler`."""
    return true_anomaly_from_eccentric(solve_kepler(mean_anomaly_rad, e), e)


def vis_viva_sma_km(r_km, v2_km2_s2, gm_km3_s2: float):
    """Semi-major axis (km) from the radius (km) and the squared speed (km^2/s^2) by vis-viva,
    v^2 = GM (2 / r - 1 / a): a = 1 / (2 / r - v^2 / GM). Negative for an open orbit, inf for a parabola."""
    return 1.0 / (2.0 / r_km - v2_km2_s2 / gm_km3_s2)


def eccentricity_vector(r_vec_km, v_vec_kms, gm_km3_s2: float, h_vec=None, r_km=None):
    """Eccentricity vector (..., 3) e = v x h / GM - r / |r| of positions (..., 3) (km) and velocities (km/s).

    ``h_vec`` = r x v and ``r_km`` = |r| (...,) are computed when not given (callers that have them pass them).
    """
    h = np.cross(r_vec_km, v_vec_kms) if h_vec is None else h_vec
    r = np.linalg.norm(r_vec_km, axis=-1) if r_km is None else r_km
    return np.cross(v_vec_kms, h) / gm_km3_s2 - r_vec_km / r[..., None]


def elements_to_state(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Cartesian state(s) (..., 6) in km, km/s from elements (..., 6) [a, e, i, RAAN, AOP, M] (rad)."""
    el = np.asarray(elements, dtype=float)
    a, e, inc, raan, aop, M = np.moveaxis(el, -1, 0)
    E = solve_kepler(M, e)
    cos_E, sin_E = np.cos(E), np.sin(E)
    sqrt_1me2 = np.sqrt(1.0 - e * e)
    x_pf = a * (cos_E - e)
    y_pf = a * sqrt_1me2 * sin_E
    r = a * (1.0 - e * cos_E)
    n_factor = np.sqrt(gm_km3_s2 * a) / r
    vx_pf = -n_factor * sin_E
    vy_pf = n_factor * sqrt_1me2 * cos_E
    cO, sO, cw, sw, ci, si = (
        np.cos(raan),
        np.sin(raan),
        np.cos(aop),
        np.sin(aop),
        np.cos(inc),
        np.sin(inc),
    )
    p_hat = np.stack([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si], axis=-1)
    q_hat = np.stack([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si], axis=-1)
    r_vec = x_pf[..., None] * p_hat + y_pf[..., None] * q_hat
    v_vec = vx_pf[..., None] * p_hat + vy_pf[..., None] * q_hat
    return np.concatenate([r_vec, v_vec], axis=-1)


def state_to_elements(state: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Osculating elements (..., 6) [a, e, i, RAAN, AOP, M] (km, rad) from states (..., 6).

    RAAN is set to 0 for equatorial orbits and AOP to 0 for circular ones (the conventional
    choice); angles are in [0, 2 pi), inclination in [0, pi]. An orbit that is no longer closed
    (e >= 1, e.g. a satellite escaping after a close pass) has no mean anomaly: M is NaN, a <= 0 or inf.
    """
    s = np.asarray(state, dtype=float)
    r_vec, v_vec = s[..., :3], s[..., 3:]
    r = np.linalg.norm(r_vec, axis=-1)
    v2 = np.sum(v_vec * v_vec, axis=-1)
    h_vec = np.cross(r_vec, v_vec)
    h = np.linalg.norm(h_vec, axis=-1)
    rv = np.sum(r_vec * v_vec, axis=-1)
    e_vec = ((v2 - gm_km3_s2 / r)[..., None] * r_vec - rv[..., None] * v_vec) / gm_km3_s2
    e = np.linalg.norm(e_vec, axis=-1)
    a = vis_viva_sma_km(r, v2, gm_km3_s2)
    inc = np.arccos(np.clip(h_vec[..., 2] / h, -1.0, 1.0))
    node = np.stack([-h_vec[..., 1], h_vec[..., 0], np.zeros_like(h)], axis=-1)
    n_norm = np.linalg.norm(node, axis=-1)
    equatorial = n_norm < 1e-12 * h
    node_hat = np.where(
        equatorial[..., None],
        np.array([1.0, 0.0, 0.0]),
        node / np.where(equatorial, 1.0, n_norm)[..., None],
    )
    raan = np.mod(np.arctan2(node_hat[..., 1], node_hat[..., 0]), TWO_PI)
    h_hat = h_vec / h[..., None]
    circular = e < 1e-12
    e_hat = np.where(circular[..., None], node_hat, e_vec / np.where(circular, 1.0, e)[..., None])
    aop = np.mod(
        np.arctan2(
            np.sum(np.cross(node_hat, e_hat) * h_hat, axis=-1), np.sum(node_hat * e_hat, axis=-1)
        ),
        TWO_PI,
    )
    r_hat = r_vec / r[..., None]
    nu = np.arctan2(np.sum(np.cross(e_hat, r_hat) * h_hat, axis=-1), np.sum(e_hat * r_hat, axis=-1))
    closed = e < 1.0
    M = np.where(
        closed, np.mod(mean_anomaly_from_true(nu, np.where(closed, e, 0.0)), TWO_PI), np.nan
    )
    return np.stack([a, e, inc, raan, aop, M], axis=-1)


def kepler_states(elements: np.ndarray, dt_s: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Two-body states (n, ntime, 6) of elements (n, 6) [a, e, i, RAAN, AOP, M] (km, rad) after ``dt_s`` (ntime,).

    The mean anomaly advances at n = sqrt(GM / a^3); the other elements stay fixed.
    """
    el = np.atleast_2d(np.asarray(elements, dtype=float))
    dt = np.atleast_1d(np.asarray(dt_s, dtype=float))
    series = np.repeat(el[:, None, :], dt.size, axis=1)
    series[..., 5] += np.sqrt(gm_km3_s2 / el[:, None, 0] ** 3) * dt
    return elements_to_state(series, gm_km3_s2)


def orbital_period_s(sma_km, gm_km3_s2: float):
    """Keplerian period (s)."""
    return TWO_PI * np.sqrt(np.asarray(sma_km, dtype=float) ** 3 / gm_km3_s2)
