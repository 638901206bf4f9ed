"""Frozen and librating orbits: the doubly-averaged model of :mod:`lnss_lib.design_life.screen` in the ``moon_op`` frame.

Above a few thousand km the Earth's tide drives e, i and AOP, and it is symmetric about
the Earth-Moon orbital plane (``moon_op``, :func:`lnss_lib.frames.moon_op_to_j2000`), not the lunar
equator. In that frame the doubly-averaged potential of :func:`lnss_lib.design_life.secular.averaged_potential`
(lunar J2 + Earth and Sun quadrupole tides) is nearly axisymmetric about z: the lunar pole is tilted
by about 6.7 deg and the ecliptic normal by about 5.1 deg. Averaged over the orbit's node (which
circulates in about a year at a = 6000 km), a J2 about a pole tilted by ``eps`` is a J2 of
``J2 P2(cos eps)`` about z, and a tide tensor ``T`` becomes ``diag((T_xx + T_yy) / 2, (T_xx + T_yy) / 2, T_zz)``
(:class:`FrozenModel`). The axisymmetric model has two integrals, the Kozai integral
``j_z = sqrt(1 - e^2) cos i`` and the potential ``Phi(e, AOP) = A(e) + B(e) sin^2(AOP)`` at fixed j_z, so:

* frozen orbits are the fixed points at AOP = 90 or 270 deg where ``dPhi/de`` at fixed j_z vanishes
  (:func:`frozen_inclination_deg`, :func:`frozen_eccentricity`); without J2 this is the Kozai family
  ``e^2 + (5/3) cos^2 i = 1``; lunar J2 moves it to higher inclination at low a;
* any (a, e, i, AOP) moves on the level curve ``Phi = Phi_0`` at its j_z: :func:`libration` returns
  its range of e, i and AOP (a libration about AOP 90 / 270 deg, or a circulation).

The frame is the mean ``moon_op`` (:func:`mean_plane_axes`): z is the month-averaged Earth orbit normal,
which regresses about the ecliptic pole in 18.6 years (1.7 deg a year), so i, AOP and the libration are
read against the plane of the time, not axes frozen at the epoch. What the model leaves out, the orbit
shows on top of the libration (:func:`allowances`): the Earth's tide swings the orbit-averaged e-vector
and plane at twice the Earth's sidereal frequency (half a month) and within each orbit, and the tilted
pole and the plane's regression make the orbit normal precess about a Laplace axis a little off z.
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field as default_field

import numpy as np
from scipy.optimize import brentq

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..frames import orbit_plane_axes_j2000
from ..settings import Dynamics, StabilitySettings
from .secular import (
    SIDEREAL_MONTH_DAYS,
    SecularField,
    averaged_potential,
    elements_from_vectors,
    secular_rates,
)

__all__ = [
    "mean_plane_axes",
    "FrozenModel",
    "orbit_vectors_deg",
    "mean_plane_elements",
    "potential",
    "frozen_inclination_deg",
    "frozen_eccentricity",
    "libration",
    "allowances",
]

_Z = np.array([0.0, 0.0, 1.0])


def mean_plane_axes(field: SecularField, t_days) -> np.ndarray:
    """Rotations (m, 3, 3) from the mean ``moon_op`` frame to J2000 at ``t_days`` (m,) since the field's epoch.

    z is the month-averaged Earth orbit normal (the null direction of the tide tensor ``T``, on the lunar
    pole's side), x the node of the lunar equator on that plane (:func:`lnss_lib.frames.orbit_plane_axes_j2000`);
    unlike :func:`lnss_lib.frames.moon_op_to_j2000` it carries no monthly wobble of the osculating orbit.
    """
    out = []
    for t in np.atleast_1d(np.asarray(t_days, dtype=float)):
        tide, pole = field.at(float(t))
        normal = np.linalg.eigh(tide)[1][:, 0]
        out.append(orbit_plane_axes_j2000(normal if normal @ pole > 0.0 else -normal, pole))
    return np.stack(out)


@dataclass(frozen=True)
class FrozenModel:
    """The node-averaged, axisymmetric doubly-averaged model in ``moon_op`` (z: the Earth-Moon orbit normal).

    ``tide`` (3, 3) (1/s^2), diagonal and axisymmetric about z; ``j2`` the lunar J2 about the pole
    ``pole`` (3,) (node-averaged: :attr:`j2_axial` about z); ``gm_km3_s2``, ``r_ref_km`` of the Moon;
    ``frame_spin`` (3,) (rad/s) the turn of the Earth's orbit plane (its 18.6-year regression, the part
    normal to z). The pole's tilt and the spin set only the forced swing of i (:func:`allowances`).
    """

    tide: np.ndarray
    gm_km3_s2: float
    j2: float
    r_ref_km: float
    pole: np.ndarray = default_field(default_factory=lambda: _Z.copy())
    frame_spin: np.ndarray = default_field(default_factory=lambda: np.zeros(3))

    @property
    def j2_axial(self) -> float:
        """The node-averaged J2 about z: ``J2 P2(cos tilt)``."""
        return self.j2 * 0.5 * (3.0 * self.pole[2] ** 2 - 1.0)

    @property
    def tilt_deg(self) -> float:
        """Angle (deg) of the lunar pole from z."""
        return float(np.degrees(np.arccos(np.clip(self.pole[2], -1.0, 1.0))))

    @classmethod
    def circular(
        cls, gm_km3_s2: float, j2: float, r_ref_km: float, gm_body_km3_s2: float, a_body_km: float
    ) -> FrozenModel:
        """One perturber on a circular orbit in the x-y plane and a J2 about z (``j2 = 0``: the Kozai problem)."""
        tide = 0.5 * gm_body_km3_s2 / a_body_km**3 * (np.eye(3) - np.outer(_Z, _Z))
        return cls(tide, float(gm_km3_s2), float(j2), float(r_ref_km))

    @classmethod
    def from_field(
        cls, field: SecularField, t_day: float = 0.0, spin_days: float = DAYS_PER_JULIAN_YEAR
    ) -> FrozenModel:
        """Node-average of a :class:`lnss_lib.design_life.secular.SecularField` at ``t_day`` in the mean ``moon_op`` frame
        (:func:`mean_plane_axes`); the frame's turn over the next ``spin_days`` (within the field's span)."""
        tide, pole = field.at(t_day)
        t_end = min(t_day + spin_days, float(field.t_days[-1]))
        rot, rot_end = mean_plane_axes(field, [t_day, t_end])
        tide_op, pole_op = rot.T @ tide @ rot, rot.T @ pole
        side = 0.5 * (tide_op[0, 0] + tide_op[1, 1])
        spin = np.zeros(3)
        if t_end > t_day:
            z_end = rot.T @ rot_end[:, 2]
            spin = np.cross(_Z, z_end) / ((t_end - t_day) * SECONDS_PER_DAY)
        return cls(
            np.diag([side, side, tide_op[2, 2]]),
            field.gm_km3_s2,
            field.j2,
            field.r_ref_km,
            pole_op,
            spin,
        )

    @classmethod
    def from_settings(
        cls, stability: StabilitySettings, dynamics: Dynamics, t0_tdb_s: float
    ) -> FrozenModel:
        """The model at TDB ``t0_tdb_s`` from SPICE (the ``[stability]`` tide, one year tabulated)."""
        return cls.from_field(
            SecularField.from_settings(stability, dynamics, float(t0_tdb_s), DAYS_PER_JULIAN_YEAR)
        )


def orbit_vectors_deg(e, inc_deg, aop_deg, raan_deg=0.0) -> tuple[np.ndarray, np.ndarray]:
    """(e vector, j = sqrt(1 - e^2) h_hat), each (n, 3), of orbits given by e, i, AOP and RAAN (deg)."""
    e, inc, aop, raan = np.broadcast_arrays(
        *(
            np.atleast_1d(np.asarray(x, dtype=float))
            for x in (e, np.radians(inc_deg), np.radians(aop_deg), np.radians(raan_deg))
        )
    )
    node = np.stack([np.cos(raan), np.sin(raan), np.zeros_like(raan)], axis=-1)
    h_hat = np.stack(
        [np.sin(raan) * np.sin(inc), -np.cos(raan) * np.sin(inc), np.cos(inc)], axis=-1
    )
    in_plane = np.cross(h_hat, node)
    e_vec = e[:, None] * (np.cos(aop)[:, None] * node + np.sin(aop)[:, None] * in_plane)
    return e_vec, np.sqrt(1.0 - e**2)[:, None] * h_hat


def mean_plane_elements(
    field: SecularField, elements_deg, rot_el_to_j2000: np.ndarray, t_day: float = 0.0
) -> dict:
    """Elements (n, 6) [sma_km, e, i, RAAN, AOP, M] (deg) given in a frame (``x_j2000 = rot x``) read in the mean
    ``moon_op`` frame at ``t_day`` (:func:`mean_plane_axes`): ``sma_km``, ``ecc``, ``inc_deg``, ``raan_deg``, ``aop_deg``."""
    el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    e_vec, j_vec = orbit_vectors_deg(el[:, 1], el[:, 2], el[:, 4], el[:, 3])
    rot = mean_plane_axes(field, [t_day])[0].T @ np.asarray(rot_el_to_j2000, dtype=float)
    return {"sma_km": el[:, 0], **elements_from_vectors(e_vec, j_vec, rot)}


def potential(model: FrozenModel, sma_km, e, inc_deg, aop_deg) -> np.ndarray:
    """Doubly-averaged potential (n,) (km^2/s^2) of orbits (broadcast arrays) in the model's frame."""
    a, e, inc, aop = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(x, dtype=float)) for x in (sma_km, e, inc_deg, aop_deg))
    )
    e_vec, j_vec = orbit_vectors_deg(e, inc, aop)
    return averaged_potential(
        e_vec, j_vec, a, model.tide, _Z, model.gm_km3_s2, model.j2_axial, model.r_ref_km
    )


