"""GPS constellation and the GPS-LNSS link (paper Section 2.2, eq. 15-24, Table 1).

Two layers, pure kernels apart from orchestration (TLE reading and selection live in
:mod:`lnss_lib.tle`, TEME -> J2000 and the time scales in :mod:`lnss_lib.frames`, the PDOP
geometry in :mod:`lnss_lib.geometry`):

* **Link kernels** (eq. 15-24): lunar occultation cone (eq. 17-18), off-boresight angle (eq. 19-20),
  Earth occultation with the atmospheric margin (eq. 21) plus the ray / WGS-84 ellipsoid test,
  beam mask, link budget (eq. 22-24), GPS-LNSS PDOP with the clock column (eq. 5-7) and the
  95th-percentile ("2-sigma") filtered mean.
* **Orchestration**: :func:`gps_link` / :func:`gps_link_summary` on the GPS states of
  :func:`~lnss_lib.gps_states.gps_states_mci` (SGP4 in TEME -> J2000 -> Moon-centred; computed once
  per run, cached, reused across designs) with the transmit pattern of :mod:`lnss_lib.gain_pattern`.

Units and frames are in the names: ``r_mci_km`` Moon-centred J2000, ``r_eci_km`` Earth-centred
J2000, ``r_teme_km`` Earth-centred TEME, ``t_tdb_s`` TDB seconds past J2000 (SPICE ET).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numba as nb
import numpy as np
import xarray as xr

from .constants import BOLTZMANN_J_K, C_M_S, MIN_VISIBLE, WGS84_A_KM, WGS84_B_KM
from .gain_pattern import GainPattern, gain_for_settings
from .geometry import block_inverse, filtered_mean, normal_matrix_entries, position_block_inverse

if TYPE_CHECKING:
    from .settings import BodyConstants, GpsSettings

__all__ = [
    "lunar_occultation",
    "off_boresight_deg",
    "earth_occultation",
    "ray_hits_ellipsoid",
    "segment_hits_ellipsoid",
    "free_space_loss_db",
    "cn0_dbhz",
    "pdop_kernel",
    "pdop_along_axis",
    "gps_link",
    "gps_link_metrics",
    "gps_link_summary",
]


# --------------------------------------------------------------------------------------------
# Link kernels (pure numpy, broadcasting over any leading axes)
# --------------------------------------------------------------------------------------------


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1)
    return v / norm[..., None], norm


def _angle_deg(a_hat: np.ndarray, b_hat: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(a_hat * b_hat, axis=-1), -1.0, 1.0)))


def lunar_occultation(
    r_lnss_mci_km: np.ndarray, r_gps_mci_km: np.ndarray, r_moon_km: float
) -> np.ndarray:
    """True where the Moon blocks the LNSS -> GPS line of sight (eq. 15-18).

    theta_moon = acos(-u . z_hat) (u: unit LNSS -> GPS, z_hat: unit Moon -> LNSS) is compared with
    the Moon's angular radius alpha_moon = asin(R_moon / |r_LNSS|): blocked if theta_moon < alpha_moon.
    """
    u_hat, _ = _unit(r_gps_mci_km - r_lnss_mci_km)
    z_hat, r_lnss = _unit(r_lnss_mci_km)
    theta = _angle_deg(-u_hat, z_hat)
    alpha = np.degrees(np.arcsin(np.clip(r_moon_km / r_lnss, -1.0, 1.0)))
    return theta < alpha


def off_boresight_deg(r_gps_eci_km: np.ndarray, r_lnss_eci_km: np.ndarray) -> np.ndarray:
    """Off-boresight angle theta_off (deg, eq. 19-20): boresight -r_GPS (Earth-centred) vs GPS -> LNSS."""
    b_hat, _ = _unit(-r_gps_eci_km)
    u_hat, _ = _unit(r_lnss_eci_km - r_gps_eci_km)
    return _angle_deg(b_hat, u_hat)


def earth_occultation(
    theta_off_deg: np.ndarray, r_gps_eci_km: np.ndarray, r_earth_km: float, margin_deg: float
) -> np.ndarray:
    """True where theta_off < alpha_earth + margin (eq. 21): behind the Earth or its atmosphere."""
    alpha = np.degrees(np.arcsin(r_earth_km / np.linalg.norm(r_gps_eci_km, axis=-1)))
    return theta_off_deg < alpha + margin_deg


def ray_hits_ellipsoid(
    p0_km: np.ndarray, p1_km: np.ndarray, a_km: float = WGS84_A_KM, b_km: float = WGS84_B_KM
) -> np.ndarray:
    """True where the segment p0 -> p1 meets the ellipsoid x^2/a^2 + y^2/a^2 + z^2/b^2 = 1 (axes along z).

    Both ends are in the ellipsoid's own frame (Earth-centred, z along the pole). Scaling by
    (1/a, 1/a, 1/b) turns the ellipsoid into the unit sphere; the segment meets it if its closest
    point to the origin is inside.
    """
    scale = np.array([1.0 / a_km, 1.0 / a_km, 1.0 / b_km])
    q0 = np.asarray(p0_km) * scale
    d = np.asarray(p1_km) * scale - q0
    s = np.clip(-np.sum(q0 * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
    closest = q0 + s[..., None] * d
    return np.sum(closest * closest, axis=-1) < 1.0


@nb.njit(cache=True, inline="always")
def segment_hits_ellipsoid(p0_km, p1_km, a_km, b_km):
    """:func:`ray_hits_ellipsoid`'s test for one segment ``p0_km`` -> ``p1_km`` (3,) (divided by the
    axes, not multiplied by their inverses), inlined into both compiled link kernels
    (:func:`_link_kernel`, :func:`lnss_lib.gnss._gnss_kernel`) so that they block the same links."""
    q0x, q0y, q0z = p0_km[0] / a_km, p0_km[1] / a_km, p0_km[2] / b_km
    dx, dy, dz = p1_km[0] / a_km - q0x, p1_km[1] / a_km - q0y, p1_km[2] / b_km - q0z
    sc = min(max(-(q0x * dx + q0y * dy + q0z * dz) / (dx * dx + dy * dy + dz * dz), 0.0), 1.0)
    cx, cy, cz = q0x + sc * dx, q0y + sc * dy, q0z + sc * dz
    return cx * cx + cy * cy + cz * cz < 1.0


def free_space_loss_db(distance_km: np.ndarray, frequency_hz: float) -> np.ndarray:
    """Free-space loss 20 log10(4 pi d / lambda) (eq. 23), lambda = c / f."""
    wavelength_m = C_M_S / frequency_hz
    return 20.0 * np.log10(4.0 * np.pi * np.asarray(distance_km) * 1e3 / wavelength_m)


def cn0_dbhz(
    gain_tx_dbi: np.ndarray,
    distance_km: np.ndarray,
    *,
    p_tx_dbw: float,
    losses_db: float,
    g_rx_dbi: float,
    frequency_hz: float,
    noise_temperature_k: float,
) -> np.ndarray:
    """C/N0 (dB-Hz, eq. 22-24): P_tx - L_tx + G_tx + G_rx - FSL - 10 log10(k T)."""
    if not noise_temperature_k > 0.0:
        raise ValueError(f"noise temperature must be positive (K); got {noise_temperature_k!r}")
    eirp = p_tx_dbw - losses_db + np.asarray(gain_tx_dbi)
    return (
        eirp
        + g_rx_dbi
        - free_space_loss_db(distance_km, frequency_hz)
        - 10.0 * np.log10(BOLTZMANN_J_K * noise_temperature_k)
    )


def _position_block(los_hat, visible, clock_column: bool):
    """(entries of the position block of (G^T G)^-1, ok, enough) from lines of sight (..., n, 3)."""
    los = np.asarray(los_hat, dtype=float)
    n_vis, entries = normal_matrix_entries(
        los[..., 0], los[..., 1], los[..., 2], visible, axis=-1, clock_column=clock_column
    )
    *inverse, ok = position_block_inverse(*entries)
    return inverse, ok, n_vis >= (MIN_VISIBLE if clock_column else MIN_VISIBLE - 1)


def pdop_kernel(los_hat: np.ndarray, visible: np.ndarray, clock_column: bool = True) -> np.ndarray:
    """PDOP (eq. 5-7) from unit lines of sight (..., n, 3) and a visibility mask (..., n).

    The position block of (G^T G)^-1 comes from :mod:`lnss_lib.geometry` (centred Schur complement
    of the clock column; without it, A^-1 with A = sum_k l_k l_k^T). PDOP = sqrt(trace); NaN with
    fewer than 4 visible (3 without clock column), inf for a singular geometry.
    """
    (ixx, iyy, izz, _, _, _), ok, enough = _position_block(los_hat, visible, clock_column)
    pdop = np.where(ok, np.sqrt(np.maximum(ixx + iyy + izz, 0.0)), np.inf)
    return np.where(enough, pdop, np.nan)


def pdop_along_axis(
    los_hat: np.ndarray, visible: np.ndarray, axis_hat: np.ndarray, clock_column: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Split PDOP into the error along ``axis_hat`` (..., 3) and across it: (sigma_along, sigma_across).

    sigma_along^2 = a^T Q a and sigma_across^2 = PDOP^2 - sigma_along^2 with Q the position block of
    (G^T G)^-1 (see :func:`pdop_kernel`); NaN where PDOP is undefined or the geometry singular.
    Taking ``axis_hat`` toward the Earth shows the range / clock degeneracy of nearly parallel
    lines of sight: with the clock column almost all of the PDOP lies along it.
    """
    (qxx, qyy, qzz, qxy, qxz, qyz), ok, enough = _position_block(los_hat, visible, clock_column)
    a = np.broadcast_to(np.asarray(axis_hat, dtype=float), qxx.shape + (3,))
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    along2 = (
        ax * ax * qxx
        + ay * ay * qyy
        + az * az * qzz
        + 2.0 * (ax * ay * qxy + ax * az * qxz + ay * az * qyz)
    )
    total2 = qxx + qyy + qzz
    defined = ok & enough
    along = np.where(defined, np.sqrt(np.maximum(along2, 0.0)), np.nan)
    across = np.where(defined, np.sqrt(np.clip(total2 - along2, 0.0, None)), np.nan)
    return along, across


