"""Dilution-of-precision geometry shared by the lunar grid (:mod:`lnss_lib.dop`) and the GPS link
(:mod:`lnss_lib.gps`): the position block of (G^T G)^-1 (paper eq. 5-7) and the filtered means and
availability of the DOP statistics (eq. 9-14).

With G = [l_k^T, 1] over the visible satellites (unit lines of sight l_k, eq. 5), the position block
of (G^T G)^-1 is the inverse of the Schur complement of the clock,
S = sum_k (l_k - l_mean)(l_k - l_mean)^T, written centred: with nearly parallel lines of sight (GPS
seen from the Moon) the uncentred form A - b b^T / N loses most of its digits to cancellation.
Without the clock column the block is A^-1, A = sum_k l_k l_k^T. Both go through one closed-form
inverse (:func:`position_block_inverse`) with one singularity rule: det S <= :data:`SINGULAR_RTOL`
(trace S / 3)^3 is singular. Eq. 6's pseudo-inverse equals the inverse whenever G has full rank.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .sections import PDOP_FILTERS

__all__ = [
    "SINGULAR_RTOL",
    "PDOP_FILTERS",
    "normal_matrix_entries",
    "block_inverse",
    "position_block_inverse",
    "weighted_dop_stats",
    "sigma_filtered_mean",
    "availability_pct",
    "filtered_mean",
]

SINGULAR_RTOL = (
    1e-12  # det S relative to (trace S / 3)^3 below which the geometry counts as singular
)


@nb.njit(cache=True)
def _normal_sums(lx, ly, lz, w, centred):
    """Counts (m,) and entries (6, m) of sum_k w_k (l_k - l_mean)(l_k - l_mean)^T over axis 0 of (n, m) arrays
    (``w``: weights or a boolean mask; without ``centred`` the mean is left at zero).

    Two passes, both streaming along axis 1 (contiguous): the weighted means, then the products.
    """
    n, m = lx.shape
    count = np.zeros(m)
    mean = np.zeros((3, m))
    for k in range(n):
        for j in range(m):
            wk = 1.0 * w[k, j]
            count[j] += wk
            if centred:
                mean[0, j] += wk * lx[k, j]
                mean[1, j] += wk * ly[k, j]
                mean[2, j] += wk * lz[k, j]
    if centred:
        for j in range(m):
            inv = 1.0 / max(count[j], 1.0)
            mean[0, j] *= inv
            mean[1, j] *= inv
            mean[2, j] *= inv
    s = np.zeros((6, m))
    for k in range(n):
        for j in range(m):
            wk = 1.0 * w[k, j]
            x = (lx[k, j] - mean[0, j]) * wk
            y = (ly[k, j] - mean[1, j]) * wk
            z = (lz[k, j] - mean[2, j]) * wk
            s[0, j] += x * x
            s[1, j] += y * y
            s[2, j] += z * z
            s[3, j] += x * y
            s[4, j] += x * z
            s[5, j] += y * z
    return count, s


def _leading(a, axis: int, dtype=float) -> np.ndarray:
    """``a`` with ``axis`` first and the rest flattened: a C-contiguous (n, m) array of ``dtype``."""
    moved = np.moveaxis(np.asarray(a, dtype=dtype), axis, 0)
    return np.ascontiguousarray(moved.reshape(moved.shape[0], -1))


def normal_matrix_entries(lx, ly, lz, visible, axis: int = -1, clock_column: bool = True):
    """(n_visible, (sxx, syy, szz, sxy, sxz, syz)): the matrix whose inverse is the position block of
    (G^T G)^-1, summed over the satellites along ``axis``; every output has the inputs' shape without it.

    ``lx``, ``ly``, ``lz``: components of the unit lines of sight; ``visible``: mask of the same shape
    (invisible satellites do not count). With ``clock_column`` the centred Schur complement
    S = sum_k (l_k - l_mean)(l_k - l_mean)^T over the visible satellites, else A = sum_k l_k l_k^T.
    """
    shape = np.delete(np.shape(lx), axis)
    mask = np.asarray(visible)
    w = _leading(mask, axis, bool if mask.dtype == bool else float)
    count, sums = _normal_sums(
        _leading(lx, axis), _leading(ly, axis), _leading(lz, axis), w, bool(clock_column)
    )
    return count.reshape(shape), tuple(sums[k].reshape(shape) for k in range(6))


@nb.njit(cache=True)
def _regular(det, t):
    """``det > SINGULAR_RTOL * t ** 3.0``, the same decision every time, without the power where it cannot matter:
    t * t * t is within 1e-15 of the power (three roundings against one), so a determinant outside 1e-14 of the
    threshold decides on the product alone; the power is computed only in that band (and for tiny or non-finite
    values). The libm call per grid sample and epoch cost 5.0 -> 2.3 ms for a design's 138,384 decisions (the same bits,
    interleaved A/B in one process), a quarter of the DOP grid's time."""
    if t > 1e-90 and t < 1e90:
        threshold = SINGULAR_RTOL * (t * t * t)
        if det > threshold * (1.0 + 1e-14):
            return True
        if det < threshold * (1.0 - 1e-14):
            return False
    return det > SINGULAR_RTOL * t**3.0


