"""Notebook 08: what does keeping a design for its whole life cost, and do the campaign's cheap predictors know?

Question: on designs spanning Table 3 (the standalone ELFO, the frozen family near i = 56-63 deg
with AOP 90/270 deg, high-a high-i orbits, low near-circular ones, and the quick campaign's best
designs), how does the closed-loop station keeping flown over the design life compare with the
campaign-grade estimate from the 10-day arc (ratio and Spearman rank correlation of the Delta-V),
which designs does the stability screen get wrong, and which regions of the design space can be
kept at all?

Verdict (the notebook prints it from the numbers, for the profile's controller and both element frames). Words
here from ``run_validation(load_settings("paper", overrides={"life_evaluation": {"validation_life_days": 365,
"validation_max_sats_per_plane": 1}}))``: one year, one satellite per plane, the 15 ``validation_designs`` (no
campaign folder), elements read in the lunar equator / in ``moon_op`` (``frames.element_frame``), under the
``service`` controller (in brackets the fixed-element ``box``, ``design_life.controller =
"box"``); Delta-V in km/s per satellite and year, "sustainable" = no satellite lost and each within 1 km/s/yr:

- standalone ELFO: sustainable; median 0.22 (all relative node) / nothing (box 0.42 / 0.031).
- frozen family: 4 of 4 sustainable in both frames (box 1 / 4), 2 / 3 within the relative node and slot
  tolerances throughout; median 0.32 / 0.13, at most 0.72 / 0.61 (box median 0.75 / 0.56). Natural drift
  loses all four in the lunar equator, two in ``moon_op``. The cost is the perilune (safety) and the
  relative node.
- high a, high i: not sustainable, 0 / 1 of 4 (box 0 / 0); median 0.84 / 0.65, at most 1.41 / 1.10:
  Lidov-Kozai drives the perilunes into the Moon within three months and the safety burns either fail to
  save them or exceed the cap.
- low near-circular: sustainable, 3 of 3 (box 2 / 3), at most 0.003 (phase only: the relative node of the
  i 1 deg design is held as the tilt of its plane, which a node difference barely moves).
- other (mid a, low i): sustainable, 3 of 3 (box 1 / 3); median 0.16 / 0, at most 0.94 / 0.16.
- in all: 11 / 12 of 15 sustainable (box 5 / 11); no design paid for navigation.
- the campaign-grade estimate / closed loop ratio runs 1.17-37 / 1.84-48 (median 4.2 / 5.9); Spearman rho
  0.37 (p 0.29, 10 designs) / 0.61 (p 0.15, 7) over the designs with a ratio. The estimate prices holding
  fixed elements, which the service controller does not fly: it neither ranks nor budgets.
- the stability screen agrees with natural drift on 14 / 15 of 15: in the lunar equator it misses the a 9000 km
  e 0.6 i 56.2 design, whose mean perilune stays 112 km up while the real one reaches the surface on day 102.

Box figures in brackets were measured before the Delta-V cap was enforced per burn set;
service figures after it and after the relative node became the tilt of the plane, with the fixed tolerances
(``[design_life.service] tolerances = "fixed"``: 4.7 deg of tilt, 20 deg of slot); under the derived default
(:mod:`lnss_lib.design_life.tolerances`) the 15 designs were not re-flown in both frames. Note that a validation
flown with one satellite per plane derives the tolerances of that smaller constellation (tighter: fewer satellites
share the sky), not of the full design.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

from ..constellation import WalkerDesign
from ..design_life.evaluation import life_metrics, run_design_life, short_arc_predictors
from ..keys import DESIGN_KEYS
from ..outputs import cached_json, display_path
from ..progress import steps
from ..settings import Settings

__all__ = [
    "REGIONS",
    "region_of",
    "campaign_designs",
    "validation_designs",
    "flown_elements",
    "validate_design",
    "validation_table",
    "compare",
    "screen_misses",
    "region_summary",
    "verdict",
    "run_validation",
    "frame_rerun",
]

REGIONS = (
    "standalone ELFO",
    "frozen family",
    "high a, high i",
    "low near-circular",
    "campaign",
    "other",
)


def region_of(design, campaign: bool = False) -> str:
    """Region of Table 3's space of a design ``(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)``."""
    a, e, aop, inc = (float(x) for x in design[:4])
    if campaign:
        return "campaign"
    if (
        abs(a - 6143.0) < 1.0
        and abs(e - 0.6) < 1e-9
        and abs(inc - 51.7) < 1e-9
        and abs(aop - 90.0) < 1e-9
    ):
        return "standalone ELFO"
    if 56.0 <= inc <= 63.0 and min(abs(aop - 90.0), abs(aop - 270.0)) <= 1.0:
        return "frozen family"
    if a >= 12000.0 and inc >= 70.0:
        return "high a, high i"
    if a <= 5000.0 and e <= 0.05:
        return "low near-circular"
    return "other"