# --------------------------------------------------------------------------------------------
# Orchestration
# --------------------------------------------------------------------------------------------


def _lnss_positions(lnss, times: np.ndarray) -> np.ndarray:
    """(sat, time, 3) Moon-centred J2000 km from a propagation Dataset or an array on ``times``."""
    if isinstance(lnss, xr.Dataset):
        if not np.allclose(lnss["time"].values, times, rtol=0.0, atol=1e-3):
            raise ValueError(
                "LNSS and GPS epochs differ: compute gps_states_mci on the propagation's time coord"
            )
        return lnss["r_mci_km"].transpose("sat", "time", "xyz").values
    r = np.asarray(lnss, dtype=float)
    if r.ndim == 2:
        r = r[None]
    if r.ndim != 3 or r.shape[1:] != (times.size, 3):
        raise ValueError(f"LNSS positions must have shape (sat, {times.size}, 3); got {r.shape}")
    return r


def _link_settings(gps: GpsSettings, overrides: dict) -> tuple[GpsSettings, GainPattern]:
    """``[gps]`` with ``overrides`` (any ``[gps]`` key, numbers of a float key as floats) and the transmit pattern
    (``overrides["gain"]`` or ``[gps]``'s); ``ValueError`` for an unknown key."""
    names = [item.name for item in dataclasses.fields(gps) if item.init]
    unknown = set(overrides) - set(names) - {"gain"}
    if unknown:
        raise ValueError(
            f"unknown GPS link setting(s) {sorted(unknown)}; allowed: {sorted(names)} or 'gain'"
        )
    changed = {
        k: float(v) if isinstance(getattr(gps, k), float) and not isinstance(v, bool) else v
        for k, v in overrides.items()
        if k != "gain"
    }
    cfg = dataclasses.replace(gps, **changed) if changed else gps
    return cfg, overrides.get("gain") or gain_for_settings(cfg)


