"""The doubly-averaged (secular) lunar J2 + third-body quadrupole model of the design-life stability screen.

A satellite's orbit is reduced to its eccentricity vector ``e`` and dimensionless
angular momentum ``j = sqrt(1 - e^2) h_hat`` (Moon-centred J2000); ``a`` is constant. The
orbit-averaged potential per unit mass is

* lunar J2 about the lunar pole ``k`` (Kaula 1966; vector form of Tremaine & Yavetz 2014, eq. 6):
  ``Phi_J2 = GM J2 R^2 / (4 a^3) [|j|^-3 - 3 (j.k)^2 |j|^-5]``;
* the tidal quadrupole of each third body ``b`` (Earth, optionally the Sun), averaged over the
  satellite's orbit (``<r r^T> = a^2/2 [(1 - e^2) I - j j^T + 5 e e^T]``) and, with the body's
  direction ``u`` and distance ``r_b``, over one sidereal month of the ephemeris:
  ``Phi_tide = -(a^2 / 4) [s (1 - 6 e^2) - 3 j^T T j + 15 e^T T e]``,
  ``T = < GM_b u u^T / r_b^3 >``, ``s = trace T``. For a circular perturber orbit of normal ``n``
  this is the classic Lidov-Kozai quadrupole ``-(GM_b a^2 / 8 a_b^3) [6 e^2 - 1 + 3 (j.n)^2 - 15 (e.n)^2]``
  (Tremaine, Touma & Kazandjian 2009, eq. 22; Ely 2005 for the lunar case).

The vectors evolve by the Milankovitch equations (Tremaine et al. 2009, eq. 18), ``L = sqrt(GM a)``:
``dj/dt = -(j x grad_j Phi + e x grad_e Phi) / L``, ``de/dt = -(j x grad_e Phi + e x grad_j Phi) / L``.

``T`` and ``k`` come from SPICE: the Earth's and the Sun's Moon-centred positions, averaged over a
running window of one sidereal month, and the MOON_PA pole, tabulated over the design life so that
the Earth's orbit plane and the lunar pole move as they do (``precession = true``), or frozen at
their first-month values. Satellites that share (a, e, j) (the satellites of one Walker plane) are
integrated once.

Dropped terms, by argument:
* C22 (and every tesseral/sectoral term): the Moon rotates synchronously, so within the averaging
  month the C22 bulge turns once about the pole; the average of ``x x^T - y y^T`` of a frame turning
  about z is zero, and the satellite's orbit barely changes in a month. Resonances of the orbital
  period with the lunar rotation are not modelled.
* J3 and higher zonals (J3/J2 ~ 0.04; they shape the e-AOP frozen family of low orbits, not the
  Lidov-Kozai growth that ends high inclined orbits), SRP, octupole tide ((a / a_E) e_E terms).
* Monthly terms: :mod:`lnss_lib.design_life.monthly_tide` restores them for the screen's verdict.
* Orbit-period (short-period) terms: :func:`lnss_lib.design_life.frozen.allowances` bounds them.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from ..constants import SECONDS_PER_DAY
from ..elements import eccentricity_vector, vis_viva_sma_km
from ..ephemeris import body_states_mci, ensure_kernels, rotation
from ..gravity import GravityField
from ..sections import STABILITY_BODIES
from ..settings import Dynamics, GravitySettings, StabilitySettings

__all__ = [
    "SIDEREAL_MONTH_DAYS",
    "SecularField",
    "TideSamples",
    "orbit_vectors_ej",
    "secular_rates",
    "averaged_potential",
    "integrate_secular",
    "elements_from_vectors",
    "classical_j2_rates",
    "kozai_e_max",
    "circular_tide_tensor",
]

SIDEREAL_MONTH_DAYS = 27.321661
BODIES = STABILITY_BODIES


def circular_tide_tensor(gm_body_km3_s2: float, a_body_km: float, normal) -> np.ndarray:
    """Tide tensor T (3, 3) (1/s^2) of a body on a circular orbit of radius ``a_body_km`` and unit normal."""
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    return gm_body_km3_s2 / a_body_km**3 * 0.5 * (np.eye(3) - np.outer(n, n))


@dataclass(frozen=True)
class SecularField:
    """Everything the secular right-hand side needs, tabulated on days since the epoch.

    ``t_days`` (m,) increasing; ``tide`` (m, 3, 3) tide tensors (1/s^2); ``pole`` (m, 3) unit lunar
    pole in J2000; ``gm_km3_s2``, ``j2`` (unnormalised, positive for an oblate Moon), ``r_ref_km``.
    Between nodes T and k are interpolated by a cubic spline (smooth, so that the integrator's
    error control sees no kinks; k renormalised); outside the nodes they are held.
    """

    t_days: np.ndarray
    tide: np.ndarray
    pole: np.ndarray
    gm_km3_s2: float
    j2: float
    r_ref_km: float

    @classmethod
    def constant(cls, tide, pole, gm_km3_s2: float, j2: float, r_ref_km: float) -> SecularField:
        """A field with fixed T (3, 3) and pole (3,) (analytic tests, frozen geometry)."""
        tide = np.asarray(tide, dtype=float).reshape(3, 3)
        pole = np.asarray(pole, dtype=float) / np.linalg.norm(pole)
        return cls(
            np.array([0.0, 1.0]),
            np.stack([tide, tide]),
            np.stack([pole, pole]),
            float(gm_km3_s2),
            float(j2),
            float(r_ref_km),
        )

    @classmethod
    def from_settings(
        cls, stability: StabilitySettings, dynamics: Dynamics, t0_tdb_s: float, life_days: float
    ) -> SecularField:
        """T and k from SPICE over ``life_days`` (running one-month mean of ``[stability]``), J2 from the gravity file."""
        span = life_days if stability.precession else 0.0
        return cls.from_samples(
            stability,
            dynamics,
            t0_tdb_s,
            TideSamples.from_settings(stability, dynamics, t0_tdb_s, span),
        )

    @classmethod
    def from_samples(
        cls, stability: StabilitySettings, dynamics: Dynamics, t0_tdb_s: float, samples: TideSamples
    ) -> SecularField:
        """The field of :meth:`from_settings` from tide samples already taken (``samples.out_days`` nodes)."""
        tide, out_days = samples.running_mean(samples.inst), samples.out_days
        pole = rotation(dynamics.frames.gravity, "J2000", t0_tdb_s + out_days * SECONDS_PER_DAY)[
            :, :, 2
        ]
        if not stability.precession:
            return cls.constant(tide[0], pole[0], *_gravity_constants(dynamics.gravity))
        return cls(out_days, tide, pole, *_gravity_constants(dynamics.gravity))

    def __post_init__(self) -> None:
        values = np.concatenate([self.tide.reshape(-1, 9), self.pole], axis=1)
        spline = CubicSpline(self.t_days, values, axis=0)
        object.__setattr__(self, "_knots", np.ascontiguousarray(spline.x, dtype=float))
        object.__setattr__(self, "_coef", np.ascontiguousarray(spline.c, dtype=float))

    def shifted(self, days: float) -> SecularField:
        """The same field with its epoch ``days`` later: the same cubic on shifted knots (not fitted again)."""
        out = copy.copy(self)
        object.__setattr__(out, "t_days", self.t_days - days)
        object.__setattr__(out, "_knots", self._knots - days)
        return out

    def at(self, t_day: float) -> tuple[np.ndarray, np.ndarray]:
        """(T (3, 3), k (3,)) at ``t_day`` days since the epoch."""
        v = _spline_at(self._knots, self._coef, float(t_day))
        return v[:9].reshape(3, 3), v[9:]


@dataclass(frozen=True)
class TideSamples:
    """Instantaneous tide tensors ``inst`` (m, 3, 3) (1/s^2) of ``[stability] third_bodies`` on ``t_days`` (m,)
    (step ``table_step_days``), padded by half an averaging window each side of the output nodes ``out_days``."""

    t_days: np.ndarray
    inst: np.ndarray
    weights: np.ndarray
    half: int

    @classmethod
    def from_settings(
        cls, stability: StabilitySettings, dynamics: Dynamics, t0_tdb_s: float, life_days: float
    ) -> TideSamples:
        ensure_kernels(dynamics.ephemeris)
        step, window = stability.table_step_days, stability.average_days
        half = int(np.ceil(0.5 * window / step))
        n_out = int(np.ceil(life_days / step)) + 1
        t_days = step * np.arange(-half, n_out + half)
        times = t0_tdb_s + t_days * SECONDS_PER_DAY
        gms = {"EARTH": dynamics.constants.gm_earth_km3_s2, "SUN": dynamics.constants.gm_sun_km3_s2}
        inst = np.zeros((t_days.size, 3, 3))
        for body in stability.third_bodies:
            r = body_states_mci(body, times)[:, :3]
            dist = np.linalg.norm(r, axis=1)
            inst += gms[body] * np.einsum("ni,nj->nij", r, r) / dist[:, None, None] ** 5
        weights = np.ones(2 * half + 1)
        weights[[0, -1]] = 0.5 + (0.5 * window / step - half)  # trapezoid over exactly one window
        return cls(t_days, inst, weights / weights.sum(), half)

    @property
    def out_days(self) -> np.ndarray:
        return self.t_days[self.half : self.t_days.size - self.half]

    def running_mean(self, values: np.ndarray) -> np.ndarray:
        """One-window running mean (n_out, ...) of ``values`` (m, ...) sampled on ``t_days``, at ``out_days``."""
        w = 2 * self.half + 1
        return np.stack(
            [
                np.tensordot(self.weights, values[j : j + w], axes=1)
                for j in range(self.out_days.size)
            ]
        )


def _gravity_constants(gravity: GravitySettings) -> tuple[float, float, float]:
    field = GravityField.from_settings(gravity, degree=2)
    return field.gm_km3_s2, float(-field.cnm[2, 0] * np.sqrt(5.0)), field.r_ref_km


def orbit_vectors_ej(
    states: np.ndarray, gm_km3_s2: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sma_km (n,), e vector (n, 3), j = sqrt(1 - e^2) h_hat (n, 3)) of osculating states (n, 6)."""
    s = np.atleast_2d(np.asarray(states, dtype=float))
    r, v = s[:, :3], s[:, 3:]
    rn = np.linalg.norm(r, axis=1)
    a = vis_viva_sma_km(rn, np.sum(v * v, axis=1), gm_km3_s2)
    if np.any(~(a > 0.0)):
        raise ValueError(f"the screen needs bound orbits; got a = {a[~(a > 0.0)][0]!r} km")
    h = np.cross(r, v)
    e_vec = eccentricity_vector(r, v, gm_km3_s2, h, rn)
    return a, e_vec, h / np.sqrt(gm_km3_s2 * a)[:, None]