def campaign_designs(campaign_dir: Path, n: int) -> tuple[list[tuple], str]:
    """Up to ``n`` designs of the campaign published in a campaign folder and a sentence saying where
    they come from.

    The front (``front.nc``) when it holds designs; else the ``n`` evaluated designs of least
    constraint violation (``evaluations.nc``); else none.
    """
    from ..campaign.publication import load_published

    folder = Path(campaign_dir)
    published = load_published(folder)
    for ds, label in (
        ((published.front, "its front"), (published.evaluations, "least constraint violation"))
        if published
        else ()
    ):
        if ds.sizes.get("design", 0) == 0:
            continue
        frame = ds[
            list(DESIGN_KEYS) + (["constraint_violation"] if "constraint_violation" in ds else [])
        ].to_dataframe()
        if "constraint_violation" in frame and label != "its front":
            frame = frame[np.isfinite(frame["constraint_violation"])].sort_values(
                "constraint_violation"
            )
        frame = frame.drop_duplicates(list(DESIGN_KEYS)).head(n)
        rows = [
            tuple(
                float(r[k]) if k not in ("n_planes", "sats_per_plane") else int(r[k])
                for k in DESIGN_KEYS
            )
            for _, r in frame.iterrows()
        ]
        empty = (
            "" if label == "its front" else " (its front is empty: no design met Table 3's bounds)"
        )
        return (
            rows,
            f"{len(rows)} design(s) of the campaign published in {display_path(folder)}, {label}{empty}.",
        )
    return [], f"no campaign designs: {display_path(folder)} publishes no campaign with designs."


def validation_designs(
    settings: Settings, campaign_dir: Path | None = None
) -> tuple[list[dict], str]:
    """``[life_evaluation] validation_designs`` plus the campaign's designs, each ``{"design", "region"}``."""
    section = settings.life_evaluation
    rows = [{"design": tuple(d), "region": region_of(d)} for d in section.validation_designs]
    note = "no campaign folder given."
    if campaign_dir is not None:
        extra, note = campaign_designs(campaign_dir, section.validation_front_designs)
        rows += [{"design": d, "region": region_of(d, campaign=True)} for d in extra]
    return rows, note


def flown_elements(design, max_sats_per_plane: int = 0) -> np.ndarray:
    """Walker elements (n, 6) of a design, at most ``max_sats_per_plane`` per plane (0: all) at the design's slots."""
    a, e, aop, inc, n_planes, spp = design
    return WalkerDesign(a, e, aop, inc, int(n_planes), int(spp)).elements_deg(max_sats_per_plane)


def validate_design(
    settings: Settings, design, life_days: float, max_sats_per_plane: int = 0, region: str = ""
) -> dict:
    """Closed loop and natural drift over ``life_days`` beside the estimate and the screen, for one design: the
    controller and element frame flown, the Delta-V (mean, max, ``dv_<purpose>_kms_per_year`` split), the relative
    node (tilt) and slot tolerances the service controller held (NaN under the box), the lowest perilune controlled
    and natural, impacts, and the predictors."""
    elements = flown_elements(design, max_sats_per_plane)
    runs = run_design_life(settings, elements, life_days, sample=False)
    pred = short_arc_predictors(
        settings.epoch,
        settings.dynamics,
        settings.sk_estimate,
        settings.stability,
        settings.design_life,
        settings.dop,
        elements,
        life_days,
    )
    ctl, nat = runs["controlled"], runs["natural"]
    impact = ctl["impact_day"].values
    nat_impact = nat["impact_day"].values
    row = dict(zip(DESIGN_KEYS, design))
    metrics = life_metrics(runs)
    row.update(
        region=region,
        n_sat_flown=int(elements.shape[0]),
        life_days=float(life_days),
        controller=metrics["controller"],
        element_frame=metrics["element_frame"],
        min_perilune_alt_km=metrics["min_perilune_alt_km"],
        natural_min_perilune_alt_km=metrics["natural_min_perilune_alt_km"],
        **{f"dv_{purpose}_kms_per_year": dv for purpose, dv in metrics["sk_dv_split"].items()},
        sk_dv_kms_per_year=float(ctl["dv_kms_per_year"].mean()),
        sk_dv_max_kms_per_year=float(ctl["dv_kms_per_year"].max()),
        n_maneuvers=int(ctl["n_maneuvers"].sum()),
        box_held=bool(ctl["box_held"].all()),
        raan_rel_tolerance_deg=float(ctl.attrs["raan_rel_tolerance_deg"]),
        u_rel_tolerance_deg=float(ctl.attrs["u_rel_tolerance_deg"]),
        impact_day=float(np.nanmin(impact)) if np.isfinite(impact).any() else np.nan,
        natural_impact_day=float(np.nanmin(nat_impact))
        if np.isfinite(nat_impact).any()
        else np.nan,
        sk_dv_estimate_kms_per_year=pred["sk_dv_estimate_kms_per_year"],
        stable_screen=pred["stable_screen"],
        screen_impact_day=np.nan
        if pred["screen_impact_day"] is None
        else pred["screen_impact_day"],
        screen_min_perilune_alt_km=pred["screen_min_perilune_alt_km"],
        wall_s=float(ctl.attrs["wall_s"] + nat.attrs["wall_s"]),
    )
    return row