_GPS_ARRAYS: dict[int, tuple] = {}


def _gps_arrays(gps: xr.Dataset) -> tuple:
    """(gps dataset, r_mci, r_eci, r_teme (1, time, gps, 3), earth (1, time, 1, 3), rot) pulled out of the
    Dataset once per dataset (the reference kept in the tuple pins the id)."""
    hit = _GPS_ARRAYS.get(id(gps))
    if hit is not None and hit[0] is gps:
        return hit
    if len(_GPS_ARRAYS) >= 8:
        _GPS_ARRAYS.clear()
    arrays = (
        gps,
        *(
            np.ascontiguousarray(gps[name].transpose("time", "gps", "xyz").values[None])
            for name in ("r_mci_km", "r_eci_km", "r_teme_km")
        ),
        gps["earth_mci_km"].values[None, :, None, :],
        gps["rot_teme_to_j2000"].values,
    )
    _GPS_ARRAYS[id(gps)] = arrays
    return arrays


def _link_arrays(
    constants: BodyConstants,
    cfg: GpsSettings,
    gain: GainPattern,
    gps_states: xr.Dataset,
    r_lnss: np.ndarray,
) -> dict:
    """Every array of :func:`gps_link` for LNSS positions ``r_lnss`` (sat, time, 1, 3), Moon-centred J2000 km."""
    _, r_gps_mci, r_gps_eci, r_gps_teme, earth, rot = _gps_arrays(gps_states)
    r_lnss_eci = r_lnss - earth
    r_lnss_teme = np.einsum("tji,stgj->stgi", rot, r_lnss_eci)
    moon_blocked = lunar_occultation(r_lnss, r_gps_mci, constants.r_moon_mean_km)
    theta = off_boresight_deg(r_gps_eci, r_lnss_eci)
    earth_blocked = earth_occultation(
        theta, r_gps_eci, constants.r_earth_km, cfg.atmosphere_margin_deg
    )
    ellipsoid_blocked = (
        ray_hits_ellipsoid(r_gps_teme, r_lnss_teme, WGS84_A_KM, WGS84_B_KM)
        if cfg.ellipsoid_test
        else np.zeros_like(theta, bool)
    )
    outside_beam = theta > cfg.beam_mask_deg
    los = r_gps_mci - r_lnss
    range_km = np.linalg.norm(los, axis=-1)
    g_tx = gain(theta)
    cn0 = cn0_dbhz(
        g_tx,
        range_km,
        p_tx_dbw=cfg.p_tx_dbw,
        losses_db=cfg.l_tx_db + cfg.l_pol_db,
        g_rx_dbi=cfg.g_rx_dbi,
        frequency_hz=cfg.frequency_mhz * 1e6,
        noise_temperature_k=cfg.noise_temperature_k,
    )
    strong = np.nan_to_num(cn0, nan=-np.inf) >= cfg.cn0_threshold_dbhz
    visible = ~moon_blocked & ~earth_blocked & ~ellipsoid_blocked & ~outside_beam & strong
    pdop = pdop_kernel(los / range_km[..., None], visible, bool(cfg.clock_column))
    return {
        "theta_off_deg": theta,
        "range_km": range_km,
        "gain_dbi": g_tx,
        "cn0_dbhz": cn0,
        "moon_blocked": moon_blocked,
        "earth_blocked": earth_blocked,
        "ellipsoid_blocked": ellipsoid_blocked,
        "outside_beam": outside_beam,
        "above_threshold": strong,
        "visible": visible,
        "pdop": pdop,
    }


