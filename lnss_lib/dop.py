"""South-pole surface grid, visibility and dilution of precision (paper Section 2.1, eq. 1-14).

Conventions: satellite positions ``r_mf_km`` (sat, time, 3) are in the Moon-fixed frame
(``frames.moon_fixed``, MOON_ME) in km; the receivers sit on the mean lunar sphere
(``constants.r_moon_mean_km``) at fixed selenographic latitude/longitude; times are TDB seconds
past J2000.

Kernel (:func:`dop_kernel`): elevation from the local vertical, visibility with the mask
(eq. 3-4), and the geometry matrix G = [l_hat, 1] of eq. 5 accumulated as H = G^T G over the
visible satellites only (invisible rows are zeroed, which leaves H exactly that of the visible
set). The position block of H^-1 (eq. 6) is the inverse of the clock's Schur complement
S = sum (l - l_mean)(l - l_mean)^T over the visible satellites, inverted in closed form for every
time x grid sample at once (:mod:`lnss_lib.geometry`, shared with the GPS link). PDOP and HDOP (eq. 7-8) come from its diagonal; HDOP takes the line-of-sight
axes either as the Moon-fixed x, y (``"moon_fixed"``, the paper's literal eq. 5-8) or as the
local East and North (``"enu"``, the physically horizontal error). PDOP is the same in both.
Samples with fewer than 4 visible satellites have no DOP (NaN).

The receivers' grid is :class:`~lnss_lib.surface_grid.SurfaceGrid` (built by
:func:`~lnss_lib.surface_grid.surface_grid`).

Statistics (:func:`dop_summary`): 3-sigma filtered means (eq. 9-13) over the samples that have a
DOP, availability (eq. 14) over all grid-epoch samples (no DOP counts as unavailable), mean
visible satellites; optionally area-weighted.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba as nb
import numpy as np
import xarray as xr

from .constants import MIN_VISIBLE
from .frames import rotate_to_moon_fixed
from .geometry import (
    availability_pct,
    block_inverse,
    normal_matrix_entries,
    position_block_inverse,
    sigma_filtered_mean,
    weighted_dop_stats,
)
from .sections import LOS_AXES
from .surface_grid import SurfaceGrid

if TYPE_CHECKING:
    from .settings import DopSettings, Dynamics

__all__ = [
    "elevation_deg",
    "dop_kernel",
    "check_positions",
    "dop_arrays",
    "dop_and_error_arrays",
    "dop_metrics",
    "array_metrics",
    "metrics_for_settings",
    "metrics_and_errors_for_settings",
    "dop_grid",
    "dop_summary",
    "dop_for_settings",
    "dop_from_propagation",
    "summary_for_settings",
]


def check_positions(r_mf_km) -> np.ndarray:
    """``r_mf_km`` as a float array of shape (sat, time, 3); ``ValueError`` naming the shape otherwise."""
    r = np.asarray(r_mf_km, dtype=float)
    if r.ndim != 3 or r.shape[2] != 3:
        raise ValueError(f"r_mf_km must have shape (sat, time, 3) in km; got shape {r.shape}")
    return r


def elevation_deg(r_mf_km, grid: SurfaceGrid) -> np.ndarray:
    """Elevation (deg) of each satellite above each receiver's local horizon, (sat, time, nlat, nlon).

    Satellites with non-finite positions get NaN.
    """
    r = check_positions(r_mf_km)
    d = r[:, :, None, None, :] - grid.r_mf_km[None, None, :, :, :]
    rho = np.linalg.norm(d, axis=-1)
    sin_el = np.sum(d * grid.up[None, None], axis=-1) / rho
    return np.degrees(np.arcsin(np.clip(sin_el, -1.0, 1.0)))


def dop_kernel(
    r_mf_km: np.ndarray,
    r_grid_km: np.ndarray,
    up: np.ndarray,
    elevation_mask_deg: float = 5.0,
    los_axes: str = "moon_fixed",
    time_chunk: int = 32,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Visible count, PDOP and HDOP for every epoch and receiver (eq. 3-8), each (time, npoint).

    ``r_mf_km`` (sat, time, 3) satellite positions, ``r_grid_km`` (npoint, 3) receivers and ``up``
    (npoint, 3) their local vertical, all in Moon-fixed axes (km). A satellite is visible when its
    elevation is >= the mask (eq. 3); non-finite positions are never visible. PDOP/HDOP are NaN
    with fewer than 4 visible satellites and +inf for a singular geometry. ``los_axes`` picks the
    HDOP axes: ``moon_fixed`` (x, y of the Moon-fixed frame) or ``enu`` (local East, North).
    Work proceeds in blocks of ``time_chunk`` epochs to stay in cache.
    """
    if los_axes not in LOS_AXES:
        raise ValueError(f"unknown line-of-sight axes {los_axes!r}; allowed: {', '.join(LOS_AXES)}")
    if not np.isfinite(elevation_mask_deg) or not -90.0 <= elevation_mask_deg < 90.0:
        raise ValueError(f"elevation mask must be in [-90, 90) deg; got {elevation_mask_deg!r}")
    r = check_positions(r_mf_km)
    r = np.where(np.isfinite(r).all(axis=-1, keepdims=True), r, 0.0)
    g = np.asarray(r_grid_km, dtype=float)
    u = np.asarray(up, dtype=float)
    nsat, ntime, _ = r.shape
    npt = g.shape[0]
    sin_mask = np.sin(np.radians(elevation_mask_deg))
    n_visible = np.empty((ntime, npt), dtype=np.int16)
    pdop = np.empty((ntime, npt))
    hdop = np.empty((ntime, npt))
    gx, gy, gz = (g[:, k] for k in range(3))
    ux, uy, uz = (u[:, k] for k in range(3))
    for t0 in range(0, ntime, max(int(time_chunk), 1)):
        t1 = min(t0 + max(int(time_chunk), 1), ntime)
        block = r[:, t0:t1]
        dx = block[:, :, 0, None] - gx
        dy = block[:, :, 1, None] - gy
        dz = block[:, :, 2, None] - gz
        inv_rho = 1.0 / np.maximum(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-9)
        dx *= inv_rho
        dy *= inv_rho
        dz *= inv_rho
        visible = (dx * ux + dy * uy + dz * uz) >= sin_mask
        n, entries = normal_matrix_entries(dx, dy, dz, visible, axis=0)
        ixx, iyy, izz, ixy, ixz, iyz, ok = position_block_inverse(*entries)
        trace = ixx + iyy + izz
        if los_axes == "moon_fixed":
            horizontal = ixx + iyy
        else:
            vertical = (
                ux * ux * ixx
                + uy * uy * iyy
                + uz * uz * izz
                + 2.0 * (ux * uy * ixy + ux * uz * ixz + uy * uz * iyz)
            )
            horizontal = trace - vertical
        enough = n >= MIN_VISIBLE
        n_visible[t0:t1] = n
        pdop[t0:t1] = np.where(
            enough, np.where(ok, np.sqrt(np.maximum(trace, 0.0)), np.inf), np.nan
        )
        hdop[t0:t1] = np.where(
            enough, np.where(ok, np.sqrt(np.maximum(horizontal, 0.0)), np.inf), np.nan
        )
    return n_visible, pdop, hdop


