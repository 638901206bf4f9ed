"""Mean elements by averaging the osculating orbit over one period of dense samples.

What is averaged are vectors, not angles, so nothing is singular at e -> 0 or i -> 0: the
semi-major axis, the eccentricity vector and the unit orbit normal (angular momentum direction).
Mean i and RAAN come from the mean normal, mean e and AOP from the mean eccentricity vector
projected into the mean plane (AOP counted from the mean node), and the mean argument of latitude
u = aop + M from the unwrapped osculating u, whose average is its value at the window centre.
Elements are referred to the profile's element frame (lunar equator of epoch by default):
states in Moon-centred J2000 are rotated with :func:`lnss_lib.ephemeris.element_frame_to_j2000`.

:func:`window_means` is the closed loop's compiled twin of :func:`mean_elements` (one window, J2000 states
rotated inside, the lowest osculating perilune beside), :func:`osculating_elements` that of
:func:`lnss_lib.elements.state_to_elements` for one state: the same arithmetic in another order, so each pair agrees
to rounding (``tests/design_life/test_mean_elements.py`` bounds the difference), not to the bit.
"""

from __future__ import annotations

import numba as nb
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


@nb.njit(cache=True, error_model="numpy")
def window_means(states_mci, rot_el_to_j2000, gm_km3_s2):
    """(:func:`mean_elements` of ``states_mci`` (n, 6) Moon-centred J2000 states over one orbit, rotated into the
    element frame of ``rot_el_to_j2000``; the lowest osculating perilune radius a (1 - e) (km) of the window).

    Each sample's a, e vector (v x h / GM - r / |r|) and unit normal enter the trapezoidal means as in
    :func:`mean_elements`; its osculating u = AOP + M is that of :func:`lnss_lib.elements.state_to_elements`
    (equatorial and circular conventions included). A window with a non-finite state gives NaN throughout.
    """
    n = states_mci.shape[0]
    s = np.empty((n, 6))
    for k in range(n):
        s[k] = _in_element_frame(states_mci[k], rot_el_to_j2000)
    out = np.full(6, np.nan)
    if not np.all(np.isfinite(s)):
        return out, np.nan
    a_sum = 0.0
    e_sum = np.zeros(3)
    h_sum = np.zeros(3)
    u_osc = np.empty(n)
    rp_min = np.inf
    for k in range(n):
        w = 0.5 if k == 0 or k == n - 1 else 1.0
        rx, ry, rz, vx, vy, vz = s[k, 0], s[k, 1], s[k, 2], s[k, 3], s[k, 4], s[k, 5]
        r = np.sqrt(rx * rx + ry * ry + rz * rz)
        v2 = vx * vx + vy * vy + vz * vz
        hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
        h = np.sqrt(hx * hx + hy * hy + hz * hz)
        ex = (vy * hz - vz * hy) / gm_km3_s2 - rx / r
        ey = (vz * hx - vx * hz) / gm_km3_s2 - ry / r
        ez = (vx * hy - vy * hx) / gm_km3_s2 - rz / r
        a = 1.0 / (2.0 / r - v2 / gm_km3_s2)
        a_sum += w * a
        e_sum[0] += w * ex
        e_sum[1] += w * ey
        e_sum[2] += w * ez
        h_sum[0] += w * hx / h
        h_sum[1] += w * hy / h
        h_sum[2] += w * hz / h
        rp = a * (1.0 - np.sqrt(ex * ex + ey * ey + ez * ez))
        if rp < rp_min or rp != rp:  # np.min: a NaN perilune stays
            rp_min = rp
        _, _, _, _, aop, mean_anomaly = _osculating(rx, ry, rz, vx, vy, vz, gm_km3_s2)
        u_osc[k] = aop + mean_anomaly
    u_sum = 0.5 * u_osc[0]
    correction = (
        0.0  # np.unwrap: each jump of the osculating u by more than pi taken as a full turn
    )
    for k in range(1, n):
        step = u_osc[k] - u_osc[k - 1]
        if abs(step) >= np.pi:
            wrapped = np.mod(step + np.pi, TWO_PI) - np.pi
            if wrapped == -np.pi and step > 0.0:
                wrapped = np.pi
            correction += wrapped - step
        u_sum += (0.5 if k == n - 1 else 1.0) * (u_osc[k] + correction)
    total = n - 1.0
    hm = h_sum / total
    hm /= np.sqrt(hm[0] * hm[0] + hm[1] * hm[1] + hm[2] * hm[2])
    em = e_sum / total
    node = np.array([-hm[1], hm[0], 0.0])
    node_norm = np.sqrt(node[0] * node[0] + node[1] * node[1])
    node_hat = node / node_norm if node_norm > 1e-12 else np.array([1.0, 0.0, 0.0])
    e_dot_h = em[0] * hm[0] + em[1] * hm[1] + em[2] * hm[2]
    e_in = em - e_dot_h * hm
    across = np.array(
        [
            hm[1] * node_hat[2] - hm[2] * node_hat[1],
            hm[2] * node_hat[0] - hm[0] * node_hat[2],
            hm[0] * node_hat[1] - hm[1] * node_hat[0],
        ]
    )
    out[0] = a_sum / total
    out[1] = np.sqrt(e_in[0] * e_in[0] + e_in[1] * e_in[1] + e_in[2] * e_in[2])
    out[2] = np.arccos(min(max(hm[2], -1.0), 1.0))
    out[3] = np.mod(np.arctan2(node_hat[1], node_hat[0]), TWO_PI)
    out[4] = np.mod(np.arctan2(np.sum(e_in * across), np.sum(e_in * node_hat)), TWO_PI)
    out[5] = np.mod(u_sum / total, TWO_PI)
    return out, rp_min


