"""``python -m lnss_lib bench integrator``: force evaluations against 10-day position error for each
integrator candidate, to choose the operational profile's setting.

Two orbits: the standalone ELFO (Table 4) and a high, eccentric design (a = 15000 km, e = 0.8,
apolune 27,000 km). Reference: DOP853 at rtol 1e-12 / atol 1e-14 with every gravity degree.
Candidates run with the profile's force model (including its gravity truncation); the error is the
largest position difference over the sampled 10 days. The cheapest candidate within the limit is
printed as the recommendation.
"""

from __future__ import annotations

import time

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..ephemeris import EphemerisTable, ensure_kernels, tdb_seconds
from ..forces import ForceModel
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import Dynamics, Settings, load_settings

ORBITS = {
    "ELFO": [6143.0, 0.6, 51.7, 0.0, 90.0, 0.0],
    "a15000 e0.8": [15000.0, 0.8, 60.0, 0.0, 90.0, 0.0],
}
CANDIDATES = [("RK45", rtol, rtol * 1e-3) for rtol in (1e-6, 1e-7, 1e-8, 5e-9, 2e-9, 1e-9)] + [
    ("DOP853", rtol, rtol * 1e-2) for rtol in (1e-7, 1e-8, 3e-9, 1e-9, 7e-10, 5e-10, 3e-10, 1e-10)
]
REFERENCE = ("DOP853", 1e-12, 1e-14)


def _with_setting(settings: Settings, method: str, rtol: float, atol: float) -> Dynamics:
    """The dynamics of ``settings`` with an integrator setting "candidate" (method, rtol, atol)."""
    candidate = {"method": method, "rtol": rtol, "atol": atol}
    return settings.with_overrides({"integrator": {"settings": {"candidate": candidate}}}).dynamics


def candidate_table(settings: Settings, days: float = 10.0) -> list[dict]:
    """One row per (orbit, candidate): evaluations, wall (s) and the 10-day error (m) against the reference."""
    dynamics = settings.dynamics
    ensure_kernels(dynamics.ephemeris)
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB")
    duration = days * SECONDS_PER_DAY
    table = EphemerisTable.build(dynamics, t0, t0 + duration)
    model = ForceModel.build(dynamics, table)
    full = settings.with_overrides({"gravity": {"truncation_kms2": 0.0}})
    full_model = ForceModel.build(full.dynamics, table)
    rows = []
    for name, elements in ORBITS.items():
        y0 = elements_deg_to_states(dynamics, [elements], t0)
        ref = propagate_states(
            _with_setting(full, *REFERENCE),
            y0,
            t0,
            duration,
            900.0,
            setting="candidate",
            model=full_model,
        ).r_mci_km.values[0]
        for method, rtol, atol in CANDIDATES:
            prof = _with_setting(settings, method, rtol, atol)
            walls = []
            for _ in range(3):
                start = time.perf_counter()
                ds = propagate_states(
                    prof, y0, t0, duration, 900.0, setting="candidate", model=model
                )
                walls.append(time.perf_counter() - start)
            error_m = 1e3 * float(np.max(np.linalg.norm(ds.r_mci_km.values[0] - ref, axis=-1)))
            rows.append(
                {
                    "orbit": name,
                    "method": method,
                    "rtol": rtol,
                    "atol": atol,
                    "n_rhs": int(ds.n_rhs[0]),
                    "wall_s": min(walls),
                    "error_m": error_m,
                }
            )
    return rows


def run(
    profile_name: str = "paper", limit_m: float = 100.0, overrides: dict | None = None
) -> list[dict]:
    settings = load_settings(profile_name, overrides=overrides)
    rows = candidate_table(settings)
    print(
        f"10-day error against {REFERENCE[0]} {REFERENCE[1]:g}/{REFERENCE[2]:g} (full field); candidates with "
        f"[{profile_name}] forces, gravity truncation {settings.gravity.truncation_kms2:g} km/s^2"
    )
    for row in rows:
        print(
            f"  {row['orbit']:12s} {row['method']:6s} rtol {row['rtol']:7.0e} atol {row['atol']:7.0e}: "
            f"{row['n_rhs']:7d} evaluations, {1e3 * row['wall_s']:7.1f} ms, error {row['error_m']:12.3f} m"
        )
    cost = {}
    for row in rows:
        key = (row["method"], row["rtol"], row["atol"])
        ok, n = cost.get(key, (True, 0))
        cost[key] = (ok and row["error_m"] <= limit_m, n + row["n_rhs"])
    passing = sorted((n, key) for key, (ok, n) in cost.items() if ok)
    if passing:
        n, (method, rtol, atol) = passing[0]
        print(
            f"cheapest within {limit_m:g} m on every orbit: {method} rtol {rtol:g} atol {atol:g} "
            f"({n} evaluations over the orbits)"
        )
    else:
        print(f"no candidate within {limit_m:g} m on every orbit")
    return rows
