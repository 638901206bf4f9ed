"""Every GNSS at the Moon: Galileo, BeiDou-3 and GLONASS beside GPS (the paper's closing remark, Section 7).

Three parts, on top of the GPS link of :mod:`lnss_lib.gps` (eq. 15-24), which stays as it is:

* **Nominal constellations** (:func:`load_nominal_slots`, :func:`nominal_positions_teme`): each
  system's published reference slots (``params/data/gnss/nominal_slots.toml``: Walker patterns, the
  BeiDou IGSO and GEO slots), circular orbits propagated as Kepler plus the J2 secular rates of the
  node and the argument of latitude, in TEME (the equator of date and the Greenwich angle of SGP4,
  which places the GEO and IGSO slots at their longitudes), then to J2000 and the Moon as the GPS
  states are. Where a document fixes the period rather than the radius (GLONASS, IGSO, GEO) the
  semi-major axis is solved from the ground-track repeat under J2 (:func:`repeat_sma_km`).
  What the model leaves out: J2 short-period terms (about 1.5 J2 R^2 / a, 2 km at MEO) and the
  lunisolar pull (tidal acceleration 2 GM r / d^3, 5e-9 km/s^2 from the Moon at Galileo's radius,
  periodic: ~0.3 km; its node drift, 3/4 (GM_b / d^3) / n cos i from the Moon and the Sun, about 5 %
  of J2's: some 10 km across the orbit in 10 days). At the Moon a 20 km error turns a line of sight
  by 20 / 384 400 rad (11 arcsec) and an off-boresight angle by 20 / 26 000 rad (0.04 deg): far below
  what the nominal-slot assumption itself leaves open (where each real satellite stands in its slot
  at the study epoch).
* **Link budget per system** (:func:`system_transmitters`): each system gets the GPS budget of
  Table 1 (``[gps]``: power, losses, receiver gain, noise temperature, threshold, beam mask,
  occultation tests) with two stated changes. The transmit pattern is the published GPS IIR
  pattern with its angle axis scaled by asin(R_E / a_GPS) / asin(R_E / a): every GNSS antenna is a
  shaped array built to cover the Earth's disc from its own orbit, and no Galileo, BeiDou or GLONASS
  pattern ships with the workbook. The EIRP is shifted by the difference between the system's ICD
  minimum received power and GPS's, carried back to the transmitter through each system's
  edge-of-coverage free-space loss (``[gnss.<system>]``): every system keeps the margin Table 1's
  budget has over its own ICD minimum.
* **Multi-GNSS geometry** (:func:`gnss_link_arrays`, :func:`combined_pdop`): one clock offset per
  system (inter-system biases unknown): eliminating a system's clock centres its lines of sight on
  their mean, so the position block of (G^T G)^-1 is the inverse of the sum of each system's
  centred scatter matrix (with one system it is eq. 5-7 with the clock column, as for GPS). The
  compiled kernel returns each system's visible count and scatter at every epoch; the PDOP of any
  combination of systems is the inverse of their sum.
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numba as nb
import numpy as np
import xarray as xr
from sgp4.propagation import gstime

from .config import data_path
from .constants import (
    BOLTZMANN_J_K,
    C_M_S,
    EARTH_J2,
    MIN_VISIBLE,
    WGS84_A_KM,
    WGS84_B_KM,
    WGS84_GM_KM3_S2,
    WGS84_OMEGA_RAD_S,
)
from .ephemeris import body_states_mci
from .errors import ConfigError
from .frames import teme_to_j2000, tt_centuries, utc_julian_dates
from .gain_pattern import gain_for_settings
from .geometry import block_inverse, filtered_mean
from .gps import segment_hits_ellipsoid
from .gps_states import gps_states_mci

if TYPE_CHECKING:
    from .settings import BodyConstants, GnssSettings, GpsSettings

__all__ = [
    "Shell",
    "load_nominal_slots",
    "secular_rates",
    "nodal_period_s",
    "repeat_period_s",
    "repeat_sma_km",
    "nominal_positions_teme",
    "gnss_states_mci",
    "Transmitters",
    "system_transmitters",
    "gnss_link_arrays",
    "combined_pdop",
    "gnss_link_summary",
]

SHELL_KINDS = ("MEO", "IGSO", "GEO")


@dataclass(frozen=True)
class Shell:
    """One group of a system's nominal slots: circular orbits of one radius and inclination.

    ``raan_deg`` and ``u_deg`` (n,) are the right ascension of the node and the argument of latitude
    of each slot in TEME at the study epoch; ``repeat`` (revolutions, sidereal days) the published
    ground-track repeat; ``published_period_s`` a period the document prints (NaN where none)."""

    system: str
    kind: str
    sma_km: float
    inc_deg: float
    raan_deg: np.ndarray
    u_deg: np.ndarray
    repeat: tuple[int, int]
    published_period_s: float


def secular_rates(sma_km, inc_deg) -> tuple[np.ndarray, np.ndarray]:
    """J2 secular rates (rad/s) of a circular orbit: the node, and the argument of latitude (M + omega).

    Omega_dot = -3/2 n J2 (R/a)^2 cos i; (M + omega)_dot = n (1 + 3/4 J2 (R/a)^2 (8 cos^2 i - 2))
    (the sum of the mean-anomaly and perigee rates for e = 0; Vallado, Section 9.6)."""
    a = np.asarray(sma_km, dtype=float)
    n = np.sqrt(WGS84_GM_KM3_S2 / a**3)
    k = EARTH_J2 * (WGS84_A_KM / a) ** 2
    c = np.cos(np.radians(inc_deg))
    return -1.5 * n * k * c, n * (1.0 + 0.75 * k * (8.0 * c * c - 2.0))


def nodal_period_s(sma_km, inc_deg) -> np.ndarray:
    """Draconic (node-to-node) period under J2, s: 2 pi / (M + omega)_dot."""
    return 2.0 * np.pi / secular_rates(sma_km, inc_deg)[1]


def repeat_period_s(sma_km, inc_deg, revolutions: int, sidereal_days: int) -> np.ndarray:
    """The draconic period a ground track that repeats after ``revolutions`` in ``sidereal_days`` needs, s:
    m 2 pi / (k (omega_E - Omega_dot)) (the Earth turns under the regressing node)."""
    raan_dot, _ = secular_rates(sma_km, inc_deg)
    return sidereal_days * 2.0 * np.pi / (revolutions * (WGS84_OMEGA_RAD_S - raan_dot))


def repeat_sma_km(inc_deg: float, revolutions: int, sidereal_days: int) -> float:
    """Semi-major axis (km) whose J2 draconic period gives the ground-track repeat (fixed-point, to 1 mm)."""
    period_s = (
        sidereal_days * 2.0 * np.pi / (revolutions * WGS84_OMEGA_RAD_S)
    )  # Kepler's first guess
    a = (WGS84_GM_KM3_S2 * (period_s / (2.0 * np.pi)) ** 2) ** (1 / 3)
    for _ in range(50):
        target = float(repeat_period_s(a, inc_deg, revolutions, sidereal_days))
        new = a * (target / float(nodal_period_s(a, inc_deg))) ** (2.0 / 3.0)
        if abs(new - a) < 1e-6:
            return new
        a = new
    raise RuntimeError(
        f"repeat_sma_km: no convergence for i = {inc_deg} deg, {revolutions} rev / {sidereal_days} d"
    )


def _walker(total: int, planes: int, phasing: int) -> tuple[np.ndarray, np.ndarray]:
    """(RAAN, argument of latitude) deg of a Walker T/P/F pattern, plane 1 at RAAN 0 and u 0."""
    per_plane = total // planes
    plane, slot = np.divmod(np.arange(total), per_plane)
    return 360.0 * plane / planes, (
        360.0 * slot / per_plane + 360.0 * phasing * plane / total
    ) % 360.0


def _shell(system: str, table: dict, gmst_deg: float, where: str) -> Shell:
    """A :class:`Shell` of one ``[[<system>.shell]]`` table; ``gmst_deg``: Greenwich angle at the epoch."""
    kind, inc = table.get("kind"), table.get("inc_deg")
    revs, days = table.get("repeat", (0, 0))
    if (
        kind not in SHELL_KINDS
        or not isinstance(inc, float)
        or not 0.0 <= inc <= 180.0
        or revs < 1
        or days < 1
    ):
        raise ConfigError(
            f"{where}: a shell needs kind in {SHELL_KINDS}, inc_deg in [0, 180] and repeat = "
            f"[revolutions, sidereal days] >= 1; got {table!r}",
            key="gnss.nominal_file",
        )
    sma = float(table["sma_km"]) if "sma_km" in table else repeat_sma_km(inc, revs, days)
    if "walker" in table:
        total, planes, phasing = table["walker"]
        if total < 1 or planes < 1 or total % planes:
            raise ConfigError(
                f"{where}: walker = {table['walker']!r}; allowed: [T, P, F] with T a multiple of P",
                key="gnss.nominal_file",
            )
        raan, u = _walker(total, planes, phasing)
    elif kind == "IGSO":
        # one figure-eight track: slot k reaches its ascending node k/count of a sidereal day after slot 0,
        # when the Earth has turned 360 k / count deg more
        step = 360.0 * np.arange(table["count"]) / table["count"]
        raan, u = (table["node_longitude_deg"] + gmst_deg + step) % 360.0, (-step) % 360.0
    elif kind == "GEO":
        lon = np.asarray(table["longitudes_deg"], dtype=float)
        raan, u = np.zeros_like(lon), (lon + gmst_deg) % 360.0
    else:
        raise ConfigError(
            f"{where}: a {kind} shell needs walker = [T, P, F]", key="gnss.nominal_file"
        )
    return Shell(
        system,
        kind,
        sma,
        inc,
        np.asarray(raan, float),
        np.asarray(u, float),
        (int(revs), int(days)),
        float(table.get("draconic_period_s", math.nan)),
    )


def load_nominal_slots(path: str | Path, systems, gmst_deg: float = 0.0) -> list[Shell]:
    """The shells of ``systems`` (any of Galileo, BeiDou, GLONASS) from a nominal-slots TOML file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"nominal slots file not found: {path}", key="gnss.nominal_file")
    data = tomllib.loads(path.read_text())
    shells = []
    for system in systems:
        if system not in data or not data[system].get("shell"):
            there = ", ".join(k for k, v in data.items() if isinstance(v, dict))
            raise ConfigError(
                f"{path}: no [[{system}.shell]] table; systems there: {there}",
                key="gnss.nominal_file",
            )
        shells.extend(
            _shell(system, table, gmst_deg, f"{path} [{system}] shell {k + 1}")
            for k, table in enumerate(data[system]["shell"])
        )
    return shells