def _inc_at_jz_deg(e, jz):
    return np.degrees(
        np.arccos(np.clip(jz / np.sqrt(1.0 - np.asarray(e, dtype=float) ** 2), -1.0, 1.0))
    )


def _dphi_de(model: FrozenModel, sma_km: float, e, inc_deg, step: float = 1e-6) -> np.ndarray:
    """dPhi/de at AOP 90 deg along the Kozai integral j_z (central difference), for arrays e and inc_deg."""
    e, inc = np.broadcast_arrays(
        np.atleast_1d(np.asarray(e, dtype=float)), np.atleast_1d(np.asarray(inc_deg, dtype=float))
    )
    jz = np.sqrt(1.0 - e**2) * np.cos(np.radians(inc))
    ee = np.concatenate([e - step, e + step])
    phi = potential(model, sma_km, ee, _inc_at_jz_deg(ee, np.concatenate([jz, jz])), 90.0)
    return (phi[e.size :] - phi[: e.size]) / (2.0 * step)


def _roots(fun, lo: float, hi: float, n: int = 361) -> list[float]:
    """Roots of a vectorised ``fun`` on [lo, hi]: sign changes on an n-point grid, refined by brentq."""
    grid = np.linspace(lo, hi, n)
    vals = fun(grid)
    scalar = lambda x: float(fun(np.array([x]))[0])
    return [
        brentq(scalar, grid[k], grid[k + 1], xtol=1e-12)
        for k in np.flatnonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)
    ]


