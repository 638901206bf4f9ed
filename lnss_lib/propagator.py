"""Compiled adaptive Runge-Kutta propagation of lunar orbits, one step sequence per satellite.

Methods: Dormand-Prince 5(4) ("RK45", the paper's Table 2 at RelTol 1e-6 / AbsTol 1e-9) and
Dormand-Prince 8(5,3) ("DOP853", the converged setting). Butcher tableaux, error norms and the
step-size controller are those of ``scipy.integrate.solve_ivp``, so the straightforward reference
in :mod:`lnss_lib.reference` and this engine take the same steps. Output on the sampling grid by
quintic Hermite interpolation of position (from r, v, a at the step ends) and its derivative.

Satellites run in parallel (``numba.prange``). An orbit that goes below the lunar surface plus the
minimum altitude stops there: :func:`propagate_states` raises :class:`ImpactError` for a single
satellite, or flags it (``impact``, ``impact_t_tdb_s``) in batch mode; its later samples are NaN
and ``valid`` says which samples are real. An exception inside a parallel loop can end it without
reaching the caller, so a batch kernel starts its outputs as NaN and its status as "not run", and
:func:`check_batch` checks both after the loop.
"""

from __future__ import annotations

import numba as nb
import numpy as np
import xarray as xr
from scipy.integrate._ivp import dop853_coefficients as _dop853
from scipy.integrate._ivp.rk import RK45 as _RK45

from .constants import EARTH_MOON_DISTANCE_KM, MAX_OUTPUT_SAMPLES, SECONDS_PER_DAY
from .elements import check_states_km, elements_to_state, validate_elements
from .ephemeris import EphemerisTable, check_span, ensure_kernels, tdb_iso, tdb_seconds
from .errors import ConfigError, ImpactError, PropagationError
from .forces import SCRATCH_SIZE, SOLAR_P, SRP_K, TERMS, ForceModel, acceleration
from .frames import element_frame_to_j2000
from .gravity import new_workspace
from .sections import METHODS, SEMI_MAJOR_AXIS, SEMI_MAJOR_AXIS_WHY
from .setting_rule import allowed_range_text, in_range
from .settings import Dynamics, EpochSettings, IntegratorSetting

__all__ = [
    "METHODS",
    "STATUS_TEXT",
    "check_batch",
    "check_elements_deg",
    "integrate_one",
    "integrate_many",
    "integrate_batch",
    "output_times",
    "propagate_states",
    "elements_deg_to_states",
    "propagate_elements",
]

(
    STATUS_NOT_RUN,
    STATUS_OK,
    STATUS_IMPACT,
    STATUS_MAX_STEPS,
    STATUS_STEP_TOO_SMALL,
    STATUS_NON_FINITE,
) = -1, 0, 1, 2, 3, 4
STATUS_TEXT = {
    -1: "not run (the compiled loop ended before this satellite finished)",
    0: "ok",
    1: "impact",
    2: "maximum number of steps",
    3: "step size too small",
    4: "non-finite state or acceleration",
}

# Butcher tableaux in one layout: A (s x s), B (s), C (s), E5 and E3 (s + 1; E3 unused for RK45)
_RK45_TAB = (
    np.ascontiguousarray(_RK45.A, dtype=float),
    np.ascontiguousarray(_RK45.B, dtype=float),
    np.ascontiguousarray(_RK45.C, dtype=float),
    np.ascontiguousarray(_RK45.E, dtype=float),
    np.zeros(7),
)
_N = _dop853.N_STAGES
_DOP853_TAB = (
    np.ascontiguousarray(_dop853.A[:_N, :_N]),
    np.ascontiguousarray(_dop853.B),
    np.ascontiguousarray(_dop853.C[:_N]),
    np.ascontiguousarray(_dop853.E5),
    np.ascontiguousarray(_dop853.E3),
)
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


