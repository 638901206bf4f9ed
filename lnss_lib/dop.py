"""South-pole surface grid, visibility and dilution of precision (paper Section 2.1, eq. 1-14).

Conventions: satellite positions ``r_mf_km`` (sat, time, 3) are in the Moon-fixed frame
(``frames.moon_fixed``, MOON_ME) in km; the receivers sit on the mean lunar sphere
(``constants.r_moon_mean_km``) at fixed selenographic latitude/longitude; times are TDB seconds
past J2000.

Kernel (:func:`dop_kernel`): elevation from the local vertical, visibility with the mask
(eq. 3-4), and the geometry matrix G = [l_hat, 1] of eq. 5 accumulated as H = G^T G over the
visible satellites only (invisible rows are zeroed, which leaves H exactly that of the visible
set). The position block of H^-1 (eq. 6) is the inverse of the Schur complement
S = A - b b^T / N_v (A = sum l l^T, b = sum l), inverted in closed form for every time x grid
sample at once. PDOP and HDOP (eq. 7-8) come from its diagonal; HDOP takes the line-of-sight
axes either as the Moon-fixed x, y (``"moon_fixed"``, the paper's literal eq. 5-8) or as the
local East and North (``"enu"``, the physically horizontal error). PDOP is the same in both.
Samples with fewer than 4 visible satellites have no DOP (NaN).

Statistics (:func:`dop_summary`): 3-sigma filtered means (eq. 9-13) over the samples that have a
DOP, availability (eq. 14) over all grid-epoch samples (no DOP counts as unavailable), mean
visible satellites; optionally area-weighted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from .constellation import PAPER_TABLE_4 as _PAPER
from .elements import orbital_period_s
from .ephemeris import ELEMENT_FRAMES

LOS_AXES = ("moon_fixed", "enu")
WEIGHTINGS = ("none", "cos_lat", "cell_area")
MIN_VISIBLE = 4


@dataclass(frozen=True)
class SurfaceGrid:
    """Receivers on a sphere, fixed in the Moon-fixed frame (eq. 1-2).

    ``lat_deg`` (nlat,), ``lon_deg`` (nlon,); ``r_mf_km``, ``east``, ``north``, ``up``
    (nlat, nlon, 3): positions (km) and local unit vectors in Moon-fixed axes; ``weight``
    (nlat, nlon): sample weights summing to 1 (uniform unless an area weighting was chosen).
    At latitude -90 deg every longitude repeats the pole (as in the paper), with East/North
    turned by the longitude.
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    radius_km: float
    weighting: str
    r_mf_km: np.ndarray
    east: np.ndarray
    north: np.ndarray
    up: np.ndarray
    weight: np.ndarray

    @property
    def n_points(self) -> int:
        return self.lat_deg.size * self.lon_deg.size

    @property
    def shape(self) -> tuple[int, int]:
        return self.lat_deg.size, self.lon_deg.size


def _inclusive_range(start: float, stop: float, step: float, name: str) -> np.ndarray:
    if not (np.isfinite(start) and np.isfinite(stop) and np.isfinite(step)) or step <= 0.0:
        raise ValueError(f"{name}: step must be positive and bounds finite; got {start}..{stop} step {step}")
    if stop < start:
        raise ValueError(f"{name}: upper bound {stop} is below lower bound {start}")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    return start + step * np.arange(n)


def _area_weights(lat_deg: np.ndarray, lat_step_deg: float, nlon: int, weighting: str) -> np.ndarray:
    """Weights (nlat, nlon) summing to 1.

    ``cos_lat``: proportional to cos(lat) (the pole gets none). ``cell_area``: area of the band
    [lat - step/2, lat + step/2] clipped to [-90, 90] deg, i.e. cos(lat) for interior rows and
    the polar cap shared among the repeated pole points.
    """
    lat = np.radians(lat_deg)
    if weighting == "none":
        row = np.ones_like(lat)
    elif weighting == "cos_lat":
        row = np.clip(np.cos(lat), 0.0, None)
    elif weighting == "cell_area":
        half = np.radians(lat_step_deg) / 2.0
        lo = np.clip(lat - half, -np.pi / 2, np.pi / 2)
        hi = np.clip(lat + half, -np.pi / 2, np.pi / 2)
        row = np.sin(hi) - np.sin(lo)
    else:
        raise ValueError(f"unknown area weighting {weighting!r}; allowed: {', '.join(WEIGHTINGS)}")
    if row.sum() <= 0.0:
        raise ValueError(f"area weighting {weighting!r} gives zero total weight for latitudes {lat_deg.tolist()}")
    weights = np.repeat(row[:, None], nlon, axis=1)
    return weights / weights.sum()


