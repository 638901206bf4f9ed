"""Notebook 07: is the front a property of the problem or of the seed?

Question: the paper ran NSGA-II once, and so does the workbook's shipped campaign (``paper_dv_physical``, seed 1,
120 x 1000, ``outputs/reference/paper_dv_physical/``). Are the hypervolume it converges to, Table 6's picks and the
smallest feasible constellation properties of the problem, or of seed 1? The multi-objective optimisation literature
judges an evolutionary search over independent runs; the study ``params/studies/paper_dv_physical_seeds.toml`` runs
the same campaign with seeds 1-5 for 300 generations each (the shipped run's hypervolume reaches 99 % of its
1000-generation value by generation 163) and ships each seed's history and front
(``outputs/reference/paper_dv_physical_seeds/``, :mod:`lnss_lib.campaign.study_reference`).

Read here, from the shipped files: the hypervolume per generation of every seed (:func:`hypervolume_curves`: the
campaign's own measure, the feasible designs so far normalised by one reference point, the profile's
``[campaign.hypervolume]``, checked to be the same for every seed) and its spread over the seeds per generation
(:func:`curve_spread`); per seed (:func:`seed_table`) the final value, the generation at which it reaches 99 % and
99.9 % of it (:func:`~lnss_lib.studies.pareto.hypervolume_milestones`), the front and the smallest feasible
constellation (:func:`~lnss_lib.studies.pareto.smallest_constellation`, the paper's coverage); Table 6 per seed, by
the rules and bounds notebook 07 applies to the shipped run (:func:`table6_of`, :func:`table6_by_seed`); and per rule
whether the pick changes with the seed (:func:`what_changes`): the same design (the design grid is discrete, so
"the same" is exact), the same Walker pattern with another orbit, or another constellation, with the spread of the
value the rule ranks by. :func:`against_shipped` sets the study's seed 1 beside the shipped run of the same seed (the
same search only where the kernels were compiled for the same processor model: README, Notes for developers).

Verdict (notebook 07 prints it from the shipped study, :func:`verdict`): a property of the problem. Over seeds 1-5
the hypervolume after 300 generations spans 0.13 % of its median, every seed reaching 99 % of its final value by
generation 100; the smallest feasible constellation is 6 satellites in 2 planes of 3 for every seed, in another orbit
each time (a 5600-6400 km, e 0.58-0.62, i 83-85 deg); six of Table 6's seven rules pick the same Walker pattern in
another orbit, and the seventh (most GPS satellites visible) swaps between 3 x 3 and 5 x 4 on a difference in the
fourth digit of its criterion. The seed moves the orbit within the front, not its answers.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import xarray as xr

from ..campaign.fitness import deltav_constraint
from ..keys import DESIGN_KEYS, design_text
from ..paper import SMALLEST_CONSTELLATION, TABLE_6
from .pareto import TABLE6_RULES, hypervolume_milestones, smallest_constellation, table6

__all__ = [
    "SEED_STUDY",
    "RULE_CRITERIA",
    "SMALLEST_RULE",
    "seed_study",
    "hypervolume_curves",
    "curve_spread",
    "table6_of",
    "table6_by_seed",
    "seed_table",
    "what_changes",
    "against_shipped",
    "verdict",
]

SEED_STUDY = (
    "paper_dv_physical_seeds"  # params/studies/<name>.toml, shipped in outputs/reference/<name>/
)

RULE_CRITERIA = {  # each rule of Table 6 (lnss_lib.studies.pareto.TABLE6_RULES) -> the value it ranks by
    "fewest satellites (ties: lowest Delta-V)": "n_sat",
    "best PDOP with fewer than 10 satellites": "pdop_mean_3sigma",
    "best PDOP": "pdop_mean_3sigma",
    "best HDOP": "hdop_mean_3sigma",
    "best GPS geometry (lowest GPS-LNSS PDOP)": "gps_pdop_mean",
    "most GPS satellites visible": "gps_visible_mean",
    "lowest station-keeping Delta-V": None,  # the campaign's Delta-V metric (its bound's)
}
SMALLEST_RULE = "smallest feasible constellation"  # the row of :func:`what_changes` for it
_COUNTS = ("n_evaluations_cum", "n_feasible_cum", "n_feasible_pop", "n_cache_hits")
_PLURAL = {  # an answer of :func:`what_changes`, said of several rules
    "the same design in every seed": "pick the same design in every seed",
    "the same constellation (pattern), another orbit": "pick the same constellation with another orbit",
    "changes with the seed": "change with the seed",
    "no pick": "pick nothing in any seed",
}


def seed_study(root=None):
    """The shipped seed study (:class:`~lnss_lib.campaign.study_reference.StudyReference`: each seed's history and
    front), or None when it is not shipped (``root``: default ``outputs/reference``)."""
    from ..campaign.study_reference import load_study_reference

    return load_study_reference(SEED_STUDY, root)


def hypervolume_curves(histories: dict[str, xr.Dataset]) -> pd.DataFrame:
    """The hypervolume per generation (rows) of each campaign (columns, by name). ValueError when the campaigns
    measured it against different reference points (the ``hypervolume_reference`` of their histories): their values
    would not compare."""
    references = {name: h.attrs.get("hypervolume_reference") for name, h in histories.items()}
    if (
        len({json.dumps(json.loads(r), sort_keys=True) if r else r for r in references.values()})
        > 1
    ):
        raise ValueError(
            f"the campaigns measured the hypervolume against different reference points: {references}"
        )
    curves = pd.DataFrame(
        {name: h["hypervolume"].to_series() for name, h in histories.items()}
    ).rename_axis(index="generation")
    return curves


def curve_spread(curves: pd.DataFrame) -> pd.DataFrame:
    """Per generation of :func:`hypervolume_curves`, over the campaigns that reached it: the smallest, median and
    largest hypervolume and the spread (largest - smallest) in % of the median (NaN while the median is 0)."""
    low, median, high = curves.min(axis=1), curves.median(axis=1), curves.max(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        spread = 100.0 * (high - low) / median.where(median > 0)
    return pd.DataFrame({"min": low, "median": median, "max": high, "spread (% of median)": spread})


def table6_of(front: xr.Dataset) -> tuple[pd.DataFrame, str, float]:
    """(Table 6, its Delta-V metric, the Delta-V bound applied) of a campaign's front by notebook 07's rule: the
    front's designs with PDOP and HDOP availability >= Table 6's (:data:`lnss_lib.paper.TABLE_6`) and the Delta-V
    within the campaign's bound, one per rule of :data:`~lnss_lib.studies.pareto.TABLE6_RULES`; when none meets the
    bound, the same without it (bound inf)."""
    dv_metric, dv_bound = deltav_constraint(front)
    for bound in (dv_bound, np.inf):
        picks = table6(
            front,
            availability_min_pct=TABLE_6["availability_min_pct"],
            dv_max_kms_per_year=bound,
            dv_metric=dv_metric,
        )
        if len(picks):
            return picks, dv_metric, bound
    return picks, dv_metric, np.inf


def table6_by_seed(fronts: dict[str, xr.Dataset]) -> pd.DataFrame:
    """Table 6 of every campaign's front (:func:`table6_of`), one row per (campaign, rule): ``campaign``, ``rule``,
    the design's :data:`~lnss_lib.keys.DESIGN_KEYS`, the value the rule ranks by (``criterion``, its ``value``),
    the Delta-V metric's value (``dv``) and the design in words. A campaign with no pick has no row."""
    rows = []
    for name, front in fronts.items():
        picks, dv_metric, _ = table6_of(front)
        for _, pick in picks.iterrows():
            for rule in pick["why selected"].split("; "):
                criterion = RULE_CRITERIA[rule] or dv_metric
                rows.append(
                    {
                        "campaign": name,
                        "rule": rule,
                        **{k: pick[k] for k in DESIGN_KEYS},
                        "n_sat": int(pick["n_sat"]),
                        "criterion": criterion,
                        "value": float(pick[criterion]),
                        "dv": float(pick[dv_metric]),
                        "design": design_text(pick),
                    }
                )
    order = {reason: i for i, (reason, _) in enumerate(TABLE6_RULES)}
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    return table.sort_values(
        ["rule", "campaign"], key=lambda c: c.map(order) if c.name == "rule" else c, kind="stable"
    ).reset_index(drop=True)


