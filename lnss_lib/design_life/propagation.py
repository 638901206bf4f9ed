"""The propagation kernel of the design life: each satellite integrated with the full force model from one
station-keeping check to the next, flying its impulsive burns on the way (:func:`integrate_chunk`), the force
model whose ephemeris table spans the life, and the trim of insertion elements to the design's mean elements.
:mod:`lnss_lib.design_life.closed_loop` runs the controller on top of it."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..constants import SECONDS_PER_DAY
from ..elements import orbital_period_s
from ..ephemeris import EphemerisTable, ensure_kernels
from ..forces import SCRATCH_SIZE, ForceModel
from ..frames import element_frame_to_j2000
from ..gravity import new_workspace
from ..propagator import (
    METHODS,
    STATUS_NOT_RUN,
    STATUS_OK,
    check_batch,
    elements_deg_to_states,
    integrate_one,
)
from ..settings import Dynamics, IntegratorSetting
from .mean_elements import mean_elements, to_element_frame, wrap_pi

__all__ = ["integrate_chunk", "life_force_model", "trim_to_mean", "TRIM_ELEMENTS"]


@nb.njit(cache=True, parallel=True)
def integrate_chunk(
    y0s,
    active,
    t0,
    t_out,
    burn_t,
    burn_dv_rtn,
    method,
    rtol,
    atol,
    r_min_km,
    max_steps,
    args,
    degree,
):
    """Integrate each active satellite from (t0, y0) to t_out[-1], flying its burns on the way.

    ``burn_t`` (n_sat, k) burn epochs in (t0, t_out[-1]] (NaN = none, sorted), ``burn_dv_rtn``
    (n_sat, k, 3) impulses in the RTN axes of the state at the burn. Returns (states at t_out
    (n_sat, n_out, 6), end states (n_sat, 6), status, stop epoch); states after an impact are NaN.
    Outputs start as NaN and the status as "not run" (inactive satellites keep it): check them with
    :func:`lnss_lib.propagator.check_batch`.
    """
    n_sat = y0s.shape[0]
    n_out = t_out.shape[0]
    t_end = t_out[n_out - 1]
    states = np.full((n_sat, n_out, 6), np.nan)
    y_end = np.full((n_sat, 6), np.nan)
    status = np.full(n_sat, STATUS_NOT_RUN, dtype=np.int64)
    t_stop = np.full(n_sat, np.nan)
    for i in nb.prange(n_sat):
        if not active[i]:
            continue
        work = (np.zeros(SCRATCH_SIZE), new_workspace(degree))
        y = y0s[i].copy()
        t = t0
        k = 0
        while True:
            is_burn = k < burn_t.shape[1] and not np.isnan(burn_t[i, k])
            t_seg = burn_t[i, k] if is_burn else t_end
            count = 0
            for j in range(n_out):
                if t_out[j] > t and t_out[j] <= t_seg:
                    count += 1
            seg = np.empty(count + 1)
            idx = np.empty(count, dtype=np.int64)
            c = 0
            for j in range(n_out):
                if t_out[j] > t and t_out[j] <= t_seg:
                    seg[c] = t_out[j]
                    idx[c] = j
                    c += 1
            seg[count] = t_seg
            if count > 0 and seg[count - 1] == t_seg:
                seg = seg[:count]
            out, st, ts, _ = integrate_one(
                y, t, seg, method, rtol, atol, r_min_km, max_steps, args, work
            )
            for c in range(count):
                states[i, idx[c]] = out[c]
            if st != 0:
                status[i] = st
                t_stop[i] = ts
                break
            y = out[out.shape[0] - 1].copy()
            t = t_seg
            if not is_burn:
                break
            r = y[:3]
            v = y[3:]
            rn = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
            hx, hy, hz = (
                r[1] * v[2] - r[2] * v[1],
                r[2] * v[0] - r[0] * v[2],
                r[0] * v[1] - r[1] * v[0],
            )
            hn = np.sqrt(hx * hx + hy * hy + hz * hz)
            rh = r / rn
            nh = np.array([hx, hy, hz]) / hn
            th = np.array(
                [
                    nh[1] * rh[2] - nh[2] * rh[1],
                    nh[2] * rh[0] - nh[0] * rh[2],
                    nh[0] * rh[1] - nh[1] * rh[0],
                ]
            )
            dv = burn_dv_rtn[i, k]
            for q in range(3):
                y[3 + q] += dv[0] * rh[q] + dv[1] * th[q] + dv[2] * nh[q]
            k += 1
        y_end[i] = y
        if status[i] == STATUS_NOT_RUN:
            status[i] = STATUS_OK
    return states, y_end, status, t_stop


def life_force_model(
    dynamics: Dynamics, t0_tdb_s: float, life_days: float, degree: int | None = None
) -> ForceModel:
    """One force model whose ephemeris table spans the whole life (plus one day of margin)."""
    ensure_kernels(dynamics.ephemeris)
    table = EphemerisTable.build(dynamics, t0_tdb_s, t0_tdb_s + (life_days + 1.0) * SECONDS_PER_DAY)
    return ForceModel.build(dynamics, table, degree=degree)


TRIM_ELEMENTS = (0, 1, 2, 3, 4)
"""Columns of ``[a, e, i, raan, aop]`` trimmed so that their one-orbit means equal the design's."""


