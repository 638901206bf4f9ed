"""Force model in Moon-centred J2000 (km, km/s^2, TDB): the compiled kernels and their set-up.

Terms (each switchable in ``params``): lunar gravity field (``gravity``), Sun/Earth/Jupiter as
differential third bodies, cannonball solar radiation pressure with conical Moon and Earth shadow,
the Schwarzschild relativistic term of the Moon, and Earth albedo from a Lambertian sphere.

A :class:`ForceModel` bundles numbers and tables into a plain tuple (``.kernel_args``) that the
compiled :func:`acceleration` takes, so the integrator never calls Python or SPICE.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from .ephemeris import EphemerisTable, hermite_apply, hermite_basis, hermite_sum
from .errors import ConfigError
from .gravity import GravityField, harmonic_acceleration, tabulated_truncation_degree
from .sections import CR_AREA_MASS, CR_AREA_MASS_WHY, THIRD_BODIES
from .setting_rule import allowed_range_text, in_range
from .settings import Dynamics

__all__ = [
    "BODY_ORDER",
    "SCRATCH_SIZE",
    "TERMS",
    "ForceModel",
    "shadow_geometry",
    "conical_fraction",
    "shadow_fraction",
    "shadow_factor",
    "acceleration_terms",
    "acceleration",
    "acceleration_breakdown",
]

BODY_ORDER = THIRD_BODIES  # rows of the ephemeris table; Sun and Earth also occult/illuminate
SCRATCH_SIZE = 24
TERMS = ("central", "harmonics", "SUN", "EARTH", "JUPITER", "srp", "relativity", "albedo")

# indices into the scalar parameter vector of the kernels
GM, R_REF, R_MOON, R_EARTH, R_SUN, AU, C_LIGHT, SRP_K, ALBEDO, SOLAR_P = range(10)
# indices into the flag vector
F_HARMONICS, F_SUN, F_EARTH, F_JUPITER, F_SRP, F_SHADOW, F_REL, F_ALBEDO = range(8)


@dataclass(frozen=True)
class ForceModel:
    """Everything the compiled acceleration needs, built once per run from the dynamics settings."""

    scalars: np.ndarray
    flags: np.ndarray
    gm_bodies: np.ndarray
    table: EphemerisTable
    field: GravityField

    @classmethod
    def build(
        cls,
        dynamics: Dynamics,
        table: EphemerisTable,
        *,
        degree: int | None = None,
        srp_cr_area_mass_m2_kg: float | None = None,
    ) -> ForceModel:
        """Force model of the dynamics settings; ``degree`` and Cr*A/m (m^2/kg) may override theirs.

        The settings were checked when loaded (third bodies, shadow model, finite constants); checked
        here are the arguments, the table and the field file's coefficients.
        """
        if tuple(table.body_names) != BODY_ORDER:
            raise ValueError(f"ephemeris table must hold {BODY_ORDER}; got {table.body_names}")
        if table.rot_pa.shape[0] != table.bodies.shape[0]:
            raise ValueError(
                "ephemeris table: the rotation and the bodies must share one grid (interpolated with "
                f"one index); got {table.rot_pa.shape[0]} and {table.bodies.shape[0]} nodes"
            )
        const, forces = dynamics.constants, dynamics.forces
        field = GravityField.from_settings(dynamics.gravity, degree)
        if srp_cr_area_mass_m2_kg is None:
            craft = dynamics.spacecraft
            srp_cr_area_mass_m2_kg = craft.cr * craft.area_m2 / craft.mass_kg
        if not (
            isinstance(srp_cr_area_mass_m2_kg, (int, float, np.floating))
            and np.isfinite(srp_cr_area_mass_m2_kg)
            and in_range(srp_cr_area_mass_m2_kg, CR_AREA_MASS)
        ):
            raise ConfigError(
                f"Cr*A/m = {srp_cr_area_mass_m2_kg!r} m^2/kg is not allowed; allowed: a finite number "
                f"in {allowed_range_text(CR_AREA_MASS)} ({CR_AREA_MASS_WHY})",
                key="srp_cr_area_mass_m2_kg",
            )
        if not (np.all(np.isfinite(field.cnm)) and np.all(np.isfinite(field.snm))):
            raise ConfigError(
                f"gravity field {dynamics.gravity.file} holds non-finite coefficients",
                key="gravity.file",
            )
        solar_pressure_n_m2 = forces.solar_flux_w_m2 / (const.c_km_s * 1e3)
        scalars = np.zeros(10)
        scalars[GM] = field.gm_km3_s2
        scalars[R_REF] = field.r_ref_km
        scalars[R_MOON] = const.r_moon_mean_km
        scalars[R_EARTH] = const.r_earth_km
        scalars[R_SUN] = const.r_sun_km
        scalars[AU] = const.au_km
        scalars[C_LIGHT] = const.c_km_s
        scalars[SRP_K] = solar_pressure_n_m2 * srp_cr_area_mass_m2_kg * 1e-3  # km/s^2 at 1 au
        scalars[ALBEDO] = forces.earth_albedo
        scalars[SOLAR_P] = solar_pressure_n_m2
        flags = np.zeros(8, dtype=np.int64)
        flags[F_HARMONICS] = 1
        flags[F_SUN] = "SUN" in forces.third_bodies
        flags[F_EARTH] = "EARTH" in forces.third_bodies
        flags[F_JUPITER] = "JUPITER" in forces.third_bodies
        flags[F_SRP] = bool(forces.srp)
        flags[F_SHADOW] = forces.shadow == "conical"
        flags[F_REL] = bool(forces.relativity)
        flags[F_ALBEDO] = bool(forces.albedo)
        gm_bodies = np.array([const.gm_sun_km3_s2, const.gm_earth_km3_s2, const.gm_jupiter_km3_s2])
        return cls(scalars, flags, gm_bodies, table, field)

    @property
    def kernel_args(self) -> tuple:
        """The tuple :func:`acceleration` and the integrator take."""
        tab = self.table
        return (
            self.scalars,
            self.flags,
            self.gm_bodies,
            np.array([tab.t0_tdb_s, tab.step_s]),
            tab.bodies,
            tab.rot_pa,
            tab.rot_pa_rate,
            self.field.tables,
            self.field.truncation_radii_km,
        )

    def describe(self) -> str:
        """One line naming the active terms, for dataset attributes."""
        f = self.flags
        parts = [
            f"gravity AIUB-GRL350B {self.field.degree}x{self.field.degree} (MOON_PA)"
            + (
                f", degrees dropped below {self.field.truncation_kms2:g} km/s^2"
                if self.field.truncation_kms2
                else ""
            )
        ]
        parts += [b for b, k in zip(BODY_ORDER, (F_SUN, F_EARTH, F_JUPITER)) if f[k]]
        if f[F_SRP]:
            parts.append("SRP" + (" with conical shadow" if f[F_SHADOW] else ""))
        if f[F_REL]:
            parts.append("Schwarzschild relativity")
        if f[F_ALBEDO]:
            parts.append("Earth albedo")
        return ", ".join(parts)


@nb.njit(cache=True)
def shadow_geometry(
    rx: float,
    ry: float,
    rz: float,
    sun_x: float,
    sun_y: float,
    sun_z: float,
    bx: float,
    by: float,
    bz: float,
    radius_body: float,
    radius_sun: float,
) -> tuple:
    """(inside the body, sin a, sin b, cos c) of :func:`shadow_fraction`: the sines of the apparent radii of the Sun (a)
    and of a spherical body at (bx, by, bz) (b), and the cosine of their separation (c), seen from (rx, ry, rz)."""
    sx, sy, sz = rx - bx, ry - by, rz - bz
    dx, dy, dz = sun_x - rx, sun_y - ry, sun_z - rz
    s_norm = np.sqrt(sx * sx + sy * sy + sz * sz)
    d_norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    if s_norm <= radius_body:
        return True, 0.0, 0.0, 0.0
    return (
        False,
        min(1.0, radius_sun / d_norm),
        radius_body / s_norm,
        -(sx * dx + sy * dy + sz * dz) / (s_norm * d_norm),
    )


@nb.njit(cache=True)
def conical_fraction(sin_a: float, sin_b: float, cos_c: float) -> float:
    """Visible fraction of the solar disc from the angles of :func:`shadow_geometry` (Montenbruck & Gill 2000,
    Sec. 3.4.2: full, none, annular, or the overlap of the two discs)."""
    a = np.arcsin(sin_a)
    b = np.arcsin(sin_b)
    c = np.arccos(max(-1.0, min(1.0, cos_c)))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:
        return 1.0 - (b * b) / (a * a)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = np.sqrt(max(a * a - x * x, 0.0))
    area = (
        a * a * np.arccos(max(-1.0, min(1.0, x / a)))
        + b * b * np.arccos(max(-1.0, min(1.0, (c - x) / b)))
        - c * y
    )
    return 1.0 - area / (np.pi * a * a)


@nb.njit(cache=True)
def shadow_fraction(
    rx: float,
    ry: float,
    rz: float,
    sun_x: float,
    sun_y: float,
    sun_z: float,
    bx: float,
    by: float,
    bz: float,
    radius_body: float,
    radius_sun: float,
) -> float:
    """Fraction of the solar disc visible from (rx, ry, rz) past one spherical occulting body at (bx, by, bz)
    (conical model; Montenbruck & Gill (2000), Sec. 3.4.2, :func:`conical_fraction`), all km.

    A satellite in full sunlight, c >= a + b, is told from the cosines (cos c < cos(a + b) less 1e-6, far above the
    rounding of the angles) without the inverse trigonometric functions: the same 1.0 they give.
    """
    inside, sin_a, sin_b, cos_c = shadow_geometry(
        rx, ry, rz, sun_x, sun_y, sun_z, bx, by, bz, radius_body, radius_sun
    )
    if inside:
        return 0.0
    lit = cos_c + sin_a * sin_b + 1e-6  # < cos(a) cos(b): fully lit; cos(a) cos(b) >= 0
    if lit < 0.0 or lit < np.sqrt(1.0 - sin_a * sin_a) * np.sqrt(1.0 - sin_b * sin_b):
        return 1.0
    return conical_fraction(sin_a, sin_b, cos_c)


@nb.njit(cache=True)
def shadow_factor(
    r_sc: np.ndarray,
    r_sun: np.ndarray,
    bx: float,
    by: float,
    bz: float,
    radius_body: float,
    radius_sun: float,
) -> float:
    """:func:`shadow_fraction` of position vectors ``r_sc`` and ``r_sun`` (km)."""
    return shadow_fraction(
        r_sc[0], r_sc[1], r_sc[2], r_sun[0], r_sun[1], r_sun[2], bx, by, bz, radius_body, radius_sun
    )


@nb.njit(cache=True)
def _third_body(
    rx: float,
    ry: float,
    rz: float,
    bx: float,
    by: float,
    bz: float,
    gm_b: float,
    terms: np.ndarray,
    row: int,
) -> None:
    """Differential point-mass acceleration of a body at (bx, by, bz) on a satellite at (rx, ry, rz) (Moon-centred),
    added to ``terms[row]``."""
    dx, dy, dz = bx - rx, by - ry, bz - rz
    d3 = (dx * dx + dy * dy + dz * dz) ** 1.5
    b3 = (bx * bx + by * by + bz * bz) ** 1.5
    terms[row, 0] += gm_b * (dx / d3 - bx / b3)
    terms[row, 1] += gm_b * (dy / d3 - by / b3)
    terms[row, 2] += gm_b * (dz / d3 - bz / b3)


@nb.njit(cache=True)
def _body_component(bodies: np.ndarray, body: int, basis: tuple, axis: int) -> float:
    """Coordinate ``axis`` (0-2) of the position (km) of row ``body`` of the ephemeris table at
    :func:`~lnss_lib.ephemeris.hermite_basis`'s weights (its rate in column ``axis + 3``)."""
    k = basis[0]
    return hermite_sum(
        basis,
        bodies[k, body, axis],
        bodies[k, body, axis + 3],
        bodies[k + 1, body, axis],
        bodies[k + 1, body, axis + 3],
    )