def _smallest(front: xr.Dataset) -> pd.Series | None:
    """The smallest feasible constellation of a front at the paper's coverage (notebook 07's rule)."""
    dv_metric, _ = deltav_constraint(front)
    return smallest_constellation(front, dv_metric, SMALLEST_CONSTELLATION["availability_pct"])


def seed_table(histories: dict[str, xr.Dataset], fronts: dict[str, xr.Dataset]) -> pd.DataFrame:
    """One row per campaign: seed, generations run, final hypervolume and its share of the median final value of
    the campaigns, the generations at which it reaches 99 % and 99.9 % of its own final value, unique feasible designs,
    front designs, Table 6's picks (distinct designs) and the smallest feasible constellation (satellites, its
    Delta-V, the design in words; "none" when no design of the front reaches the paper's coverage)."""
    finals = {name: float(h["hypervolume"].values[-1]) for name, h in histories.items()}
    median = float(np.median(list(finals.values())))
    rows = []
    for name, history in histories.items():
        milestones = hypervolume_milestones(history)["first generation"]
        front = fronts[name]
        small = _smallest(front)
        dv_metric, _ = deltav_constraint(front)
        rows.append(
            {
                "campaign": name,
                "seed": int(history.attrs["seed"]),
                "generations": int(history["generation"].values[-1]),
                "final hypervolume": finals[name],
                "final / median of the seeds (%)": 100.0 * finals[name] / median
                if median > 0
                else np.nan,
                "generation at 99 %": milestones.loc[0.99],
                "generation at 99.9 %": milestones.loc[0.999],
                "unique feasible designs": int(history["n_feasible_cum"].values[-1]),
                "front designs": int(front.sizes["design"]),
                "Table 6 designs": len(table6_of(front)[0]),
                "smallest: satellites": np.nan if small is None else int(small["n_sat"]),
                f"smallest: {dv_metric}": float(small.get(dv_metric, np.nan))
                if small is not None
                else np.nan,
                "smallest: design": "none" if small is None else design_text(small),
            }
        )
    return pd.DataFrame(rows).set_index("campaign")