@nb.njit(cache=True)
def _link_kernel(
    r_lnss,
    r_gps_mci,
    r_gps_eci,
    r_gps_teme,
    earth,
    rot,
    theta_tab,
    gain_tab,
    r_moon,
    r_earth,
    margin_deg,
    beam_deg,
    ellipsoid,
    a_km,
    b_km,
    eirp_base_db,
    fsl_factor,
    noise_db,
    threshold_dbhz,
    clock,
    n_visible,
    pdop,
):
    """:func:`_link_arrays`'s visibility (eq. 15-24) and PDOP (eq. 5-7) for one LNSS satellite ``r_lnss`` (time, 3),
    one (epoch, GPS) pair at a time, into ``n_visible`` and ``pdop`` (time,)."""
    ntime, ngps, _ = r_gps_mci.shape
    lx = np.empty(ngps)
    ly = np.empty(ngps)
    lz = np.empty(ngps)
    lnss_teme = np.empty(3)
    for t in range(ntime):
        px, py, pz = r_lnss[t, 0], r_lnss[t, 1], r_lnss[t, 2]
        r_norm = np.sqrt(px * px + py * py + pz * pz)
        zx, zy, zz = px / r_norm, py / r_norm, pz / r_norm
        alpha_moon = np.degrees(np.arcsin(min(max(r_moon / r_norm, -1.0), 1.0)))
        ex, ey, ez = px - earth[t, 0], py - earth[t, 1], pz - earth[t, 2]
        for i in range(3):
            lnss_teme[i] = rot[t, 0, i] * ex + rot[t, 1, i] * ey + rot[t, 2, i] * ez
        n = 0
        for g in range(ngps):
            ux = r_gps_mci[t, g, 0] - px
            uy = r_gps_mci[t, g, 1] - py
            uz = r_gps_mci[t, g, 2] - pz
            rng = np.sqrt(ux * ux + uy * uy + uz * uz)
            ux /= rng
            uy /= rng
            uz /= rng
            if (
                np.degrees(np.arccos(min(max(-(ux * zx + uy * zy + uz * zz), -1.0), 1.0)))
                < alpha_moon
            ):
                continue  # behind the Moon (eq. 17-18)
            gx, gy, gz = r_gps_eci[t, g, 0], r_gps_eci[t, g, 1], r_gps_eci[t, g, 2]
            g_norm = np.sqrt(gx * gx + gy * gy + gz * gz)
            vx, vy, vz = ex - gx, ey - gy, ez - gz
            v_norm = np.sqrt(vx * vx + vy * vy + vz * vz)
            cos_off = -(gx * vx + gy * vy + gz * vz) / (g_norm * v_norm)
            theta = np.degrees(np.arccos(min(max(cos_off, -1.0), 1.0)))  # off-boresight (eq. 19-20)
            if theta > beam_deg or theta < np.degrees(np.arcsin(r_earth / g_norm)) + margin_deg:
                continue  # outside the beam, or behind the Earth (eq. 21)
            if ellipsoid and segment_hits_ellipsoid(r_gps_teme[t, g], lnss_teme, a_km, b_km):
                continue  # through the WGS-84 ellipsoid
            if theta < theta_tab[0] or theta > theta_tab[-1]:
                continue  # no gain tabulated: no link
            cn0 = (
                eirp_base_db
                + np.interp(theta, theta_tab, gain_tab)
                - 20.0 * np.log10(fsl_factor * rng)
                - noise_db
            )
            if not cn0 >= threshold_dbhz:
                continue  # link budget (eq. 22-24)
            lx[n] = ux
            ly[n] = uy
            lz[n] = uz
            n += 1
        n_visible[t] = n
        if n < (MIN_VISIBLE if clock else MIN_VISIBLE - 1):
            pdop[t] = np.nan
            continue
        mx = my = mz = 0.0
        if clock:
            for k in range(n):
                mx += lx[k]
                my += ly[k]
                mz += lz[k]
            mx /= n
            my /= n
            mz /= n
        sxx = syy = szz = sxy = sxz = syz = 0.0
        for k in range(n):
            x, y, z = lx[k] - mx, ly[k] - my, lz[k] - mz
            sxx += x * x
            syy += y * y
            szz += z * z
            sxy += x * y
            sxz += x * z
            syz += y * z
        ixx, iyy, izz, _, _, _, ok = block_inverse(sxx, syy, szz, sxy, sxz, syz)
        pdop[t] = np.sqrt(max(ixx + iyy + izz, 0.0)) if ok else np.inf