def _gradients(e_vec, j_vec, sma_km, tide, pole, gm, j2, r_ref):
    """grad_e Phi and grad_j Phi (n, 3) (km^2/s^2) of the averaged potential."""
    a2 = (sma_km**2)[:, None]
    s = np.trace(tide)
    grad_e = -0.25 * a2 * (-12.0 * s * e_vec + 30.0 * e_vec @ tide)
    grad_j = -0.25 * a2 * (-6.0 * j_vec @ tide)
    jn = np.linalg.norm(j_vec, axis=1)[:, None]
    jk = (j_vec @ pole)[:, None]
    c = (gm * j2 * r_ref**2 / (4.0 * sma_km**3))[:, None]
    grad_j = grad_j + c * (
        -3.0 * j_vec / jn**5 - 6.0 * jk * pole / jn**5 + 15.0 * jk**2 * j_vec / jn**7
    )
    return grad_e, grad_j


def averaged_potential(
    e_vec, j_vec, sma_km, tide, pole, gm_km3_s2: float, j2: float, r_ref_km: float
) -> np.ndarray:
    """Doubly-averaged potential per unit mass (n,) (km^2/s^2), tide plus J2 (see module docstring)."""
    e_vec, j_vec = np.atleast_2d(e_vec), np.atleast_2d(j_vec)
    a = np.atleast_1d(np.asarray(sma_km, dtype=float))
    s = np.trace(tide)
    tide_part = (
        -0.25
        * a**2
        * (
            s * (1.0 - 6.0 * np.sum(e_vec**2, axis=1))
            - 3.0 * np.einsum("ni,ij,nj->n", j_vec, tide, j_vec)
            + 15.0 * np.einsum("ni,ij,nj->n", e_vec, tide, e_vec)
        )
    )
    jn = np.linalg.norm(j_vec, axis=1)
    jk = j_vec @ pole
    return tide_part + gm_km3_s2 * j2 * r_ref_km**2 / (4.0 * a**3) * (jn**-3 - 3.0 * jk**2 * jn**-5)