def frozen_inclination_deg(model: FrozenModel, sma_km: float, e: float) -> float:
    """Inclination (deg, prograde) to z of the orbit of semi-major axis ``sma_km`` and eccentricity ``e`` frozen
    at AOP 90 / 270 deg; the root nearest the Kozai family ``e^2 + (5/3) cos^2 i = 1`` where there are
    several, NaN where there is none (retrograde: 180 deg minus it)."""
    if not (0.0 < e < 1.0 and sma_km > 0.0):
        raise ValueError(f"need 0 < e < 1 and sma_km > 0; got e = {e!r}, sma_km = {sma_km!r}")
    roots = _roots(lambda inc: _dphi_de(model, sma_km, e, inc), 0.5, 89.999)
    kozai = np.degrees(np.arccos(min(1.0, np.sqrt(0.6 * (1.0 - e**2)))))
    return float(min(roots, key=lambda r: abs(r - kozai))) if roots else float("nan")


def frozen_eccentricity(
    model: FrozenModel, sma_km: float, inc_deg: float, *, min_perilune_km: float = 0.0
) -> float:
    """Eccentricity of the orbit of semi-major axis ``sma_km`` and inclination ``inc_deg`` frozen at AOP 90 / 270
    deg, with perilune radius above ``min_perilune_km``; the root nearest the Kozai family, NaN where none."""
    if not (0.0 < inc_deg < 180.0 and sma_km > 0.0):
        raise ValueError(
            f"need 0 < inc_deg < 180 and sma_km > 0; got inc_deg = {inc_deg!r}, sma_km = {sma_km!r}"
        )
    e_hi = min(0.999, 1.0 - min_perilune_km / sma_km)
    if e_hi <= 1e-3:
        return float("nan")
    roots = _roots(lambda e: _dphi_de(model, sma_km, e, inc_deg), 1e-3, e_hi)
    kozai = np.sqrt(max(0.0, 1.0 - 5.0 / 3.0 * np.cos(np.radians(inc_deg)) ** 2))
    return float(min(roots, key=lambda r: abs(r - kozai))) if roots else float("nan")