def gps_link_metrics(
    gps: GpsSettings, constants: BodyConstants, gps_states: xr.Dataset, r_lnss_mci_km: np.ndarray
) -> dict[str, float]:
    """:func:`gps_link_summary` of :func:`gps_link` (first satellite) without the Dataset: the campaign's path.

    ``r_lnss_mci_km`` (sat, time, 3) on the GPS dataset's epochs; the first satellite is used, as in
    the paper. One compiled pass (:func:`_link_kernel`) with :func:`gps_link`'s tests in its order;
    libm and numpy's vectorised arccos/log10 may round differently, so the metrics agree to ~1e-12
    unless a link sits exactly on a threshold (``tests/test_gps.py`` checks the agreement).
    """
    cfg, gain = gps, gain_for_settings(gps)
    r = np.ascontiguousarray(_lnss_positions(r_lnss_mci_km, gps_states["time"].values)[0])
    _, r_gps_mci, r_gps_eci, r_gps_teme, earth, rot = _gps_arrays(gps_states)
    wavelength_m = C_M_S / (cfg.frequency_mhz * 1e6)
    ntime = r.shape[0]
    n_visible = np.full(ntime, -1, dtype=np.int64)  # -1: not computed (checked after the kernel)
    pdop = np.full(ntime, np.nan)
    _link_kernel(
        r,
        r_gps_mci[0],
        r_gps_eci[0],
        r_gps_teme[0],
        np.ascontiguousarray(earth[0, :, 0]),
        rot,
        np.asarray(gain.off_boresight_deg, dtype=float),
        np.asarray(gain.gain_dbi, dtype=float),
        constants.r_moon_mean_km,
        constants.r_earth_km,
        cfg.atmosphere_margin_deg,
        cfg.beam_mask_deg,
        cfg.ellipsoid_test,
        WGS84_A_KM,
        WGS84_B_KM,
        cfg.p_tx_dbw - (cfg.l_tx_db + cfg.l_pol_db) + cfg.g_rx_dbi,
        4.0 * np.pi * 1e3 / wavelength_m,
        10.0 * np.log10(BOLTZMANN_J_K * cfg.noise_temperature_k),
        cfg.cn0_threshold_dbhz,
        cfg.clock_column,
        n_visible,
        pdop,
    )
    if np.any(n_visible < 0):
        raise RuntimeError(
            f"the GPS link kernel left {int(np.sum(n_visible < 0))} of {ntime} epochs not computed"
        )
    return _summary(pdop[None], n_visible[None], cfg.pdop_filter)


