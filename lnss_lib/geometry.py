"""Dilution-of-precision geometry shared by the lunar grid (:mod:`lnss_lib.dop`) and the GPS link
(:mod:`lnss_lib.gps`): the position block of (G^T G)^-1 (paper eq. 5-7) and the filtered means and
availability of the DOP statistics (eq. 9-14).
"""

from __future__ import annotations

import numpy as np

from .constants import MIN_VISIBLE

__all__ = ["PDOP_FILTERS", "sigma_filtered_mean", "availability_pct", "filtered_mean"]

def _inverse_position_block(n, bx, by, bz, axx, ayy, azz, axy, axz, ayz):
    """Entries of the position block of (G^T G)^-1 via the Schur complement S = A - b b^T / n.

    Returns (ixx, iyy, izz, ixy, ixz, iyz, det_ok) where det_ok flags non-singular S.
    """
    inv_n = 1.0 / np.maximum(n, 1.0)
    sxx = axx - bx * bx * inv_n
    syy = ayy - by * by * inv_n
    szz = azz - bz * bz * inv_n
    sxy = axy - bx * by * inv_n
    sxz = axz - bx * bz * inv_n
    syz = ayz - by * bz * inv_n
    cxx = syy * szz - syz * syz
    cyy = sxx * szz - sxz * sxz
    czz = sxx * syy - sxy * sxy
    cxy = sxz * syz - sxy * szz
    cxz = sxy * syz - syy * sxz
    cyz = sxy * sxz - sxx * syz
    det = sxx * cxx + sxy * cxy + sxz * cxz
    scale = ((sxx + syy + szz) / 3.0) ** 3
    det_ok = det > 1e-12 * scale
    inv_det = 1.0 / np.where(det_ok, det, 1.0)
    return cxx * inv_det, cyy * inv_det, czz * inv_det, cxy * inv_det, cxz * inv_det, cyz * inv_det, det_ok


def _position_normal_matrix(los_hat, visible, clock_column: bool):
    """(M, n_visible, satellites needed): M (..., 3, 3) is the matrix whose inverse is the position block of
    (G^T G)^-1 (see :func:`pdop_kernel`)."""
    w = np.asarray(visible, dtype=float)
    los = np.asarray(los_hat, dtype=float)
    n_vis = w.sum(axis=-1)
    if clock_column:
        mean = np.sum(w[..., None] * los, axis=-2) / np.maximum(n_vis, 1.0)[..., None]
        los = los - mean[..., None, :]
    m = np.einsum("...k,...ki,...kj->...ij", w, los, los)
    return m, n_vis, MIN_VISIBLE if clock_column else MIN_VISIBLE - 1


PDOP_FILTERS = ("percentile95", "sigma2", "none")


def sigma_filtered_mean(values, weights=None, n_sigma: float = 3.0) -> tuple[float, int]:
    """Mean of the samples within ``n_sigma`` standard deviations of the mean (eq. 9-13).

    Non-finite samples (no DOP, singular geometry) are left out before the mean and sigma.
    Optional ``weights`` (broadcast to ``values``) give weighted mean and sigma. Returns
    (filtered mean, number of samples kept); (NaN, 0) when no finite sample exists.
    """
    v = np.asarray(values, dtype=float)
    w = np.ones_like(v) if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), v.shape)
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
    w = np.ones_like(v) if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), v.shape)
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