def secular_rates(e_vec, j_vec, sma_km, tide, pole, gm_km3_s2: float, j2: float, r_ref_km: float):
    """Milankovitch rates (de/dt, dj/dt), each (n, 3) in 1/s, of vectors (n, 3) with sma_km (n,)."""
    e_vec, j_vec = np.atleast_2d(e_vec), np.atleast_2d(j_vec)
    a = np.atleast_1d(np.asarray(sma_km, dtype=float))
    grad_e, grad_j = _gradients(
        e_vec, j_vec, a, np.asarray(tide), np.asarray(pole), gm_km3_s2, j2, r_ref_km
    )
    inv_l = (1.0 / np.sqrt(gm_km3_s2 * a))[:, None]
    de = -inv_l * (np.cross(j_vec, grad_e) + np.cross(e_vec, grad_j))
    dj = -inv_l * (np.cross(j_vec, grad_j) + np.cross(e_vec, grad_e))
    return de, dj


@nb.njit(cache=True)
def _spline_at(knots: np.ndarray, coef: np.ndarray, t: float) -> np.ndarray:
    """The piecewise cubic (scipy ``CubicSpline`` ``x``, ``c`` (4, m - 1, 12)) at ``t`` clamped to the knots;
    components 9-11 (the pole) renormalised."""
    t = min(max(t, knots[0]), knots[-1])
    i = min(max(np.searchsorted(knots, t, side="right") - 1, 0), knots.size - 2)
    dx = t - knots[i]
    v = ((coef[0, i] * dx + coef[1, i]) * dx + coef[2, i]) * dx + coef[3, i]
    v[9:] /= np.sqrt(v[9] * v[9] + v[10] * v[10] + v[11] * v[11])
    return v


