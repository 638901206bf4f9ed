"""The force model's right-hand side before its speed work, kept here only to time it beside the new one.

Before, each evaluation chose its gravity degree with the loop :func:`lnss_lib.gravity.truncation_degree`
(a sum with a division per degree; now a lookup in radii tabulated once per field), interpolated the
MOON_PA rotation, the Sun, the Earth and Jupiter each with its own interval and Hermite weights (now one
:func:`lnss_lib.ephemeris.hermite_basis` for all), and summed the harmonic acceleration with the
coefficients C_nm, S_nm and the recursion's x/y/z factors multiplied per term
(:func:`harmonic_acceleration_before`; now tables folded once per field and one padded loop per degree row,
:func:`lnss_lib.gravity.harmonic_acceleration`), and took the conical shadow's three angles at every call
(:func:`shadow_factor_before`; now a fully lit satellite is told from the cosines, the same 1.0 bit for bit).
:func:`shadow_times` times the two shadow functions alone. :func:`acceleration_terms_before` is the previous code as it
was (a copy kept for this comparison only); the new sums are reordered, so the two agree to round-off
(~1e-15 relative), not bit for bit. :func:`rhs_points` records the (t, y) points an integration of one
satellite evaluates (RK45 or DOP853 with scipy's controller, the compiled engine's: ``tests/test_propagator.py``
checks that both take the same steps), and :func:`replay_times` times both right-hand sides on them."""

from __future__ import annotations

import time

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp

from ..ephemeris import hermite_apply, hermite_basis, hermite_cubic
from ..forces import (
    ALBEDO,
    AU,
    C_LIGHT,
    F_ALBEDO,
    F_EARTH,
    F_HARMONICS,
    F_JUPITER,
    F_REL,
    F_SHADOW,
    F_SRP,
    F_SUN,
    GM,
    R_EARTH,
    R_MOON,
    R_REF,
    R_SUN,
    SCRATCH_SIZE,
    SRP_K,
    TERMS,
    ForceModel,
    acceleration,
    conical_fraction,
    shadow_factor,
    shadow_geometry,
)
from ..gravity import fill_vw, truncation_degree


@nb.njit(cache=True, fastmath=True)
def harmonic_acceleration_before(r_bf_km, cnm, snm, coef, gm, r_ref, degree, work, out):
    """The previous :func:`lnss_lib.gravity.harmonic_acceleration` (same result to round-off)."""
    V = work[0]
    W = work[1]
    fill_vw(r_bf_km[0], r_bf_km[1], r_bf_km[2], r_ref, degree + 1, coef, V, W)
    ax = 0.0
    ay = 0.0
    az = 0.0
    for n in range(degree + 1):
        c_row, s_row = cnm[n], snm[n]
        up_row, dn_row, z_row = coef[2, n], coef[3, n], coef[4, n]
        v, w = V[n + 1], W[n + 1]
        c = c_row[0]
        ax -= c * up_row[0] * v[1]
        ay -= c * up_row[0] * w[1]
        az -= c * z_row[0] * v[0]
        for m in range(1, n + 1):
            c = c_row[m]
            s = s_row[m]
            f_up = up_row[m]
            f_dn = dn_row[m]
            ax += f_up * (-c * v[m + 1] - s * w[m + 1]) + f_dn * (c * v[m - 1] + s * w[m - 1])
            ay += f_up * (-c * w[m + 1] + s * v[m + 1]) + f_dn * (-c * w[m - 1] + s * v[m - 1])
            az += z_row[m] * (-c * v[m] - s * w[m])
    scale = gm / (r_ref * r_ref)
    out[0] = scale * ax
    out[1] = scale * ay
    out[2] = scale * az


