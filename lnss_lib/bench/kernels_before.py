"""The force model's right-hand side before issue 23's speed work, kept here only to time it beside the new one.

Before, each evaluation chose its gravity degree with the loop :func:`lnss_lib.gravity.truncation_degree`
(a sum with a division per degree; now a lookup in radii tabulated once per field) and interpolated the
MOON_PA rotation, the Sun, the Earth and Jupiter each with its own interval and Hermite weights (now one
:func:`lnss_lib.ephemeris.hermite_basis` for all). The terms themselves did not change
(:func:`lnss_lib.forces.terms_at`), so :func:`acceleration_before` is the previous right-hand side, equal to
the new one bit for bit. :func:`rhs_points` records the (t, y) points an RK45 integration of one satellite
evaluates (RK45 or DOP853 with scipy's controller, the compiled engine's: ``tests/test_propagator.py`` checks that both take
the same steps), and :func:`replay_times` times both right-hand sides on them.
"""

from __future__ import annotations

import time

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp

from ..ephemeris import hermite_cubic
from ..forces import F_HARMONICS, F_JUPITER, GM, R_REF, SCRATCH_SIZE, TERMS, ForceModel, acceleration, terms_at
from ..gravity import truncation_degree


@nb.njit(cache=True)
def acceleration_before(t, y, args, truncation_kms2, work, scratch, terms, out):
    """The previous :func:`lnss_lib.forces.acceleration`: four interpolations and the truncation loop."""
    scalars, flags, t0dt, bodies, rot_pa, rot_pa_rate, coef = args[0], args[1], args[3], args[4], args[5], args[6], args[9]
    degree = coef.shape[1] - 2
    if flags[F_HARMONICS] and degree >= 2:
        hermite_cubic(rot_pa, rot_pa_rate, t0dt[0], t0dt[1], t, scratch[0:9])
    hermite_cubic(bodies[:, 0, :3], bodies[:, 0, 3:], t0dt[0], t0dt[1], t, scratch[15:18])
    hermite_cubic(bodies[:, 1, :3], bodies[:, 1, 3:], t0dt[0], t0dt[1], t, scratch[18:21])
    if flags[F_JUPITER]:
        hermite_cubic(bodies[:, 2, :3], bodies[:, 2, 3:], t0dt[0], t0dt[1], t, scratch[21:24])
    r2 = y[0] * y[0] + y[1] * y[1] + y[2] * y[2]
    r_norm = np.sqrt(r2)
    kept = truncation_degree(r_norm, coef, scalars[GM], scalars[R_REF], degree, truncation_kms2)
    terms_at(y, r2, r_norm, kept, args, work, scratch, terms)
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
def _replay_before(ts, ys, args, truncation_kms2, work, scratch, terms, out):
    total = 0.0
    for i in range(ts.shape[0]):
        acceleration_before(ts[i], ys[i], args, truncation_kms2, work, scratch, terms, out)
        total += out[0]
    return total


@nb.njit(cache=True)
def _largest_difference(ts, ys, args, truncation_kms2, work, scratch, terms):
    new, before = np.empty(3), np.empty(3)
    worst = 0.0
    for i in range(ts.shape[0]):
        acceleration(ts[i], ys[i], args, work, scratch, terms, new)
        acceleration_before(ts[i], ys[i], args, truncation_kms2, work, scratch, terms, before)
        for j in range(3):
            worst = max(worst, abs(new[j] - before[j]))
    return worst


def rhs_points(model: ForceModel, y0: np.ndarray, t0_tdb_s: float, duration_s: float, method: str, rtol: float,
               atol: float) -> tuple[np.ndarray, np.ndarray]:
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
    two alternating) and whether the two accelerations are equal bit for bit at every point."""
    args, tol = model.kernel_args, model.field.truncation_kms2
    work, scratch, terms, out = model.field.workspace(), np.zeros(SCRATCH_SIZE), np.zeros((len(TERMS), 3)), np.zeros(3)
    identical = _largest_difference(ts, ys, args, tol, work, scratch, terms) == 0.0
    times = {"new": [], "before": []}
    for _ in range(repeats):
        start = time.process_time()
        _replay_new(ts, ys, args, work, scratch, terms, out)
        times["new"].append(time.process_time() - start)
        start = time.process_time()
        _replay_before(ts, ys, args, tol, work, scratch, terms, out)
        times["before"].append(time.process_time() - start)
    return {"new_s": float(np.median(times["new"])), "before_s": float(np.median(times["before"])),
            "identical": bool(identical), "n_rhs": int(ts.shape[0])}
