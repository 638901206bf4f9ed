"""``python -m lnss_lib bench evaluate``: one 20-satellite design at the profile's fidelity, after warm-up."""

from __future__ import annotations

import time

import numpy as np

from ..config import load_profile
from ..evaluator import EvaluationContext, evaluate_design


def run(profile_name: str = "paper", repeats: int = 5) -> None:
    profile = load_profile(profile_name)
    start = time.perf_counter()
    context = EvaluationContext.from_profile(profile)
    print(f"context (tables, force model, rotations, grid, GPS states): {time.perf_counter() - start:.2f} s")
    design = dict(sma_km=6143.0, ecc=0.6, aop_deg=90.0, inc_deg=51.7, n_planes=4, sats_per_plane=5)
    start = time.perf_counter()
    evaluate_design(context, **design)
    print(f"first evaluation (JIT compile or cache load): {time.perf_counter() - start:.2f} s")
    results = [evaluate_design(context, **design) for _ in range(repeats)]
    walls = np.array([r["wall_s"] for r in results])
    parts = {k: np.median([r["timing_s"][k] for r in results]) for k in results[0]["timing_s"]}
    print(f"20-satellite design {design}, {profile['epoch']['duration_days']:.0f} days, degree "
          f"{profile['gravity']['degree']}: median {np.median(walls):.3f} s wall (min {walls.min():.3f}, {repeats} runs)")
    print("  " + ", ".join(f"{k} {v:.3f} s" for k, v in parts.items()))