def _pattern(row) -> str:
    return f"{int(row['n_planes'])} planes x {int(row['sats_per_plane'])}"


def what_changes(picks: pd.DataFrame, fronts: dict[str, xr.Dataset]) -> pd.DataFrame:
    """Per rule of Table 6 (``picks``: :func:`table6_by_seed`), and for the smallest feasible constellation of each
    front: over the campaigns, how many picked anything, the distinct designs and Walker patterns (planes x satellites
    per plane) picked, the satellite counts, the range of the value the rule ranks by, and the answer: "the same
    design in every seed", "the same constellation (pattern), another orbit", "changes with the seed" or "no pick"."""
    smallest = []
    for name, front in fronts.items():
        small = _smallest(front)
        if small is not None:
            smallest.append(
                {
                    "campaign": name,
                    "rule": SMALLEST_RULE,
                    **{k: small[k] for k in DESIGN_KEYS},
                    "n_sat": int(small["n_sat"]),
                    "criterion": "n_sat",
                    "value": float(small["n_sat"]),
                }
            )
    rules = [reason for reason, _ in TABLE6_RULES] + [SMALLEST_RULE]
    every = pd.concat([picks, pd.DataFrame(smallest)], ignore_index=True)
    rows = []
    for rule in rules:
        chosen = every[every["rule"] == rule] if len(every) else every
        designs = {tuple(float(v) for v in row[list(DESIGN_KEYS)]) for _, row in chosen.iterrows()}
        patterns = sorted({_pattern(row) for _, row in chosen.iterrows()})
        complete = len(chosen) == len(fronts)
        if not len(chosen):
            answer = "no pick"
        elif complete and len(designs) == 1:
            answer = "the same design in every seed"
        elif complete and len(patterns) == 1:
            answer = "the same constellation (pattern), another orbit"
        else:
            answer = "changes with the seed"
        rows.append(
            {
                "rule": rule,
                "seeds with a pick": len(chosen),
                "distinct designs": len(designs),
                "patterns": ", ".join(patterns),
                "satellites": ", ".join(str(n) for n in sorted(set(chosen["n_sat"])))
                if len(chosen)
                else "",
                "ranked by": chosen["criterion"].iloc[0] if len(chosen) else "",
                "lowest": chosen["value"].min() if len(chosen) else np.nan,
                "highest": chosen["value"].max() if len(chosen) else np.nan,
                "answer": answer,
            }
        )
    return pd.DataFrame(rows).set_index("rule")