def gps_link(
    gps: GpsSettings,
    constants: BodyConstants,
    gps_states: xr.Dataset,
    lnss,
    *,
    sats="first",
    **overrides,
) -> xr.Dataset:
    """GPS-LNSS visibility, C/N0 and PDOP (eq. 15-24, Section 2.2.4) on the GPS dataset's epochs.

    ``gps``: the ``[gps]`` section; ``constants``: the Moon's and the Earth's radii; ``gps_states``: from
    :func:`gps_states_mci`; ``lnss``: a propagation Dataset (``r_mci_km`` (sat, time,
    xyz)) or an array (sat, time, 3) of Moon-centred J2000 km. ``sats``: "first" (the paper's
    choice), "all", or a list of satellite indices. ``overrides``: any ``[gps]`` key (e.g.
    ``noise_temperature_k=150``, ``beam_mask_deg=60``, ``clock_column=False``) or ``gain``: a
    :class:`GainPattern`.

    A link is visible when the Moon does not block it (eq. 17-18), theta_off is inside the beam
    mask, the Earth (eq. 21, with the margin) and the WGS-84 ellipsoid do not block it, and
    C/N0 >= the threshold. The ellipsoid test is done in TEME (z along the true pole of date; polar
    motion, ~10 m, neglected). Dataset dims (sat, time, gps): ``theta_off_deg``, ``range_km``,
    ``gain_dbi``, ``cn0_dbhz``, the blocking masks and ``visible``; (sat, time): ``n_visible``,
    ``pdop`` (NaN below 4 visible).
    """
    cfg, gain = _link_settings(gps, overrides)
    times = gps_states["time"].values
    r_all = _lnss_positions(lnss, times)
    if isinstance(sats, str):
        if sats not in ("first", "all"):
            raise ValueError(f"sats must be 'first', 'all' or a list of indices; got {sats!r}")
        index = [0] if sats == "first" else list(range(r_all.shape[0]))
    else:
        index = [int(s) for s in sats]
        if any(s < 0 or s >= r_all.shape[0] for s in index):
            raise ValueError(f"satellite index out of range 0..{r_all.shape[0] - 1}: {index}")
    r_lnss = r_all[index][:, :, None, :]  # (sat, time, 1, 3)
    arrays = _link_arrays(constants, cfg, gain, gps_states, r_lnss)
    visible, pdop = arrays["visible"], arrays["pdop"]
    dims = ("sat", "time", "gps")
    ds = xr.Dataset(
        {
            **{
                name: (dims, arrays[name])
                for name in (
                    "theta_off_deg",
                    "range_km",
                    "gain_dbi",
                    "cn0_dbhz",
                    "moon_blocked",
                    "earth_blocked",
                    "ellipsoid_blocked",
                    "outside_beam",
                    "above_threshold",
                    "visible",
                )
            },
            "n_visible": (("sat", "time"), visible.sum(axis=-1)),
            "pdop": (("sat", "time"), pdop),
        },
        coords={
            "sat": index,
            "time": times,
            "gps": gps_states["gps"].values,
            "prn": ("gps", gps_states["prn"].values),
            "name": ("gps", gps_states["name"].values),
        },
        attrs={
            "gain_pattern": gain.source,
            "noise_temperature_k": cfg.noise_temperature_k,
            "beam_mask_deg": cfg.beam_mask_deg,
            "clock_column": int(cfg.clock_column),
            "cn0_threshold_dbhz": cfg.cn0_threshold_dbhz,
            "pdop_filter": cfg.pdop_filter,
            "frame": "Moon-centred J2000",
            "time_scale": "TDB seconds past J2000",
        },
    )
    ds["pdop"].attrs["long_name"] = "GPS-LNSS PDOP (eq. 5-7), NaN with fewer than 4 visible"
    ds["cn0_dbhz"].attrs["long_name"] = "C/N0 at the LNSS receiver (eq. 24), dB-Hz"
    return ds