@nb.njit(cache=True)
def _vertical_variance(ux, uy, uz, ixx, iyy, izz, ixy, ixz, iyz):
    """u^T S^-1 u: the variance along the local vertical ``u`` of a position covariance given by its six entries."""
    return (
        ux * ux * ixx
        + uy * uy * iyy
        + uz * uz * izz
        + 2.0 * (ux * uy * ixy + ux * uz * ixz + uy * uz * iyz)
    )


@nb.njit(cache=True)
def _grid_kernel(
    r, gx, gy, gz, ux, uy, uz, sin_mask, enu, n_visible, pdop, hdop, var_m2, b2_m2, sigma_h, sigma_v
):
    """:func:`dop_kernel`'s arithmetic on ``r`` (time, sat, 3), one epoch at a time: lines of sight and
    visibility (sat, point), the centred normal matrix in two passes weighted by visibility (as
    :func:`lnss_lib.geometry.normal_matrix_entries`) and its inverse
    (:func:`lnss_lib.geometry.block_inverse`); the loops over points are independent and vectorise.

    With a non-empty ``var_m2`` (time, sat) the same lines of sight also build the weighted normal matrix of
    the position error (:func:`_weighted_normal_sums`), whose inverse is the position covariance (m^2):
    ``sigma_h`` and ``sigma_v`` (time, point) take its horizontal (local East and North) and vertical 1-sigma
    (:func:`_horizontal_vertical`). The DOP outputs are the same bits either way.
    """
    ntime, nsat, _ = r.shape
    npt = gx.shape[0]
    weighted = var_m2.shape[1] > 0
    lx = np.empty((nsat, npt))
    ly = np.empty((nsat, npt))
    lz = np.empty((nsat, npt))
    wv = np.empty((nsat, npt))
    count = np.empty(npt)
    mx = np.empty(npt)
    my = np.empty(npt)
    mz = np.empty(npt)
    s = np.empty((6, npt))
    qv = np.empty((nsat, npt))
    qm = np.empty((4, npt))
    q = np.empty((6, npt))
    for t in range(ntime):
        count[:] = 0.0
        mx[:] = 0.0
        my[:] = 0.0
        mz[:] = 0.0
        for k in range(nsat):
            rx, ry, rz = r[t, k, 0], r[t, k, 1], r[t, k, 2]
            lxk, lyk, lzk, wk = lx[k], ly[k], lz[k], wv[k]
            for p in range(npt):
                dx = rx - gx[p]
                dy = ry - gy[p]
                dz = rz - gz[p]
                inv_rho = 1.0 / max(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-9)
                dx *= inv_rho
                dy *= inv_rho
                dz *= inv_rho
                w = 1.0 if dx * ux[p] + dy * uy[p] + dz * uz[p] >= sin_mask else 0.0
                lxk[p] = dx
                lyk[p] = dy
                lzk[p] = dz
                wk[p] = w
                count[p] += w
                mx[p] += w * dx
                my[p] += w * dy
                mz[p] += w * dz
        for p in range(npt):
            inv = 1.0 / max(count[p], 1.0)
            mx[p] *= inv
            my[p] *= inv
            mz[p] *= inv
        s[:, :] = 0.0
        for k in range(nsat):
            lxk, lyk, lzk, wk = lx[k], ly[k], lz[k], wv[k]
            for p in range(npt):
                x = (lxk[p] - mx[p]) * wk[p]
                y = (lyk[p] - my[p]) * wk[p]
                z = (lzk[p] - mz[p]) * wk[p]
                s[0, p] += x * x
                s[1, p] += y * y
                s[2, p] += z * z
                s[3, p] += x * y
                s[4, p] += x * z
                s[5, p] += y * z
        if weighted:
            _weighted_normal_sums(lx, ly, lz, wv, ux, uy, uz, var_m2[t], b2_m2, qv, qm, q)
        for p in range(npt):
            n = count[p]
            n_visible[t, p] = int(n)
            if weighted:
                sigma_h[t, p], sigma_v[t, p] = _horizontal_vertical(
                    n, q[0, p], q[1, p], q[2, p], q[3, p], q[4, p], q[5, p], ux[p], uy[p], uz[p]
                )
            if n < MIN_VISIBLE:
                pdop[t, p] = np.nan
                hdop[t, p] = np.nan
                continue
            ixx, iyy, izz, ixy, ixz, iyz, ok = block_inverse(
                s[0, p], s[1, p], s[2, p], s[3, p], s[4, p], s[5, p]
            )
            if not ok:
                pdop[t, p] = np.inf
                hdop[t, p] = np.inf
                continue
            trace = ixx + iyy + izz
            if enu:
                vertical = _vertical_variance(ux[p], uy[p], uz[p], ixx, iyy, izz, ixy, ixz, iyz)
                horizontal = trace - vertical
            else:
                horizontal = ixx + iyy
            pdop[t, p] = np.sqrt(max(trace, 0.0))
            hdop[t, p] = np.sqrt(max(horizontal, 0.0))