# inline="always" here and on forces.acceleration / acceleration_terms: the kernel arguments (a tuple of nine arrays,
# each a struct of seven words) are copied at every call that is not inlined; folding the three levels into the
# integrator is a fifth of the propagation time (the same bits; bench integrator; 11 s more to compile once)
@nb.njit(cache=True, inline="always")
def _rhs(t, y, args, work, terms, acc, out):
    acceleration(t, y, args, work[1], work[0], terms, acc)
    out[0] = y[3]
    out[1] = y[4]
    out[2] = y[5]
    out[3] = acc[0]
    out[4] = acc[1]
    out[5] = acc[2]


@nb.njit(cache=True)
def _rms_scaled(vec, scale):
    s = 0.0
    for j in range(vec.shape[0]):
        q = vec[j] / scale[j]
        s += q * q
    return np.sqrt(s / vec.shape[0])


@nb.njit(cache=True)
def _hermite5(t0, y0, f0, t1, y1, f1, t, out):
    """Quintic Hermite position (from r, v, a at both ends) and its derivative at ``t``."""
    h = t1 - t0
    s = (t - t0) / h
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s4 * s
    h0 = 1 - 10 * s3 + 15 * s4 - 6 * s5
    h1 = s - 6 * s3 + 8 * s4 - 3 * s5
    h2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5
    h3 = 10 * s3 - 15 * s4 + 6 * s5
    h4 = -4 * s3 + 7 * s4 - 3 * s5
    h5 = 0.5 * s3 - s4 + 0.5 * s5
    d0 = (-30 * s2 + 60 * s3 - 30 * s4) / h
    d1 = (1 - 18 * s2 + 32 * s3 - 15 * s4) / h
    d2 = (s - 4.5 * s2 + 6 * s3 - 2.5 * s4) / h
    d3 = -d0
    d4 = (-12 * s2 + 28 * s3 - 15 * s4) / h
    d5 = (1.5 * s2 - 4 * s3 + 2.5 * s4) / h
    for j in range(3):
        p0, v0, a0 = y0[j], f0[j] * h, f0[j + 3] * h * h
        p1, v1, a1 = y1[j], f1[j] * h, f1[j + 3] * h * h
        out[j] = h0 * p0 + h1 * v0 + h2 * a0 + h3 * p1 + h4 * v1 + h5 * a1
        out[j + 3] = d0 * p0 + d1 * v0 + d2 * a0 + d3 * p1 + d4 * v1 + d5 * a1


@nb.njit(cache=True)
def _initial_step(t0, y0, f0, t_bound, order, rtol, atol, args, work, terms, acc, f1):
    """scipy's ``select_initial_step`` (Hairer, Norsett & Wanner, Sec. II.4)."""
    n = y0.shape[0]
    scale = np.empty(n)
    for j in range(n):
        scale[j] = atol + abs(y0[j]) * rtol
    d0 = _rms_scaled(y0, scale)
    d1 = _rms_scaled(f0, scale)
    interval = abs(t_bound - t0)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    if not np.isfinite(h0):
        return np.nan  # the scaled norms overflowed (tolerances far too small): the caller stops
    h0 = min(h0, interval)
    y1 = y0 + h0 * f0
    _rhs(t0 + h0, y1, args, work, terms, acc, f1)
    d2 = _rms_scaled(f1 - f0, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100.0 * h0, h1, interval)


