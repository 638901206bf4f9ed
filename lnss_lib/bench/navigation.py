"""``python -m lnss_lib bench navigation``: what judging navigation over the design life adds to a design evaluation.

The campaign's path (:func:`~lnss_lib.evaluator.evaluate_constellation`) under the profile (operational by default),
without (old) and with (new) the life estimate's availability over the life
(:data:`~lnss_lib.keys.LIFE_NAVIGATION_KEYS`): old rebuilds only the navigation windows the monitor judges, new every
window of the life (:func:`~lnss_lib.design_life.life_navigation.navigation_restores`); the restores and every other
metric are the same (old judges the campaign on the 10-day availability, as before). Designs of ``bench evaluate``
(the Table 4 ELFO and a Table 3 sample), one numba thread, the two alternating design by design, best of
``repeats``. The budget: at most 15 % more evaluation time.
"""

from __future__ import annotations

from ..keys import LIFE_NAVIGATION_KEYS
from ..settings import load_settings
from .estimate import alternating, design_text, mean_increase


def _on_the_arc(name: str) -> str:
    """An objective or bound on the navigation over the life read on the 10-day arc instead (``-`` kept)."""
    for span in ("_life_estimate", "_worst_month_estimate"):
        if name.endswith(span):
            return name[: -len(span)]
    return name


def run(
    profile_name: str = "operational",
    n_designs: int = 12,
    repeats: int = 3,
    overrides: dict | None = None,
) -> dict:
    """Print per-design evaluation times without and with the navigation over the life, and the mean increase."""
    profile = load_settings(profile_name, overrides=overrides)
    others = [k for k in profile.evaluator.extra_metrics if k not in LIFE_NAVIGATION_KEYS]
    arc_judged = {
        "objectives": [_on_the_arc(name) for name in profile.campaign.objectives],
        "constraints": {
            **{k: "off" for k in profile.campaign.constraints if k in LIFE_NAVIGATION_KEYS},
            **{
                _on_the_arc(k): v
                for k, v in profile.campaign.constraints.items()
                if k in LIFE_NAVIGATION_KEYS
            },
        },
    }
    variants = {
        "old": {
            "evaluator": {"extra_metrics": others},
            "sk_estimate": {"model": "life"},
            "campaign": arc_judged,
        },
        "new": {
            "evaluator": {"extra_metrics": [*others, *LIFE_NAVIGATION_KEYS]},
            "sk_estimate": {"model": "life"},
        },
    }
    designs, rows = alternating(
        profile,
        variants,
        n_designs,
        repeats,
        "seconds (without -> with the navigation over the life)",
    )
    for design, best in zip(designs, rows):
        old, new = best["old"], best["new"]
        same = old["sk_dv_estimate_kms_per_year"] == new["sk_dv_estimate_kms_per_year"]
        print(
            f"  {design_text(design)}: {old['wall_s']:.3f} -> {new['wall_s']:.3f} s; PDOP availability "
            f"{new['pdop_avail_pct']:.1f} % on the arc, {new['pdop_avail_pct_life_estimate']:.1f} % over the life, "
            f"{new['pdop_avail_pct_worst_month_estimate']:.1f} % in the worst month"
            + ("" if same else "; the Delta-V estimate differs")
        )
    return mean_increase(rows, "old", "new")
