"""Mean elements by averaging the osculating orbit over one period of dense samples.

What is averaged are vectors, not angles, so nothing is singular at e -> 0 or i -> 0: the
semi-major axis, the eccentricity vector and the unit orbit normal (angular momentum direction).
Mean i and RAAN come from the mean normal, mean e and AOP from the mean eccentricity vector
projected into the mean plane (AOP counted from the mean node), and the mean argument of latitude
u = aop + M from the unwrapped osculating u, whose average is its value at the window centre.
Elements are referred to the profile's element frame (lunar equator of epoch by default):
states in Moon-centred J2000 are rotated with :func:`lnss_lib.ephemeris.element_frame_to_j2000`.
"""

from __future__ import annotations

import numpy as np

from ..elements import TWO_PI, eccentricity_vector, state_to_elements, vis_viva_sma_km

MEAN_ELEMENTS = ("a_km", "e", "inc_rad", "raan_rad", "aop_rad", "u_rad")
"""Columns of :func:`mean_elements`: u is the mean argument of latitude aop + M."""


def to_element_frame(states_mci: np.ndarray, rot_el_to_j2000: np.ndarray) -> np.ndarray:
    """States (..., 6) rotated from Moon-centred J2000 into the element frame (x_el = R^T x_j2000)."""
    s = np.asarray(states_mci, dtype=float)
    rot = np.asarray(rot_el_to_j2000, dtype=float)
    return np.concatenate([s[..., :3] @ rot, s[..., 3:6] @ rot], axis=-1)


def mean_elements(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Mean ``[sma_km, e, i, raan, aop, u]`` (..., 6) (rad) of states (..., n, 6) spanning one orbit.

    The n samples (along axis -2) must be equally spaced in time and cover one orbital period
    (first and last sample one period apart count once each half: trapezoidal weights).
    """
    s = np.asarray(states, dtype=float)
    if s.ndim < 2 or s.shape[-1] != 6 or s.shape[-2] < 8:
        raise ValueError(f"states must have shape (..., n >= 8, 6) over one orbit; got {s.shape}")
    n = s.shape[-2]
    w = np.ones(n)
    w[0] = w[-1] = 0.5
    w /= w.sum()
    r_vec, v_vec = s[..., :3], s[..., 3:6]
    r = np.linalg.norm(r_vec, axis=-1, keepdims=True)
    v2 = np.sum(v_vec * v_vec, axis=-1, keepdims=True)
    h_vec = np.cross(r_vec, v_vec)
    e_vec = eccentricity_vector(r_vec, v_vec, gm_km3_s2, h_vec, r[..., 0])
    a = vis_viva_sma_km(r[..., 0], v2[..., 0], gm_km3_s2)
    h_hat = h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)
    a_mean = np.einsum("...n,n->...", a, w)
    e_mean = np.einsum("...nk,n->...k", e_vec, w)
    h_mean = np.einsum("...nk,n->...k", h_hat, w)
    h_mean /= np.linalg.norm(h_mean, axis=-1, keepdims=True)
    inc = np.arccos(np.clip(h_mean[..., 2], -1.0, 1.0))
    node = np.stack([-h_mean[..., 1], h_mean[..., 0], np.zeros_like(inc)], axis=-1)
    node_norm = np.linalg.norm(node, axis=-1, keepdims=True)
    node_hat = np.where(
        node_norm > 1e-12, node / np.where(node_norm > 1e-12, node_norm, 1.0), np.array([1.0, 0, 0])
    )
    raan = np.mod(np.arctan2(node_hat[..., 1], node_hat[..., 0]), TWO_PI)
    e_in = e_mean - np.sum(e_mean * h_mean, axis=-1, keepdims=True) * h_mean
    ecc = np.linalg.norm(e_in, axis=-1)
    across = np.cross(h_mean, node_hat)
    aop = np.mod(
        np.arctan2(np.sum(e_in * across, axis=-1), np.sum(e_in * node_hat, axis=-1)), TWO_PI
    )
    osc = state_to_elements(s, gm_km3_s2)
    u_osc = np.unwrap(osc[..., 4] + osc[..., 5], axis=-1)
    u_mean = np.mod(np.einsum("...n,n->...", u_osc, w), TWO_PI)
    out = np.stack([a_mean, ecc, inc, raan, aop, u_mean], axis=-1)
    return np.where(np.all(np.isfinite(s), axis=(-2, -1))[..., None], out, np.nan)


def wrap_pi(angle_rad):
    """Angle(s) wrapped to [-pi, pi)."""
    return np.mod(np.asarray(angle_rad, dtype=float) + np.pi, TWO_PI) - np.pi


def circular_mean(angle_rad, axis=-1):
    """Mean direction of angles (rad), in [-pi, pi); NaNs ignored (0 when all are NaN)."""
    ang = np.asarray(angle_rad, dtype=float)
    return np.arctan2(np.nansum(np.sin(ang), axis=axis), np.nansum(np.cos(ang), axis=axis))


def relative_angles(
    angle_rad: np.ndarray, nominal_rad: np.ndarray, active: np.ndarray | None = None
) -> np.ndarray:
    """Angle minus its nominal value minus the circular mean of that difference over the satellites
    (``active`` ones only), wrapped to [-pi, pi): each satellite's offset from its slot when the common
    motion of the whole constellation (RAAN precession, mean along-track motion) is left free."""
    diff = wrap_pi(np.asarray(angle_rad, dtype=float) - np.asarray(nominal_rad, dtype=float))
    use = diff if active is None else np.where(active, diff, np.nan)
    return wrap_pi(diff - circular_mean(use))