@nb.njit(cache=True)
def integrate_one(y0, t0, t_out, method, rtol, atol, r_min_km, max_steps, args, work):
    """Integrate one satellite from (t0, y0) to t_out[-1]; return (states at t_out, status, t_stop, n_rhs).

    ``method`` 0 = RK45, 1 = DOP853; ``work`` = (force scratch, gravity scratch). States after an
    impact or failure are NaN.
    """
    if method == 0:
        A, B, C, E5, E3 = _RK45_TAB
        order = 4
    else:
        A, B, C, E5, E3 = _DOP853_TAB
        order = 7
    n_stages = B.shape[0]
    exponent = -1.0 / (order + 1)
    n = 6
    terms = np.empty((len(TERMS), 3))
    acc = np.empty(3)
    K = np.zeros((n_stages + 1, n))
    y = y0.copy()
    f = np.empty(n)
    y_new = np.empty(n)
    f_new = np.empty(n)
    y_stage = np.empty(n)
    tmp = np.empty(n)
    scale = np.empty(n)
    err5 = np.empty(n)
    err3 = np.empty(n)
    n_out = t_out.shape[0]
    states = np.full((n_out, n), np.nan)
    t_bound = t_out[n_out - 1]
    _rhs(t0, y, args, work, terms, acc, f)
    n_rhs = 1
    t = t0
    k_out = 0
    while k_out < n_out and t_out[k_out] <= t0:
        states[k_out] = y
        k_out += 1
    if k_out == n_out:
        return states, STATUS_OK, t, n_rhs
    h_abs = _initial_step(t0, y, f, t_bound, order, rtol, atol, args, work, terms, acc, tmp)
    n_rhs += 1
    status = STATUS_OK
    steps = 0
    while t < t_bound:
        if steps >= max_steps:
            status = STATUS_MAX_STEPS
            break
        if not np.isfinite(h_abs):  # e.g. tolerances so small that the error norms overflow
            status = STATUS_NON_FINITE
            break
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        t_new = t
        while not accepted:
            if h_abs < min_step:
                status = STATUS_STEP_TOO_SMALL
                break
            t_new = t + h_abs
            if t_new > t_bound:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            for j in range(n):
                K[0, j] = f[j]
            for s in range(1, n_stages):
                for j in range(n):
                    dy = 0.0
                    for q in range(s):
                        dy += A[s, q] * K[q, j]
                    y_stage[j] = y[j] + h * dy
                _rhs(t + C[s] * h, y_stage, args, work, terms, acc, tmp)
                for j in range(n):
                    K[s, j] = tmp[j]
            for j in range(n):
                dy = 0.0
                for q in range(n_stages):
                    dy += B[q] * K[q, j]
                y_new[j] = y[j] + h * dy
            _rhs(t + h, y_new, args, work, terms, acc, f_new)
            n_rhs += n_stages
            for j in range(n):
                K[n_stages, j] = f_new[j]
                scale[j] = atol + max(abs(y[j]), abs(y_new[j])) * rtol
            for j in range(n):
                e5 = 0.0
                e3 = 0.0
                for q in range(n_stages + 1):
                    e5 += K[q, j] * E5[q]
                    e3 += K[q, j] * E3[q]
                err5[j] = e5 / scale[j]
                err3[j] = e3 / scale[j]
            if method == 0:
                error_norm = 0.0
                for j in range(n):
                    error_norm += (h * err5[j]) ** 2
                error_norm = np.sqrt(error_norm / n)
            else:
                n5 = 0.0
                n3 = 0.0
                for j in range(n):
                    n5 += err5[j] * err5[j]
                    n3 += err3[j] * err3[j]
                if n5 == 0.0 and n3 == 0.0:
                    error_norm = 0.0
                else:
                    error_norm = abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * n)
            if not np.isfinite(error_norm):
                status = STATUS_NON_FINITE
                break
            if error_norm < 1.0:
                factor = (
                    MAX_FACTOR
                    if error_norm == 0.0
                    else min(MAX_FACTOR, SAFETY * error_norm**exponent)
                )
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(MIN_FACTOR, SAFETY * error_norm**exponent)
                rejected = True
        if not accepted:
            break
        steps += 1
        while k_out < n_out and t_out[k_out] <= t_new:
            if t_out[k_out] == t_new:
                for j in range(n):
                    states[k_out, j] = y_new[j]
            else:
                _hermite5(t, y, f, t_new, y_new, f_new, t_out[k_out], tmp)
                for j in range(n):
                    states[k_out, j] = tmp[j]
            r_out = np.sqrt(states[k_out, 0] ** 2 + states[k_out, 1] ** 2 + states[k_out, 2] ** 2)
            if r_out < r_min_km:
                states[k_out, :] = np.nan
                status = STATUS_IMPACT
                t = t_out[k_out]
                break
            k_out += 1
        if status == STATUS_IMPACT:
            break
        if np.sqrt(y_new[0] ** 2 + y_new[1] ** 2 + y_new[2] ** 2) < r_min_km:
            status = STATUS_IMPACT
            t = t_new
            break
        t = t_new
        for j in range(n):
            y[j] = y_new[j]
            f[j] = f_new[j]
    return states, status, t, n_rhs