@nb.njit(cache=True)
def _weighted_normal_sums(lx, ly, lz, visible, ux, uy, uz, var_m2, b2_m2, qv, qm, q):
    """Entries ``q`` (6, point) of the weighted least-squares normal matrix with the clock eliminated,
    S_w = sum_k q_k (l_k - l_w)(l_k - l_w)^T, l_w = sum_k q_k l_k / sum_k q_k, over the visible satellites:
    satellite k at a point weighs q_k = 1 / (``var_m2[k]`` + ``b2_m2`` / sin^2(elevation)), its user range
    error variance (m^2). With every q_k = 1 this is the DOP's S (eq. 5-6). ``qv`` (sat, point) and ``qm``
    (4, point) are work arrays; the lines of sight ``lx``, ``ly``, ``lz`` and the 0/1 ``visible`` (sat, point)
    are those of the DOP pass."""
    nsat, npt = lx.shape
    qm[:, :] = 0.0
    for k in range(nsat):
        lxk, lyk, lzk, wk, qk = lx[k], ly[k], lz[k], visible[k], qv[k]
        var_k = var_m2[k]
        for p in range(npt):
            sin2 = lxk[p] * ux[p] + lyk[p] * uy[p] + lzk[p] * uz[p]
            sin2 *= sin2
            qw = (
                wk[p] * sin2 / max(var_k * sin2 + b2_m2, 1e-300)
            )  # 1 / (var + b2 / sin^2), one division
            qk[p] = qw
            qm[0, p] += qw
            qm[1, p] += qw * lxk[p]
            qm[2, p] += qw * lyk[p]
            qm[3, p] += qw * lzk[p]
    for p in range(npt):
        inv = 1.0 / qm[0, p] if qm[0, p] > 0.0 else 0.0
        qm[1, p] *= inv
        qm[2, p] *= inv
        qm[3, p] *= inv
    q[:, :] = 0.0
    for k in range(nsat):
        lxk, lyk, lzk, qk = lx[k], ly[k], lz[k], qv[k]
        for p in range(npt):
            qw = qk[p]
            x = lxk[p] - qm[1, p]
            y = lyk[p] - qm[2, p]
            z = lzk[p] - qm[3, p]
            q[0, p] += qw * x * x
            q[1, p] += qw * y * y
            q[2, p] += qw * z * z
            q[3, p] += qw * x * y
            q[4, p] += qw * x * z
            q[5, p] += qw * y * z