@nb.njit(cache=True)
def _body_position(bodies: np.ndarray, body: int, basis: tuple) -> tuple:
    """Position (km) of row ``body`` of the ephemeris table (positions in columns 0-2, velocities, their rates, in
    3-5) at :func:`~lnss_lib.ephemeris.hermite_basis`'s weights, indexed without a view of the table."""
    return (
        _body_component(bodies, body, basis, 0),
        _body_component(bodies, body, basis, 1),
        _body_component(bodies, body, basis, 2),
    )


@nb.njit(cache=True, inline="always")
def acceleration_terms(
    t: float, y: np.ndarray, args: tuple, work: np.ndarray, scratch: np.ndarray, terms: np.ndarray
) -> None:
    """Each term of the acceleration (km/s^2, Moon-centred J2000) into ``terms`` (8, 3), order ``TERMS``.

    ``work`` is the gravity scratch array, ``scratch`` a float array of at least 24 elements. The rotation
    and the bodies are interpolated with one interval and weight computation; the gravity degree is looked
    up in the field's tabulated radii. Vectors are held as scalars, not as views of arrays (each view was an
    array struct built and reference-counted per call; the same arithmetic, the same bits: ``bench integrator``).
    Inlined into the integrator (see ``lnss_lib.propagator._rhs``).
    """
    scalars, flags, gm_bodies, t0dt, bodies, rot_pa, rot_pa_rate, tables, radii = args
    terms[:, :] = 0.0
    rx, ry, rz = y[0], y[1], y[2]
    gm = scalars[GM]
    r2 = rx * rx + ry * ry + rz * rz
    r_norm = np.sqrt(r2)
    terms[0, 0] = -gm * rx / (r2 * r_norm)
    terms[0, 1] = -gm * ry / (r2 * r_norm)
    terms[0, 2] = -gm * rz / (r2 * r_norm)
    degree = tables.shape[1] - 2
    basis = hermite_basis(
        rot_pa.shape[0], t0dt[0], t0dt[1], t
    )  # one grid for the rotation and the bodies
    if flags[F_HARMONICS] and degree >= 2:
        buf = scratch[0:9]
        r_bf = scratch[9:12]
        a_bf = scratch[12:15]
        hermite_apply(rot_pa, rot_pa_rate, basis, buf)
        for i in range(3):
            r_bf[i] = buf[3 * i] * rx + buf[3 * i + 1] * ry + buf[3 * i + 2] * rz
        kept = tabulated_truncation_degree(r_norm, radii)  # per-evaluation degree truncation
        harmonic_acceleration(r_bf, tables, gm, scalars[R_REF], kept, work, a_bf)
        for j in range(3):
            terms[1, j] = (
                buf[j] * a_bf[0] + buf[3 + j] * a_bf[1] + buf[6 + j] * a_bf[2] - terms[0, j]
            )
    sun_x, sun_y, sun_z = _body_position(bodies, 0, basis)
    earth_x, earth_y, earth_z = _body_position(bodies, 1, basis)
    if flags[F_SUN]:
        _third_body(rx, ry, rz, sun_x, sun_y, sun_z, gm_bodies[0], terms, 2)
    if flags[F_EARTH]:
        _third_body(rx, ry, rz, earth_x, earth_y, earth_z, gm_bodies[1], terms, 3)
    if flags[F_JUPITER]:
        jup_x, jup_y, jup_z = _body_position(bodies, 2, basis)
        _third_body(rx, ry, rz, jup_x, jup_y, jup_z, gm_bodies[2], terms, 4)
    if flags[F_SRP]:
        ux, uy, uz = rx - sun_x, ry - sun_y, rz - sun_z
        d = np.sqrt(ux * ux + uy * uy + uz * uz)
        nu = 1.0
        if flags[F_SHADOW]:
            nu = shadow_fraction(
                rx, ry, rz, sun_x, sun_y, sun_z, 0.0, 0.0, 0.0, scalars[R_MOON], scalars[R_SUN]
            )
            if nu > 0.0:
                nu *= shadow_fraction(
                    rx,
                    ry,
                    rz,
                    sun_x,
                    sun_y,
                    sun_z,
                    earth_x,
                    earth_y,
                    earth_z,
                    scalars[R_EARTH],
                    scalars[R_SUN],
                )
        k = nu * scalars[SRP_K] * (scalars[AU] / d) ** 2 / d
        terms[5, 0] = k * ux
        terms[5, 1] = k * uy
        terms[5, 2] = k * uz
    if flags[F_REL]:
        vx, vy, vz = y[3], y[4], y[5]
        c2 = scalars[C_LIGHT] ** 2
        v2 = vx * vx + vy * vy + vz * vz
        rv = rx * vx + ry * vy + rz * vz
        f = gm / (c2 * r2 * r_norm)
        terms[6, 0] = f * ((4.0 * gm / r_norm - v2) * rx + 4.0 * rv * vx)
        terms[6, 1] = f * ((4.0 * gm / r_norm - v2) * ry + 4.0 * rv * vy)
        terms[6, 2] = f * ((4.0 * gm / r_norm - v2) * rz + 4.0 * rv * vz)
    if flags[F_ALBEDO]:
        qx, qy, qz = rx - earth_x, ry - earth_y, rz - earth_z
        q = np.sqrt(qx * qx + qy * qy + qz * qz)
        ex, ey, ez = sun_x - earth_x, sun_y - earth_y, sun_z - earth_z
        e_norm = np.sqrt(ex * ex + ey * ey + ez * ez)
        cos_phase = (ex * qx + ey * qy + ez * qz) / (e_norm * q)
        phase = np.arccos(max(-1.0, min(1.0, cos_phase)))
        lambert = (np.sin(phase) + (np.pi - phase) * np.cos(phase)) / np.pi
        # reflected flux / incident flux of a Lambertian sphere: (2/3) A (R/q)^2 lambert(phase)
        ratio = (
            (2.0 / 3.0)
            * scalars[ALBEDO]
            * (scalars[R_EARTH] / q) ** 2
            * lambert
            * (scalars[AU] / e_norm) ** 2
        )
        k = ratio * scalars[SRP_K] / q
        terms[7, 0] = k * qx
        terms[7, 1] = k * qy
        terms[7, 2] = k * qz


