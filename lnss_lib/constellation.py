"""LNSS constellations as arrays of Keplerian elements (paper Section 5.1, eq. 42; Table 4).

Every constellation is an ``elements_deg`` array of shape (nsat, 6) with columns
``keys.ELEMENT_KEYS`` = ``[sma_km, ecc, inc_deg, raan_deg, aop_deg, mean_anomaly_deg]``, referred to the profile's element frame
(``frames.element_frame``: lunar equator of epoch by default, see
:func:`lnss_lib.frames.element_frame_to_j2000`), which is what
``lnss_lib.propagator.propagate_elements`` takes. Satellites are ordered plane by plane; the
first satellite (plane 1, M = 0) is the one the paper uses for the GPS link and Delta-V.

Validation here is physical only (closed orbit above the surface, integer counts); the design
bounds of Table 3 belong to the optimiser, so the standalone ELFO (8 satellites per plane) is a
valid constellation.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .elements import kepler_states, validate_elements
from .ephemeris import ensure_kernels
from .frames import element_frame_to_j2000
from .keys import ELEMENT_KEYS

if TYPE_CHECKING:
    from .settings import Dynamics, StandaloneElfoSettings

__all__ = [
    "planes_elements_deg",
    "WalkerDesign",
    "walker_design",
    "explicit_constellation",
    "standalone_elfo",
    "two_body_positions_mci",
]


def _positive_int(value, name: str) -> int:
    """``value`` as an int if it is a positive integer (integral floats accepted), else ``ValueError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"{name} must be a positive integer; got {value!r} ({type(value).__name__})"
        )
    if not np.isfinite(float(value)) or float(value) != int(value) or int(value) < 1:
        raise ValueError(f"{name} must be a positive integer; got {value!r}")
    return int(value)


def _check_inclination(inc_deg) -> None:
    inc = np.atleast_1d(np.asarray(inc_deg, dtype=float))
    bad = ~np.isfinite(inc) | (inc < 0.0) | (inc > 180.0)
    if np.any(bad):
        raise ValueError(f"inclination must be in [0, 180] deg; got {inc[bad][0]!r}")


def _check_finite_angles(values, name: str) -> None:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if np.any(~np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (deg); got {arr[~np.isfinite(arr)][0]!r}")


def _surface_limits(dynamics: Dynamics) -> tuple[float, float]:
    """(mean lunar radius km, minimum altitude km): the perilune floor."""
    return dynamics.constants.r_moon_mean_km, dynamics.impact.min_altitude_km


def planes_elements_deg(
    sma_km: float, e: float, inc_deg: float, aop_deg: float, raan_deg, sats_per_plane: int
) -> np.ndarray:
    """Elements (nsat, 6) of planes with the given RAANs, ``sats_per_plane`` satellites each.

    Within a plane the mean anomalies are ``(s - 1) 360 / Ns`` deg, s = 1..Ns (the first at
    M = 0); satellites are ordered plane by plane. Angles are wrapped to [0, 360).
    """
    ns = _positive_int(sats_per_plane, "sats_per_plane")
    raans = np.atleast_1d(np.asarray(raan_deg, dtype=float))
    if raans.ndim != 1 or raans.size == 0:
        raise ValueError(
            f"raan_deg must be a non-empty 1-D list of angles; got shape {raans.shape}"
        )
    _check_finite_angles(raans, "raan_deg")
    mean_anomalies = np.arange(ns) * 360.0 / ns
    raan_col = np.repeat(raans, ns)
    m_col = np.tile(mean_anomalies, raans.size)
    n = raan_col.size
    return np.column_stack(
        [
            np.full(n, float(sma_km)),
            np.full(n, float(e)),
            np.full(n, float(inc_deg)),
            np.mod(raan_col, 360.0),
            np.full(n, float(np.mod(aop_deg, 360.0))),
            np.mod(m_col, 360.0),
        ]
    )


@dataclass(frozen=True)
class WalkerDesign:
    """Walker-type design of Table 3: ``n_planes`` planes, ``sats_per_plane`` satellites each.

    RAAN of plane p is ``raan_offset_deg + (p - 1) 360 / Np`` (eq. 42, offset 0 in the paper);
    satellites are equally spaced in mean anomaly from M = 0. Angles in degrees, ``sma_km`` in km. The
    fields before ``raan_offset_deg`` are :data:`lnss_lib.keys.DESIGN_KEYS`, in that order.
    Construction checks e in [0, 1), a > 0, inclination in [0, 180] deg and positive integer
    counts; :func:`walker_design` also checks the perilune against the lunar surface.
    """

    sma_km: float
    ecc: float
    aop_deg: float
    inc_deg: float
    n_planes: int
    sats_per_plane: int
    raan_offset_deg: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "n_planes", _positive_int(self.n_planes, "n_planes (Np)"))
        object.__setattr__(
            self, "sats_per_plane", _positive_int(self.sats_per_plane, "sats_per_plane (Ns)")
        )
        validate_elements(self.sma_km, self.ecc, r_body_km=0.0)
        _check_inclination(self.inc_deg)
        _check_finite_angles([self.aop_deg, self.raan_offset_deg], "aop_deg and raan_offset_deg")

    @property
    def n_sat(self) -> int:
        """Total number of satellites Np * Ns."""
        return self.n_planes * self.sats_per_plane

    def raan_deg(self) -> np.ndarray:
        """RAAN of each plane (deg, eq. 42), shape (Np,)."""
        return np.mod(
            self.raan_offset_deg + np.arange(self.n_planes) * 360.0 / self.n_planes, 360.0
        )

    def elements_deg(self, max_sats_per_plane: int = 0) -> np.ndarray:
        """Elements (n_sat, 6) ``[sma_km, ecc, inc_deg, raan_deg, aop_deg, M_deg]``, plane by plane; with
        ``max_sats_per_plane`` > 0 at most that many per plane, at the design's slots (the first of each plane)."""
        el = planes_elements_deg(
            self.sma_km, self.ecc, self.inc_deg, self.aop_deg, self.raan_deg(), self.sats_per_plane
        )
        k = (
            self.sats_per_plane
            if max_sats_per_plane <= 0
            else min(self.sats_per_plane, int(max_sats_per_plane))
        )
        return el.reshape(self.n_planes, self.sats_per_plane, 6)[:, :k].reshape(-1, 6)