@nb.njit(cache=True)
def shadow_factor_before(r_sc, r_sun, bx, by, bz, radius_body, radius_sun):
    """The previous :func:`lnss_lib.forces.shadow_factor`: the three angles at every call (the same values)."""
    inside, sin_a, sin_b, cos_c = shadow_geometry(
        r_sc[0], r_sc[1], r_sc[2], r_sun[0], r_sun[1], r_sun[2], bx, by, bz, radius_body, radius_sun
    )
    return 0.0 if inside else conical_fraction(sin_a, sin_b, cos_c)


@nb.njit(cache=True)
def _third_body_before(r, r_b, gm_b, out):
    """The previous differential third-body term, on views of arrays (the same sums as the current one)."""
    dx, dy, dz = r_b[0] - r[0], r_b[1] - r[1], r_b[2] - r[2]
    d3 = (dx * dx + dy * dy + dz * dz) ** 1.5
    b3 = (r_b[0] * r_b[0] + r_b[1] * r_b[1] + r_b[2] * r_b[2]) ** 1.5
    out[0] += gm_b * (dx / d3 - r_b[0] / b3)
    out[1] += gm_b * (dy / d3 - r_b[1] / b3)
    out[2] += gm_b * (dz / d3 - r_b[2] / b3)


@nb.njit(cache=True)
def acceleration_terms_before(t, y, args, field_before, work, scratch, terms):
    """The previous :func:`lnss_lib.forces.acceleration_terms`; the field's coefficients and truncation
    tolerance come in ``field_before`` = (cnm, snm, coef, truncation_kms2) (:func:`before_field`): the
    kernel arguments now hold the folded tables and the tabulated radii instead."""
    scalars, flags, gm_bodies, t0dt, bodies, rot_pa, rot_pa_rate = args[:7]
    cnm, snm, coef, truncation_kms2 = field_before
    terms[:, :] = 0.0
    r = y[:3]
    v = y[3:6]
    gm = scalars[GM]
    r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    r_norm = np.sqrt(r2)
    for j in range(3):
        terms[0, j] = -gm * r[j] / (r2 * r_norm)
    degree = cnm.shape[0] - 1
    buf = scratch[0:9]
    r_bf = scratch[9:12]
    a_bf = scratch[12:15]
    if flags[F_HARMONICS] and degree >= 2:
        hermite_cubic(rot_pa, rot_pa_rate, t0dt[0], t0dt[1], t, buf)
        for i in range(3):
            r_bf[i] = buf[3 * i] * r[0] + buf[3 * i + 1] * r[1] + buf[3 * i + 2] * r[2]
        kept = truncation_degree(r_norm, coef, gm, scalars[R_REF], degree, truncation_kms2)
        harmonic_acceleration_before(r_bf, cnm, snm, coef, gm, scalars[R_REF], kept, work, a_bf)
        for j in range(3):
            terms[1, j] = (
                buf[j] * a_bf[0] + buf[3 + j] * a_bf[1] + buf[6 + j] * a_bf[2] - terms[0, j]
            )
    r_sun = scratch[15:18]
    r_earth = scratch[18:21]
    r_jup = scratch[21:24]
    hermite_cubic(bodies[:, 0, :3], bodies[:, 0, 3:], t0dt[0], t0dt[1], t, r_sun)
    hermite_cubic(bodies[:, 1, :3], bodies[:, 1, 3:], t0dt[0], t0dt[1], t, r_earth)
    if flags[F_SUN]:
        _third_body_before(r, r_sun, gm_bodies[0], terms[2])
    if flags[F_EARTH]:
        _third_body_before(r, r_earth, gm_bodies[1], terms[3])
    if flags[F_JUPITER]:
        hermite_cubic(bodies[:, 2, :3], bodies[:, 2, 3:], t0dt[0], t0dt[1], t, r_jup)
        _third_body_before(r, r_jup, gm_bodies[2], terms[4])
    if flags[F_SRP]:
        ux, uy, uz = r[0] - r_sun[0], r[1] - r_sun[1], r[2] - r_sun[2]
        d = np.sqrt(ux * ux + uy * uy + uz * uz)
        nu = 1.0
        if flags[F_SHADOW]:
            nu = shadow_factor_before(r, r_sun, 0.0, 0.0, 0.0, scalars[R_MOON], scalars[R_SUN])
            if nu > 0.0:
                nu *= shadow_factor_before(
                    r, r_sun, r_earth[0], r_earth[1], r_earth[2], scalars[R_EARTH], scalars[R_SUN]
                )
        k = nu * scalars[SRP_K] * (scalars[AU] / d) ** 2 / d
        terms[5, 0] = k * ux
        terms[5, 1] = k * uy
        terms[5, 2] = k * uz
    if flags[F_REL]:
        c2 = scalars[C_LIGHT] ** 2
        v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        rv = r[0] * v[0] + r[1] * v[1] + r[2] * v[2]
        f = gm / (c2 * r2 * r_norm)
        for j in range(3):
            terms[6, j] = f * ((4.0 * gm / r_norm - v2) * r[j] + 4.0 * rv * v[j])
    if flags[F_ALBEDO]:
        qx, qy, qz = r[0] - r_earth[0], r[1] - r_earth[1], r[2] - r_earth[2]
        q = np.sqrt(qx * qx + qy * qy + qz * qz)
        ex, ey, ez = r_sun[0] - r_earth[0], r_sun[1] - r_earth[1], r_sun[2] - r_earth[2]
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