@nb.njit(cache=True)
def _rhs_kernel(
    y: np.ndarray,
    sma_km: np.ndarray,
    tide: np.ndarray,
    pole: np.ndarray,
    gm: float,
    j2: float,
    r_ref: float,
    scale: float,
) -> np.ndarray:
    """Compiled :func:`secular_rates` on a flat state [e (3), j (3)] per orbit, times ``scale``."""
    n = sma_km.size
    out = np.empty(6 * n)
    s = tide[0, 0] + tide[1, 1] + tide[2, 2]
    ge = np.empty(3)
    gj = np.empty(3)
    for q in range(n):
        e = y[6 * q : 6 * q + 3]
        j = y[6 * q + 3 : 6 * q + 6]
        a = sma_km[q]
        jn = np.sqrt(j[0] * j[0] + j[1] * j[1] + j[2] * j[2])
        jk = j[0] * pole[0] + j[1] * pole[1] + j[2] * pole[2]
        c = gm * j2 * r_ref * r_ref / (4.0 * a * a * a)
        for m in range(3):
            te = tide[0, m] * e[0] + tide[1, m] * e[1] + tide[2, m] * e[2]
            tj = tide[0, m] * j[0] + tide[1, m] * j[1] + tide[2, m] * j[2]
            ge[m] = -0.25 * a * a * (-12.0 * s * e[m] + 30.0 * te)
            gj[m] = 1.5 * a * a * tj + c * (
                -3.0 * j[m] / jn**5 - 6.0 * jk * pole[m] / jn**5 + 15.0 * jk * jk * j[m] / jn**7
            )
        f = -scale / np.sqrt(gm * a)
        for m in range(3):
            m1 = (m + 1) % 3
            m2 = (m + 2) % 3
            out[6 * q + m] = f * (j[m1] * ge[m2] - j[m2] * ge[m1] + e[m1] * gj[m2] - e[m2] * gj[m1])
            out[6 * q + 3 + m] = f * (
                j[m1] * gj[m2] - j[m2] * gj[m1] + e[m1] * ge[m2] - e[m2] * ge[m1]
            )
    return out