def surface_grid(lat_min_deg: float = -90.0, lat_max_deg: float = -60.0, lat_step_deg: float = 10.0,
                 lon_min_deg: float = 0.0, lon_max_deg: float = 350.0, lon_step_deg: float = 10.0,
                 radius_km: float = 1737.4, weighting: str = "none") -> SurfaceGrid:
    """Latitude-longitude grid of eq. 1-2, bounds inclusive (defaults: 4 x 36 = 144 points).

    Latitudes must lie in [-90, 90] deg; ``weighting`` is one of ``none`` (the paper),
    ``cos_lat`` or ``cell_area`` (see :func:`_area_weights`).
    """
    lat = _inclusive_range(float(lat_min_deg), float(lat_max_deg), float(lat_step_deg), "latitude grid")
    lon = _inclusive_range(float(lon_min_deg), float(lon_max_deg), float(lon_step_deg), "longitude grid")
    if lat[0] < -90.0 or lat[-1] > 90.0:
        raise ValueError(f"grid latitudes must lie in [-90, 90] deg; got {lat_min_deg}..{lat_max_deg}")
    if not np.isfinite(radius_km) or radius_km <= 0.0:
        raise ValueError(f"grid radius must be positive (km); got {radius_km!r}")
    phi, lam = np.meshgrid(np.radians(lat), np.radians(lon), indexing="ij")
    cphi, sphi, clam, slam = np.cos(phi), np.sin(phi), np.cos(lam), np.sin(lam)
    up = np.stack([cphi * clam, cphi * slam, sphi], axis=-1)
    east = np.stack([-slam, clam, np.zeros_like(clam)], axis=-1)
    north = np.stack([-sphi * clam, -sphi * slam, cphi], axis=-1)
    weight = _area_weights(lat, float(lat_step_deg), lon.size, weighting)
    return SurfaceGrid(lat, lon, float(radius_km), weighting, radius_km * up, east, north, up, weight)


def grid_from_profile(profile: dict) -> SurfaceGrid:
    """The :func:`surface_grid` described by ``profile["dop"]`` on the mean lunar sphere."""
    cfg = profile["dop"]
    return surface_grid(cfg["lat_min_deg"], cfg["lat_max_deg"], cfg["lat_step_deg"],
                        cfg["lon_min_deg"], cfg["lon_max_deg"], cfg["lon_step_deg"],
                        radius_km=profile["constants"]["r_moon_mean_km"], weighting=cfg["area_weighting"])


def _check_positions(r_mf_km) -> np.ndarray:
    r = np.asarray(r_mf_km, dtype=float)
    if r.ndim != 3 or r.shape[2] != 3:
        raise ValueError(f"r_mf_km must have shape (sat, time, 3) in km; got shape {r.shape}")
    return r


def elevation_deg(r_mf_km, grid: SurfaceGrid) -> np.ndarray:
    """Elevation (deg) of each satellite above each receiver's local horizon, (sat, time, nlat, nlon).

    Satellites with non-finite positions get NaN.
    """
    r = _check_positions(r_mf_km)
    d = r[:, :, None, None, :] - grid.r_mf_km[None, None, :, :, :]
    rho = np.linalg.norm(d, axis=-1)
    sin_el = np.sum(d * grid.up[None, None], axis=-1) / rho
    return np.degrees(np.arcsin(np.clip(sin_el, -1.0, 1.0)))


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


