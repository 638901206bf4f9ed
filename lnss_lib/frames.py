"""Frames, rotations and time scales (one model per section, skyfield's ``precessionlib`` pattern).

* **Element frames** (:data:`ELEMENT_FRAMES`, :func:`element_frame_to_j2000`): the frame in which a
  constellation's Keplerian elements are given (lunar equator of epoch, J2000, or the Moon
  orbital-plane frame ``moon_op`` of Ely 2005 / LuPNT).
* **Moon-fixed rotation** (:func:`rotate_to_moon_fixed`, :func:`rotate_with`): Moon-centred J2000
  to the ``frames.moon_fixed`` frame through SPICE, or (:func:`moon_fixed_rotations`) from the force model's
  tabulated rotation when the Moon-fixed frame is fixed to the gravity frame.
* **RTN** (:func:`rtn_basis`, :func:`to_rtn`, :func:`from_rtn`): radial, transverse, normal axes
  of an orbit state (the axes of the Gauss equations, :mod:`lnss_lib.gve`).
* **Time scales and TEME -> J2000** (paper Section 2.2, for SGP4's GPS states): SGP4 gives positions
  in TEME (true equator, mean equinox of date) at UTC epochs. TDB -> UTC goes through SPICE
  ``deltet`` and TDB -> TT through ``unitim``. r_J2000 = P^T N^T R3(-EqE) r_TEME with IAU-1976
  precession (P), IAU-1980 nutation (N) truncated to its 13 terms of amplitude >= 10 mas, and the
  1982 equation of the equinoxes EqE = dpsi cos(eps_mean) (the TEME convention of Vallado et al.
  2006). The 93 skipped nutation terms sum to at most :data:`NUTATION_SKIPPED_DPSI_MAS` in longitude
  and :data:`NUTATION_SKIPPED_DEPS_MAS` in obliquity, a frame error below 0.12 arcsec (15 m at GPS
  radius); the IAU-1976/1980 models themselves differ from IAU-2006/2000A by up to about 0.1 arcsec
  (about 10 m) and the J2000/ICRF frame bias (23 mas) is ignored as SPICE does. All of this is far
  below the error of SGP4 itself (kilometres).

Units and frames are in the names; times are TDB seconds past J2000 (SPICE ET).
"""

from __future__ import annotations

import numpy as np
import spiceypy as spice

from .constants import ARCSEC_RAD, SECONDS_PER_DAY, SECONDS_PER_JULIAN_CENTURY
from .ephemeris import EphemerisTable, body_states_mci, ensure_kernels, rotation, spice_errors
from .sections import ELEMENT_FRAMES, POLE_FRAMES
from .settings import Dynamics

__all__ = [
    "ELEMENT_FRAMES",
    "POLE_FRAMES",
    "element_frame_to_j2000",
    "moon_op_axes_j2000",
    "orbit_plane_axes_j2000",
    "moon_op_to_j2000",
    "FIXED_OFFSET_TOLERANCE",
    "fixed_offset",
    "moon_fixed_rotations",
    "rotate_to_moon_fixed",
    "rotate_with",
    "latitude_deg",
    "rtn_basis",
    "to_rtn",
    "from_rtn",
    "J2000_JD",
    "NUTATION_SKIPPED_DPSI_MAS",
    "NUTATION_SKIPPED_DEPS_MAS",
    "utc_julian_dates",
    "tt_centuries",
    "precession_iau1976",
    "mean_obliquity_iau1980",
    "nutation_iau1980",
    "nutation_matrix",
    "teme_to_j2000",
]

J2000_JD = 2451545.0

# ---------------------------------------------------------------------------------------------
# Element frames and the Moon-fixed frame
# ---------------------------------------------------------------------------------------------