def against_shipped(study: xr.Dataset, shipped: xr.Dataset) -> dict:
    """The study's history of a seed beside the shipped run of that seed (their common generations): the last
    generation up to which every count (:data:`_COUNTS`) and the hypervolume are equal bit for bit, the first at which
    a count differs (another design evaluated: the searches have parted; None when they never do), and the largest
    relative hypervolume difference before that."""
    last = int(min(study["generation"].values[-1], shipped["generation"].values[-1]))
    a, b = (h.sel(generation=slice(1, last)) for h in (study, shipped))
    same_counts = np.all([a[k].values == b[k].values for k in _COUNTS], axis=0)
    identical = same_counts & (a["hypervolume"].values == b["hypervolume"].values)
    generations = a["generation"].values
    parted = np.flatnonzero(~same_counts)
    before = slice(0, parted[0] if parted.size else generations.size)
    hv_a, hv_b = a["hypervolume"].values[before], b["hypervolume"].values[before]
    with np.errstate(invalid="ignore", divide="ignore"):
        relative = np.abs(hv_a - hv_b) / np.abs(hv_b)
    return {
        "generations compared": last,
        "identical through": int(generations[np.argmin(identical)] - 1)
        if not identical.all()
        else last,
        "searches part at": int(generations[parted[0]]) if parted.size else None,
        "largest relative hypervolume difference before": float(np.nanmax(relative))
        if relative.size
        else 0.0,
    }


def verdict(curves: pd.DataFrame, table: pd.DataFrame, changes: pd.DataFrame) -> list[str]:
    """The answer in sentences, from :func:`hypervolume_curves`, :func:`seed_table` and :func:`what_changes`."""
    finals = curves.ffill().iloc[-1]
    spread = curve_spread(curves.ffill().iloc[[-1]]).iloc[0]
    at99 = table["generation at 99 %"].dropna()
    lines = [
        f"hypervolume after {int(curves.index[-1])} generations over {len(finals)} seeds: "
        f"{finals.min():.4f} to {finals.max():.4f} (median {finals.median():.4f}; spread "
        f"{spread['spread (% of median)']:.2f} % of the median); "
        + (
            f"{len(at99)} seed(s) reached 99 % of their own final value by generation {int(at99.min())} to "
            f"{int(at99.max())} (median {at99.median():.0f})"
            if len(at99)
            else "no seed's hypervolume rose above 0 (no feasible design inside the reference box)"
        )
    ]
    small = changes.loc[SMALLEST_RULE]
    lines.append(
        f"smallest feasible constellation (PDOP and HDOP availability >= "
        f"{SMALLEST_CONSTELLATION['availability_pct']:g} %): {small['answer']} (satellites: "
        f"{small['satellites'] or 'none'}; patterns: {small['patterns'] or 'none'}; "
        f"{small['distinct designs']} distinct design(s) over {small['seeds with a pick']} seed(s))"
    )
    rules = changes.drop(index=SMALLEST_RULE)
    counts = rules["answer"].value_counts()
    lines.append(
        f"Table 6's {len(rules)} rules: "
        + "; ".join(f"{n} {_PLURAL[answer]}" for answer, n in counts.items())
        + (
            f" (changing: {', '.join(rules.index[rules['answer'] == 'changes with the seed'])})"
            if "changes with the seed" in counts
            else ""
        )
    )
    return lines
