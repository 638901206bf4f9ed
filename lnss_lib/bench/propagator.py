"""``python -m lnss_lib bench propagator``: reference (scipy + SPICE + numpy) against the compiled engine.

The standalone ELFO (Table 4 first satellite) over the profile's span at degree 30 with the full
force model; then a 20-satellite Walker constellation (4 planes x 5) on all cores.
"""

from __future__ import annotations

import time

import numba as nb
import numpy as np

from ..constants import SECONDS_PER_DAY
from ..ephemeris import EphemerisTable, ensure_kernels, tdb_seconds
from ..forces import SCRATCH_SIZE, ForceModel, acceleration
from ..propagator import elements_deg_to_states, propagate_states
from ..reference import propagate_reference
from ..settings import load_settings


@nb.njit(cache=True)
def _evaluation_loop(n, t0, y, args, work, scratch, terms, out):
    total = 0.0
    for i in range(n):
        acceleration(t0 + 60.0 * (i % 1000), y, args, work, scratch, terms, out)
        total += out[0]
    return total


def run(profile_name: str = "paper", overrides: dict | None = None) -> None:
    settings = load_settings(profile_name, overrides=overrides)
    dynamics = settings.dynamics
    ensure_kernels(dynamics.ephemeris)
    elfo = settings.standalone_elfo
    elements = [[elfo.sma_km, elfo.ecc, elfo.inc_deg, elfo.raan_deg[0], elfo.aop_deg, 0.0]]
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB")
    duration = settings.epoch.duration_days * SECONDS_PER_DAY
    step = settings.epoch.step_s
    y0 = elements_deg_to_states(dynamics, elements, t0)
    print(
        f"ELFO a={elfo.sma_km} km e={elfo.ecc} i={elfo.inc_deg} deg, {duration / SECONDS_PER_DAY:.0f} days, "
        f"degree {dynamics.gravity.degree}, setting {dynamics.integrator.setting}"
    )

    start = time.perf_counter()
    table = EphemerisTable.build(dynamics, t0, t0 + duration)
    model = ForceModel.build(dynamics, table)
    setup_s = time.perf_counter() - start
    start = time.perf_counter()
    propagate_states(dynamics, y0, t0, 3600.0, step, model=model)
    first_call_s = time.perf_counter() - start
    print(
        f"engine first call (JIT compile or on-disk cache load): {first_call_s:.2f} s; tables + field set-up: {setup_s:.3f} s"
    )

    work, scratch, terms, out = (
        model.field.workspace(),
        np.zeros(SCRATCH_SIZE),
        np.zeros((8, 3)),
        np.zeros(3),
    )
    state = y0[0].copy()
    _evaluation_loop(10, t0, state, model.kernel_args, work, scratch, terms, out)
    n_loop = 200_000
    start = time.perf_counter()
    _evaluation_loop(n_loop, t0, state, model.kernel_args, work, scratch, terms, out)
    us_per_eval = (time.perf_counter() - start) / n_loop * 1e6
    print(f"(b) force evaluation, full model degree {model.field.degree}: {us_per_eval:.2f} us")

    walls = []
    for _ in range(3):
        start = time.perf_counter()
        engine = propagate_states(dynamics, y0, t0, duration, step, model=model)
        walls.append(time.perf_counter() - start)
    wall_b = min(walls)
    n_b = int(engine.n_rhs[0])
    print(
        f"(b) engine: {n_b} evaluations, {wall_b:.3f} s wall, {wall_b / n_b * 1e6:.2f} us per evaluation incl. integrator"
    )

    start = time.perf_counter()
    final_a, n_a = propagate_reference(dynamics, y0[0], t0, duration)
    wall_a = time.perf_counter() - start
    print(
        f"(a) reference (solve_ivp RK45, SPICE in RHS, numpy harmonics): {n_a} evaluations, {wall_a:.2f} s wall, "
        f"{wall_a / n_a * 1e6:.0f} us per evaluation"
    )
    diff_m = np.linalg.norm(final_a[:3] - engine.r_mci_km.values[0, -1]) * 1e3
    print(f"speedup (a)/(b): {wall_a / wall_b:.0f}x")
    print(
        f"position difference (a) - (b) after {duration / SECONDS_PER_DAY:.0f} days at equal tolerance: {diff_m:.3f} m"
    )

    walker = [
        [elfo.sma_km, elfo.ecc, elfo.inc_deg, 90.0 * plane, elfo.aop_deg, 72.0 * slot]
        for plane in range(4)
        for slot in range(5)
    ]
    states = elements_deg_to_states(dynamics, walker, t0)
    propagate_states(dynamics, states, t0, duration, step, model=model)
    walls = []
    for _ in range(3):
        start = time.perf_counter()
        walker_ds = propagate_states(dynamics, states, t0, duration, step, model=model)
        walls.append(time.perf_counter() - start)
    print(
        f"20 satellites (4 planes x 5), {nb.get_num_threads()} threads: {min(walls):.3f} s wall "
        f"({int(walker_ds.n_rhs.sum())} evaluations)"
    )