def walker_design(
    dynamics: Dynamics,
    sma_km: float,
    ecc: float,
    aop_deg: float,
    inc_deg: float,
    n_planes: int,
    sats_per_plane: int,
    raan_offset_deg: float = 0.0,
) -> WalkerDesign:
    """A :class:`WalkerDesign` whose perilune a(1 - e) clears the surface (``constants.r_moon_mean_km``
    + ``impact.min_altitude_km``); ``ValueError`` naming the bad value otherwise."""
    design = WalkerDesign(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane, raan_offset_deg)
    r_body_km, min_alt_km = _surface_limits(dynamics)
    validate_elements(design.sma_km, design.ecc, r_body_km, min_alt_km)
    return design


def explicit_constellation(dynamics: Dynamics, elements_deg) -> np.ndarray:
    """Validated (nsat, 6) array from any list of element sets ``[sma_km, e, inc_deg, raan_deg, aop_deg, M_deg]``.

    Checks shape, closed orbits above the surface (as :func:`walker_design`), inclination in
    [0, 180] deg and finite angles; RAAN, AOP and M are wrapped to [0, 360).
    """
    el = np.array(elements_deg, dtype=float)
    if el.ndim == 1 and el.size == 6:
        el = el[None, :]
    if el.ndim != 2 or el.shape[1] != 6 or el.shape[0] == 0:
        raise ValueError(
            f"elements_deg must have shape (nsat, 6) with columns {', '.join(ELEMENT_KEYS)}; got shape {el.shape}"
        )
    r_body_km, min_alt_km = _surface_limits(dynamics)
    validate_elements(el[:, 0], el[:, 1], r_body_km, min_alt_km)
    _check_inclination(el[:, 2])
    _check_finite_angles(el[:, 3:], "raan_deg, aop_deg and M_deg")
    el[:, 3:] = np.mod(el[:, 3:], 360.0)
    return el


def standalone_elfo(elfo: StandaloneElfoSettings, dynamics: Dynamics) -> np.ndarray:
    """Elements (nsat, 6) of the paper's standalone ELFO (Table 4) from ``[standalone_elfo]``, checked against
    the surface (:func:`explicit_constellation`).

    Planes at the listed RAANs (0 and 180 deg), ``sats_per_plane`` (8) satellites each equally
    spaced in mean anomaly from M = 0: 16 satellites, a = 6143 km, e = 0.6, i = 51.7 deg,
    AOP = 90 deg.
    """
    el = planes_elements_deg(
        elfo.sma_km, elfo.ecc, elfo.inc_deg, elfo.aop_deg, elfo.raan_deg, elfo.sats_per_plane
    )
    return explicit_constellation(dynamics, el)


def two_body_positions_mci(dynamics: Dynamics, elements_deg, t_tdb_s) -> np.ndarray:
    """Keplerian (two-body) positions (nsat, ntime, 3) km in Moon-centred J2000 at TDB epochs.

    ``elements_deg`` (nsat, 6) hold at the first epoch ``t_tdb_s[0]`` in the element frame
    ``dynamics.frames.element_frame`` (rotated with :func:`lnss_lib.frames.element_frame_to_j2000`); the mean anomaly
    advances at sqrt(GM / a^3) with ``gravity.gm_km3_s2``. A reference for the propagated orbits.
    """
    el = explicit_constellation(dynamics, elements_deg)
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    el_rad = np.concatenate([el[:, :2], np.radians(el[:, 2:])], axis=1)
    ensure_kernels(dynamics.ephemeris)
    rot = element_frame_to_j2000(dynamics, float(times[0]))
    return kepler_states(el_rad, times - times[0], dynamics.gravity.gm_km3_s2)[..., :3] @ rot.T