@nb.njit(cache=True, parallel=True)
def integrate_many(y0s, t0, t_out, method, rtol, atol, r_min_km, max_steps, args, degree):
    """:func:`integrate_one` for each row of ``y0s``, in parallel; returns (states, status, t_stop, n_rhs).

    Outputs start as NaN and the status as ``STATUS_NOT_RUN``: check them with :func:`check_batch`.
    """
    n_sat = y0s.shape[0]
    states = np.full((n_sat, t_out.shape[0], 6), np.nan)
    status = np.full(n_sat, STATUS_NOT_RUN, dtype=np.int64)
    t_stop = np.full(n_sat, np.nan)
    n_rhs = np.zeros(n_sat, dtype=np.int64)
    for i in nb.prange(n_sat):
        work = (np.zeros(SCRATCH_SIZE), new_workspace(degree))
        s, st, ts, nr = integrate_one(
            y0s[i], t0, t_out, method, rtol, atol, r_min_km, max_steps, args, work
        )
        states[i] = s
        status[i] = st
        t_stop[i] = ts
        n_rhs[i] = nr
    return states, status, t_stop, n_rhs


def check_batch(
    status: np.ndarray,
    t_stop: np.ndarray,
    states: np.ndarray,
    t_out: np.ndarray,
    t0: float,
    active: np.ndarray | None = None,
) -> np.ndarray:
    """After a compiled batch loop: :class:`PropagationError` naming every (active) satellite that was not
    run, failed, or left a non-finite sample after ``t0`` and before its stop; returns the impact mask.

    ``states`` (n_sat, n_out, 6) on ``t_out``; an impacted satellite's samples from its stop on are NaN.
    """
    active = (
        np.ones(status.shape[0], dtype=bool) if active is None else np.asarray(active, dtype=bool)
    )
    impact = active & (status == STATUS_IMPACT)
    before_stop = (t_out[None, :] > t0) & (
        (status == STATUS_OK)[:, None] | (t_out[None, :] < t_stop[:, None])
    )
    holes = np.any(before_stop & ~np.all(np.isfinite(states), axis=2), axis=1)
    bad = active & (((status != STATUS_OK) & ~impact) | (impact & ~np.isfinite(t_stop)) | holes)
    if bad.any():
        sats = np.flatnonzero(bad).tolist()
        texts = [
            STATUS_TEXT.get(int(status[i]), f"unknown status {int(status[i])}")
            if status[i] != STATUS_OK or not holes[i]
            else "non-finite samples"
            for i in sats
        ]
        detail = "; ".join(
            f"{i}: {text}" + (f" at t = {t_stop[i]:.1f} s TDB" if np.isfinite(t_stop[i]) else "")
            for i, text in zip(sats[:10], texts)
        )
        raise PropagationError(
            f"propagation failed for satellite(s) {sats} ({detail})", sats=sats, statuses=texts
        )
    return impact


def _check_states(states_mci: np.ndarray, gm_km3_s2: float, r_min_km: float | None) -> np.ndarray:
    """The states as floats; :func:`~lnss_lib.elements.check_states_km` for one given alone (``r_min_km``, the
    surface floor), finite and within the Earth-Moon distance for a batch (whose impacts are flagged)."""
    states = np.atleast_2d(np.asarray(states_mci, dtype=float))
    if states.ndim != 2 or states.shape[1] != 6:
        raise ValueError(
            f"states must have shape (n_sat, 6) [x, y, z, vx, vy, vz]; got {states.shape}"
        )
    if not np.all(np.isfinite(states)):
        raise ValueError("states contain non-finite values")
    if r_min_km is not None:
        return check_states_km(states, gm_km3_s2, r_min_km)
    radius = np.linalg.norm(states[:, :3], axis=1)
    if np.any(radius > EARTH_MOON_DISTANCE_KM):
        k = int(np.argmax(radius))
        raise ConfigError(
            f"state {k}: radius {radius[k]:.6g} km is not allowed; allowed: up to {EARTH_MOON_DISTANCE_KM:,.0f} "
            "km (the Earth-Moon distance: beyond it the Earth, not the Moon, is the central body)",
            key="state",
        )
    return states