def gps_link_summary(ds: xr.Dataset, pdop_filter: str | None = None) -> dict[str, float]:
    """Means over every (sat, time) sample of :func:`gps_link`'s result.

    ``gps_visible_mean``: visible GPS satellites averaged over all epochs, zeros included;
    ``gps_pdop_mean``: filtered mean PDOP (:func:`filtered_mean`, default the dataset's filter)
    over the epochs with >= 4 visible; also the unfiltered mean and median, the fraction of epochs
    with a PDOP and the number of samples the filter kept.
    """
    return _summary(
        ds["pdop"].values, ds["n_visible"].values, pdop_filter or ds.attrs["pdop_filter"]
    )


def _summary(pdop: np.ndarray, n_visible: np.ndarray, method: str) -> dict[str, float]:
    mean, kept = filtered_mean(pdop, method)
    finite = pdop[np.isfinite(pdop)]
    return {
        "gps_visible_mean": float(np.mean(n_visible)),
        "gps_pdop_mean": mean,
        "gps_pdop_unfiltered_mean": float(finite.mean()) if finite.size else float("nan"),
        "gps_pdop_median": float(np.median(finite)) if finite.size else float("nan"),
        "gps_pdop_available_fraction": float(np.isfinite(pdop).mean()),
        "gps_pdop_samples_kept": kept,
    }
