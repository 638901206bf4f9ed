"""Notebook 08: what does keeping a design for its whole life cost, and do the campaign's cheap predictors know?
(issue 11 items 3, 4 and 7)

Question: on designs spanning Table 3 (the standalone ELFO, the frozen family near i = 56-63 deg
with AOP 90/270 deg, high-a high-i orbits, low near-circular ones, and the quick campaign's best
designs), how does the closed-loop station keeping flown over the design life compare with the
campaign-grade estimate from the 10-day arc (ratio and Spearman rank correlation of the Delta-V),
which designs does the stability screen get wrong, and which regions of the design space can be
kept at all?

Verdict (the notebook prints it from the numbers, for the profile's controller and for the elements read in
the lunar equator and in ``moon_op``; words here from a one-year life, one satellite per plane, under the
fixed-element ``box`` controller of issue 11, before the ``service`` controller of issue 19): over weeks the
campaign-grade estimate ranks designs by closed-loop cost, over a year only weakly: the Lidov-Kozai growth it
sees as a 10-day slope dominates the year, and designs that need more than Table 3's 1 km/s/yr saturate the
closed loop's cap, so the estimate is a screen for cheap designs, not a budget (it over-predicts low near-
circular orbits many times over and under-predicts the near-equatorial low orbit). The stability screen agrees
with natural drift on all designs but one frozen-family orbit whose mean perilune stays about 100 km up while
the real one, swinging with the monthly terms the averaging removes, reaches the surface. High, inclined
orbits (a >= 12000 km, i >= 70 deg) are not sustainable; the frozen family mostly not over a year (its
perilunes are driven down within months and the cap is reached); the standalone ELFO, the low orbits and the
operational campaign's low near-polar designs are sustainable inside their box for a few tenths of a km/s a
year.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

from ..constellation import WalkerDesign
from ..designlife import life_metrics, run_design_life, short_arc_predictors
from ..keys import DESIGN_KEYS
from ..outputs import display_path
from ..progress import steps

__all__ = ["REGIONS", "region_of", "campaign_designs", "validation_designs", "flown_elements", "validate_design",
           "validation_table", "compare", "screen_misses", "region_summary", "verdict", "run_validation"]

REGIONS = ("standalone ELFO", "frozen family", "high a, high i", "low near-circular", "campaign", "other")


def region_of(design, campaign: bool = False) -> str:
    """Region of Table 3's space of a design ``(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)``."""
    a, e, aop, inc = (float(x) for x in design[:4])
    if campaign:
        return "campaign"
    if abs(a - 6143.0) < 1.0 and abs(e - 0.6) < 1e-9 and abs(inc - 51.7) < 1e-9 and abs(aop - 90.0) < 1e-9:
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
    for ds, label in ((published.front, "its front"), (published.evaluations, "least constraint violation")) \
            if published else ():
        if ds.sizes.get("design", 0) == 0:
            continue
        frame = ds[list(DESIGN_KEYS) + (["constraint_violation"] if "constraint_violation" in ds else [])].to_dataframe()
        if "constraint_violation" in frame and label != "its front":
            frame = frame[np.isfinite(frame["constraint_violation"])].sort_values("constraint_violation")
        frame = frame.drop_duplicates(list(DESIGN_KEYS)).head(n)
        rows = [tuple(float(r[k]) if k not in ("n_planes", "sats_per_plane") else int(r[k]) for k in DESIGN_KEYS)
                for _, r in frame.iterrows()]
        empty = "" if label == "its front" else " (its front is empty: no design met Table 3's bounds)"
        return rows, f"{len(rows)} design(s) of the campaign published in {display_path(folder)}, {label}{empty}."
    return [], f"no campaign designs: {display_path(folder)} publishes no campaign with designs."


def validation_designs(profile: dict, campaign_dir: Path | None = None) -> tuple[list[dict], str]:
    """``[life_evaluation] validation_designs`` plus the campaign's designs, each ``{"design", "region"}``."""
    section = profile["life_evaluation"]
    rows = [{"design": tuple(d), "region": region_of(d)} for d in section["validation_designs"]]
    note = "no campaign folder given."
    if campaign_dir is not None:
        extra, note = campaign_designs(campaign_dir, int(section["validation_front_designs"]))
        rows += [{"design": d, "region": region_of(d, campaign=True)} for d in extra]
    return rows, note


