"""``python -m lnss_lib bench evaluate``: design evaluations at the profile's fidelity, after warm-up, today's
path, the issue-12 path and today's path with the user's position error in metres side by side.

Old path: every gravity degree at every step, the DOP grid and GPS link through their Datasets
(:func:`~lnss_lib.evaluator.analyse_constellation`). New path: the campaign's
(:func:`~lnss_lib.evaluator.evaluate_constellation`): gravity degrees bounded below
``gravity.truncation_kms2`` dropped, DOP and GPS link in compiled passes. Metres: the new path with every
metric of :data:`~lnss_lib.keys.NAVIGATION_ERROR_KEYS` added to the profile's extra metrics (uploads, ephemeris
ages and the weighted position error in the DOP grid's pass). One numba thread, as in a campaign worker; the
paths alternate design by design so machine load hits them alike.
"""

from __future__ import annotations

import time

import numba
import numpy as np

from ..campaign import CampaignPlan
from ..constellation import WalkerDesign
from ..errors import ImpactError
from ..evaluator import EvaluationContext, analyse_constellation, evaluate_constellation
from ..keys import METRIC_KEYS, NAVIGATION_ERROR_KEYS
from ..paper import EVALUATIONS
from ..settings import load_settings

PARTS = ("propagation", "dop", "deltav", "gps")


def _designs(campaign: CampaignPlan, n: int, seed: int = 12) -> list[WalkerDesign]:
    """``n`` Walker designs drawn uniformly from the campaign grid (Table 3) that do not start inside the Moon."""
    grid = campaign.grid
    rng = np.random.default_rng(seed)
    out = [WalkerDesign(6143.0, 0.6, 90.0, 51.7, 4, 5)]
    while len(out) < n:
        d = grid.designs(rng.integers(0, grid.n_levels + 1).reshape(1, -1))[0]
        try:
            design = WalkerDesign(
                d["sma_km"],
                d["ecc"],
                d["aop_deg"],
                d["inc_deg"],
                d["n_planes"],
                d["sats_per_plane"],
            )
            design.elements_deg()
        except ValueError:
            continue
        out.append(design)
    return out


def run(
    profile_name: str = "paper",
    n_designs: int = 12,
    repeats: int = 2,
    overrides: dict | None = None,
) -> dict:
    """Print old and new per-design times (20-satellite ELFO design and a Table 3 sample) and projections."""
    numba.set_num_threads(1)
    profile = load_settings(profile_name, overrides=overrides)
    full = profile.with_overrides({"gravity": {"truncation_kms2": 0.0}})
    start = time.perf_counter()
    new_ctx = EvaluationContext.build(profile)
    old_ctx = EvaluationContext.build(full)
    extras = list(dict.fromkeys(profile.evaluator.extra_metrics + NAVIGATION_ERROR_KEYS))
    metres_ctx = EvaluationContext.build(
        profile.with_overrides({"evaluator": {"extra_metrics": extras}})
    )
    print(
        f"contexts (tables, force model, rotations, grid, GPS states), all three: {time.perf_counter() - start:.2f} s"
    )

    def old(elements):
        return analyse_constellation(old_ctx, elements)["metrics"]

    def new(elements):
        return evaluate_constellation(new_ctx, elements)

    def metres(elements):
        return evaluate_constellation(metres_ctx, elements)

    paths = {"old": old, "new": new, "metres": metres}

    designs = _designs(CampaignPlan.of(profile), n_designs)
    start = time.perf_counter()
    for func in paths.values():
        func(designs[0].elements_deg())
    print(f"first evaluations (JIT compile or cache load): {time.perf_counter() - start:.2f} s")
    rows = []
    for design in designs:
        elements = design.elements_deg()
        best = dict.fromkeys(paths)
        for _ in range(repeats):
            for name, func in paths.items():
                try:
                    result = func(elements)
                except ImpactError:
                    result = None
                if result is None or not result.get("evaluated", True) or "timing_s" not in result:
                    best[name] = "infeasible"
                    continue
                if (
                    best[name] is None
                    or best[name] == "infeasible"
                    or result["wall_s"] < best[name]["wall_s"]
                ):
                    best[name] = result
        if all(isinstance(result, dict) for result in best.values()):
            rows.append((design, best["old"], best["new"], best["metres"]))
    print(
        f"{profile.epoch.duration_days:.0f} days, degree {profile.gravity.degree}, integrator "
        f"{profile.integrator.setting}, 1 thread; min of {repeats} alternating runs, seconds (old -> new | with metres):"
    )
    for design, o, n, m in rows:
        diff = max(
            abs(n[k] - o[k]) / max(abs(o[k]), 1e-300)
            for k in (
                "pdop_mean_3sigma",
                "hdop_mean_3sigma",
                "pdop_avail_pct",
                "dv_total_kms_per_year",
                "gps_visible_mean",
            )
            if o[k] == o[k]
        )
        same = all(m[k] == n[k] or m[k] != m[k] and n[k] != n[k] for k in METRIC_KEYS)
        print(
            f"  a {design.sma_km:7.0f} e {design.ecc:4.2f} i {design.inc_deg:4.0f} w {design.aop_deg:5.0f} "
            f"{design.n_planes}x{design.sats_per_plane}: {o['wall_s']:.3f} -> {n['wall_s']:.3f} | {m['wall_s']:.3f} ("
            + ", ".join(
                f"{k} {o['timing_s'][k]:.3f}->{n['timing_s'][k]:.3f}|{m['timing_s'][k]:.3f}"
                for k in PARTS
            )
            + f"); metrics max rel diff {diff:.1e}; eq. 45 metrics with metres {'the same' if same else 'DIFFER'}"
        )
    old_mean, new_mean, metres_mean = (
        float(np.mean([row[i]["wall_s"] for row in rows])) for i in (1, 2, 3)
    )
    shares = {
        k: [np.mean([row[i]["timing_s"][k] for row in rows]) for i in (1, 2, 3)] for k in PARTS
    }
    print(
        f"  mean over {len(rows)} designs: {old_mean:.3f} s -> {new_mean:.3f} s ({old_mean / new_mean:.2f}x); "
        + ", ".join(f"{k} {a:.3f}->{b:.3f}" for k, (a, b, _) in shares.items())
    )
    print(
        f"  the metres add {100.0 * (metres_mean / new_mean - 1.0):+.1f} % ({new_mean:.3f} s -> {metres_mean:.3f} s; "
        f"DOP grid pass {shares['dop'][1]:.3f} -> {shares['dop'][2]:.3f} s)"
    )
    print(
        f"  evaluation time alone for {EVALUATIONS} designs on 2 workers: {EVALUATIONS * old_mean / 2 / 3600:.1f} h -> "
        f"{EVALUATIONS * new_mean / 2 / 3600:.1f} h (add the campaign's overhead from `bench campaign`)"
    )
    return {
        "old_mean_s": old_mean,
        "new_mean_s": new_mean,
        "metres_mean_s": metres_mean,
        "rows": len(rows),
    }