def validation_table(rows: list[dict]) -> pd.DataFrame:
    """Rows of :func:`validate_design` as a table, with the estimate / closed-loop ratio and the screen's call.

    ``ratio`` is NaN where the closed loop lost a satellite (its Delta-V then covers a shorter
    life), flew no manoeuvre in the span (zero Delta-V) or the estimate is undefined; ``screen_call``: ``agree``, ``missed impact`` (screen stable,
    natural drift hits the Moon) or ``false alarm`` (screen unstable, natural drift survives).
    """
    table = pd.DataFrame(rows)
    closed_ok = ~np.isfinite(table["impact_day"].astype(float))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = table["sk_dv_estimate_kms_per_year"].astype(float) / table[
            "sk_dv_kms_per_year"
        ].astype(float)
    table["ratio"] = np.where(closed_ok & np.isfinite(ratio), ratio, np.nan)
    natural_stable = ~np.isfinite(table["natural_impact_day"].astype(float))
    screen = table["stable_screen"].astype(bool)
    table["screen_call"] = np.where(
        screen == natural_stable, "agree", np.where(screen, "missed impact", "false alarm")
    )
    return table


def compare(table: pd.DataFrame) -> dict:
    """Ratio statistics and the Spearman rank correlation of estimate vs closed loop, over designs with a ratio."""
    ok = np.isfinite(table["ratio"].astype(float))
    closed = table.loc[ok, "sk_dv_kms_per_year"].astype(float).to_numpy()
    est = table.loc[ok, "sk_dv_estimate_kms_per_year"].astype(float).to_numpy()
    ratio = est / closed if ok.any() else np.array([])
    rho, p_value = spearmanr(est, closed) if ok.sum() >= 3 else (np.nan, np.nan)
    return {
        "n_compared": int(ok.sum()),
        "n_designs": int(len(table)),
        "ratio_median": float(np.median(ratio)) if ratio.size else np.nan,
        "ratio_min": float(ratio.min()) if ratio.size else np.nan,
        "ratio_max": float(ratio.max()) if ratio.size else np.nan,
        "ratio_geometric_mean": float(np.exp(np.mean(np.log(ratio))))
        if ratio.size and np.all(ratio > 0)
        else np.nan,
        "spearman_rho": float(rho),
        "spearman_p": float(p_value),
    }


def screen_misses(table: pd.DataFrame) -> pd.DataFrame:
    """Every design the screen gets wrong against natural drift, with the closed loop's impact beside it."""
    cols = list(DESIGN_KEYS) + [
        "region",
        "stable_screen",
        "screen_impact_day",
        "screen_min_perilune_alt_km",
        "natural_impact_day",
        "impact_day",
        "screen_call",
    ]
    return table.loc[table["screen_call"] != "agree", cols]


def region_summary(table: pd.DataFrame, dv_bound_kms_per_year: float) -> pd.DataFrame:
    """Per region: designs; ``sustainable`` (no satellite lost under station keeping and every satellite's
    closed-loop Delta-V within the bound); ``box_held`` (every quantity the controller holds within its tolerance
    throughout as well); ``natural_survives``."""
    sustainable = ~np.isfinite(table["impact_day"].astype(float)) & (
        table["sk_dv_max_kms_per_year"].astype(float) <= dv_bound_kms_per_year
    )
    frame = table.assign(
        sustainable=sustainable,
        held=sustainable & table["box_held"].astype(bool),
        natural_survives=~np.isfinite(table["natural_impact_day"].astype(float)),
    )
    return (
        frame.groupby("region", sort=False)
        .agg(
            designs=("sustainable", "size"),
            sustainable=("sustainable", "sum"),
            box_held=("held", "sum"),
            natural_survives=("natural_survives", "sum"),
            dv_median_kms_per_year=("sk_dv_kms_per_year", "median"),
            dv_max_kms_per_year=("sk_dv_max_kms_per_year", "max"),
        )
        .reset_index()
    )