def flown_elements(design, max_sats_per_plane: int = 0) -> np.ndarray:
    """Walker elements (n, 6) of a design, at most ``max_sats_per_plane`` per plane (0: all) at the design's slots."""
    a, e, aop, inc, n_planes, spp = design
    el = WalkerDesign(a, e, inc, aop, int(n_planes), int(spp)).elements_deg()
    k = int(spp) if max_sats_per_plane <= 0 else min(int(spp), int(max_sats_per_plane))
    return el.reshape(int(n_planes), int(spp), 6)[:, :k].reshape(-1, 6)


def validate_design(profile: dict, design, life_days: float, max_sats_per_plane: int = 0, region: str = "") -> dict:
    """Closed loop and natural drift over ``life_days`` beside the estimate and the screen, for one design: the
    controller and element frame flown, the Delta-V (mean, max, ``dv_<purpose>_kms_per_year`` split), the lowest
    perilune controlled and natural, impacts, and the predictors."""
    elements = flown_elements(design, max_sats_per_plane)
    runs = run_design_life(profile, elements, life_days, sample=False)
    pred = short_arc_predictors(profile, profile, elements, life_days)
    ctl, nat = runs["controlled"], runs["natural"]
    impact = ctl["impact_day"].values
    nat_impact = nat["impact_day"].values
    row = dict(zip(DESIGN_KEYS, design))
    metrics = life_metrics(runs)
    row.update(region=region, n_sat_flown=int(elements.shape[0]), life_days=float(life_days),
               controller=metrics["controller"], element_frame=metrics["element_frame"],
               min_perilune_alt_km=metrics["min_perilune_alt_km"],
               natural_min_perilune_alt_km=metrics["natural_min_perilune_alt_km"],
               **{f"dv_{purpose}_kms_per_year": dv for purpose, dv in metrics["sk_dv_split"].items()},
               sk_dv_kms_per_year=float(ctl["dv_kms_per_year"].mean()),
               sk_dv_max_kms_per_year=float(ctl["dv_kms_per_year"].max()),
               n_maneuvers=int(ctl["n_maneuvers"].sum()), box_held=bool(ctl["box_held"].all()),
               impact_day=float(np.nanmin(impact)) if np.isfinite(impact).any() else np.nan,
               natural_impact_day=float(np.nanmin(nat_impact)) if np.isfinite(nat_impact).any() else np.nan,
               sk_dv_estimate_kms_per_year=pred["sk_dv_estimate_kms_per_year"], stable_screen=pred["stable_screen"],
               screen_impact_day=np.nan if pred["screen_impact_day"] is None else pred["screen_impact_day"],
               screen_min_perilune_alt_km=pred["screen_min_perilune_alt_km"],
               wall_s=float(ctl.attrs["wall_s"] + nat.attrs["wall_s"]))
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
        ratio = table["sk_dv_estimate_kms_per_year"].astype(float) / table["sk_dv_kms_per_year"].astype(float)
    table["ratio"] = np.where(closed_ok & np.isfinite(ratio), ratio, np.nan)
    natural_stable = ~np.isfinite(table["natural_impact_day"].astype(float))
    screen = table["stable_screen"].astype(bool)
    table["screen_call"] = np.where(screen == natural_stable, "agree",
                                    np.where(screen, "missed impact", "false alarm"))
    return table


def compare(table: pd.DataFrame) -> dict:
    """Ratio statistics and the Spearman rank correlation of estimate vs closed loop, over designs with a ratio."""
    ok = np.isfinite(table["ratio"].astype(float))
    closed = table.loc[ok, "sk_dv_kms_per_year"].astype(float).to_numpy()
    est = table.loc[ok, "sk_dv_estimate_kms_per_year"].astype(float).to_numpy()
    ratio = est / closed if ok.any() else np.array([])
    rho, p_value = spearmanr(est, closed) if ok.sum() >= 3 else (np.nan, np.nan)
    return {"n_compared": int(ok.sum()), "n_designs": int(len(table)),
            "ratio_median": float(np.median(ratio)) if ratio.size else np.nan,
            "ratio_min": float(ratio.min()) if ratio.size else np.nan,
            "ratio_max": float(ratio.max()) if ratio.size else np.nan,
            "ratio_geometric_mean": float(np.exp(np.mean(np.log(ratio)))) if ratio.size and np.all(ratio > 0) else np.nan,
            "spearman_rho": float(rho), "spearman_p": float(p_value)}