@nb.njit(cache=True)
def acceleration_before(t, y, args, field_before, work, scratch, terms, out):
    """The previous :func:`lnss_lib.forces.acceleration`."""
    acceleration_terms_before(t, y, args, field_before, work, scratch, terms)
    for j in range(3):
        total = 0.0
        for k in range(terms.shape[0]):
            total += terms[k, j]
        out[j] = total


@nb.njit(cache=True)
def _replay_new(ts, ys, args, work, scratch, terms, out):
    total = 0.0
    for i in range(ts.shape[0]):
        acceleration(ts[i], ys[i], args, work, scratch, terms, out)
        total += out[0]
    return total


@nb.njit(cache=True)
def _replay_before(ts, ys, args, field_before, work, scratch, terms, out):
    total = 0.0
    for i in range(ts.shape[0]):
        acceleration_before(ts[i], ys[i], args, field_before, work, scratch, terms, out)
        total += out[0]
    return total


@nb.njit(cache=True)
def _largest_difference(ts, ys, args, field_before, work, scratch, terms):
    """Largest relative difference |new - before| / |before| of the two total accelerations over the points."""
    new, before = np.empty(3), np.empty(3)
    worst = 0.0
    for i in range(ts.shape[0]):
        acceleration(ts[i], ys[i], args, work, scratch, terms, new)
        acceleration_before(ts[i], ys[i], args, field_before, work, scratch, terms, before)
        d2 = 0.0
        b2 = 0.0
        for j in range(3):
            d2 += (new[j] - before[j]) ** 2
            b2 += before[j] ** 2
        worst = max(worst, np.sqrt(d2 / b2))
    return worst


def before_field(model: ForceModel) -> tuple:
    """(cnm, snm, coef, truncation_kms2) of the model's field: what :func:`acceleration_terms_before` needs."""
    field = model.field
    return field.cnm, field.snm, field.coef, field.truncation_kms2