@nb.njit(cache=True)
def _horizontal_vertical(n, sxx, syy, szz, sxy, sxz, syz, ux, uy, uz):
    """(horizontal, vertical) 1-sigma of S^-1 (S given by its six entries, ``n`` visible satellites) about the
    local vertical ``u``: NaN with fewer than :data:`MIN_VISIBLE`, +inf when S is singular."""
    if n < MIN_VISIBLE:
        return np.nan, np.nan
    ixx, iyy, izz, ixy, ixz, iyz, ok = block_inverse(sxx, syy, szz, sxy, sxz, syz)
    if not ok:
        return np.inf, np.inf
    vertical = _vertical_variance(ux, uy, uz, ixx, iyy, izz, ixy, ixz, iyz)
    return np.sqrt(max(ixx + iyy + izz - vertical, 0.0)), np.sqrt(max(vertical, 0.0))


def dop_arrays(
    r_mf_km, r_grid_km, up, elevation_mask_deg: float = 5.0, los_axes: str = "moon_fixed"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`dop_kernel`'s (n_visible, pdop, hdop), each (time, npoint), from one compiled pass.

    Same conventions and inputs as :func:`dop_kernel`; the results agree with it to rounding (the
    visible lines of sight are summed in the same order; ``tests/test_dop.py`` checks the agreement).
    """
    return dop_and_error_arrays(r_mf_km, r_grid_km, up, elevation_mask_deg, los_axes)[:3]


def dop_and_error_arrays(
    r_mf_km,
    r_grid_km,
    up,
    elevation_mask_deg: float = 5.0,
    los_axes: str = "moon_fixed",
    uere_var_m2=None,
    multipath_zenith_m: float = 0.0,
) -> tuple[np.ndarray, ...]:
    """(n_visible, pdop, hdop, sigma_h_m, sigma_v_m), each (time, npoint), from one compiled pass.

    The first three are :func:`dop_arrays`'s. With ``uere_var_m2`` (sat, time), each satellite's user range
    error variance (m^2) apart from the lunar-surface multipath, the weighted least-squares position error
    of the same fix: satellite k weighs 1 / sigma_k^2, sigma_k^2 = ``uere_var_m2`` + (``multipath_zenith_m`` /
    sin(elevation))^2, and ``sigma_h_m`` / ``sigma_v_m`` are the horizontal (local East and North) and
    vertical 1-sigma of the covariance (sum_k g_k g_k^T / sigma_k^2)^-1 (NaN with fewer than 4 visible, +inf
    for a singular geometry). With every sigma_k equal to sigma they are sigma x HDOP and sigma x VDOP in
    East-North-Up axes. Without ``uere_var_m2`` the last two are None.
    """
    if los_axes not in LOS_AXES:
        raise ValueError(f"unknown line-of-sight axes {los_axes!r}; allowed: {', '.join(LOS_AXES)}")
    if not np.isfinite(elevation_mask_deg) or not -90.0 <= elevation_mask_deg < 90.0:
        raise ValueError(f"elevation mask must be in [-90, 90) deg; got {elevation_mask_deg!r}")
    r = check_positions(r_mf_km)
    r = np.ascontiguousarray(
        np.where(np.isfinite(r).all(axis=-1, keepdims=True), r, 0.0).transpose(1, 0, 2)
    )
    g = np.asarray(r_grid_km, dtype=float).reshape(-1, 3)
    u = np.asarray(up, dtype=float).reshape(-1, 3)
    ntime, nsat, npt = r.shape[0], r.shape[1], g.shape[0]
    if uere_var_m2 is None:
        var = np.empty((ntime, 0))
    else:
        var = np.ascontiguousarray(np.asarray(uere_var_m2, dtype=float).T)
        if var.shape != (ntime, nsat) or not np.all(var > 0.0) or not np.all(np.isfinite(var)):
            raise ValueError(
                f"uere_var_m2 must be positive and finite with shape (sat, time) = ({nsat}, {ntime}); "
                f"got shape {var.T.shape}"
            )
    if not np.isfinite(multipath_zenith_m) or multipath_zenith_m < 0.0:
        raise ValueError(
            f"multipath_zenith_m must be a finite number >= 0 (m); got {multipath_zenith_m!r}"
        )
    n_visible = np.full(
        (ntime, npt), -1, dtype=np.int16
    )  # -1: not computed (checked after the kernel)
    pdop = np.full((ntime, npt), np.nan)
    hdop = np.full((ntime, npt), np.nan)
    sigma_h = np.full((ntime, npt if var.shape[1] else 0), np.nan)
    sigma_v = np.full_like(sigma_h, np.nan)
    _grid_kernel(
        r,
        *(np.ascontiguousarray(g[:, k]) for k in range(3)),
        *(np.ascontiguousarray(u[:, k]) for k in range(3)),
        float(np.sin(np.radians(elevation_mask_deg))),
        los_axes == "enu",
        n_visible,
        pdop,
        hdop,
        var,
        float(multipath_zenith_m) ** 2,
        sigma_h,
        sigma_v,
    )
    if np.any(n_visible < 0):
        raise RuntimeError(
            f"the DOP grid kernel left {int(np.sum(n_visible < 0))} of {n_visible.size} "
            "(epoch, point) samples not computed"
        )
    if uere_var_m2 is None:
        return n_visible, pdop, hdop, None, None
    return n_visible, pdop, hdop, sigma_h, sigma_v


def dop_metrics(
    r_mf_km,
    grid: SurfaceGrid,
    *,
    elevation_mask_deg: float = 5.0,
    los_axes: str = "moon_fixed",
    threshold: float = 15.0,
    n_sigma: float = 3.0,
    weighted: bool = True,
) -> dict[str, float]:
    """:func:`dop_summary` of :func:`dop_grid` without the Dataset: the campaign's path (compiled grid
    pass :func:`dop_arrays` and compiled statistics :func:`lnss_lib.geometry.weighted_dop_stats`).

    Same keys; agrees with ``dop_summary(dop_grid(...))`` to summation rounding (~1e-13 relative).
    """
    n_visible, pdop, hdop = dop_arrays(r_mf_km, grid.r_mf_km, grid.up, elevation_mask_deg, los_axes)
    w = grid.weight.reshape(-1) if weighted else np.ones(grid.n_points)
    return array_metrics(n_visible, pdop, hdop, w, threshold, n_sigma)


def array_metrics(n_visible, pdop, hdop, w, threshold: float, n_sigma: float) -> dict[str, float]:
    """:func:`dop_metrics` of the grid pass's (time, point) arrays with sample weights ``w`` (point,)."""
    w_total = float(np.sum(w)) * pdop.shape[0]
    p_mean, p_kept, p_raw, p_avail = weighted_dop_stats(pdop, w, float(n_sigma), float(threshold))
    h_mean, h_kept, h_raw, h_avail = weighted_dop_stats(hdop, w, float(n_sigma), float(threshold))
    with np.errstate(invalid="ignore"):
        both = (pdop < threshold) & (hdop < threshold)
    return {
        "mean_visible_sats": float(np.sum(n_visible @ w) / w_total),
        "pdop_mean_3sigma": float(p_mean),
        "hdop_mean_3sigma": float(h_mean),
        "pdop_mean_raw": float(p_raw),
        "hdop_mean_raw": float(h_raw),
        "pdop_avail_pct": float(p_avail),
        "hdop_avail_pct": float(h_avail),
        "availability_pct": min(100.0, float(100.0 * np.sum(both @ w) / w_total)),
        "fewer_than_4_pct": float(100.0 * np.sum((n_visible < MIN_VISIBLE) @ w) / w_total),
        "n_samples": int(pdop.size),
        "pdop_kept": int(p_kept),
        "hdop_kept": int(h_kept),
    }