@nb.njit(cache=True)
def _field_rhs(
    t_day: float,
    y: np.ndarray,
    sma_km: np.ndarray,
    knots: np.ndarray,
    coef: np.ndarray,
    gm: float,
    j2: float,
    r_ref: float,
) -> np.ndarray:
    v = _spline_at(knots, coef, t_day)
    return _rhs_kernel(
        y, sma_km, v[:9].copy().reshape(3, 3), v[9:].copy(), gm, j2, r_ref, SECONDS_PER_DAY
    )


@nb.njit(cache=True)
def _rk4_secular(
    y0: np.ndarray,
    sma_km: np.ndarray,
    floor_km: np.ndarray,
    t_out: np.ndarray,
    max_step_days: float,
    knots: np.ndarray,
    coef: np.ndarray,
    gm: float,
    j2: float,
    r_ref: float,
):
    """Classical RK4 over ``t_out`` (each output interval in equal steps of at most ``max_step_days``); an orbit
    whose perilune ``a (1 - |e|)`` reaches its floor stops there (crossing interpolated linearly in the step).
    Returns (states (m, 6 n), NaN after an impact; impact_day (n,); number of right-hand sides)."""
    n = sma_km.size
    out = np.full((t_out.size, 6 * n), np.nan)
    impact = np.full(n, np.nan)
    y = y0.copy()
    margin = np.empty(n)
    for q in range(n):
        e = y[6 * q : 6 * q + 3]
        margin[q] = (
            sma_km[q] * (1.0 - np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])) - floor_km[q]
        )
        if margin[q] <= 0.0:
            impact[q] = t_out[0]
            y[6 * q : 6 * q + 6] = np.nan
    out[0] = y
    n_rhs = 0
    for i in range(t_out.size - 1):
        steps = max(int(np.ceil((t_out[i + 1] - t_out[i]) / max_step_days - 1e-9)), 1)
        h = (t_out[i + 1] - t_out[i]) / steps
        for k in range(steps):
            t = t_out[i] + k * h
            k1 = _field_rhs(t, y, sma_km, knots, coef, gm, j2, r_ref)
            k2 = _field_rhs(t + 0.5 * h, y + 0.5 * h * k1, sma_km, knots, coef, gm, j2, r_ref)
            k3 = _field_rhs(t + 0.5 * h, y + 0.5 * h * k2, sma_km, knots, coef, gm, j2, r_ref)
            k4 = _field_rhs(t + h, y + h * k3, sma_km, knots, coef, gm, j2, r_ref)
            y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            n_rhs += 4
            for q in range(n):
                if not np.isnan(impact[q]):
                    continue
                e = y[6 * q : 6 * q + 3]
                m = (
                    sma_km[q] * (1.0 - np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]))
                    - floor_km[q]
                )
                if m <= 0.0:
                    impact[q] = t + h * margin[q] / (margin[q] - m)
                    y[6 * q : 6 * q + 6] = np.nan
                margin[q] = m
        out[i + 1] = y
    return out, impact, n_rhs