def output_times(t0_tdb_s: float, duration_s: float, step_s: float) -> np.ndarray:
    """Sampling grid t0, t0 + step, ..., t0 + duration (TDB s); duration and step must be positive."""
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"duration must be positive and finite (s); got {duration_s}")
    if not (np.isfinite(step_s) and step_s > 0):
        raise ConfigError(f"sampling step must be positive and finite (s); got {step_s}")
    if not np.isfinite(t0_tdb_s):
        raise ConfigError(f"start epoch must be finite (TDB s); got {t0_tdb_s}")
    if duration_s / step_s > MAX_OUTPUT_SAMPLES:
        raise ConfigError(
            f"duration {duration_s:g} s at a sampling step of {step_s:g} s gives {duration_s / step_s:.3g} "
            f"samples; allowed: at most {MAX_OUTPUT_SAMPLES:,} (48 bytes each per satellite)",
            key="step_s",
        )
    n = int(np.floor(duration_s / step_s + 1e-9))
    times = t0_tdb_s + step_s * np.arange(n + 1)
    if times[-1] < t0_tdb_s + duration_s - 1e-6:
        times = np.append(times, t0_tdb_s + duration_s)
    return times


def propagate_states(
    dynamics: Dynamics,
    states_mci,
    t0_tdb_s: float,
    duration_s: float,
    step_s: float,
    *,
    setting: str | None = None,
    degree: int | None = None,
    srp_cr_area_mass_m2_kg: float | None = None,
    batch: bool | None = None,
    model: ForceModel | None = None,
    max_steps: int = 5_000_000,
) -> xr.Dataset:
    """Propagate Moon-centred J2000 states (n_sat, 6; km, km/s) from TDB ``t0_tdb_s``.

    Returns a Dataset (dims ``sat``, ``time``, ``xyz``) sampled every ``step_s`` seconds. With one
    satellite (unless ``batch=True``) a state that is no lunar orbit's raises ConfigError
    (:func:`~lnss_lib.elements.check_states_km`: inside the Moon, unbound, faster than light) and an impact
    raises :class:`ImpactError`; in batch mode it is flagged. ``model`` reuses a prepared :class:`ForceModel` (its table must span the arc); ``setting``
    names one of ``dynamics.integrator``'s settings (default: its own).
    """
    batch = np.atleast_2d(np.asarray(states_mci)).shape[0] > 1 if batch is None else batch
    states = _check_states(
        states_mci, dynamics.gravity.gm_km3_s2, None if batch else dynamics.r_impact_km
    )
    integ = dynamics.integrator.named(setting)
    times = output_times(t0_tdb_s, duration_s, step_s)
    if model is None:
        table = EphemerisTable.build(dynamics, t0_tdb_s, times[-1])
        model = ForceModel.build(
            dynamics, table, degree=degree, srp_cr_area_mass_m2_kg=srp_cr_area_mass_m2_kg
        )
    elif degree is not None or srp_cr_area_mass_m2_kg is not None:
        raise ValueError(
            "degree and srp_cr_area_mass_m2_kg belong to the force model: pass them to "
            "ForceModel.build, not together with model="
        )
    r_min = dynamics.r_impact_km
    out, status, t_stop, n_rhs, impact = integrate_batch(
        dynamics, states, t0_tdb_s, times, model, setting=setting, max_steps=max_steps
    )
    if not batch and impact[0]:
        days = (t_stop[0] - t0_tdb_s) / SECONDS_PER_DAY
        raise ImpactError(
            f"orbit hits the Moon (radius below {r_min:.1f} km) at {tdb_iso(t_stop[0])} TDB, "
            f"{days:.3f} days after the start",
            sat=0,
            t_tdb_s=float(t_stop[0]),
            days=float(days),
        )
    return _as_dataset(out, times, status, t_stop, n_rhs, integ, model)