def metrics_for_settings(dop: DopSettings, r_mf_km, grid: SurfaceGrid) -> dict[str, float]:
    """:func:`dop_metrics` on ``grid`` with the mask, LOS axes, threshold and filter width of ``[dop]``."""
    return dop_metrics(
        r_mf_km,
        grid,
        elevation_mask_deg=dop.elevation_mask_deg,
        los_axes=dop.los_axes,
        threshold=dop.availability_threshold,
        n_sigma=dop.filter_sigma,
    )


def metrics_and_errors_for_settings(
    dop: DopSettings, r_mf_km, grid: SurfaceGrid, uere_var_m2, multipath_zenith_m: float
) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """(:func:`metrics_for_settings`, sigma_h_m, sigma_v_m): the DOP metrics (the same bits) and the weighted
    position errors (time, point) of :func:`dop_and_error_arrays`, from one compiled pass."""
    n_visible, pdop, hdop, sigma_h, sigma_v = dop_and_error_arrays(
        r_mf_km,
        grid.r_mf_km,
        grid.up,
        dop.elevation_mask_deg,
        dop.los_axes,
        uere_var_m2,
        multipath_zenith_m,
    )
    stats = array_metrics(
        n_visible, pdop, hdop, grid.weight.reshape(-1), dop.availability_threshold, dop.filter_sigma
    )
    return stats, sigma_h, sigma_v


