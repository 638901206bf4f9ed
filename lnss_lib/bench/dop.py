"""Benchmark of the south-pole DOP evaluation: 20 satellites, 961 epochs, 144 points.

Keplerian orbits of a 5-plane x 4-satellite Walker design (a = 6143 km, e = 0.6, i = 51.7 deg,
AOP = 90 deg) over 10 days at 900 s, taken directly as Moon-fixed positions (the benchmark times
the DOP grid, not SPICE). Today's numpy path and the compiled path run alternately, side by side.
"""

from __future__ import annotations

import time

import numpy as np

from ..constellation import WalkerDesign
from ..dop import (
    dop_arrays,
    dop_for_settings,
    dop_kernel,
    metrics_for_settings,
    summary_for_settings,
)
from ..elements import kepler_states
from ..settings import load_settings
from ..surface_grid import SurfaceGrid


def _positions_km(gm: float, n_epochs: int, step_s: float) -> np.ndarray:
    """Keplerian positions (20, n_epochs, 3) km of the benchmark design about a body of ``gm`` (km^3/s^2)."""
    el_deg = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 5, 4).elements_deg()
    el = np.concatenate([el_deg[:, :2], np.radians(el_deg[:, 2:])], axis=1)
    return kepler_states(el, step_s * np.arange(n_epochs), gm)[..., :3]


def _alternating_ms(funcs: dict, repeats: int) -> dict:
    """Min and median wall time (ms) of each callable, run alternately in the same loop (same load)."""
    for func in funcs.values():
        func()
    samples = {name: [] for name in funcs}
    for _ in range(repeats):
        for name, func in funcs.items():
            start = time.perf_counter()
            func()
            samples[name].append(1e3 * (time.perf_counter() - start))
    return {name: (min(v), float(np.median(v))) for name, v in samples.items()}


def run(profile_name: str = "paper", repeats: int = 9, overrides: dict | None = None) -> dict:
    """Print today's path (numpy kernel + Dataset + numpy statistics) and the compiled path side by side.

    Both run alternately in one loop so machine load hits them alike; prints min and median (ms)
    and the largest relative difference of the summary metrics. Returns the numbers.
    """
    profile = load_settings(profile_name, overrides=overrides)
    dop = profile.dop
    grid = SurfaceGrid.from_settings(dop, profile.constants.r_moon_mean_km)
    r_mf_km = _positions_km(profile.gravity.gm_km3_s2, 961, 900.0)
    points, up = grid.r_mf_km.reshape(-1, 3), grid.up.reshape(-1, 3)
    print(
        f"DOP grid benchmark: {r_mf_km.shape[0]} satellites x {r_mf_km.shape[1]} epochs x {grid.n_points} points "
        f"(min / median of {repeats} alternating runs, ms)"
    )
    funcs = {
        "old kernel (dop_kernel, numpy)": lambda: dop_kernel(
            r_mf_km, points, up, 5.0, "moon_fixed"
        ),
        "new kernel (dop_arrays, one compiled pass)": lambda: dop_arrays(
            r_mf_km, points, up, 5.0, "moon_fixed"
        ),
        "old kernel + Dataset + summary": lambda: summary_for_settings(
            dop, dop_for_settings(dop, r_mf_km, None, grid)
        ),
        "new kernel + compiled statistics": lambda: metrics_for_settings(dop, r_mf_km, grid),
    }
    times = _alternating_ms(funcs, repeats)
    for name, (lo, med) in times.items():
        print(f"  {name:44s}: {lo:7.1f} / {med:7.1f}")
    old = summary_for_settings(dop, dop_for_settings(dop, r_mf_km, None, grid))
    new = metrics_for_settings(dop, r_mf_km, grid)
    same = all(
        np.array_equal(a, b, equal_nan=True)
        for a, b in zip(dop_kernel(r_mf_km, points, up, 5.0), dop_arrays(r_mf_km, points, up, 5.0))
    )
    rel = max(abs(new[k] - old[k]) / max(abs(old[k]), 1e-300) for k in old if old[k] == old[k])
    ratio = (
        times["old kernel + Dataset + summary"][0] / times["new kernel + compiled statistics"][0]
    )
    print(
        f"  grid arrays bit-for-bit equal: {same}; summary metrics largest relative difference {rel:.1e}; "
        f"speed-up (grid + summary, min) {ratio:.1f}x (target: new <= 15 ms on a quiet machine)"
    )
    return {"times_ms": times, "bit_for_bit": same, "max_rel_diff": rel, "speedup": ratio}


if __name__ == "__main__":
    run()