def integrate_batch(
    dynamics: Dynamics,
    states_mci: np.ndarray,
    t0_tdb_s: float,
    times: np.ndarray,
    model: ForceModel,
    *,
    setting: str | None = None,
    max_steps: int = 5_000_000,
) -> tuple:
    """The arrays behind :func:`propagate_states` (batch mode), without its Dataset: the campaign's path.

    States (n_sat, 6) from TDB ``t0_tdb_s`` sampled at ``times`` (:func:`output_times`) with a prepared ``model``
    whose table spans them. Returns (states (n_sat, n_time, 6), NaN from an impact on; status; t_stop; n_rhs;
    impact mask), checked by :func:`check_batch`.
    """
    states = _check_states(states_mci, dynamics.gravity.gm_km3_s2, None)
    if model.table.t0_tdb_s > t0_tdb_s or model.table.t_end_tdb_s < times[-1]:
        raise ValueError("the force model's ephemeris table does not span the requested arc")
    integ = dynamics.integrator.named(setting)
    out, status, t_stop, n_rhs = integrate_many(
        states,
        float(t0_tdb_s),
        times,
        METHODS.index(integ.method),
        integ.rtol,
        integ.atol,
        dynamics.r_impact_km,
        max_steps,
        model.kernel_args,
        model.field.degree,
    )
    return out, status, t_stop, n_rhs, check_batch(status, t_stop, out, times, float(t0_tdb_s))


def _as_dataset(
    out, times, status, t_stop, n_rhs, integ: IntegratorSetting, model: ForceModel
) -> xr.Dataset:
    n_sat = out.shape[0]
    valid = np.all(np.isfinite(out), axis=2)
    ds = xr.Dataset(
        {
            "r_mci_km": (("sat", "time", "xyz"), out[:, :, :3]),
            "v_mci_kms": (("sat", "time", "xyz"), out[:, :, 3:]),
            "valid": (("sat", "time"), valid),
            "impact": ("sat", status == STATUS_IMPACT),
            "impact_t_tdb_s": ("sat", np.where(status == STATUS_IMPACT, t_stop, np.nan)),
            "status": ("sat", np.array([STATUS_TEXT[int(s)] for s in status])),
            "n_rhs": ("sat", n_rhs),
        },
        coords={"sat": np.arange(n_sat), "time": times, "xyz": ["x", "y", "z"]},
        attrs={
            "frame": "Moon-centred J2000 (ICRF axes), km and km/s",
            "time_scale": "TDB; coordinate time is seconds past J2000 TDB",
            "epoch_tdb": tdb_iso(times[0]),
            "force_model": model.describe(),
            "integrator": integ.method,
            "integrator_setting": integ.name,
            "rtol": integ.rtol,
            "atol": integ.atol,
            "gm_km3_s2": model.field.gm_km3_s2,
            "srp_cr_area_mass_m2_kg": float(model.scalars[SRP_K] / model.scalars[SOLAR_P] * 1e3),
            "output": "quintic Hermite interpolation between integrator steps",
        },
    )
    ds["time"].attrs.update(units="s", long_name="TDB seconds past J2000")
    ds["r_mci_km"].attrs.update(units="km")
    ds["v_mci_kms"].attrs.update(units="km/s")
    return ds


ELEMENT_RANGES = (
    ("semi-major axis sma_km", SEMI_MAJOR_AXIS),
    ("eccentricity e", (0.0, 1.0, False, True)),
    ("inclination inc_deg", (0.0, 180.0, False, False)),
    ("raan_deg", (None, None, False, False)),
    ("aop_deg", (None, None, False, False)),
    ("mean_anomaly_deg", (None, None, False, False)),
)


