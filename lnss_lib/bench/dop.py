"""Benchmark of the south-pole DOP evaluation (issue 3): 20 satellites, 961 epochs, 144 points.

Keplerian orbits of a 5-plane x 4-satellite Walker design (a = 6143 km, e = 0.6, i = 51.7 deg,
AOP = 90 deg) over 10 days at 900 s, taken directly as Moon-fixed positions (the benchmark times
the DOP grid, not SPICE). Prints the median of several runs of the kernel, of the full Dataset
and of the summary statistics.
"""

from __future__ import annotations

import time

import numpy as np

from ..config import load_profile
from ..constellation import WalkerDesign
from ..dop import dop_grid, dop_kernel, dop_summary, grid_from_profile
from ..elements import kepler_states


def _positions_km(profile: dict, n_epochs: int, step_s: float) -> np.ndarray:
    """Keplerian positions (20, n_epochs, 3) km of the benchmark design."""
    gm = float(profile["gravity"]["gm_km3_s2"])
    el_deg = WalkerDesign(6143.0, 0.6, 51.7, 90.0, 5, 4).elements_deg()
    el = np.concatenate([el_deg[:, :2], np.radians(el_deg[:, 2:])], axis=1)
    return kepler_states(el, step_s * np.arange(n_epochs), gm)[..., :3]


def _median_s(func, repeats: int) -> float:
    func()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def run(profile_name: str = "paper", repeats: int = 7) -> None:
    """Print the median wall time (ms) of one DOP grid evaluation, per stage and LOS convention."""
    profile = load_profile(profile_name)
    grid = grid_from_profile(profile)
    r_mf_km = _positions_km(profile, 961, 900.0)
    points, up = grid.r_mf_km.reshape(-1, 3), grid.up.reshape(-1, 3)
    print(f"DOP grid benchmark: {r_mf_km.shape[0]} satellites x {r_mf_km.shape[1]} epochs x {grid.n_points} points "
          f"(median of {repeats} runs)")
    for axes in ("moon_fixed", "enu"):
        t_kernel = _median_s(lambda: dop_kernel(r_mf_km, points, up, 5.0, axes), repeats)
        print(f"  dop_kernel ({axes:10s}): {1e3 * t_kernel:7.1f} ms")
    ds = dop_grid(r_mf_km, grid)
    t_grid = _median_s(lambda: dop_grid(r_mf_km, grid), repeats)
    t_summary = _median_s(lambda: dop_summary(ds), repeats)
    print(f"  dop_grid (Dataset)      : {1e3 * t_grid:7.1f} ms")
    print(f"  dop_summary             : {1e3 * t_summary:7.1f} ms")
    print(f"  grid + summary          : {1e3 * (t_grid + t_summary):7.1f} ms (target: well under 200 ms)")


if __name__ == "__main__":
    run()