@nb.njit(cache=True, error_model="numpy")
def osculating_elements(state_mci, rot_el_to_j2000, gm_km3_s2):
    """Osculating ``[a, e, i, raan, aop, M]`` (6,) (km, rad) of one Moon-centred J2000 state (6,) in the element
    frame of ``rot_el_to_j2000``: the compiled twin of :func:`lnss_lib.elements.state_to_elements` (its
    equatorial and circular conventions; M NaN when e >= 1), equal to it to rounding."""
    x = _in_element_frame(state_mci, rot_el_to_j2000)
    return np.array(_osculating(x[0], x[1], x[2], x[3], x[4], x[5], gm_km3_s2))


@nb.njit(cache=True, error_model="numpy")
def _in_element_frame(state_mci, rot_el_to_j2000):
    """One Moon-centred J2000 state (6,) in the element frame: r and v times ``rot_el_to_j2000`` (element frame
    -> J2000) from the left, as :func:`to_element_frame` (each entry summed in the same order)."""
    x = np.empty(6)
    for j in range(3):
        x[j] = (
            state_mci[0] * rot_el_to_j2000[0, j]
            + state_mci[1] * rot_el_to_j2000[1, j]
            + state_mci[2] * rot_el_to_j2000[2, j]
        )
        x[3 + j] = (
            state_mci[3] * rot_el_to_j2000[0, j]
            + state_mci[4] * rot_el_to_j2000[1, j]
            + state_mci[5] * rot_el_to_j2000[2, j]
        )
    return x


@nb.njit(cache=True, error_model="numpy")
def _osculating(rx, ry, rz, vx, vy, vz, gm_km3_s2):
    """(a, e, i, raan, aop, M) of one state as :func:`lnss_lib.elements.state_to_elements` gives them."""
    r = np.sqrt(rx * rx + ry * ry + rz * rz)
    v2 = vx * vx + vy * vy + vz * vz
    hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    h = np.sqrt(hx * hx + hy * hy + hz * hz)
    rv = rx * vx + ry * vy + rz * vz
    c = v2 - gm_km3_s2 / r
    ex = (c * rx - rv * vx) / gm_km3_s2
    ey = (c * ry - rv * vy) / gm_km3_s2
    ez = (c * rz - rv * vz) / gm_km3_s2
    e = np.sqrt(ex * ex + ey * ey + ez * ez)
    a = 1.0 / (2.0 / r - v2 / gm_km3_s2)
    inc = np.arccos(min(max(hz / h, -1.0), 1.0))
    nx, ny = -hy, hx
    n_norm = np.sqrt(nx * nx + ny * ny)
    if n_norm < 1e-12 * h:
        nx, ny = 1.0, 0.0
    else:
        nx, ny = nx / n_norm, ny / n_norm
    raan = np.mod(np.arctan2(ny, nx), TWO_PI)
    if e < 1e-12:
        ux, uy, uz = nx, ny, 0.0
    else:
        ux, uy, uz = ex / e, ey / e, ez / e
    kx, ky, kz = hx / h, hy / h, hz / h
    aop = np.mod(
        np.arctan2((ny * uz) * kx + (-nx * uz) * ky + (nx * uy - ny * ux) * kz, nx * ux + ny * uy),
        TWO_PI,
    )
    px, py, pz = rx / r, ry / r, rz / r
    cx, cy, cz = uy * pz - uz * py, uz * px - ux * pz, ux * py - uy * px
    nu = np.arctan2(cx * kx + cy * ky + cz * kz, ux * px + uy * py + uz * pz)
    if not e < 1.0:
        return a, e, inc, raan, aop, np.nan
    big_e = 2.0 * np.arctan2(
        np.sqrt(1.0 - e) * np.sin(nu / 2.0), np.sqrt(1.0 + e) * np.cos(nu / 2.0)
    )
    return a, e, inc, raan, aop, np.mod(big_e - e * np.sin(big_e), TWO_PI)


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