def trim_to_mean(
    dynamics: Dynamics,
    elements_deg,
    t0_tdb_s: float,
    model: ForceModel,
    integ: IntegratorSetting,
    *,
    samples_per_orbit: int = 64,
    iterations: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """Osculating insertion elements (n_sat, 6) (deg) whose mean elements over the first orbit equal ``elements_deg``.

    The design's elements are read as MEAN elements (an operator deploys satellites with matched mean
    periods, else a common osculating a at different mean anomalies leaves their mean a several km
    apart and the slots drift apart by ~1 deg/day). Fixed-point iteration: propagate one orbit with the full
    force model, compare the one-orbit mean a, e, i, RAAN and AOP with the design and shift the osculating
    values by the difference; the mean argument of latitude (at the window centre, less the design's mean
    motion over half a window) is trimmed through M. Insertion is not a manoeuvre: no Delta-v is counted.
    A satellite whose first orbit cannot be propagated keeps its last elements (residual NaN; the life
    propagation then reports it lost), and one whose next trim step would leave 0 <= e < 1 keeps its last step.
    Returns (trimmed elements, final mean-minus-design residual (n_sat, 6): km, -, deg x 4).
    """
    design = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    gm = dynamics.gravity.gm_km3_s2
    rot = element_frame_to_j2000(dynamics, t0_tdb_s)
    r_min = dynamics.r_impact_km
    period = orbital_period_s(design[:, 0], gm)
    n_win = int(samples_per_orbit)
    osc = design.copy()
    resid = np.zeros_like(design)
    n_sat = design.shape[0]
    done = np.zeros(n_sat, dtype=bool)
    for _ in range(int(iterations) + 1):
        states = elements_deg_to_states(dynamics, osc, t0_tdb_s)
        mean = np.full((n_sat, 6), np.nan)
        for i in range(n_sat):
            t_win = t0_tdb_s + period[i] * np.linspace(0.0, 1.0, n_win + 1)
            out, _, status, _ = integrate_chunk(
                states[i : i + 1],
                np.ones(1, dtype=bool),
                t0_tdb_s,
                t_win,
                np.full((1, 1), np.nan),
                np.zeros((1, 1, 3)),
                METHODS.index(integ.method),
                integ.rtol,
                integ.atol,
                r_min,
                5_000_000,
                model.kernel_args,
                model.field.degree,
            )
            if status[0] != STATUS_OK:
                if status[0] == STATUS_NOT_RUN:  # the compiled loop lost an error: never a loss
                    check_batch(status, np.full(1, np.nan), out, t_win, t0_tdb_s)
                done[i] = True
                continue
            check_batch(
                status, np.full(1, np.nan), out, t_win, t0_tdb_s
            )  # "ok" means every sample was written
            out[0, 0] = states[i]  # the kernel fills epochs after t0 only
            mean[i] = mean_elements(to_element_frame(out[0], rot), gm)
        u_design = (
            np.radians(design[:, 4] + design[:, 5]) + np.pi
        )  # one orbit: u advances 2 pi, centre at pi
        resid = np.column_stack(
            [
                mean[:, 0] - design[:, 0],
                mean[:, 1] - design[:, 1],
                np.degrees(wrap_pi(mean[:, 2:5] - np.radians(design[:, 2:5]))),
                np.degrees(wrap_pi(mean[:, 5] - u_design)),
            ]
        )
        if _ == iterations:
            break
        step = osc.copy()
        step[:, list(TRIM_ELEMENTS)] -= resid[:, list(TRIM_ELEMENTS)]
        step[:, 5] -= resid[:, 5] - resid[:, 4]  # u = aop + M: the aop trim already moved u
        done |= ~(
            np.all(np.isfinite(step), axis=1)
            & (step[:, 0] > 0.0)
            & (step[:, 1] >= 0.0)
            & (step[:, 1] < 1.0)
        )
        osc = np.where(done[:, None], osc, step)
    return osc, resid