@nb.njit(cache=True)
def block_inverse(sxx, syy, szz, sxy, sxz, syz):
    """Scalar S^-1 by the adjugate: (ixx, iyy, izz, ixy, ixz, iyz, ok); the one formula behind
    :func:`position_block_inverse` and the fused grid kernel of :mod:`lnss_lib.dop`."""
    cxx = syy * szz - syz * syz
    cyy = sxx * szz - sxz * sxz
    czz = sxx * syy - sxy * sxy
    cxy = sxz * syz - sxy * szz
    cxz = sxy * syz - syy * sxz
    cyz = sxy * sxz - sxx * syz
    det = sxx * cxx + sxy * cxy + sxz * cxz
    ok = _regular(det, (sxx + syy + szz) / 3.0)
    inv_det = 1.0 / (det if ok else 1.0)
    return (
        cxx * inv_det,
        cyy * inv_det,
        czz * inv_det,
        cxy * inv_det,
        cxz * inv_det,
        cyz * inv_det,
        ok,
    )


@nb.njit(cache=True)
def _block_inverse_loop(s, out, ok):
    for j in range(s.shape[1]):
        ixx, iyy, izz, ixy, ixz, iyz, good = block_inverse(
            s[0, j], s[1, j], s[2, j], s[3, j], s[4, j], s[5, j]
        )
        out[0, j] = ixx
        out[1, j] = iyy
        out[2, j] = izz
        out[3, j] = ixy
        out[4, j] = ixz
        out[5, j] = iyz
        ok[j] = good


def position_block_inverse(sxx, syy, szz, sxy, sxz, syz):
    """Entries of S^-1 for symmetric S given by its six entries (:func:`block_inverse`); arrays broadcast.

    Returns (ixx, iyy, izz, ixy, ixz, iyz, ok), ``ok`` False where S is singular
    (det S <= :data:`SINGULAR_RTOL` (trace S / 3)^3); the entries there are finite but meaningless.
    """
    arrays = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (sxx, syy, szz, sxy, sxz, syz))
    )
    shape = arrays[0].shape
    s = np.ascontiguousarray(np.stack([a.reshape(-1) for a in arrays]))
    out = np.full_like(s, np.nan)
    ok = np.zeros(s.shape[1], dtype=bool)
    _block_inverse_loop(s, out, ok)
    return tuple(out[k].reshape(shape) for k in range(6)) + (ok.reshape(shape),)


