"""A straightforward reference propagator, kept to check and time the compiled engine against.

Written the obvious way on purpose: ``scipy.integrate.solve_ivp``, SPICE calls inside the
right-hand side, and the gravity field summed in spherical coordinates with the classical
normalised Legendre recursion (independent of the Cartesian recursion in :mod:`lnss_lib.gravity`;
singular exactly at the poles, which the reference never visits in the benchmarks).
"""

from __future__ import annotations

import numpy as np
import spiceypy as spice
from scipy.integrate import solve_ivp

from .ephemeris import NAIF_BODY, ensure_kernels, spice_errors
from .forces import shadow_factor
from .gravity import GravityField
from .settings import Dynamics

__all__ = [
    "legendre_normalised",
    "harmonic_acceleration_spherical",
    "ReferenceModel",
    "propagate_reference",
]


def legendre_normalised(
    degree: int, sin_phi: float, cos_phi: float
) -> tuple[np.ndarray, np.ndarray]:
    """Fully normalised P_nm(sin phi) and dP_nm/dphi, (degree + 2, degree + 2) arrays [n, m]."""
    size = degree + 2
    P = np.zeros((size, size))
    dP = np.zeros((size, size))
    P[0, 0] = 1.0
    for m in range(1, size):
        factor = np.sqrt(3.0) if m == 1 else np.sqrt((2.0 * m + 1.0) / (2.0 * m))
        P[m, m] = factor * cos_phi * P[m - 1, m - 1]
    for m in range(size):
        for n in range(m + 1, size):
            a = np.sqrt((2.0 * n - 1.0) * (2.0 * n + 1.0) / ((n - m) * (n + m)))
            b = (
                np.sqrt(
                    (2.0 * n + 1.0)
                    * (n + m - 1.0)
                    * (n - m - 1.0)
                    / ((n - m) * (n + m) * (2.0 * n - 3.0))
                )
                if n >= m + 2
                else 0.0
            )
            P[n, m] = a * sin_phi * P[n - 1, m] - (b * P[n - 2, m] if n >= m + 2 else 0.0)
    tan_phi = sin_phi / cos_phi
    for n in range(degree + 1):
        for m in range(n + 1):
            k = 0.5 if m == 0 else 1.0
            dP[n, m] = np.sqrt(k * (n - m) * (n + m + 1.0)) * P[n, m + 1] - m * tan_phi * P[n, m]
    return P, dP


def harmonic_acceleration_spherical(r_bf_km: np.ndarray, field: GravityField) -> np.ndarray:
    """Body-fixed acceleration (km/s^2) from the gradient of U in spherical coordinates."""
    x, y, z = r_bf_km
    r = np.sqrt(x * x + y * y + z * z)
    rxy = np.hypot(x, y)
    sin_phi, cos_phi = z / r, rxy / r
    lam = np.arctan2(y, x)
    P, dP = legendre_normalised(field.degree, sin_phi, cos_phi)
    n = np.arange(field.degree + 1)[:, None]
    m = np.arange(field.degree + 1)[None, :]
    ratio = (field.r_ref_km / r) ** n
    cos_ml, sin_ml = np.cos(m * lam), np.sin(m * lam)
    C, S = field.cnm, field.snm
    Pn, dPn = P[: field.degree + 1, : field.degree + 1], dP[: field.degree + 1, : field.degree + 1]
    gm = field.gm_km3_s2
    dU_dr = -gm / r**2 * np.sum((n + 1) * ratio * Pn * (C * cos_ml + S * sin_ml))
    dU_dphi = gm / r * np.sum(ratio * dPn * (C * cos_ml + S * sin_ml))
    dU_dlam = gm / r * np.sum(ratio * m * Pn * (S * cos_ml - C * sin_ml))
    r_hat = np.array([cos_phi * np.cos(lam), cos_phi * np.sin(lam), sin_phi])
    phi_hat = np.array([-sin_phi * np.cos(lam), -sin_phi * np.sin(lam), cos_phi])
    lam_hat = np.array([-np.sin(lam), np.cos(lam), 0.0])
    return dU_dr * r_hat + dU_dphi / r * phi_hat + dU_dlam / (r * cos_phi) * lam_hat