def nominal_positions_teme(shells: list[Shell], dt_s) -> np.ndarray:
    """Positions (sat, time, 3) km in TEME of every slot, ``dt_s`` seconds after the epoch: Kepler + J2 secular."""
    dt = np.asarray(dt_s, dtype=float)
    out = []
    for shell in shells:
        raan_dot, u_dot = secular_rates(shell.sma_km, shell.inc_deg)
        raan = np.radians(shell.raan_deg)[:, None] + raan_dot * dt[None, :]
        u = np.radians(shell.u_deg)[:, None] + u_dot * dt[None, :]
        ci, si = math.cos(math.radians(shell.inc_deg)), math.sin(math.radians(shell.inc_deg))
        cu, su, co, so = np.cos(u), np.sin(u), np.cos(raan), np.sin(raan)
        out.append(
            shell.sma_km
            * np.stack([co * cu - so * su * ci, so * cu + co * su * ci, su * si], axis=-1)
        )
    return np.concatenate(out, axis=0)


_STATE_CACHE: dict[str, xr.Dataset] = {}


def gnss_states_mci(gnss: GnssSettings, gps: GpsSettings, start_tdb: str, t_tdb_s) -> xr.Dataset:
    """Positions of every satellite of ``gnss.systems`` at TDB epochs: Dataset (sat, time, xyz) as
    :func:`lnss_lib.gps_states.gps_states_mci` (``r_mci_km``, ``r_eci_km``, ``r_teme_km``,
    ``earth_mci_km``, ``rot_teme_to_j2000``) with coords ``system`` and ``name`` on ``sat``. GPS:
    SGP4 from the ``[gps]`` TLEs (the same states as the GPS link); the others:
    :func:`nominal_positions_teme` from the epoch ``t_tdb_s[0]``, whose Greenwich angle (UT1 taken
    as UTC) places the GEO and IGSO slots."""
    t = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    path = data_path(gnss.nominal_file, "gnss.nominal_file")
    key = hashlib.sha256(
        b"".join(
            [
                path.read_bytes(),
                repr(gnss.systems).encode(),
                repr(gps).encode(),
                start_tdb.encode(),
                t.tobytes(),
            ]
        )
    ).hexdigest()
    if key in _STATE_CACHE:
        return _STATE_CACHE[key]
    if len(_STATE_CACHE) >= 8:
        _STATE_CACHE.clear()
    rot = teme_to_j2000(tt_centuries(t))
    earth = body_states_mci("EARTH", t)[:, :3]
    parts, systems, names = [], [], []
    if "gps" in gnss.systems:
        g = gps_states_mci(gps, start_tdb, t)
        parts.append(g["r_teme_km"].values)
        systems += ["gps"] * g.sizes["gps"]
        names += [str(n) for n in g["name"].values]
    others = [s for s in gnss.systems if s != "gps"]
    if others:
        jd, fr = utc_julian_dates(t[:1])
        shells = load_nominal_slots(path, others, math.degrees(gstime(float(jd[0] + fr[0]))))
        parts.append(nominal_positions_teme(shells, t - t[0]))
        for shell in shells:
            systems += [shell.system] * shell.raan_deg.size
            names += [f"{shell.system} {shell.kind} {k + 1}" for k in range(shell.raan_deg.size)]
    r_teme = np.concatenate(parts, axis=0)
    r_eci = np.einsum("tij,gtj->gti", rot, r_teme)
    ds = xr.Dataset(
        {
            "r_mci_km": (("sat", "time", "xyz"), r_eci + earth[None]),
            "r_eci_km": (("sat", "time", "xyz"), r_eci),
            "r_teme_km": (("sat", "time", "xyz"), r_teme),
            "rot_teme_to_j2000": (("time", "i", "j"), rot),
            "earth_mci_km": (("time", "xyz"), earth),
        },
        coords={
            "sat": np.arange(len(systems)),
            "time": t,
            "xyz": ["x", "y", "z"],
            "system": ("sat", systems),
            "name": ("sat", names),
        },
        attrs={
            "frame": "J2000 (r_mci_km Moon-centred, r_eci_km Earth-centred); r_teme_km TEME",
            "time_scale": "TDB seconds past J2000",
            "nominal_file": str(path),
            "propagator": "GPS: SGP4 from TLEs; others: nominal slots, Kepler + J2 secular rates",
        },
    )
    _STATE_CACHE[key] = ds
    return ds