def check_elements_deg(elements_deg) -> np.ndarray:
    """Elements (n, 6) [sma_km, e, i, RAAN, AOP, M] (deg) as floats, every value finite and in its domain
    (0 < a <= the Moon's Hill radius, 0 <= e < 1, 0 <= i <= 180 deg); ConfigError naming the element, the value,
    the range and, for a, why."""
    try:
        el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    except (TypeError, ValueError):
        raise ConfigError(
            f"elements must be numbers [sma_km, e, i, RAAN, AOP, M]; got {elements_deg!r}"
        ) from None
    if el.ndim != 2 or el.shape[1] != 6:
        raise ConfigError(
            f"elements must have shape (n_sat, 6) [sma_km, e, i, RAAN, AOP, M] in degrees; got {el.shape}"
        )
    for col, (name, spec) in enumerate(ELEMENT_RANGES):
        for row, value in enumerate(el[:, col]):
            if not np.isfinite(value) or not in_range(value, spec):
                where = f"satellite {row}: " if el.shape[0] > 1 else ""
                why = f" ({SEMI_MAJOR_AXIS_WHY})" if col == 0 else ""
                raise ConfigError(
                    f"{where}{name} = {float(value)!r} is not allowed; allowed: a finite number in "
                    f"{allowed_range_text(spec)}{why}",
                    key=name.split()[-1],
                )
    return el


def elements_deg_to_states(dynamics: Dynamics, elements_deg, t0_tdb_s: float) -> np.ndarray:
    """Moon-centred J2000 states (n, 6) of elements (n, 6) [sma_km, e, i, RAAN, AOP, M] (deg) in the element frame.

    Raises ``ValueError`` for e outside [0, 1), non-positive a, or a perilune below the surface plus
    the minimum altitude.
    """
    el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    if el.ndim != 2 or el.shape[1] != 6:
        raise ValueError(
            f"elements must have shape (n_sat, 6) [sma_km, e, i, RAAN, AOP, M] in degrees; got {el.shape}"
        )
    validate_elements(
        el[:, 0], el[:, 1], dynamics.constants.r_moon_mean_km, dynamics.impact.min_altitude_km
    )
    bad = ~np.isfinite(el[:, 2:])
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"satellite {row}: {('inclination', 'RAAN', 'AOP', 'mean anomaly')[col]} is not finite "
            f"({el[row, col + 2]!r} deg)"
        )
    check_span(t0_tdb_s, t0_tdb_s)
    el_rad = el.copy()
    el_rad[:, 2:] = np.radians(el[:, 2:])
    states_frame = elements_to_state(el_rad, dynamics.gravity.gm_km3_s2)
    rot = element_frame_to_j2000(dynamics, t0_tdb_s)
    return np.concatenate([states_frame[:, :3] @ rot.T, states_frame[:, 3:] @ rot.T], axis=1)


def propagate_elements(
    dynamics: Dynamics,
    epoch: EpochSettings,
    elements_deg,
    *,
    setting: str | None = None,
    degree: int | None = None,
    t0_tdb_s: float | None = None,
    duration_s: float | None = None,
    step_s: float | None = None,
    batch: bool | None = None,
    model: ForceModel | None = None,
) -> xr.Dataset:
    """Propagate satellites given by elements (n, 6) [sma_km, e, inc, RAAN, AOP, M] (deg) in ``frames.element_frame``.

    Defaults: the ``epoch`` settings' start, duration and sampling step.
    """
    ensure_kernels(dynamics.ephemeris)
    t0 = tdb_seconds(epoch.start_tdb, "TDB") if t0_tdb_s is None else float(t0_tdb_s)
    duration = epoch.duration_days * SECONDS_PER_DAY if duration_s is None else float(duration_s)
    step = epoch.step_s if step_s is None else float(step_s)
    states = elements_deg_to_states(dynamics, elements_deg, t0)
    ds = propagate_states(
        dynamics,
        states,
        t0,
        duration,
        step,
        setting=setting,
        degree=degree,
        batch=batch,
        model=model,
    )
    ds["elements_deg"] = (("sat", "element"), np.atleast_2d(np.asarray(elements_deg, dtype=float)))
    ds = ds.assign_coords(
        element=["a_km", "e", "inc_deg", "raan_deg", "aop_deg", "mean_anomaly_deg"]
    )
    ds.attrs["element_frame"] = dynamics.frames.element_frame
    return ds
