"""``python -m lnss_lib bench estimate``: what the life-long estimate of the service controller's cost adds to a design
evaluation, beside the 10-day box slope it replaces.

The campaign's path (:func:`~lnss_lib.evaluator.evaluate_constellation`) with ``[sk_estimate] model = "arc"`` (old)
and ``"life"`` (new), everything else the profile's, on the designs of ``bench evaluate`` (the Table 4 ELFO and a
Table 3 sample); one numba thread; the two alternate design by design so machine load hits both alike, best of
``repeats``. The issue's budget: at most 20 % more evaluation time.
"""

from __future__ import annotations

import numba
import numpy as np

from ..campaign import CampaignPlan
from ..evaluator import EvaluationContext, evaluate_constellation
from ..keys import LIFE_NAVIGATION_KEYS
from ..settings import load_settings
from .evaluate import _designs

MODELS = ("arc", "life")


def alternating(
    profile, variants: dict, n_designs: int, repeats: int, compared: str
) -> tuple[list, list[dict]]:
    """The designs of ``bench evaluate`` evaluated under every variant of ``profile`` (name -> overrides) in turn,
    ``repeats`` times, so that machine load hits them alike, one numba thread, after one warm-up evaluation each;
    prints the header naming what is ``compared``. Returns (designs, per design name -> its fastest result)."""
    numba.set_num_threads(1)
    contexts = {
        name: EvaluationContext.build(profile.with_overrides(over))
        for name, over in variants.items()
    }
    designs = _designs(CampaignPlan.of(profile), n_designs)
    for context in contexts.values():
        evaluate_constellation(context, designs[0].elements_deg())  # JIT compile or cache load
    print(
        f"{profile.epoch.duration_days:.0f}-day arc, life {profile.stability.life_days:g} days, 1 thread; best of "
        f"{repeats} alternating runs, {compared}:"
    )
    rows = []
    for design in designs:
        elements = design.elements_deg()
        best = {}
        for _ in range(repeats):
            for name, context in contexts.items():
                result = evaluate_constellation(context, elements)
                if name not in best or result["wall_s"] < best[name]["wall_s"]:
                    best[name] = result
        rows.append(best)
    return designs, rows


def design_text(design) -> str:
    return (
        f"a {design.sma_km:7.0f} e {design.ecc:4.2f} i {design.inc_deg:4.0f} w {design.aop_deg:5.0f} "
        f"{design.n_planes}x{design.sats_per_plane}"
    )


def mean_increase(rows: list[dict], old: str, new: str) -> dict:
    """Print and return the mean evaluation time of the ``old`` and ``new`` variants over the designs."""
    old_s, new_s = (float(np.mean([row[m]["wall_s"] for row in rows])) for m in (old, new))
    print(
        f"  mean over {len(rows)} designs: {old_s:.3f} s -> {new_s:.3f} s ({100.0 * (new_s / old_s - 1.0):+.1f} %)"
    )
    return {"old_mean_s": old_s, "new_mean_s": new_s, "rows": len(rows)}


def run(
    profile_name: str = "operational",
    n_designs: int = 12,
    repeats: int = 3,
    overrides: dict | None = None,
) -> dict:
    """Print old (``arc``) and new (``life``) per-design evaluation times and estimates, and the mean increase."""
    profile = load_settings(profile_name, overrides=overrides)
    wanted = {
        "evaluator": {
            "extra_metrics": sorted(
                {*profile.evaluator.extra_metrics, "sk_dv_estimate_kms_per_year"}
                - set(LIFE_NAVIGATION_KEYS)
            )
        }
    }
    designs, rows = alternating(
        profile,
        {m: {**wanted, "sk_estimate": {"model": m}} for m in MODELS},
        n_designs,
        repeats,
        "seconds and km/s per satellite and year (arc -> life)",
    )
    for design, best in zip(designs, rows):
        old, new = best["arc"], best["life"]
        print(
            f"  {design_text(design)}: {old['wall_s']:.3f} -> {new['wall_s']:.3f} s; "
            f"estimate {old['sk_dv_estimate_kms_per_year']:.3f} -> {new['sk_dv_estimate_kms_per_year']:.3f}"
        )
    return mean_increase(rows, *MODELS)