@nb.njit(cache=True)
def weighted_dop_stats(values, weights, n_sigma, threshold):
    """Eq. 9-14 on (time, point) samples in compiled loops, ``weights`` (point,) shared by every epoch.

    Returns (filtered mean, samples kept, raw mean over finite samples, availability % over all
    samples (value < ``threshold``)); the same quantities as :func:`sigma_filtered_mean` and
    :func:`availability_pct` (which sum pairwise: the two agree to rounding, ~1e-13 relative).
    """
    nt, npt = values.shape
    sw = 0.0
    swv = 0.0
    w_all = 0.0
    w_ok = 0.0
    for t in range(nt):
        for p in range(npt):
            v = values[t, p]
            w = weights[p]
            w_all += w
            if np.isfinite(v):
                sw += w
                swv += w * v
                if v < threshold:
                    w_ok += w
    if sw <= 0.0:
        return np.nan, 0, np.nan, min(100.0, 100.0 * w_ok / w_all)
    mu = swv / sw
    s2 = 0.0
    for t in range(nt):
        for p in range(npt):
            v = values[t, p]
            if np.isfinite(v):
                s2 += weights[p] * (v - mu) ** 2
    limit = n_sigma * np.sqrt(s2 / sw)
    kw = 0.0
    kwv = 0.0
    kept = 0
    for t in range(nt):
        for p in range(npt):
            v = values[t, p]
            if np.isfinite(v) and abs(v - mu) <= limit:
                kw += weights[p]
                kwv += weights[p] * v
                kept += 1
    return kwv / kw, kept, mu, min(100.0, 100.0 * w_ok / w_all)


def sigma_filtered_mean(values, weights=None, n_sigma: float = 3.0) -> tuple[float, int]:
    """Mean of the samples within ``n_sigma`` standard deviations of the mean (eq. 9-13).

    Non-finite samples (no DOP, singular geometry) are left out before the mean and sigma.
    Optional ``weights`` (broadcast to ``values``) give weighted mean and sigma. Returns
    (filtered mean, number of samples kept); (NaN, 0) when no finite sample exists.
    """
    v = np.asarray(values, dtype=float)
    w = (
        np.ones_like(v)
        if weights is None
        else np.broadcast_to(np.asarray(weights, dtype=float), v.shape)
    )
    finite = np.isfinite(v)
    v, w = v[finite], w[finite]
    if v.size == 0 or w.sum() <= 0.0:
        return float("nan"), 0
    mu = np.sum(w * v) / np.sum(w)
    sigma = np.sqrt(np.sum(w * (v - mu) ** 2) / np.sum(w))
    keep = np.abs(v - mu) <= n_sigma * sigma
    return float(np.sum(w[keep] * v[keep]) / np.sum(w[keep])), int(keep.sum())


def availability_pct(values, threshold: float = 15.0, weights=None) -> float:
    """Percentage of ALL samples with value < ``threshold`` (eq. 14); NaN (no DOP) counts as unavailable."""
    v = np.asarray(values, dtype=float)
    w = (
        np.ones_like(v)
        if weights is None
        else np.broadcast_to(np.asarray(weights, dtype=float), v.shape)
    )
    with np.errstate(invalid="ignore"):
        ok = v < threshold
    return min(100.0, float(100.0 * np.sum(w * ok) / np.sum(w)))  # min: rounding of the weight sums


def filtered_mean(values, method: str = "percentile95") -> tuple[float, int]:
    """Mean of the finite samples after the filter; returns (mean, samples kept).

    ``percentile95`` (default; the paper's "2-sigma (95th percentile) filter"): samples above the
    95th percentile (linear interpolation, numpy default) are dropped. ``sigma2``: samples with
    |p - mean| > 2 sigma are dropped (eq. 12 with 2 instead of 3). ``none``: plain mean.
    """
    if method not in PDOP_FILTERS:
        raise ValueError(f"unknown PDOP filter {method!r}; allowed: {', '.join(PDOP_FILTERS)}")
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), 0
    if method == "percentile95":
        v = v[v <= np.percentile(v, 95.0)]
    elif method == "sigma2":
        v = v[np.abs(v - v.mean()) <= 2.0 * v.std()]
    return float(v.mean()), int(v.size)