def libration(
    model: FrozenModel,
    sma_km: float,
    e: float,
    inc_deg: float,
    aop_deg: float,
    *,
    n_grid: int = 4001,
) -> dict:
    """The level curve of the orbit (a, e, i, AOP) at its Kozai integral: ranges of e, i and AOP.

    Returns ``ecc_min``, ``ecc_max``, ``inc_min_deg``, ``inc_max_deg``, ``aop_min_deg``, ``aop_max_deg``
    (the AOP range about the libration centre; 0 and 360 when the AOP circulates), ``librating``
    (AOP stays on one side of the line of nodes: about 90 deg or about 270 deg), ``centre_aop_deg``
    (90 or 270; NaN when circulating) and ``jz`` (``sqrt(1 - e^2) cos i``).
    """
    if not (0.0 < e < 1.0 and sma_km > 0.0 and 0.0 < inc_deg < 180.0):
        raise ValueError(
            f"need 0 < e < 1, sma_km > 0 and 0 < inc_deg < 180; got e = {e!r}, sma_km = {sma_km!r}, "
            f"inc_deg = {inc_deg!r}"
        )
    jz = np.sqrt(1.0 - e**2) * np.cos(np.radians(inc_deg))
    e_top = np.sqrt(1.0 - jz**2)  # i -> 0 (or 180) on the Kozai integral
    phi0 = float(potential(model, sma_km, e, inc_deg, aop_deg)[0])

    def sin2_aop(ee):
        """sin^2 AOP on the level curve at eccentricity ee (Phi = A + B sin^2 AOP along j_z)."""
        ee = np.atleast_1d(ee)
        inc = _inc_at_jz_deg(ee, jz)
        base = potential(model, sma_km, ee, inc, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return (phi0 - base) / (potential(model, sma_km, ee, inc, 90.0) - base)

    def edge(direction: int) -> tuple[float, bool]:
        """Far end of the level curve from e in ``direction``; True where it ends at AOP 90/270 (a turning point)."""
        stop = e_top * (1.0 - 1e-9) if direction > 0 else 1e-9
        grid = np.linspace(e, stop, n_grid)[1:]
        s = sin2_aop(grid)
        out = np.flatnonzero(~((s >= 0.0) & (s <= 1.0)))
        if out.size == 0:
            return float(stop), False
        k = out[0]
        inside = e if k == 0 else grid[k - 1]
        turning = not (s[k] < 0.0)
        level = 1.0 if turning else 0.0
        f = lambda x: float(sin2_aop(x)[0]) - level
        if k == 0 or np.sign(f(inside)) == np.sign(f(grid[k])):
            return float(inside), turning
        return float(brentq(f, inside, grid[k], xtol=1e-13)), turning

    (e_lo, lo_turn), (e_hi, hi_turn) = edge(-1), edge(+1)
    ee = np.linspace(e_lo, e_hi, 401)
    s_min = (
        float(np.clip(np.min(sin2_aop(ee)), 0.0, 1.0))
        if e_hi > e_lo
        else float(np.sin(np.radians(aop_deg)) ** 2)
    )
    librating = lo_turn and hi_turn and s_min > 0.0
    upper = np.sin(np.radians(aop_deg)) >= 0.0
    half = np.degrees(np.arcsin(np.sqrt(s_min)))
    centre = (90.0 if upper else 270.0) if librating else float("nan")
    aop_lo, aop_hi = (
        ((half, 180.0 - half) if upper else (180.0 + half, 360.0 - half))
        if librating
        else (0.0, 360.0)
    )
    inc = _inc_at_jz_deg(np.array([e_lo, e_hi]), jz)
    return {
        "ecc_min": e_lo,
        "ecc_max": e_hi,
        "inc_min_deg": float(inc.min()),
        "inc_max_deg": float(inc.max()),
        "aop_min_deg": float(aop_lo),
        "aop_max_deg": float(aop_hi),
        "librating": bool(librating),
        "centre_aop_deg": centre,
        "jz": float(jz),
    }


def _precession_rate(e_vec, j_vec, sma_km, tide, j2, model: FrozenModel) -> float:
    """Signed rate (rad/s) at which j turns about z under ``tide`` and a J2 about z."""
    _, dj = secular_rates(e_vec, j_vec, sma_km, tide, _Z, model.gm_km3_s2, j2, model.r_ref_km)
    turn = np.cross(_Z, j_vec[0])
    return float(dj[0] @ turn / (turn @ turn))


def allowances(model: FrozenModel, sma_km: float, e: float, inc_deg: float, aop_deg: float) -> dict:
    """What the node-averaged, doubly-averaged model leaves out: bounds on the real orbit's excursions past
    the :func:`libration` ranges (e dimensionless, angles in deg).

    * monthly (``ecc_monthly``, ``inc_monthly_deg``): the Earth's tide, orbit-averaged but not
      month-averaged, swings e and j at twice the Earth's sidereal frequency: the rates of
      :func:`lnss_lib.design_life.secular.secular_rates` under the tide's oscillating part
      ``Q(phi) = (c / 2) [cos phi (xx - yy) + sin phi (xy + yx)]`` (``c = T_xx + T_yy``) at the worst
      phase, divided by ``2 n_month``;
    * orbital (``ecc_orbital``): within one orbit a tidal acceleration ``|f| <= 2 c r`` moves the
      e-vector at ``|de/dt| <= 4 c (1 + e) / n`` (``|f x h| + |v x (r x f)|`` over GM with
      ``r v <= sqrt(GM a)``), over half an orbit ``4 pi c (1 + e) / n^2``;
    * tilt (``inc_tilt_deg``): the orbit normal precesses about the sum of its turn rates, ``w_tide z``
      (the tide), ``w_J2 k`` (J2 about the lunar pole k) and minus the frame's own turn (the Earth orbit's
      regression); that axis leans ``phi`` from z (a Laplace plane), so i to z swings by up to ``2 phi``.

    ``ecc`` = 2 (monthly + orbital): once at the start (osculating elements taken as mean ones) and
    once at any later time; ``inc_deg`` = 2 monthly + 2 phi.
    """
    c = float(model.tide[0, 0] + model.tide[1, 1])
    x, y = np.eye(3)[0], np.eye(3)[1]
    e_vec, j_vec = orbit_vectors_deg(e, inc_deg, aop_deg)
    rates_e, rates_i = [], []
    for phi in np.radians(np.arange(0.0, 180.0, 2.0)):
        q = (
            0.5
            * c
            * (
                np.cos(phi) * (np.outer(x, x) - np.outer(y, y))
                + np.sin(phi) * (np.outer(x, y) + np.outer(y, x))
            )
        )
        de, dj = secular_rates(e_vec, j_vec, sma_km, q, _Z, model.gm_km3_s2, 0.0, model.r_ref_km)
        rates_e.append(np.linalg.norm(de[0]))
        rates_i.append(np.linalg.norm(np.cross(dj[0], j_vec[0])) / np.sum(j_vec[0] ** 2))
    n_month = 2.0 * np.pi / (SIDEREAL_MONTH_DAYS * SECONDS_PER_DAY)
    ecc_monthly, inc_monthly = (
        max(rates_e) / (2.0 * n_month),
        np.degrees(max(rates_i) / (2.0 * n_month)),
    )
    n = np.sqrt(model.gm_km3_s2 / sma_km**3)
    ecc_orbital = 4.0 * np.pi * c * (1.0 + e) / n**2
    w_tide = _precession_rate(e_vec, j_vec, sma_km, model.tide, 0.0, model)
    w_j2 = _precession_rate(e_vec, j_vec, sma_km, np.zeros((3, 3)), model.j2, model)
    axis = w_tide * _Z + w_j2 * model.pole - model.frame_spin
    laplace = np.arctan2(np.linalg.norm(axis[:2]), abs(axis[2]))
    return {
        "ecc_monthly": float(ecc_monthly),
        "ecc_orbital": float(ecc_orbital),
        "inc_monthly_deg": float(inc_monthly),
        "inc_tilt_deg": float(2.0 * np.degrees(laplace)),
        "ecc": float(2.0 * (ecc_monthly + ecc_orbital)),
        "inc_deg": float(2.0 * inc_monthly + 2.0 * np.degrees(laplace)),
    }
