"""Classical Keplerian elements <-> Cartesian states (pure, vectorised numpy kernels).

Elements are ``(a_km, e, i_rad, raan_rad, aop_rad, M_rad)``, referred to whatever frame the
Cartesian state is in; :func:`lnss_lib.ephemeris.element_frame_to_j2000` supplies the rotation
between the element frame and Moon-centred J2000. Angles are radians here; degree conversion
belongs to the callers that read user input.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidOrbitError

__all__ = ["TWO_PI", "validate_elements", "solve_kepler", "elements_to_state", "state_to_elements",
           "kepler_states", "orbital_period_s"]

TWO_PI = 2.0 * np.pi


def validate_elements(a_km, e, r_body_km: float, min_altitude_km: float = 0.0) -> None:
    """Raise :class:`~lnss_lib.errors.InvalidOrbitError` (a ValueError) naming the bad value if elements are not a
    closed orbit above the surface."""
    a = np.atleast_1d(np.asarray(a_km, dtype=float))
    ecc = np.atleast_1d(np.asarray(e, dtype=float))
    if np.any(~np.isfinite(a)) or np.any(a <= 0.0):
        raise InvalidOrbitError(f"semi-major axis must be positive and finite (km); got {a[(a <= 0) | ~np.isfinite(a)][0]!r}")
    if np.any(~np.isfinite(ecc)) or np.any((ecc < 0.0) | (ecc >= 1.0)):
        bad = ecc[(ecc < 0.0) | (ecc >= 1.0) | ~np.isfinite(ecc)][0]
        raise InvalidOrbitError(f"eccentricity must be in [0, 1) (closed orbits only); got e = {bad!r}")
    perilune = a * (1.0 - ecc)
    floor = r_body_km + min_altitude_km
    if np.any(perilune < floor):
        k = int(np.argmax(perilune < floor))
        raise InvalidOrbitError(
            f"perilune radius a(1-e) = {perilune[k]:.1f} km (a = {a[k]:.1f} km, e = {ecc[k]:.4f}) is below "
            f"{floor:.1f} km (lunar radius {r_body_km} km + minimum altitude {min_altitude_km} km): the orbit hits the Moon"
        )


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
    cO, sO, cw, sw, ci, si = np.cos(raan), np.sin(raan), np.cos(aop), np.sin(aop), np.cos(inc), np.sin(inc)
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
    a = 1.0 / (2.0 / r - v2 / gm_km3_s2)
    inc = np.arccos(np.clip(h_vec[..., 2] / h, -1.0, 1.0))
    node = np.stack([-h_vec[..., 1], h_vec[..., 0], np.zeros_like(h)], axis=-1)
    n_norm = np.linalg.norm(node, axis=-1)
    equatorial = n_norm < 1e-12 * h
    node_hat = np.where(equatorial[..., None], np.array([1.0, 0.0, 0.0]), node / np.where(equatorial, 1.0, n_norm)[..., None])
    raan = np.mod(np.arctan2(node_hat[..., 1], node_hat[..., 0]), TWO_PI)
    h_hat = h_vec / h[..., None]
    circular = e < 1e-12
    e_hat = np.where(circular[..., None], node_hat, e_vec / np.where(circular, 1.0, e)[..., None])
    aop = np.mod(np.arctan2(np.sum(np.cross(node_hat, e_hat) * h_hat, axis=-1), np.sum(node_hat * e_hat, axis=-1)), TWO_PI)
    r_hat = r_vec / r[..., None]
    nu = np.arctan2(np.sum(np.cross(e_hat, r_hat) * h_hat, axis=-1), np.sum(e_hat * r_hat, axis=-1))
    closed = e < 1.0
    E = 2.0 * np.arctan2(np.sqrt(np.where(closed, 1.0 - e, 0.0)) * np.sin(nu / 2.0), np.sqrt(1.0 + e) * np.cos(nu / 2.0))
    M = np.where(closed, np.mod(E - e * np.sin(E), TWO_PI), np.nan)
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


def orbital_period_s(a_km, gm_km3_s2: float):
    """Keplerian period (s)."""
    return TWO_PI * np.sqrt(np.asarray(a_km, dtype=float) ** 3 / gm_km3_s2)