class ReferenceModel:
    """Full force model evaluated with SPICE at every call (same physics as :mod:`lnss_lib.forces`)."""

    def __init__(
        self,
        dynamics: Dynamics,
        *,
        degree: int | None = None,
        srp_cr_area_mass_m2_kg: float | None = None,
    ):
        ensure_kernels(dynamics.ephemeris)
        self.gravity_frame = dynamics.frames.gravity
        self.field = GravityField.from_settings(dynamics.gravity, degree)
        const, forces, craft = dynamics.constants, dynamics.forces, dynamics.spacecraft
        self.const, self.forces = const, forces
        cr_am = (
            craft.cr * craft.area_m2 / craft.mass_kg
            if srp_cr_area_mass_m2_kg is None
            else srp_cr_area_mass_m2_kg
        )
        self.srp_1au_kms2 = forces.solar_flux_w_m2 / (const.c_km_s * 1e3) * cr_am * 1e-3
        self.gm = {
            "SUN": const.gm_sun_km3_s2,
            "EARTH": const.gm_earth_km3_s2,
            "JUPITER": const.gm_jupiter_km3_s2,
        }
        self.n_calls = 0

    def acceleration(self, t_tdb_s: float, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Total acceleration (km/s^2, Moon-centred J2000)."""
        self.n_calls += 1
        with spice_errors(
            "give the reference model's lunar frame (frames.gravity) and third bodies"
        ):
            rot = np.asarray(spice.pxform("J2000", self.gravity_frame, t_tdb_s))
            pos = {
                b: np.asarray(spice.spkpos(NAIF_BODY[b], t_tdb_s, "J2000", "NONE", "MOON")[0])
                for b in ("SUN", "EARTH", "JUPITER")
            }
        acc = rot.T @ harmonic_acceleration_spherical(rot @ r, self.field)
        for body in self.forces.third_bodies:
            rb = pos[body]
            acc += self.gm[body] * (
                (rb - r) / np.linalg.norm(rb - r) ** 3 - rb / np.linalg.norm(rb) ** 3
            )
        c = self.const
        if self.forces.srp:
            u = r - pos["SUN"]
            d = np.linalg.norm(u)
            nu = 1.0
            if self.forces.shadow == "conical":
                nu = shadow_factor(r, pos["SUN"], 0.0, 0.0, 0.0, c.r_moon_mean_km, c.r_sun_km)
                nu *= shadow_factor(r, pos["SUN"], *pos["EARTH"], c.r_earth_km, c.r_sun_km)
            acc += nu * self.srp_1au_kms2 * (c.au_km / d) ** 2 * u / d
        if self.forces.relativity:
            gm, rn = self.field.gm_km3_s2, np.linalg.norm(r)
            acc += gm / (c.c_km_s**2 * rn**3) * ((4 * gm / rn - v @ v) * r + 4 * (r @ v) * v)
        if self.forces.albedo:
            q = r - pos["EARTH"]
            e = pos["SUN"] - pos["EARTH"]
            phase = np.arccos(np.clip(e @ q / (np.linalg.norm(e) * np.linalg.norm(q)), -1, 1))
            lambert = (np.sin(phase) + (np.pi - phase) * np.cos(phase)) / np.pi
            ratio = (
                (2 / 3)
                * self.forces.earth_albedo
                * (c.r_earth_km / np.linalg.norm(q)) ** 2
                * lambert
            )
            ratio *= (c.au_km / np.linalg.norm(e)) ** 2
            acc += ratio * self.srp_1au_kms2 * q / np.linalg.norm(q)
        return acc

    def rhs(self, t_tdb_s: float, y: np.ndarray) -> np.ndarray:
        return np.concatenate([y[3:], self.acceleration(t_tdb_s, y[:3], y[3:])])


def propagate_reference(
    dynamics: Dynamics,
    state_mci: np.ndarray,
    t0_tdb_s: float,
    duration_s: float,
    *,
    setting: str | None = None,
    degree: int | None = None,
) -> tuple[np.ndarray, int]:
    """Final Moon-centred J2000 state after ``duration_s`` and the number of force evaluations."""
    integ = dynamics.integrator.named(setting)
    model = ReferenceModel(dynamics, degree=degree)
    sol = solve_ivp(
        model.rhs,
        (t0_tdb_s, t0_tdb_s + duration_s),
        np.asarray(state_mci, dtype=float),
        method=integ.method,
        rtol=integ.rtol,
        atol=integ.atol,
    )
    if not sol.success:
        raise RuntimeError(f"reference propagation failed: {sol.message}")
    return sol.y[:, -1], sol.nfev