def dop_kernel(r_mf_km: np.ndarray, r_grid_km: np.ndarray, up: np.ndarray, elevation_mask_deg: float = 5.0,
               los_axes: str = "moon_fixed", time_chunk: int = 32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    r = _check_positions(r_mf_km)
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
        dx *= visible
        dy *= visible
        dz *= visible
        n = visible.sum(axis=0, dtype=np.int16)
        nf = n.astype(float)
        ixx, iyy, izz, ixy, ixz, iyz, ok = _inverse_position_block(
            nf, dx.sum(axis=0), dy.sum(axis=0), dz.sum(axis=0),
            np.einsum("stp,stp->tp", dx, dx), np.einsum("stp,stp->tp", dy, dy), np.einsum("stp,stp->tp", dz, dz),
            np.einsum("stp,stp->tp", dx, dy), np.einsum("stp,stp->tp", dx, dz), np.einsum("stp,stp->tp", dy, dz),
        )
        trace = ixx + iyy + izz
        if los_axes == "moon_fixed":
            horizontal = ixx + iyy
        else:
            vertical = (ux * ux * ixx + uy * uy * iyy + uz * uz * izz
                        + 2.0 * (ux * uy * ixy + ux * uz * ixz + uy * uz * iyz))
            horizontal = trace - vertical
        enough = n >= MIN_VISIBLE
        n_visible[t0:t1] = n
        pdop[t0:t1] = np.where(enough, np.where(ok, np.sqrt(np.maximum(trace, 0.0)), np.inf), np.nan)
        hdop[t0:t1] = np.where(enough, np.where(ok, np.sqrt(np.maximum(horizontal, 0.0)), np.inf), np.nan)
    return n_visible, pdop, hdop


def dop_grid(r_mf_km, grid: SurfaceGrid, *, t_tdb_s=None, elevation_mask_deg: float = 5.0,
             los_axes: str = "moon_fixed") -> xr.Dataset:
    """Visibility and DOP over the grid (eq. 3-8) as a Dataset with dims (time, lat, lon).

    Variables ``n_visible``, ``pdop``, ``hdop`` (NaN where fewer than 4 visible) and ``weight``
    (lat, lon); coordinate ``time`` in TDB seconds past J2000 (``t_tdb_s``, default 0..n-1).
    """
    r = _check_positions(r_mf_km)
    ntime = r.shape[1]
    times = np.arange(ntime, dtype=float) if t_tdb_s is None else np.asarray(t_tdb_s, dtype=float)
    if times.shape != (ntime,):
        raise ValueError(f"t_tdb_s must have one entry per epoch ({ntime}); got shape {times.shape}")
    nlat, nlon = grid.shape
    n_visible, pdop, hdop = dop_kernel(r, grid.r_mf_km.reshape(-1, 3), grid.up.reshape(-1, 3),
                                       elevation_mask_deg, los_axes)
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
    ds["hdop"].attrs["long_name"] = f"HDOP (eq. 8) in {los_axes} axes, NaN with fewer than 4 visible"
    ds["lat"].attrs["units"] = "deg"
    ds["lon"].attrs["units"] = "deg"
    return ds


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


def dop_summary(ds: xr.Dataset, *, threshold: float = 15.0, n_sigma: float = 3.0,
                weighted: bool = True) -> dict[str, float]:
    """Scalar metrics of a :func:`dop_grid` Dataset (eq. 9-14).

    ``pdop_mean_3sigma``, ``hdop_mean_3sigma`` (filtered means over samples with a DOP),
    ``pdop_mean_raw``, ``hdop_mean_raw``, ``pdop_availability_pct``, ``hdop_availability_pct``,
    ``availability_pct`` (both below threshold), ``n_visible_mean``, ``fewer_than_4_pct``,
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
        "n_visible_mean": float(np.sum(w * nvis) / np.sum(w)),
        "pdop_mean_3sigma": pdop_mean,
        "hdop_mean_3sigma": hdop_mean,
        "pdop_mean_raw": float(np.sum(w[fin_p] * pdop[fin_p]) / np.sum(w[fin_p])) if fin_p.any() else float("nan"),
        "hdop_mean_raw": float(np.sum(w[fin_h] * hdop[fin_h]) / np.sum(w[fin_h])) if fin_h.any() else float("nan"),
        "pdop_availability_pct": availability_pct(pdop, threshold, w),
        "hdop_availability_pct": availability_pct(hdop, threshold, w),
        "availability_pct": min(100.0, float(100.0 * np.sum(w * both) / np.sum(w))),
        "fewer_than_4_pct": float(100.0 * np.sum(w * (nvis < MIN_VISIBLE)) / np.sum(w)),
        "n_samples": int(pdop.size),
        "pdop_kept": pdop_kept,
        "hdop_kept": hdop_kept,
    }


def rotate_to_moon_fixed(profile: dict, r_mci_km: np.ndarray, t_tdb_s: np.ndarray) -> np.ndarray:
    """Moon-centred J2000 positions (sat, time, 3) -> Moon-fixed (``frames.moon_fixed``) positions."""
    from .ephemeris import ensure_kernels, rotation

    ensure_kernels(profile)
    return rotate_with(rotation("J2000", profile["frames"]["moon_fixed"], np.asarray(t_tdb_s, dtype=float)), r_mci_km)


def rotate_with(rot: np.ndarray, vectors) -> np.ndarray:
    """Vectors (sat, time, 3) rotated by one matrix per epoch, rot (time, 3, 3): out = rot[t] @ v[s, t]."""
    return np.einsum("tij,stj->sti", rot, np.asarray(vectors, dtype=float))


def dop_for_profile(profile: dict, r_mf_km, t_tdb_s, *, los_axes: str | None = None,
                    grid: SurfaceGrid | None = None) -> xr.Dataset:
    """:func:`dop_grid` with the grid, mask and LOS axes of ``profile["dop"]`` (overridable)."""
    cfg = profile["dop"]
    return dop_grid(r_mf_km, grid or grid_from_profile(profile), t_tdb_s=t_tdb_s,
                    elevation_mask_deg=float(cfg["elevation_mask_deg"]),
                    los_axes=los_axes or cfg["los_axes"])


def dop_from_propagation(profile: dict, ds: xr.Dataset, *, los_axes: str | None = None,
                         grid: SurfaceGrid | None = None) -> xr.Dataset:
    """DOP grid for a propagator Dataset (``r_mci_km`` (sat, time, xyz), ``time`` TDB s).

    Rotates to the Moon-fixed frame with SPICE (``ephemeris.rotation``) and calls
    :func:`dop_for_profile`.
    """
    r_mci = ds["r_mci_km"].transpose("sat", "time", "xyz").values
    times = ds["time"].values.astype(float)
    return dop_for_profile(profile, rotate_to_moon_fixed(profile, r_mci, times), times,
                           los_axes=los_axes, grid=grid)


def summary_from_profile(profile: dict, ds: xr.Dataset) -> dict[str, float]:
    """:func:`dop_summary` with the threshold and filter width of ``profile["dop"]``."""
    cfg = profile["dop"]
    return dop_summary(ds, threshold=float(cfg["availability_threshold"]), n_sigma=float(cfg["filter_sigma"]))


# ---------------------------------------------------------------------------------------------
# Analysis: element frame x line-of-sight axes study (paper Table 4 DOP rows, NOTES.md "Frames")
# ---------------------------------------------------------------------------------------------

PAPER_TABLE_4 = {key: _PAPER[metric] for key, metric in (
    ("n_visible_mean", "mean_visible_sats"), ("pdop_mean_3sigma", "pdop_mean_3sigma"),
    ("hdop_mean_3sigma", "hdop_mean_3sigma"), ("pdop_availability_pct", "pdop_avail_pct"),
    ("hdop_availability_pct", "hdop_avail_pct"))}
SUMMARY_LABELS = {"n_visible_mean": "mean visible satellites", "pdop_mean_3sigma": "PDOP (3-sigma mean)",
                  "hdop_mean_3sigma": "HDOP (3-sigma mean)", "pdop_availability_pct": "PDOP availability (%)",
                  "hdop_availability_pct": "HDOP availability (%)", "availability_pct": "PDOP and HDOP < 15 (%)",
                  "fewer_than_4_pct": "samples with < 4 visible (%)", "pdop_mean_raw": "PDOP (unfiltered mean)",
                  "hdop_mean_raw": "HDOP (unfiltered mean)"}
PAPER_COLUMN = "paper (Table 4)"


def latitude_deg(r_mf_km) -> np.ndarray:
    """Selenographic latitude (deg) of Moon-fixed positions (..., 3) km."""
    r = np.asarray(r_mf_km, dtype=float)
    return np.degrees(np.arcsin(r[..., 2] / np.linalg.norm(r, axis=-1)))


def summary_table(summaries: dict[str, dict], reference: str, *, paper: dict | None = None,
                  labels: dict | None = None) -> "pd.DataFrame":
    """Metrics (rows, ``labels``) of each named :func:`dop_summary` (columns) beside the paper's Table 4.

    Columns: ``"paper (Table 4)"``, then ``summaries`` in order, then ``"default vs paper (%)"``:
    100 (reference - paper) / paper. Metrics a summary lacks are NaN (the paper gives five).
    """
    import pandas as pd

    if reference not in summaries:
        raise ValueError(f"reference column {reference!r} is not among the summaries: {', '.join(summaries)}")
    labels = SUMMARY_LABELS if labels is None else labels
    columns = {PAPER_COLUMN: PAPER_TABLE_4 if paper is None else paper, **summaries}
    table = pd.DataFrame({name: {labels[k]: values.get(k, np.nan) for k in labels} for name, values in columns.items()})
    table["default vs paper (%)"] = 100.0 * (table[reference] - table[PAPER_COLUMN]) / table[PAPER_COLUMN]
    return table


def latitude_statistics(ds_moon_fixed: xr.Dataset, ds_enu: xr.Dataset, threshold: float = 15.0) -> "pd.DataFrame":
    """Per latitude row of the grid: share of samples with PDOP >= ``threshold`` or none (eq. 14), median
    PDOP and HDOP in both line-of-sight conventions (eq. 7-8) and mean visible satellites (eq. 4).

    ``ds_moon_fixed`` and ``ds_enu``: :func:`dop_grid` results of one propagation with ``los_axes``
    ``moon_fixed`` and ``enu``. Medians skip the samples without a DOP.
    """
    import pandas as pd

    rows = []
    for lat in ds_moon_fixed["lat"].values:
        p = ds_moon_fixed["pdop"].sel(lat=lat).values
        rows.append({"lat (deg)": lat,
                     "PDOP unavailable (%)": 100.0 * np.mean(~(p < threshold)),
                     "median PDOP": np.nanmedian(p),
                     "median HDOP Moon-fixed": np.nanmedian(ds_moon_fixed["hdop"].sel(lat=lat).values),
                     "median HDOP ENU": np.nanmedian(ds_enu["hdop"].sel(lat=lat).values),
                     "mean visible": float(ds_moon_fixed["n_visible"].sel(lat=lat).mean())})
    return pd.DataFrame(rows)


def time_statistics_maps(ds_moon_fixed: xr.Dataset, ds_enu: xr.Dataset, threshold: float = 15.0) -> xr.Dataset:
    """Per receiver (lat, lon): time mean of the visible count, time medians of PDOP and of HDOP in both
    conventions (NaN samples skipped), and the PDOP availability (%, eq. 14; no DOP counts as unavailable)."""
    return xr.Dataset({
        "mean_visible": ds_moon_fixed["n_visible"].mean("time"),
        "median_pdop": ds_moon_fixed["pdop"].median("time"),
        "median_hdop_moon_fixed": ds_moon_fixed["hdop"].median("time"),
        "median_hdop_enu": ds_enu["hdop"].median("time"),
        "pdop_availability_pct": 100.0 * (ds_moon_fixed["pdop"] < threshold).mean("time"),
    })


def plane_visibility(r_mf_km, normal_mf, grid: SurfaceGrid, elevation_mask_deg: float,
                     sats_per_plane: int) -> tuple[np.ndarray, np.ndarray]:
    """Visible satellites per orbital plane and receiver-plane angles, each (plane, time, lat, lon).

    ``r_mf_km`` (sat, time, 3) Moon-fixed positions, satellites ordered plane by plane with
    ``sats_per_plane`` each; ``normal_mf`` (sat, time, 3) unit orbit normals in the same axes (the
    first satellite of each plane stands for its plane). The angle is the one between the
    receiver's position vector and the orbital plane: asin |h_hat . up| (deg).
    """
    r = _check_positions(r_mf_km)
    n = int(sats_per_plane)
    if n <= 0 or r.shape[0] % n:
        raise ValueError(f"sats_per_plane must be a positive divisor of the {r.shape[0]} satellites; got {sats_per_plane!r}")
    normal = np.asarray(normal_mf, dtype=float)
    if normal.shape != r.shape:
        raise ValueError(f"normal_mf must have the shape of r_mf_km {r.shape}; got {normal.shape}")
    visible = elevation_deg(r, grid) >= elevation_mask_deg
    counts = np.stack([visible[k:k + n].sum(axis=0) for k in range(0, r.shape[0], n)])
    angle = np.stack([np.degrees(np.arcsin(np.abs(np.einsum("tk,ijk->tij", normal[k], grid.up))))
                      for k in range(0, r.shape[0], n)])
    return counts, angle


def degenerate_geometry_rows(pdop, plane_counts, plane_angle_deg, threshold: float = 15.0) -> list[dict]:
    """Samples with PDOP >= ``threshold`` (or none) against the rest: their share, mean visible count per
    plane, share seeing only one plane, and median angle between the receiver and the plane that supplies
    most visible satellites (ties: the first plane). Arrays from :func:`plane_visibility`; ``pdop``
    (time, lat, lon). An empty class gives no row.
    """
    counts = np.asarray(plane_counts)
    angle = np.asarray(plane_angle_deg, dtype=float)
    p = np.asarray(pdop, dtype=float)
    if counts.shape[1:] != p.shape or angle.shape != counts.shape:
        raise ValueError(f"plane arrays {counts.shape}, {angle.shape} do not match pdop {p.shape} (plane, *pdop shape)")
    majority = np.take_along_axis(angle, np.argmax(counts, axis=0)[None], axis=0)[0]
    one_plane = (counts > 0).sum(axis=0) == 1
    bad = ~(p < threshold)
    rows = []
    for label, mask in ((f"PDOP >= {threshold:g} or none", bad), (f"PDOP < {threshold:g}", ~bad)):
        if mask.any():
            rows.append({"samples": label, "share (%)": 100.0 * mask.mean(),
                         **{f"visible from plane {k + 1}": counts[k][mask].mean() for k in range(counts.shape[0])},
                         "samples seeing one plane only (%)": 100.0 * np.mean(one_plane[mask]),
                         "median angle receiver-majority plane (deg)": np.median(majority[mask])})
    return rows


@dataclass
class FrameStudy:
    """One constellation propagated with its elements in each element frame, DOP in each LOS convention.

    ``profiles`` and ``propagation``: element frame -> profile and propagator Dataset; ``dop``:
    (element frame, los axes) -> :func:`dop_grid` Dataset; ``grid``: the profile's receiver grid.
    """

    profile_name: str
    elements_deg: np.ndarray
    profiles: dict
    propagation: dict
    dop: dict
    grid: SurfaceGrid

    @property
    def frames(self) -> tuple[str, ...]:
        return tuple(self.profiles)


def element_frame_study(profile_name: str, elements_deg, *, frames=ELEMENT_FRAMES, los_axes=LOS_AXES) -> FrameStudy:
    """Propagate ``elements_deg`` (nsat, 6) with the elements referred to each element frame (the profile
    otherwise unchanged) and compute the DOP grid (eq. 1-8) for each line-of-sight convention."""
    from .config import load_profile
    from .propagator import propagate_elements

    for frame in frames:
        if frame not in ELEMENT_FRAMES:
            raise ValueError(f"unknown element frame {frame!r}; allowed: {', '.join(ELEMENT_FRAMES)}")
    profiles = {frame: load_profile(profile_name, overrides={"frames": {"element_frame": frame}}) for frame in frames}
    propagation = {frame: propagate_elements(profiles[frame], elements_deg) for frame in frames}
    dop = {(frame, axes): dop_from_propagation(profiles[frame], propagation[frame], los_axes=axes)
           for frame in frames for axes in los_axes}
    return FrameStudy(profile_name, np.asarray(elements_deg, dtype=float), profiles, propagation, dop,
                      grid_from_profile(load_profile(profile_name)))


def apolune_latitude_table(study: FrameStudy, sats_per_plane: int) -> "pd.DataFrame":
    """Selenographic latitude (deg) of each plane's apolune, half a Keplerian period after the epoch, for
    each element frame of ``study`` (the first satellite of each plane starts at perilune)."""
    import pandas as pd

    from .constellation import two_body_positions_mci

    el = study.elements_deg
    leaders = list(range(0, el.shape[0], int(sats_per_plane)))
    rows = []
    for frame, profile in study.profiles.items():
        t0 = float(study.propagation[frame]["time"].values[0])
        times = np.array([t0, t0 + 0.5 * orbital_period_s(el[0, 0], profile["gravity"]["gm_km3_s2"])])
        r_mf = rotate_to_moon_fixed(profile, two_body_positions_mci(profile, el[leaders], times), times)[:, 1]
        lat = latitude_deg(r_mf)
        rows.append({"element frame": frame,
                     **{f"apolune latitude plane {k + 1} (deg)": lat[k] for k in range(len(leaders))}})
    return pd.DataFrame(rows)


def frame_study_summaries(study: FrameStudy, default_frame: str = "lunar_equator_of_epoch") -> dict[str, dict]:
    """:func:`summary_from_profile` of every (frame, axes) of ``study``, then three checks on the default
    frame with the profile's axes: a two-body (Keplerian) orbit, the ``cell_area`` weighting and the
    ``converged`` integrator setting. Keys ``"<frame> / <axes>[, check]"``."""
    from .config import load_profile
    from .constellation import two_body_positions_mci
    from .propagator import propagate_elements

    if default_frame not in study.profiles:
        raise ValueError(f"default frame {default_frame!r} is not in the study: {', '.join(study.profiles)}")
    out = {f"{frame} / {axes}": summary_from_profile(study.profiles[frame], ds) for (frame, axes), ds in study.dop.items()}
    base = study.profiles[default_frame]
    label = f"{default_frame} / {base['dop']['los_axes']}"
    times = study.propagation[study.frames[0]]["time"].values
    r_two_body = rotate_to_moon_fixed(base, two_body_positions_mci(base, study.elements_deg, times), times)
    out[f"{label}, two-body"] = summary_from_profile(base, dop_for_profile(base, r_two_body, times))
    weighted = load_profile(study.profile_name, overrides={"frames": {"element_frame": default_frame},
                                                           "dop": {"area_weighting": "cell_area"}})
    out[f"{label}, cell-area weighted"] = summary_from_profile(
        weighted, dop_from_propagation(weighted, study.propagation[default_frame], grid=grid_from_profile(weighted)))
    converged = propagate_elements(base, study.elements_deg, setting="converged")
    out[f"{label}, converged integrator"] = summary_from_profile(base, dop_from_propagation(base, converged))
    return out


def latitude_table(study: FrameStudy) -> "pd.DataFrame":
    """:func:`latitude_statistics` for every element frame of ``study``, one block of rows per frame."""
    import pandas as pd

    blocks = []
    for frame, profile in study.profiles.items():
        block = latitude_statistics(study.dop[(frame, "moon_fixed")], study.dop[(frame, "enu")],
                                    float(profile["dop"]["availability_threshold"]))
        block.insert(0, "element frame", frame)
        blocks.append(block)
    return pd.concat(blocks, ignore_index=True)


def degenerate_geometry_table(study: FrameStudy, sats_per_plane: int) -> "pd.DataFrame":
    """:func:`degenerate_geometry_rows` for every element frame of ``study`` (orbit normals h = r x v of
    the propagated states, rotated to the Moon-fixed frame)."""
    import pandas as pd

    rows = []
    for frame, profile in study.profiles.items():
        prop = study.propagation[frame]
        t = prop["time"].values
        r_mci = prop["r_mci_km"].transpose("sat", "time", "xyz").values
        v_mci = prop["v_mci_kms"].transpose("sat", "time", "xyz").values
        r_mf = rotate_to_moon_fixed(profile, r_mci, t)
        h_mf = rotate_to_moon_fixed(profile, np.cross(r_mci, v_mci), t)
        h_mf /= np.linalg.norm(h_mf, axis=-1, keepdims=True)
        counts, angle = plane_visibility(r_mf, h_mf, study.grid, float(profile["dop"]["elevation_mask_deg"]),
                                         sats_per_plane)
        pdop = study.dop[(frame, "moon_fixed")]["pdop"].values
        for row in degenerate_geometry_rows(pdop, counts, angle, float(profile["dop"]["availability_threshold"])):
            rows.append({"element frame": frame, **row})
    return pd.DataFrame(rows)