def element_frame_to_j2000(
    dynamics: Dynamics, t_epoch_tdb_s: float, frame: str | None = None
) -> np.ndarray:
    """Rotation from an element frame (default: ``frames.element_frame``) to J2000 (x_j2000 = R x_elements).

    ``lunar_equator_of_epoch``: the Moon-fixed frame (``frames.moon_fixed``) frozen at the epoch,
    so inclinations are to the lunar equator and RAAN is counted from the prime meridian at epoch.
    ``j2000``: identity (elements in the Earth's mean equator and equinox of J2000).
    ``moon_op``: the Moon orbital-plane frame built at the epoch (:func:`moon_op_to_j2000`).
    ``dynamics`` gives the frames and the kernels (loaded here when needed).
    """
    frame = dynamics.frames.element_frame if frame is None else frame
    if frame == "j2000":
        return np.eye(3)
    if frame == "lunar_equator_of_epoch":
        ensure_kernels(dynamics.ephemeris)
        return rotation(dynamics.frames.moon_fixed, "J2000", t_epoch_tdb_s)[0]
    if frame == "moon_op":
        ensure_kernels(dynamics.ephemeris)
        return moon_op_to_j2000(float(t_epoch_tdb_s))
    raise ValueError(
        f"unknown element frame {frame!r}; allowed: {', '.join(map(repr, ELEMENT_FRAMES))}"
    )


# ---------------------------------------------------------------------------------------------
# The Moon orbital-plane element frame ``moon_op`` (Ely 2005, pp. 303-304; LuPNT ``MOON_OP``).
#
# Construction at an epoch t, from the Earth's geometric state relative to the Moon in J2000 (DE421
# through SPICE) and the lunar pole:
#
# - z = unit(r_E x v_E): normal of the Earth's instantaneous (osculating) orbit about the Moon, which
#   is the normal of the Moon's orbit about the Earth;
# - x = unit(p x z), p = z-axis of ``MOON_ME`` in J2000: x lies along the intersection of the lunar
#   equator and the Earth's apparent orbit plane (the node of the orbit on the lunar equator);
# - y = z x x.
#
# The axes are frozen at the epoch: elements in ``moon_op`` are Keplerian elements of the Cartesian
# state expressed in these fixed axes. Ely (2005) takes p as the IAU Moon pole (Seidelmann et al.
# 2002, ``IAU_MOON`` in ``pck00010.tpc``); LuPNT, whose authors' group published the Bhamidipati et
# al. (2023) OP-frame constellations, takes the ``MOON_ME`` z-axis (DE421 librations). The default
# here is LuPNT's; :func:`moon_op_to_j2000` accepts ``pole_frame="IAU_MOON"`` for Ely's choice, and
# tests/test_frames_moon_op.py bounds the difference (the IAU model carries the main libration terms of the
# pole: the poles agree to a few thousandths of a degree, and the node x, which the 6.7 deg angle
# between pole and orbit normal amplifies about 9 times, to about 0.03 deg).
#
# Physics check: the Moon's orbit is inclined about 5.145 deg to the ecliptic and the lunar equator
# about 1.543 deg to it on the opposite side (Cassini's laws), so z lies about 5.1 deg from the
# ecliptic pole and about 6.7 deg from the lunar pole, varying by a few tenths of a degree with the
# solar perturbation of the osculating orbit.


def moon_op_axes_j2000(
    r_earth_km: np.ndarray, v_earth_kms: np.ndarray, pole_j2000: np.ndarray
) -> np.ndarray:
    """Rotation (3, 3) from ``moon_op`` to J2000: columns are the x, y, z axes in J2000.

    ``r_earth_km``, ``v_earth_kms``: the Earth's position and velocity relative to the Moon (J2000);
    ``pole_j2000``: the lunar pole (any length). Pure geometry, no SPICE.
    """
    h = np.cross(np.asarray(r_earth_km, dtype=float), np.asarray(v_earth_kms, dtype=float))
    return orbit_plane_axes_j2000(h, pole_j2000)