def _ranking_words(stats: dict) -> str:
    if stats["n_compared"] < 5:
        return "Too few designs to judge the ranking."
    ranks = stats["spearman_rho"] >= 0.6 and stats["spearman_p"] < 0.05
    spread = stats["ratio_max"] / stats["ratio_min"] if stats["ratio_min"] > 0 else np.inf
    budget = (
        "its ratio stays within a factor of two: a usable budget"
        if spread <= 2.0
        else f"its ratio spreads over a factor of {spread:.0f}: not a budget"
    )
    return (
        (
            "It ranks designs by station-keeping cost; "
            if ranks
            else "It does not rank designs reliably by station-keeping cost; "
        )
        + budget
        + "."
    )


def verdict(
    table: pd.DataFrame, stats: dict, regions: pd.DataFrame, dv_bound_kms_per_year: float
) -> str:
    """A plain verdict in words, built from the validation's numbers."""
    life = float(table["life_days"].iloc[0])
    lines = [
        f"Over a {life:g}-day life ({stats['n_designs']} designs; {stats['n_compared']} with a ratio: no impact "
        f"under station keeping and a non-zero closed-loop Delta-V):"
    ]
    lines.append(
        f"- the campaign-grade estimate / closed loop ratio runs from {stats['ratio_min']:.2f} to "
        f"{stats['ratio_max']:.2f} (median {stats['ratio_median']:.2f}); Spearman rank correlation "
        f"{stats['spearman_rho']:.2f} (p = {stats['spearman_p']:.2g}). " + _ranking_words(stats)
    )
    misses = table[table["screen_call"] != "agree"]
    lines.append(
        f"- the stability screen agrees with the natural-drift propagation on {len(table) - len(misses)} of "
        f"{len(table)} designs"
        + (
            ": wrong on "
            + "; ".join(
                f"a {r.sma_km:g} km e {r.ecc:g} i {r.inc_deg:g} AOP {r.aop_deg:g} ({r.screen_call})"
                for r in misses.itertuples()
            )
            if len(misses)
            else ""
        )
        + "."
    )
    for r in regions.itertuples():
        word = (
            "sustainable"
            if r.sustainable == r.designs
            else "not sustainable"
            if r.sustainable == 0
            else "partly sustainable"
        )
        lines.append(
            f"- {r.region}: {word} ({r.sustainable} of {r.designs} keep every satellite up within "
            f"{dv_bound_kms_per_year:g} km/s/yr per satellite, {r.box_held} of them within the controller's tolerances "
            f"throughout; "
            f"{r.natural_survives} survive with no control; closed-loop median {r.dv_median_kms_per_year:.3g} "
            f"km/s/yr)."
        )
    return "\n".join(lines)


def run_validation(
    settings: Settings, campaign_dir: Path | None = None, cache_dir: Path | None = None
) -> tuple[pd.DataFrame, str]:
    """:func:`validate_design` on every design of :func:`validation_designs` with ``[life_evaluation]``'s life and
    satellites per plane; returns the :func:`validation_table` and the sentence on the campaign's designs (and, with
    ``cache_dir``, how many rows were read from :func:`~lnss_lib.outputs.cached_json`'s files there)."""
    section = settings.life_evaluation
    life, per_plane = section.validation_life_days, section.validation_max_sats_per_plane
    designs, note = validation_designs(settings, campaign_dir)
    rows, hits = [], 0
    for d in steps(designs, "design-life validation", "designs"):
        row, hit = cached_json(
            cache_dir,
            "validation",
            [settings.hash, list(d["design"]), life, per_plane, d["region"]],
            lambda d=d: validate_design(settings, d["design"], life, per_plane, d["region"]),
        )
        rows.append(row)
        hits += hit
    if cache_dir is not None:
        note += (
            f" {hits} of {len(rows)} closed loops read from {display_path(cache_dir)} (computed earlier with "
            "this code, data and settings)."
        )
    return validation_table(rows), note


def frame_rerun(
    settings: Settings, element_frame: str, campaign_dir: Path | None = None
) -> tuple[Settings, Path | None]:
    """(settings, campaign folder) of the validation re-run with the elements read in ``element_frame``: every design
    of :func:`run_validation`, or with ``[life_evaluation] frame_rerun_designs`` = n > 0 the first n
    ``validation_designs`` only (no campaign designs), so a short profile can afford the re-run."""
    rerun = settings.with_overrides({"frames": {"element_frame": element_frame}})
    n = settings.life_evaluation.frame_rerun_designs
    if n <= 0:
        return rerun, campaign_dir
    designs = [list(d) for d in settings.life_evaluation.validation_designs[:n]]
    return rerun.with_overrides({"life_evaluation": {"validation_designs": designs}}), None