@nb.njit(cache=True)
def _perilune_margin_km(y: np.ndarray, sma_km: np.ndarray, floor_km: np.ndarray) -> float:
    """Smallest perilune a (1 - |e|) above its floor (km; NaN if any is) of orbits on a flat state [e (3), j (3)] per
    orbit."""
    out = np.inf
    for q in range(sma_km.size):
        e = y[6 * q : 6 * q + 3]
        margin = sma_km[q] * (1.0 - np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])) - floor_km[q]
        if np.isnan(margin):
            return margin
        out = min(out, margin)
    return out


def integrate_secular(
    sma_km,
    e0,
    j0,
    field: SecularField,
    life_days: float,
    *,
    floor_km=None,
    method: str = "DOP853",
    rtol: float = 1e-9,
    atol: float = 1e-11,
    output_step_days: float = 1.0,
    step_days: float = 0.5,
) -> dict:
    """Integrate orbits (n,) from (e0, j0) (n, 3) for ``life_days``; stop an orbit whose perilune reaches ``floor_km``.

    ``method``: a scipy ``solve_ivp`` method (``rtol``, ``atol``; the crossing located by an event to the
    integrator's accuracy), or ``"RK4"``: a compiled fixed-step RK4 of at most ``step_days`` (the
    crossing interpolated within the step; over five years 0.1 s a design instead of 0.7 s).
    Returns ``t_days`` (m,), ``e`` and ``j`` (n, m, 3) (NaN after an impact), ``impact_day`` (n,)
    (NaN when none), ``n_rhs``.
    """
    a = np.atleast_1d(np.asarray(sma_km, dtype=float))
    y0 = np.concatenate([np.atleast_2d(e0), np.atleast_2d(j0)], axis=1)
    n = a.size
    if y0.shape != (n, 6) or not np.all(np.isfinite(y0)):
        raise ValueError(f"e0 and j0 must be finite arrays of shape ({n}, 3); got {y0.shape}")
    floor = (
        np.full(n, -np.inf)
        if floor_km is None
        else np.broadcast_to(np.asarray(floor_km, float), (n,))
    )
    t_out = np.arange(0.0, life_days + 1e-9, output_step_days)
    if t_out[-1] < life_days:
        t_out = np.append(t_out, life_days)
    if method == "RK4":
        states, impact_day, n_rhs = _rk4_secular(
            y0.ravel(),
            a,
            np.asarray(floor, dtype=float).copy(),
            t_out,
            float(step_days),
            field._knots,
            field._coef,
            field.gm_km3_s2,
            field.j2,
            field.r_ref_km,
        )
        out = states.reshape(t_out.size, n, 6).transpose(1, 0, 2)
        return {
            "t_days": t_out,
            "e": out[..., :3],
            "j": out[..., 3:],
            "impact_day": impact_day,
            "n_rhs": int(n_rhs),
        }
    out = np.full((n, t_out.size, 6), np.nan)
    impact_day = np.full(n, np.nan)
    alive = np.arange(n)
    t_start, y_start, n_rhs = 0.0, y0.copy(), 0
    while alive.size and t_start < life_days:
        aa, ff = a[alive], floor[alive]

        def rhs(t, y, aa=aa):
            return _field_rhs(
                float(t),
                y,
                aa,
                field._knots,
                field._coef,
                field.gm_km3_s2,
                field.j2,
                field.r_ref_km,
            )

        def surface(t, y, aa=aa, ff=ff):
            return _perilune_margin_km(y, aa, ff)

        surface.terminal = True
        surface.direction = -1
        sol = solve_ivp(
            rhs,
            (t_start, life_days),
            y_start.ravel(),
            method=method,
            rtol=rtol,
            atol=atol,
            dense_output=True,
            events=surface,
        )
        if sol.status < 0:
            raise RuntimeError(
                f"secular integration failed at t = {sol.t[-1]:.2f} d: {sol.message}"
            )
        n_rhs += int(sol.nfev)
        t_end = float(sol.t[-1])
        mask = (t_out >= t_start) & (t_out <= t_end)
        if mask.any():
            out[alive[:, None], np.flatnonzero(mask)[None, :], :] = (
                sol.sol(t_out[mask]).T.reshape(mask.sum(), alive.size, 6).transpose(1, 0, 2)
            )
        if sol.status == 1:
            y_end = sol.y_events[0][0].reshape(-1, 6)
            e_end = np.linalg.norm(y_end[:, :3], axis=1)
            hit = aa * (1.0 - e_end) - ff <= 1e-6 * aa
            impact_day[alive[hit]] = t_end
            alive, y_start = alive[~hit], y_end[~hit]
        else:
            alive = alive[:0]
        t_start = t_end
    return {
        "t_days": t_out,
        "e": out[..., :3],
        "j": out[..., 3:],
        "impact_day": impact_day,
        "n_rhs": n_rhs,
    }