def screen_misses(table: pd.DataFrame) -> pd.DataFrame:
    """Every design the screen gets wrong against natural drift, with the closed loop's impact beside it."""
    cols = list(DESIGN_KEYS) + ["region", "stable_screen", "screen_impact_day", "screen_min_perilune_alt_km",
                                "natural_impact_day", "impact_day", "screen_call"]
    return table.loc[table["screen_call"] != "agree", cols]


def region_summary(table: pd.DataFrame, dv_bound_kms_per_year: float) -> pd.DataFrame:
    """Per region: designs; ``sustainable`` (no satellite lost under station keeping and every satellite's
    closed-loop Delta-V within the bound); ``box_held`` (every quantity the controller holds within its tolerance
    throughout as well); ``natural_survives``."""
    sustainable = (~np.isfinite(table["impact_day"].astype(float))
                   & (table["sk_dv_max_kms_per_year"].astype(float) <= dv_bound_kms_per_year))
    frame = table.assign(sustainable=sustainable, held=sustainable & table["box_held"].astype(bool),
                         natural_survives=~np.isfinite(table["natural_impact_day"].astype(float)))
    return frame.groupby("region", sort=False).agg(
        designs=("sustainable", "size"), sustainable=("sustainable", "sum"), box_held=("held", "sum"),
        natural_survives=("natural_survives", "sum"), dv_median_kms_per_year=("sk_dv_kms_per_year", "median"),
        dv_max_kms_per_year=("sk_dv_max_kms_per_year", "max")).reset_index()


def _ranking_words(stats: dict) -> str:
    if stats["n_compared"] < 5:
        return "Too few designs to judge the ranking."
    ranks = stats["spearman_rho"] >= 0.6 and stats["spearman_p"] < 0.05
    spread = stats["ratio_max"] / stats["ratio_min"] if stats["ratio_min"] > 0 else np.inf
    budget = ("its ratio stays within a factor of two: a usable budget" if spread <= 2.0
              else f"its ratio spreads over a factor of {spread:.0f}: not a budget")
    return ("It ranks designs by station-keeping cost; " if ranks
            else "It does not rank designs reliably by station-keeping cost; ") + budget + "."


def verdict(table: pd.DataFrame, stats: dict, regions: pd.DataFrame, dv_bound_kms_per_year: float) -> str:
    """A plain verdict in words, built from the validation's numbers."""
    life = float(table["life_days"].iloc[0])
    lines = [f"Over a {life:g}-day life ({stats['n_designs']} designs; {stats['n_compared']} with a ratio: no impact "
             f"under station keeping and a non-zero closed-loop Delta-V):"]
    lines.append(f"- the campaign-grade estimate / closed loop ratio runs from {stats['ratio_min']:.2f} to "
                 f"{stats['ratio_max']:.2f} (median {stats['ratio_median']:.2f}); Spearman rank correlation "
                 f"{stats['spearman_rho']:.2f} (p = {stats['spearman_p']:.2g}). " + _ranking_words(stats))
    misses = table[table["screen_call"] != "agree"]
    lines.append(f"- the stability screen agrees with the natural-drift propagation on {len(table) - len(misses)} of "
                 f"{len(table)} designs" + (": wrong on " + "; ".join(
                     f"a {r.sma_km:g} km e {r.ecc:g} i {r.inc_deg:g} AOP {r.aop_deg:g} ({r.screen_call})"
                     for r in misses.itertuples()) if len(misses) else "") + ".")
    for r in regions.itertuples():
        word = ("sustainable" if r.sustainable == r.designs else "not sustainable" if r.sustainable == 0
                else "partly sustainable")
        lines.append(f"- {r.region}: {word} ({r.sustainable} of {r.designs} keep every satellite up within "
                     f"{dv_bound_kms_per_year:g} km/s/yr per satellite, {r.box_held} of them within the controller's tolerances "
                     f"throughout; "
                     f"{r.natural_survives} survive with no control; closed-loop median {r.dv_median_kms_per_year:.3g} "
                     f"km/s/yr).")
    return "\n".join(lines)


def run_validation(profile: dict, campaign_dir: Path | None = None) -> tuple[pd.DataFrame, str]:
    """:func:`validate_design` on every design of :func:`validation_designs` with ``[life_evaluation]``'s life and
    satellites per plane; returns the :func:`validation_table` and the sentence on the campaign's designs."""
    section = profile["life_evaluation"]
    designs, note = validation_designs(profile, campaign_dir)
    rows = [validate_design(profile, d["design"], float(section["validation_life_days"]),
                            int(section["validation_max_sats_per_plane"]), d["region"])
            for d in steps(designs, "design-life validation", "designs")]
    return validation_table(rows), note