# --------------------------------------------------------------------------------------------
# Link budget per system
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Transmitters:
    """Per satellite (sat,): system index into ``systems``, the factor on theta_off that reads the GPS pattern
    (``angle_scale``), EIRP plus receiver gain without the pattern (``eirp_rx_db``, dB) and 4 pi / lambda
    (``fsl_per_km``, 1/km: free-space loss = 20 log10(fsl_per_km d))."""

    systems: tuple[str, ...]
    system_index: np.ndarray
    angle_scale: np.ndarray
    eirp_rx_db: np.ndarray
    fsl_per_km: np.ndarray


def _edge_of_coverage(sma_km, elevation_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(range km, nadir angle deg) from a satellite at radius ``sma_km`` to a user on the Earth's equatorial
    sphere who sees it at ``elevation_deg``."""
    a = np.asarray(sma_km, dtype=float)
    ce, se = math.cos(math.radians(elevation_deg)), math.sin(math.radians(elevation_deg))
    return np.sqrt(a * a - (WGS84_A_KM * ce) ** 2) - WGS84_A_KM * se, np.degrees(
        np.arcsin(WGS84_A_KM * ce / a)
    )


def _fsl_per_km(frequency_mhz: float) -> float:
    return 4.0 * np.pi * 1e3 / (C_M_S / (frequency_mhz * 1e6))


def system_transmitters(gnss: GnssSettings, gps: GpsSettings, states: xr.Dataset) -> Transmitters:
    """The per-satellite link terms of :func:`gnss_states_mci`'s satellites (see the module docstring).

    GPS: ``[gps]`` as in the GPS link (scale 1, no shift). Another system: ``[gnss.<system>]`` frequency and
    ICD minimum received power at its edge-of-coverage elevation; the pattern's angle axis scaled by the ratio
    of the Earth's angular radii and the EIRP shifted so that the modelled power at the system's edge of
    coverage exceeds its ICD minimum by what the GPS budget gives GPS over IS-GPS-200's."""
    gain = gain_for_settings(gps)
    ref = gnss.gps
    base = gps.p_tx_dbw - (gps.l_tx_db + gps.l_pol_db) + gps.g_rx_dbi
    alpha_gps = np.degrees(np.arcsin(WGS84_A_KM / ref.sma_km))
    d_gps, eta_gps = _edge_of_coverage(ref.sma_km, ref.edge_elevation_deg)
    fsl_gps = 20.0 * np.log10(_fsl_per_km(gps.frequency_mhz) * d_gps)
    margin_gps = (
        float(gain(eta_gps)) - fsl_gps - ref.min_received_power_dbw
    )  # GPS budget over its ICD minimum
    radius = np.linalg.norm(states["r_teme_km"].values[:, 0, :], axis=-1)
    system = states["system"].values
    index = np.array([gnss.systems.index(s) for s in system], dtype=np.int64)
    scale, shift = np.ones(radius.size), np.zeros(radius.size)
    fsl = np.full(radius.size, _fsl_per_km(gps.frequency_mhz))
    for name in gnss.systems:
        if name == "gps":
            continue
        tx = getattr(gnss, name)
        mask = system == name
        k = alpha_gps / np.degrees(np.arcsin(WGS84_A_KM / radius[mask]))
        d, eta = _edge_of_coverage(radius[mask], tx.edge_elevation_deg)
        f = _fsl_per_km(tx.frequency_mhz)
        # pattern shift so that gain(k eta) + shift - FSL(d) - P_min = the GPS margin
        shift[mask] = (
            margin_gps + tx.min_received_power_dbw + 20.0 * np.log10(f * d) - gain(k * eta)
        )
        scale[mask], fsl[mask] = k, f
    if np.any(~np.isfinite(shift)):
        raise ConfigError(
            "an edge-of-coverage angle falls outside the gain pattern's table; widen the pattern "
            "file or lower [gnss.<system>] edge_elevation_deg",
            key="gps.gain_file",
        )
    return Transmitters(tuple(gnss.systems), index, scale, base + shift, fsl)


# --------------------------------------------------------------------------------------------
# The compiled multi-system link
# --------------------------------------------------------------------------------------------

_ARRAYS: dict[int, tuple] = {}


def _satellite_arrays(states: xr.Dataset, margin_deg: float, r_earth_km: float) -> tuple:
    """What the kernel reads of the satellites, independent of the LNSS, prepared once per states Dataset and
    Earth margin (the reference kept in the tuple pins the id): positions (time, sat, 3) Moon-centred and in TEME,
    the unit boresight -r / |r| negated (time, sat, 3) and the cosine of the Earth's angular radius plus the
    margin seen from the satellite (time, sat)."""
    key = id(states)
    hit = _ARRAYS.get(key)
    if hit is not None and hit[0] is states and hit[1] == (margin_deg, r_earth_km):
        return hit[2]
    if len(_ARRAYS) >= 8:
        _ARRAYS.clear()
    r_mci, r_eci, r_teme = (
        np.ascontiguousarray(states[name].transpose("time", "sat", "xyz").values)
        for name in ("r_mci_km", "r_eci_km", "r_teme_km")
    )
    norm = np.linalg.norm(r_eci, axis=-1)
    cos_earth = np.cos(np.arcsin(r_earth_km / norm) + np.radians(margin_deg))
    arrays = (
        r_mci,
        np.ascontiguousarray(r_eci / norm[..., None]),
        np.ascontiguousarray(cos_earth),
        r_teme,
        np.ascontiguousarray(states["earth_mci_km"].values),
        np.ascontiguousarray(states["rot_teme_to_j2000"].values),
    )
    _ARRAYS[key] = (states, (margin_deg, r_earth_km), arrays)
    return arrays


@nb.njit(cache=True)
def _gnss_kernel(
    r_lnss,
    r_mci,
    out_hat,
    cos_earth,
    r_teme,
    earth,
    rot,
    system,
    cos_beam,
    angle_scale,
    eirp_rx_db,
    fsl_per_km,
    n_systems,
    theta_tab,
    gain_tab,
    r_moon,
    ellipsoid,
    a_km,
    b_km,
    noise_db,
    threshold_dbhz,
    clock,
    counts,
    scatter,
):
    """Visibility (eq. 15-24, the tests of :func:`lnss_lib.gps.gps_link` with cosines compared in place of
    angles) of every (epoch, satellite) pair for one LNSS satellite ``r_lnss`` (time, 3); per epoch and system
    the visible count (``counts`` (time, system)) and the scatter of the lines of sight about the system's mean
    (about 0 without the clock column): ``scatter`` (time, system, 6) xx, yy, zz, xy, xz, yz. ``out_hat``: unit
    Earth -> satellite; ``cos_earth``: cos(Earth's angular radius + margin) from the satellite (eq. 21)."""
    ntime, nsat, _ = r_mci.shape
    lx = np.empty(nsat)
    ly = np.empty(nsat)
    lz = np.empty(nsat)
    ls = np.empty(nsat, np.int64)
    mean = np.zeros((n_systems, 3))
    lnss_teme = np.empty(3)
    for t in range(ntime):
        px, py, pz = r_lnss[t, 0], r_lnss[t, 1], r_lnss[t, 2]
        r_norm = np.sqrt(px * px + py * py + pz * pz)
        zx, zy, zz = px / r_norm, py / r_norm, pz / r_norm
        s_moon = min(r_moon / r_norm, 1.0)
        cos_moon = np.sqrt(1.0 - s_moon * s_moon)  # cos of the Moon's angular radius
        if ellipsoid:
            ex, ey, ez = px - earth[t, 0], py - earth[t, 1], pz - earth[t, 2]
            for i in range(3):
                lnss_teme[i] = rot[t, 0, i] * ex + rot[t, 1, i] * ey + rot[t, 2, i] * ez
        n = 0
        for g in range(nsat):
            ux = r_mci[t, g, 0] - px
            uy = r_mci[t, g, 1] - py
            uz = r_mci[t, g, 2] - pz
            rng = np.sqrt(ux * ux + uy * uy + uz * uz)
            ux /= rng
            uy /= rng
            uz /= rng
            cos_off = (
                out_hat[t, g, 0] * ux + out_hat[t, g, 1] * uy + out_hat[t, g, 2] * uz
            )  # boresight, sat -> LNSS
            if cos_off < cos_beam[g]:
                continue  # outside the beam mask
            if cos_off > cos_earth[t, g]:
                continue  # behind the Earth + margin (eq. 21)
            if -(ux * zx + uy * zy + uz * zz) > cos_moon:
                continue  # behind the Moon (eq. 17-18)
            if ellipsoid and segment_hits_ellipsoid(r_teme[t, g], lnss_teme, a_km, b_km):
                continue  # through the WGS-84 ellipsoid
            theta = np.degrees(np.arccos(min(max(cos_off, -1.0), 1.0))) * angle_scale[g]
            if theta < theta_tab[0] or theta > theta_tab[-1]:
                continue  # no gain tabulated: no link
            cn0 = (
                eirp_rx_db[g]
                + np.interp(theta, theta_tab, gain_tab)
                - 20.0 * np.log10(fsl_per_km[g] * rng)
                - noise_db
            )
            if not cn0 >= threshold_dbhz:
                continue  # link budget (eq. 22-24)
            lx[n] = ux
            ly[n] = uy
            lz[n] = uz
            ls[n] = system[g]
            n += 1
        for s in range(n_systems):
            counts[t, s] = 0
            mean[s, 0] = mean[s, 1] = mean[s, 2] = 0.0
            for j in range(6):
                scatter[t, s, j] = 0.0
        for k in range(n):
            counts[t, ls[k]] += 1
        if clock:
            for k in range(n):
                mean[ls[k], 0] += lx[k]
                mean[ls[k], 1] += ly[k]
                mean[ls[k], 2] += lz[k]
            for s in range(n_systems):
                if counts[t, s] > 0:
                    mean[s, 0] /= counts[t, s]
                    mean[s, 1] /= counts[t, s]
                    mean[s, 2] /= counts[t, s]
        for k in range(n):
            s = ls[k]
            x, y, z = lx[k] - mean[s, 0], ly[k] - mean[s, 1], lz[k] - mean[s, 2]
            scatter[t, s, 0] += x * x
            scatter[t, s, 1] += y * y
            scatter[t, s, 2] += z * z
            scatter[t, s, 3] += x * y
            scatter[t, s, 4] += x * z
            scatter[t, s, 5] += y * z


@nb.njit(cache=True)
def _combined_pdop_kernel(counts, scatter, members, clock, pdop):
    """PDOP (time,) of the systems with ``members[s]`` true: the position block of (G^T G)^-1 with one clock
    column per system that has a visible satellite is the inverse of the sum of their centred scatters;
    NaN with fewer visible than unknowns (3 + clocks), inf for a singular geometry."""
    ntime, nsys = counts.shape
    for t in range(ntime):
        n = 0
        clocks = 0
        sxx = syy = szz = sxy = sxz = syz = 0.0
        for s in range(nsys):
            if not members[s] or counts[t, s] == 0:
                continue
            n += counts[t, s]
            clocks += 1
            sxx += scatter[t, s, 0]
            syy += scatter[t, s, 1]
            szz += scatter[t, s, 2]
            sxy += scatter[t, s, 3]
            sxz += scatter[t, s, 4]
            syz += scatter[t, s, 5]
        if n < (MIN_VISIBLE - 1 + clocks if clock else MIN_VISIBLE - 1):
            pdop[t] = np.nan
            continue
        ixx, iyy, izz, _, _, _, ok = block_inverse(sxx, syy, szz, sxy, sxz, syz)
        pdop[t] = np.sqrt(max(ixx + iyy + izz, 0.0)) if ok else np.inf


def gnss_link_arrays(
    gps: GpsSettings,
    constants: BodyConstants,
    states: xr.Dataset,
    tx: Transmitters,
    r_lnss_mci_km: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(counts (time, system), scatter (time, system, 6)) of one LNSS satellite ``r_lnss_mci_km`` (time, 3)
    on the states' epochs: the compiled pass over every (epoch, satellite) pair (:func:`_gnss_kernel`) with the
    ``[gps]`` receiver, beam mask, occultation tests and gain pattern and the transmitters ``tx``."""
    gain = gain_for_settings(gps)
    arrays = _satellite_arrays(states, gps.atmosphere_margin_deg, constants.r_earth_km)
    ntime, nsys = states.sizes["time"], len(tx.systems)
    counts = np.full(
        (ntime, nsys), -1, dtype=np.int64
    )  # -1: not computed (checked after the kernel)
    scatter = np.zeros((ntime, nsys, 6))
    cos_beam = np.cos(np.radians(np.minimum(gps.beam_mask_deg / tx.angle_scale, 180.0)))
    _gnss_kernel(
        np.ascontiguousarray(r_lnss_mci_km, dtype=float),
        *arrays,
        tx.system_index,
        cos_beam,
        tx.angle_scale,
        tx.eirp_rx_db,
        tx.fsl_per_km,
        nsys,
        np.asarray(gain.off_boresight_deg, dtype=float),
        np.asarray(gain.gain_dbi, dtype=float),
        constants.r_moon_mean_km,
        gps.ellipsoid_test,
        WGS84_A_KM,
        WGS84_B_KM,
        10.0 * np.log10(BOLTZMANN_J_K * gps.noise_temperature_k),
        gps.cn0_threshold_dbhz,
        gps.clock_column,
        counts,
        scatter,
    )
    if np.any(counts < 0):
        raise RuntimeError(
            f"the GNSS link kernel left {int(np.sum(counts[:, 0] < 0))} of {ntime} epochs not computed"
        )
    return counts, scatter


def combined_pdop(
    counts: np.ndarray, scatter: np.ndarray, systems, members, clock_column: bool = True
) -> np.ndarray:
    """PDOP (time,) of the systems named in ``members`` (a subset of ``systems``, the columns of ``counts``)."""
    unknown = set(members) - set(systems)
    if unknown or not members:
        raise ValueError(
            f"PDOP members {sorted(unknown) or members!r} not among the link's systems {list(systems)}"
        )
    pdop = np.empty(counts.shape[0])
    _combined_pdop_kernel(
        counts, scatter, np.array([s in members for s in systems]), bool(clock_column), pdop
    )
    return pdop


def gnss_link_summary(
    counts: np.ndarray,
    scatter: np.ndarray,
    systems,
    combinations: dict[str, tuple[str, ...]],
    pdop_filter: str,
    clock_column: bool = True,
) -> dict[str, dict[str, float]]:
    """Per system and per named combination of systems: ``visible_mean`` (mean over epochs, zeros included),
    ``pdop_mean`` (:func:`lnss_lib.geometry.filtered_mean` with ``pdop_filter``) and
    ``pdop_available_fraction`` (epochs with a PDOP)."""
    groups = {name: (name,) for name in systems} | dict(combinations)
    out = {}
    for label, members in groups.items():
        pdop = combined_pdop(counts, scatter, systems, members, clock_column)
        columns = [list(systems).index(m) for m in members]
        out[label] = {
            "visible_mean": float(counts[:, columns].sum(axis=1).mean()),
            "pdop_mean": filtered_mean(pdop, pdop_filter)[0],
            "pdop_available_fraction": float(np.isfinite(pdop).mean()),
        }
    return out