def elements_from_vectors(e_vec, j_vec, rot_to_frame=None) -> dict:
    """e, inclination, RAAN and AOP (deg) of (..., 3) vectors, optionally rotated (x_frame = R x) first."""
    e_vec, j_vec = np.asarray(e_vec, float), np.asarray(j_vec, float)
    if rot_to_frame is not None:
        e_vec, j_vec = e_vec @ rot_to_frame.T, j_vec @ rot_to_frame.T
    e = np.linalg.norm(e_vec, axis=-1)
    h_hat = j_vec / np.linalg.norm(j_vec, axis=-1)[..., None]
    inc = np.degrees(np.arccos(np.clip(h_hat[..., 2], -1.0, 1.0)))
    node = np.stack([-h_hat[..., 1], h_hat[..., 0], np.zeros_like(e)], axis=-1)
    raan = np.degrees(np.arctan2(node[..., 1], node[..., 0])) % 360.0
    node_hat = node / np.linalg.norm(node, axis=-1)[..., None]
    aop = (
        np.degrees(
            np.arctan2(
                np.sum(np.cross(node_hat, e_vec) * h_hat, axis=-1),
                np.sum(node_hat * e_vec, axis=-1),
            )
        )
        % 360.0
    )
    return {"ecc": e, "inc_deg": inc, "raan_deg": raan, "aop_deg": aop}


def classical_j2_rates(sma_km, e, inc_rad, gm_km3_s2: float, j2: float, r_ref_km: float) -> tuple:
    """Secular (RAAN-dot, AOP-dot) (rad/s) of J2 (Vallado eq. 9-41, 9-42), mean motion sqrt(GM / a^3)."""
    n = np.sqrt(gm_km3_s2 / np.asarray(sma_km, float) ** 3)
    k = (
        1.5
        * n
        * j2
        * (r_ref_km / (np.asarray(sma_km, float) * (1.0 - np.asarray(e, float) ** 2))) ** 2
    )
    return -k * np.cos(inc_rad), 0.5 * k * (5.0 * np.cos(inc_rad) ** 2 - 1.0)


def kozai_e_max(inc0_rad) -> np.ndarray:
    """Maximum eccentricity of the test-particle quadrupole Lidov-Kozai cycle from e0 -> 0 (0 below 39.23 deg)."""
    c2 = np.cos(np.asarray(inc0_rad, float)) ** 2
    return np.sqrt(np.clip(1.0 - 5.0 / 3.0 * c2, 0.0, None))