def dop_grid(
    r_mf_km,
    grid: SurfaceGrid,
    *,
    t_tdb_s=None,
    elevation_mask_deg: float = 5.0,
    los_axes: str = "moon_fixed",
) -> xr.Dataset:
    """Visibility and DOP over the grid (eq. 3-8) as a Dataset with dims (time, lat, lon).

    Variables ``n_visible``, ``pdop``, ``hdop`` (NaN where fewer than 4 visible) and ``weight``
    (lat, lon); coordinate ``time`` in TDB seconds past J2000 (``t_tdb_s``, default 0..n-1).
    """
    r = check_positions(r_mf_km)
    ntime = r.shape[1]
    times = np.arange(ntime, dtype=float) if t_tdb_s is None else np.asarray(t_tdb_s, dtype=float)
    if times.shape != (ntime,):
        raise ValueError(
            f"t_tdb_s must have one entry per epoch ({ntime}); got shape {times.shape}"
        )
    nlat, nlon = grid.shape
    n_visible, pdop, hdop = dop_kernel(
        r, grid.r_mf_km.reshape(-1, 3), grid.up.reshape(-1, 3), elevation_mask_deg, los_axes
    )
    dims = ("time", "lat", "lon")
    ds = xr.Dataset(
        {
            "n_visible": (dims, n_visible.reshape(ntime, nlat, nlon)),
            "pdop": (dims, pdop.reshape(ntime, nlat, nlon)),
            "hdop": (dims, hdop.reshape(ntime, nlat, nlon)),
            "weight": (("lat", "lon"), grid.weight),
        },
        coords={"time": times, "lat": grid.lat_deg, "lon": grid.lon_deg},
        attrs={
            "frame": "Moon-fixed (receivers fixed on the mean lunar sphere)",
            "time_scale": "TDB seconds past J2000",
            "radius_km": grid.radius_km,
            "elevation_mask_deg": float(elevation_mask_deg),
            "los_axes": los_axes,
            "area_weighting": grid.weighting,
            "min_visible": MIN_VISIBLE,
        },
    )
    ds["n_visible"].attrs["long_name"] = "visible satellites (eq. 4)"
    ds["pdop"].attrs["long_name"] = "PDOP (eq. 7), NaN with fewer than 4 visible"
    ds["hdop"].attrs["long_name"] = (
        f"HDOP (eq. 8) in {los_axes} axes, NaN with fewer than 4 visible"
    )
    ds["lat"].attrs["units"] = "deg"
    ds["lon"].attrs["units"] = "deg"
    return ds