@nb.njit(cache=True, inline="always")
def acceleration(
    t: float,
    y: np.ndarray,
    args: tuple,
    work: np.ndarray,
    scratch: np.ndarray,
    terms: np.ndarray,
    out: np.ndarray,
) -> None:
    """Total acceleration (km/s^2, Moon-centred J2000) at TDB ``t`` and state ``y`` into ``out``."""
    acceleration_terms(t, y, args, work, scratch, terms)
    for j in range(3):
        s = 0.0
        for k in range(terms.shape[0]):
            s += terms[k, j]
        out[j] = s


def acceleration_breakdown(
    dynamics: Dynamics,
    t_tdb_s: np.ndarray,
    state_mci: np.ndarray,
    *,
    degree: int | None = None,
    srp_cr_area_mass_m2_kg: float | None = None,
    model: ForceModel | None = None,
) -> dict:
    """Each force term (km/s^2, Moon-centred J2000) at epochs ``t_tdb_s`` (n,) and states (n, 6).

    Returns ``{term: (n, 3)}`` with keys :data:`TERMS`. Pass ``model`` to reuse its tables.
    """
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    states = np.atleast_2d(np.asarray(state_mci, dtype=float))
    if model is None:
        table = EphemerisTable.build(dynamics, float(times.min()), float(times.max()))
        model = ForceModel.build(
            dynamics, table, degree=degree, srp_cr_area_mass_m2_kg=srp_cr_area_mass_m2_kg
        )
    elif times.min() < model.table.t0_tdb_s or times.max() > model.table.t_end_tdb_s:
        raise ValueError(
            "epochs outside the force model's ephemeris table "
            f"[{model.table.t0_tdb_s:.0f}, {model.table.t_end_tdb_s:.0f}] s TDB"
        )
    out = np.full((len(times), len(TERMS), 3), np.nan)
    _breakdown_loop(
        times, states, model.kernel_args, model.field.workspace(), np.empty(SCRATCH_SIZE), out
    )
    if not np.all(np.isfinite(out)):
        raise RuntimeError(
            f"force breakdown: non-finite or missing terms at {int(np.sum(~np.isfinite(out).all(axis=(1, 2))))} "
            f"of {len(times)} epochs"
        )
    return {name: out[:, k, :] for k, name in enumerate(TERMS)}


@nb.njit(cache=True)
def _breakdown_loop(
    times: np.ndarray,
    states: np.ndarray,
    args: tuple,
    work: np.ndarray,
    scratch: np.ndarray,
    out: np.ndarray,
) -> None:
    for i in range(times.shape[0]):
        acceleration_terms(times[i], states[i], args, work, scratch, out[i])