def rhs_points(
    model: ForceModel,
    y0: np.ndarray,
    t0_tdb_s: float,
    duration_s: float,
    method: str,
    rtol: float,
    atol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The (t, y) points at which an integration of one satellite (``method`` RK45 or DOP853) evaluates the
    force model."""
    args, work = model.kernel_args, model.field.workspace()
    scratch, terms, acc = np.zeros(SCRATCH_SIZE), np.zeros((len(TERMS), 3)), np.zeros(3)
    ts, ys = [], []

    def rhs(t, y):
        ts.append(t)
        ys.append(y.copy())
        acceleration(t, y, args, work, scratch, terms, acc)
        return np.concatenate([y[3:], acc])

    solve_ivp(rhs, (t0_tdb_s, t0_tdb_s + duration_s), y0, method=method, rtol=rtol, atol=atol)
    return np.array(ts), np.array(ys)


def replay_times(model: ForceModel, ts: np.ndarray, ys: np.ndarray, repeats: int = 3) -> dict:
    """CPU seconds of the new and the previous right-hand side over every point (median of ``repeats``, the
    two alternating) and the largest relative difference of the two accelerations over the points."""
    args, field_before = model.kernel_args, before_field(model)
    work, scratch, terms, out = (
        model.field.workspace(),
        np.zeros(SCRATCH_SIZE),
        np.zeros((len(TERMS), 3)),
        np.zeros(3),
    )
    max_rel_diff = _largest_difference(ts, ys, args, field_before, work, scratch, terms)
    times = {"new": [], "before": []}
    for _ in range(repeats):
        start = time.process_time()
        _replay_new(ts, ys, args, work, scratch, terms, out)
        times["new"].append(time.process_time() - start)
        start = time.process_time()
        _replay_before(ts, ys, args, field_before, work, scratch, terms, out)
        times["before"].append(time.process_time() - start)
    return {
        "new_s": float(np.median(times["new"])),
        "before_s": float(np.median(times["before"])),
        "max_rel_diff": float(max_rel_diff),
        "n_rhs": int(ts.shape[0]),
    }


@nb.njit(cache=True)
def _replay_shadows(ts, ys, args, before, out):
    """Both bodies' shadow factors at every point into ``out`` (n, 2), the previous or the current function."""
    scalars, _, _, t0dt, bodies, rot_pa = args[:6]
    r_sun, r_earth = np.empty(3), np.empty(3)
    for i in range(ts.shape[0]):
        basis = hermite_basis(rot_pa.shape[0], t0dt[0], t0dt[1], ts[i])
        hermite_apply(bodies[:, 0, :3], bodies[:, 0, 3:], basis, r_sun)
        hermite_apply(bodies[:, 1, :3], bodies[:, 1, 3:], basis, r_earth)
        ex, ey, ez = r_earth[0], r_earth[1], r_earth[2]
        if before:
            out[i, 0] = shadow_factor_before(
                ys[i], r_sun, 0.0, 0.0, 0.0, scalars[R_MOON], scalars[R_SUN]
            )
            out[i, 1] = shadow_factor_before(
                ys[i], r_sun, ex, ey, ez, scalars[R_EARTH], scalars[R_SUN]
            )
        else:
            out[i, 0] = shadow_factor(ys[i], r_sun, 0.0, 0.0, 0.0, scalars[R_MOON], scalars[R_SUN])
            out[i, 1] = shadow_factor(ys[i], r_sun, ex, ey, ez, scalars[R_EARTH], scalars[R_SUN])


def shadow_times(model: ForceModel, ts: np.ndarray, ys: np.ndarray, repeats: int = 3) -> dict:
    """CPU seconds of the current and the previous conical shadow factor of the Moon and the Earth over every point
    (with the Hermite interpolation of the bodies, median of ``repeats``, alternating) and whether the values agree
    bit for bit."""
    new, before = np.empty((ts.shape[0], 2)), np.empty((ts.shape[0], 2))
    args = model.kernel_args
    times = {"new": [], "before": []}
    for _ in range(repeats):
        for name, out in (("new", new), ("before", before)):
            start = time.process_time()
            _replay_shadows(ts, ys, args, name == "before", out)
            times[name].append(time.process_time() - start)
    return {
        "shadow_new_s": float(np.median(times["new"])),
        "shadow_before_s": float(np.median(times["before"])),
        "shadow_same": bool(np.array_equal(new, before)),
    }