def orbit_plane_axes_j2000(normal_j2000, pole_j2000) -> np.ndarray:
    """Rotation (3, 3) whose columns are ``moon_op``-like axes: z along ``normal_j2000``, x along pole x z.

    Pure geometry (any lengths); :func:`moon_op_axes_j2000` with the Earth's osculating orbit normal, or
    :mod:`lnss_lib.design_life.frozen` with the month-averaged one.
    """
    pole = np.asarray(pole_j2000, dtype=float)
    normal = np.asarray(normal_j2000, dtype=float)
    z = normal / np.linalg.norm(normal)
    node = np.cross(pole, z)
    norm = np.linalg.norm(node)
    if not norm > 1e-9 * np.linalg.norm(pole):
        raise ValueError(
            "moon_op is undefined: the lunar pole is parallel to the Earth's orbit normal"
        )
    x = node / norm
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def moon_op_to_j2000(t_epoch_tdb_s: float, pole_frame: str = "MOON_ME") -> np.ndarray:
    """Rotation R (3, 3) with x_j2000 = R x_moon_op, the ``moon_op`` axes built at ``t_epoch_tdb_s``.

    SPICE kernels (planetary SPK, lunar PCK and frame kernels) must be loaded, e.g. with
    :func:`lnss_lib.ephemeris.ensure_kernels`. ``pole_frame``: the body-fixed frame whose z-axis is
    the lunar pole, one of :data:`POLE_FRAMES` (default ``MOON_ME``, as LuPNT).
    """
    if pole_frame not in POLE_FRAMES:
        raise ValueError(
            f"unknown lunar pole frame {pole_frame!r}; allowed: {', '.join(map(repr, POLE_FRAMES))}"
        )
    t = float(t_epoch_tdb_s)
    if not np.isfinite(t):
        raise ValueError(f"epoch must be finite (TDB seconds past J2000); got {t_epoch_tdb_s!r}")
    earth = body_states_mci("EARTH", np.array([t]))[0]
    pole = rotation(pole_frame, "J2000", np.array([t]))[0][:, 2]
    return moon_op_axes_j2000(earth[:3], earth[3:], pole)


def rotate_to_moon_fixed(
    dynamics: Dynamics, r_mci_km: np.ndarray, t_tdb_s: np.ndarray
) -> np.ndarray:
    """Moon-centred J2000 positions (sat, time, 3) -> Moon-fixed (``frames.moon_fixed``) positions."""
    ensure_kernels(dynamics.ephemeris)
    return rotate_with(
        rotation("J2000", dynamics.frames.moon_fixed, np.asarray(t_tdb_s, dtype=float)), r_mci_km
    )


FIXED_OFFSET_TOLERANCE = 1e-14
"""Largest change of any entry of a frame offset over a span for it to count as fixed (a few rounding units of
SPICE's chain of rotations; MOON_PA -> IAU_MOON changes by ~1e-4 over a day)."""


def fixed_offset(frame_from: str, frame_to: str, t_start_tdb_s: float, t_end_tdb_s: float):
    """Rotation R (3, 3), x_to = R x_from, when ``frame_to`` is fixed to ``frame_from`` over the span (their
    offset at its two ends agrees within :data:`FIXED_OFFSET_TOLERANCE`: MOON_PA -> MOON_ME, a frame to
    itself), else None (the frames turn against each other). SPICE kernels must be loaded."""
    ends = rotation(frame_from, frame_to, np.array([t_start_tdb_s, t_end_tdb_s], dtype=float))
    return ends[0] if np.max(np.abs(ends[1] - ends[0])) <= FIXED_OFFSET_TOLERANCE else None


def moon_fixed_rotations(offset: np.ndarray, table: EphemerisTable, t_tdb_s) -> np.ndarray:
    """J2000 -> Moon-fixed rotations (n, 3, 3) at TDB epochs (n,) inside ``table``: its Hermite-interpolated
    J2000 -> gravity-frame rotation (:meth:`lnss_lib.ephemeris.EphemerisTable.rotations_pa`) turned by the fixed
    ``offset`` from the gravity frame to the Moon-fixed one (:func:`fixed_offset`). The interpolation error of
    the table (step h) is below (omega h)^4 / 384 per entry, omega the Moon's spin rate
    (``tests/test_frames.py`` checks it against SPICE)."""
    return np.matmul(offset, table.rotations_pa(t_tdb_s))


def rotate_with(rot: np.ndarray, vectors) -> np.ndarray:
    """Vectors (sat, time, 3) rotated by one matrix per epoch, rot (time, 3, 3): out = rot[t] @ v[s, t]."""
    return np.einsum("tij,stj->sti", rot, np.asarray(vectors, dtype=float))


def latitude_deg(r_mf_km) -> np.ndarray:
    """Selenographic latitude (deg) of Moon-fixed positions (..., 3) km."""
    r = np.asarray(r_mf_km, dtype=float)
    return np.degrees(np.arcsin(r[..., 2] / np.linalg.norm(r, axis=-1)))