def dop_summary(
    ds: xr.Dataset, *, threshold: float = 15.0, n_sigma: float = 3.0, weighted: bool = True
) -> dict[str, float]:
    """Scalar metrics of a :func:`dop_grid` Dataset (eq. 9-14).

    ``pdop_mean_3sigma``, ``hdop_mean_3sigma`` (filtered means over samples with a DOP),
    ``pdop_mean_raw``, ``hdop_mean_raw``, ``pdop_avail_pct``, ``hdop_avail_pct``,
    ``availability_pct`` (both below threshold), ``mean_visible_sats``, ``fewer_than_4_pct``,
    ``n_samples``, ``pdop_kept``, ``hdop_kept``. With ``weighted`` the Dataset's ``weight``
    (uniform unless an area weighting was chosen) weights every sample.
    """
    weights = ds["weight"].broadcast_like(ds["pdop"]).values if weighted else None
    pdop = ds["pdop"].values
    hdop = ds["hdop"].values
    nvis = ds["n_visible"].values.astype(float)
    w = np.ones_like(pdop) if weights is None else weights
    pdop_mean, pdop_kept = sigma_filtered_mean(pdop, w, n_sigma)
    hdop_mean, hdop_kept = sigma_filtered_mean(hdop, w, n_sigma)
    fin_p, fin_h = np.isfinite(pdop), np.isfinite(hdop)
    with np.errstate(invalid="ignore"):
        both = (pdop < threshold) & (hdop < threshold)
    return {
        "mean_visible_sats": float(np.sum(w * nvis) / np.sum(w)),
        "pdop_mean_3sigma": pdop_mean,
        "hdop_mean_3sigma": hdop_mean,
        "pdop_mean_raw": float(np.sum(w[fin_p] * pdop[fin_p]) / np.sum(w[fin_p]))
        if fin_p.any()
        else float("nan"),
        "hdop_mean_raw": float(np.sum(w[fin_h] * hdop[fin_h]) / np.sum(w[fin_h]))
        if fin_h.any()
        else float("nan"),
        "pdop_avail_pct": availability_pct(pdop, threshold, w),
        "hdop_avail_pct": availability_pct(hdop, threshold, w),
        "availability_pct": min(100.0, float(100.0 * np.sum(w * both) / np.sum(w))),
        "fewer_than_4_pct": float(100.0 * np.sum(w * (nvis < MIN_VISIBLE)) / np.sum(w)),
        "n_samples": int(pdop.size),
        "pdop_kept": pdop_kept,
        "hdop_kept": hdop_kept,
    }


def dop_for_settings(
    dop: DopSettings, r_mf_km, t_tdb_s, grid: SurfaceGrid, *, los_axes: str | None = None
) -> xr.Dataset:
    """:func:`dop_grid` on ``grid`` with the mask and LOS axes of ``[dop]`` (the axes overridable)."""
    return dop_grid(
        r_mf_km,
        grid,
        t_tdb_s=t_tdb_s,
        elevation_mask_deg=dop.elevation_mask_deg,
        los_axes=los_axes or dop.los_axes,
    )


def dop_from_propagation(
    dop: DopSettings,
    dynamics: Dynamics,
    ds: xr.Dataset,
    *,
    los_axes: str | None = None,
    grid: SurfaceGrid | None = None,
) -> xr.Dataset:
    """DOP grid for a propagator Dataset (``r_mci_km`` (sat, time, xyz), ``time`` TDB s).

    Rotates to the Moon-fixed frame (``dynamics.frames.moon_fixed``) with SPICE
    (:func:`lnss_lib.frames.rotate_to_moon_fixed`) and calls :func:`dop_for_settings`; the grid defaults to
    ``[dop]``'s on the mean lunar sphere (``dynamics.constants.r_moon_mean_km``).
    """
    r_mci = ds["r_mci_km"].transpose("sat", "time", "xyz").values
    times = ds["time"].values.astype(float)
    grid = grid or SurfaceGrid.from_settings(dop, dynamics.constants.r_moon_mean_km)
    return dop_for_settings(
        dop, rotate_to_moon_fixed(dynamics, r_mci, times), times, grid, los_axes=los_axes
    )


def summary_for_settings(dop: DopSettings, ds: xr.Dataset) -> dict[str, float]:
    """:func:`dop_summary` with the threshold and filter width of ``[dop]``."""
    return dop_summary(ds, threshold=dop.availability_threshold, n_sigma=dop.filter_sigma)