# ---------------------------------------------------------------------------------------------
# RTN axes of an orbit
# ---------------------------------------------------------------------------------------------


def rtn_basis(states: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3, 3) with rows R (along r), T (N x R), N (along r x v) in the state's frame."""
    s = np.asarray(states, dtype=float)
    r_vec, v_vec = s[..., :3], s[..., 3:6]
    r_hat = r_vec / np.linalg.norm(r_vec, axis=-1, keepdims=True)
    h_vec = np.cross(r_vec, v_vec)
    n_hat = h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)
    t_hat = np.cross(n_hat, r_hat)
    return np.stack([r_hat, t_hat, n_hat], axis=-2)


def to_rtn(vectors: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Components (..., 3) [R, T, N] of vectors (..., 3) given in the states' frame."""
    return np.einsum("...ij,...j->...i", rtn_basis(states), np.asarray(vectors, dtype=float))


def from_rtn(components_rtn: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Vectors (..., 3) in the states' frame from RTN components (..., 3)."""
    return np.einsum("...ji,...j->...i", rtn_basis(states), np.asarray(components_rtn, dtype=float))


# ---------------------------------------------------------------------------------------------
# Time scales, precession-nutation and TEME -> J2000
# ---------------------------------------------------------------------------------------------

# IAU-1980 nutation series (Seidelmann 1992, Explanatory Supplement 3.222; SOFA nut80), the 13 terms
# with |dpsi amplitude| >= 100 x 0.1 mas. Columns: multipliers of l, l', F, D, Omega; dpsi sine
# coefficient and its rate per Julian century; deps cosine coefficient and its rate (0.1 mas).
_NUT80_TERMS = np.array(
    [
        [0, 0, 0, 0, 1, -171996.0, -174.2, 92025.0, 8.9],
        [0, 0, 2, -2, 2, -13187.0, -1.6, 5736.0, -3.1],
        [0, 0, 2, 0, 2, -2274.0, -0.2, 977.0, -0.5],
        [0, 0, 0, 0, 2, 2062.0, 0.2, -895.0, 0.5],
        [0, 1, 0, 0, 0, 1426.0, -3.4, 54.0, -0.1],
        [1, 0, 0, 0, 0, 712.0, 0.1, -7.0, 0.0],
        [0, 1, 2, -2, 2, -517.0, 1.2, 224.0, -0.6],
        [0, 0, 2, 0, 1, -386.0, -0.4, 200.0, 0.0],
        [1, 0, 2, 0, 2, -301.0, 0.0, 129.0, -0.1],
        [0, -1, 2, -2, 2, 217.0, -0.5, -95.0, 0.3],
        [1, 0, 0, -2, 0, -158.0, 0.0, -1.0, 0.0],
        [0, 0, 2, -2, 1, 129.0, 0.1, -70.0, 0.0],
        [-1, 0, 2, 0, 2, 123.0, 0.0, -53.0, 0.0],
    ]
)
# Sum of |amplitude| (incl. the rate terms at 2025) of the 93 IAU-1980 terms left out above (mas).
NUTATION_SKIPPED_DPSI_MAS = 88.0
NUTATION_SKIPPED_DEPS_MAS = 29.6


def utc_julian_dates(t_tdb_s) -> tuple[np.ndarray, np.ndarray]:
    """UTC Julian dates (whole part, fraction) of TDB epochs, for ``sgp4``; SPICE ``deltet`` (ET - UTC).

    Needs the leap-second kernel (:func:`lnss_lib.ephemeris.ensure_kernels`).
    """
    et = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    with spice_errors("give ET - UTC (deltet) from the leap-second kernel"):
        utc_s = et - np.array([spice.deltet(float(e), "ET") for e in et])
    days = utc_s / SECONDS_PER_DAY
    whole = np.floor(days)
    return J2000_JD + whole, days - whole


def tt_centuries(t_tdb_s) -> np.ndarray:
    """Julian centuries of TT past J2000 (SPICE ``unitim`` TDB -> TDT)."""
    et = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    with spice_errors("convert TDB to TT (unitim) with the leap-second kernel"):
        return (
            np.array([spice.unitim(float(e), "TDB", "TDT") for e in et])
            / SECONDS_PER_JULIAN_CENTURY
        )


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Passive (frame) rotations R_axis(angle), shape (n, 3, 3): x' = R x (Vallado's ROT1/2/3)."""
    a = np.atleast_1d(angle)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros((a.size, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis - 1]
    out[:, axis - 1, axis - 1] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = s
    out[:, j, i] = -s
    return out


def precession_iau1976(t_tt_cy) -> np.ndarray:
    """IAU-1976 precession P (n, 3, 3): r_mean_of_date = P r_J2000 (Lieske 1977 angles zeta, theta, z)."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    zeta = (2306.2181 + (0.30188 + 0.017998 * t) * t) * t * ARCSEC_RAD
    theta = (2004.3109 + (-0.42665 - 0.041833 * t) * t) * t * ARCSEC_RAD
    z = (2306.2181 + (1.09468 + 0.018203 * t) * t) * t * ARCSEC_RAD
    return _rot(3, -z) @ _rot(2, theta) @ _rot(3, -zeta)


def mean_obliquity_iau1980(t_tt_cy) -> np.ndarray:
    """Mean obliquity of the ecliptic (rad), IAU 1980."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    return (84381.448 + (-46.8150 + (-0.00059 + 0.001813 * t) * t) * t) * ARCSEC_RAD


def nutation_iau1980(t_tt_cy, terms: np.ndarray = _NUT80_TERMS) -> tuple[np.ndarray, np.ndarray]:
    """Nutation in longitude and obliquity (rad) from the IAU-1980 series ``terms`` (default: 13 largest)."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    turn = 2.0 * np.pi
    el = (485866.733 + (715922.633 + (31.310 + 0.064 * t) * t) * t) * ARCSEC_RAD + np.mod(
        1325.0 * t, 1.0
    ) * turn
    elp = (1287099.804 + (1292581.224 + (-0.577 - 0.012 * t) * t) * t) * ARCSEC_RAD + np.mod(
        99.0 * t, 1.0
    ) * turn
    f = (335778.877 + (295263.137 + (-13.257 + 0.011 * t) * t) * t) * ARCSEC_RAD + np.mod(
        1342.0 * t, 1.0
    ) * turn
    d = (1072261.307 + (1105601.328 + (-6.891 + 0.019 * t) * t) * t) * ARCSEC_RAD + np.mod(
        1236.0 * t, 1.0
    ) * turn
    om = (450160.280 + (-482890.539 + (7.455 + 0.008 * t) * t) * t) * ARCSEC_RAD + np.mod(
        -5.0 * t, 1.0
    ) * turn
    args = np.stack([el, elp, f, d, om], axis=-1) @ terms[:, :5].T
    dpsi = np.sum((terms[:, 5] + terms[:, 6] * t[:, None]) * np.sin(args), axis=-1)
    deps = np.sum((terms[:, 7] + terms[:, 8] * t[:, None]) * np.cos(args), axis=-1)
    return dpsi * 1e-4 * ARCSEC_RAD, deps * 1e-4 * ARCSEC_RAD


def nutation_matrix(t_tt_cy) -> np.ndarray:
    """Nutation N (n, 3, 3): r_true_of_date = N r_mean_of_date (IAU 1980, truncated)."""
    eps = mean_obliquity_iau1980(t_tt_cy)
    dpsi, deps = nutation_iau1980(t_tt_cy)
    return _rot(1, -(eps + deps)) @ _rot(3, -dpsi) @ _rot(1, eps)


def teme_to_j2000(t_tt_cy) -> np.ndarray:
    """Rotation (n, 3, 3) with r_J2000 = R r_TEME: R = P^T N^T R3(-EqE), EqE = dpsi cos(eps_mean)."""
    eps = mean_obliquity_iau1980(t_tt_cy)
    dpsi, _ = nutation_iau1980(t_tt_cy)
    p = precession_iau1976(t_tt_cy)
    n = nutation_matrix(t_tt_cy)
    return np.swapaxes(p, 1, 2) @ np.swapaxes(n, 1, 2) @ _rot(3, -dpsi * np.cos(eps))
