"""The findings page: what a run concluded, beside the paper, read from the run's own outputs.

:func:`study_answer` opens the page (and the README): the question, the paper's answer, the workbook's from the
full-size campaigns of profiles ``paper`` and ``paper_dv_physical`` (a local published run of that profile, else
the shipped results in ``outputs/reference/``, as notebooks 06-07 read them), and the number that differs most.

:func:`collect` reads ``outputs/<profile>/`` (the manifest, the tables the notebooks wrote and the
campaigns' ``evaluations.nc``) and returns one :class:`Finding` per headline result: Table 4 of the
standalone ELFO with GPS (notebook 05), the campaigns against Table 3 and the smallest constellation
(06-07), the paper's headline from the operational front flown in closed loop (07), the campaign designs over the
design life (08) and the published constellations (10). Paper
values come from :mod:`lnss_lib.paper`; no number is typed here. A topic whose outputs are missing says
which notebook writes them. :func:`findings_markdown` writes ``FINDINGS.md``; :func:`findings_html` the
top of ``index.html`` (:func:`lnss_lib.pipeline.write_index`).
"""

from __future__ import annotations

import csv
import html
import json
import math
from dataclasses import dataclass
from pathlib import Path

from .campaign.fitness import (
    deltav_constraint,
    parse_constraints,
    satisfies,
    smallest_constellation,
)
from .campaign.publication import load_published
from .campaign.reference import load_reference
from .keys import NON_NAVIGATION_METRICS, bound_text, design_text, format_value, label
from .outputs import profile_dir
from .paper import (
    EVALUATIONS,
    FEASIBLE_DESIGNS,
    SMALL_CONSTELLATION_SATS,
    SMALLEST_CONSTELLATION,
    TABLE_4,
    TABLE_6,
)

__all__ = [
    "Finding",
    "Answer",
    "study_answer",
    "run_summary",
    "collect",
    "headline_findings",
    "findings_markdown",
    "findings_html",
    "write_findings",
    "FINDINGS_FILE",
]

FINDINGS_FILE = "FINDINGS.md"
ANSWER_SOURCE = (
    "profiles paper and paper_dv_physical, 120 x 1000 each: a local published run, else the "
    "shipped results in outputs/reference/"
)
HEADLINE_FIGURES = (
    "07_fig8_hdop_pdop_deltav",
    "06_designs_pdop_dv",
)  # the first a run drew opens the page
TABLE4_FIGURES = {  # Table 4 metric -> the figure of notebook 05 that shows it
    "mean_visible_sats": "05_fig4_dop_time_series",
    "pdop_mean_3sigma": "05_fig4_dop_time_series",
    "hdop_mean_3sigma": "05_fig4_dop_time_series",
    "pdop_avail_pct": "05_fig4_dop_time_series",
    "hdop_avail_pct": "05_fig4_dop_time_series",
    "dv_total_kms_per_year": "05_fig6_thrust",
    "dv_opt_kms_per_year": "05_fig6_thrust",
    "gps_visible_mean": "05_fig7_gps",
    "gps_pdop_mean": "05_fig7_gps",
}


@dataclass(frozen=True)
class Finding:
    """One headline result: the paper's value, this run's, why they differ, and where it is shown.

    ``links`` are (text, path relative to ``outputs/<profile>/``); a path starting with ``#`` is a
    section of ``index.html``.
    """

    topic: str
    paper: str
    workbook: str
    why: str
    links: tuple[tuple[str, str], ...] = ()


def _read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def _number(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def _notebook(root: Path, number: str) -> tuple[tuple[str, str], ...]:
    """Links to the index section of notebook ``number`` and to its executed copy, when there is one."""
    books = (
        sorted((root / "notebooks").glob(f"{number}_*.ipynb"))
        if (root / "notebooks").is_dir()
        else []
    )
    return ((f"section {number}", f"#nb-{number}"),) + tuple(
        (f"notebook {number}", f"notebooks/{b.name}") for b in books
    )


def _figure(root: Path, stem: str) -> tuple[tuple[str, str], ...]:
    for suffix in (".html", ".png"):
        if (root / "figures" / f"{stem}{suffix}").is_file():
            return ((stem, f"figures/{stem}{suffix}"),)
    return ()


def _missing(topic: str, paper: str, number: str, what: str) -> Finding:
    return Finding(
        topic,
        paper,
        "not in this run",
        f"{what} is written by notebook {number}: python -m lnss_lib reproduce --only {number}",
    )


def run_summary(profile_name: str) -> dict:
    """Profile, git revision, time written and notebook wall times of the run, from its manifest."""
    path = profile_dir(profile_name) / "manifest.json"
    manifest = json.loads(path.read_text()) if path.is_file() else {}
    runs = manifest.get("notebooks", {})
    return {
        "profile": profile_name,
        "git_revision": manifest.get("git_revision", "unknown"),
        "written_utc": manifest.get("written_utc", "unknown"),
        "notebooks": {name: run.get("status", "?") for name, run in runs.items()},
        "wall_s": sum(float(run.get("wall_s", 0.0)) for run in runs.values()),
    }


def table4_findings(root: Path) -> list[Finding]:
    """Every Table 4 row of notebook 05 (``05_table4.csv``): the paper, ours and the table's own reason."""
    path = root / "tables" / "05_table4.csv"
    if not path.is_file():
        return [_missing("Table 4: standalone ELFO", "Table 4", "05", "the Table 4 comparison")]
    rows = _read_csv(path)
    keys = (
        list(TABLE_4) if len(rows) == len(TABLE_4) else [""] * len(rows)
    )  # 05_table4 lists Table 4 in order
    found = []
    for key, row in zip(keys, rows):
        difference = _number(row.get("difference (%)"))
        ours = format_value(key, _number(row.get("this workbook")))
        if math.isfinite(difference):
            ours += f" ({difference:+.1f} %)"
        links = _figure(root, TABLE4_FIGURES.get(key, "")) + _notebook(root, "05")
        if key in ("gps_visible_mean", "gps_pdop_mean"):
            links += _notebook(root, "03")
        found.append(
            Finding(
                f"Table 4: {row.get('metric', '')}",
                format_value(key, _number(row.get("paper"))),
                ours,
                row.get("why", ""),
                links,
            )
        )
    return found


def _campaign(profile_name: str):
    """The evaluations of the profile's published campaign (:mod:`lnss_lib.campaign.publication`), else its
    shipped results (``outputs/reference/<profile>/``, :mod:`lnss_lib.campaign.reference`), else None."""
    published = load_published(profile_dir(profile_name) / "campaign")
    if published is not None:
        return published.evaluations
    shipped = load_reference(profile_name)
    return None if shipped is None else shipped.evaluations


def _designs_evaluated(ds) -> int:
    """Unique designs the campaign evaluated (shipped results keep only the designs the figures read)."""
    return int(ds.attrs.get("n_designs_evaluated", ds.sizes["design"]))


@dataclass(frozen=True)
class Answer:
    """The study in four sentences: the question, the paper's answer, the workbook's, the largest difference."""

    question: str
    paper: str
    workbook: str
    differs_most: str

    def _parts(self):
        return zip(
            ("Question.", "The paper.", "This workbook.", "The number that differs most."),
            (self.question, self.paper, self.workbook, self.differs_most),
        )

    def markdown(self, width: int = 100) -> str:
        """Four paragraphs, each wrapped at ``width`` characters."""
        import textwrap

        return "\n\n".join(
            textwrap.fill(f"**{head}** {text}", width, break_on_hyphens=False)
            for head, text in self._parts()
        )

    def html(self) -> str:
        return "".join(f"<p><b>{head}</b> {html.escape(text)}</p>" for head, text in self._parts())


def study_answer(paper_bound="paper", physical_bound="paper_dv_physical") -> Answer | None:
    """The answer of the full-size campaigns: ``paper_bound`` (Table 3 as printed) and ``physical_bound`` (the
    Delta-V bound moved to the workbook's physics, :mod:`lnss_lib.studies.deltav_floor`); None without both."""
    import numpy as np

    printed, physical = _campaign(paper_bound), _campaign(physical_bound)
    if printed is None or physical is None:
        return None
    constraints = parse_constraints(printed.attrs["constraints"])
    dv_metric, dv_limit = deltav_constraint(printed)
    bounds = ", ".join(bound_text(*c) for c in constraints if c[0] != "n_sat")
    navigation = satisfies(printed, [c for c in constraints if c[0] not in NON_NAVIGATION_METRICS])
    cheapest = np.nanmin(printed[dv_metric].values[navigation]) if navigation.any() else math.nan
    target_pct, paper_dv = (
        SMALLEST_CONSTELLATION["availability_pct"],
        SMALLEST_CONSTELLATION["dv_below_kms_per_year"],
    )
    physical_metric, physical_limit = deltav_constraint(physical)
    feasible = satisfies(physical, parse_constraints(physical.attrs["constraints"]))
    i = smallest_constellation(physical, feasible, physical_metric, availability_min_pct=target_pct)
    if i is None:
        return None
    dv = float(physical[physical_metric].values[i])
    return Answer(
        question=(
            "What is the smallest constellation of lunar navigation satellites meeting the paper's Table 3 "
            f"bounds ({bounds}) at the lunar south pole?"
        ),
        paper=(
            f"As few as {SMALLEST_CONSTELLATION['n_sat']} satellites, over {target_pct:g} % availability, below "
            f"{paper_dv:g} km/s/yr; {FEASIBLE_DESIGNS:,} feasible designs in at most {EVALUATIONS:,} evaluations."
        ),
        workbook=(
            f"The geometry agrees and the cost does not. {int(physical['n_sat'].values[i])} satellites "
            f"({design_text(physical.isel(design=i))}) give {format_value('pdop_avail_pct', physical['pdop_avail_pct'].values[i])} % "
            f"PDOP and {format_value('hdop_avail_pct', physical['hdop_avail_pct'].values[i])} % HDOP availability; but none of the {_designs_evaluated(printed):,} designs of the full-size campaign "
            f"meets the {dv_limit:g} km/s/yr bound: the cheapest of the {int(navigation.sum()):,} meeting the "
            f"navigation bounds costs {format_value(dv_metric, cheapest)} km/s/yr. With the bound at "
            f"{physical_limit:g} km/s/yr (the paper's margin over the one design it prices, kept at the "
            f"workbook's physics), {int(feasible.sum()):,} of {_designs_evaluated(physical):,} designs are "
            "feasible."
        ),
        differs_most=(
            f"The station-keeping Delta-V of the smallest constellation over {target_pct:g} %: "
            f"{format_value(dv_metric, dv)} km/s/yr per satellite against the paper's below {paper_dv:g}, "
            f"{dv / paper_dv:.1f} times. The workbook prices the whole perturbing acceleration (a "
            "least-squares inverse of the Gauss equations); the paper's inverse solves them one at a time "
            "and caps its singular divisors, which sets its cost (notebook 04 shows both)."
        ),
    )


def campaign_findings(root: Path, profile_name: str, companion: str | None) -> list[Finding]:
    """Per campaign (this profile's and its companion's): designs meeting every Table 3 bound against the
    paper's count, and the smallest constellation meeting them with its Delta-V against the paper's size."""
    import numpy as np

    found = []
    for name in filter(None, (profile_name, companion)):
        kind = "paper-faithful" if name == profile_name else "operational"
        ds = _campaign(name)
        if ds is None:
            found.append(
                _missing(
                    f"Campaign ({kind}, {name})",
                    f"{FEASIBLE_DESIGNS} feasible",
                    "06",
                    f"the {name} campaign",
                )
            )
            continue
        constraints = parse_constraints(ds.attrs["constraints"])
        dv_metric, dv_limit = deltav_constraint(ds)
        feasible = satisfies(ds, constraints)
        navigation = satisfies(ds, [c for c in constraints if c[0] not in NON_NAVIGATION_METRICS])
        n = _designs_evaluated(ds)
        links = (
            _figure(root, "06_designs_pdop_dv")
            + _figure(root, "07_fig8_hdop_pdop_deltav")
            + _notebook(root, "06")
        )
        dv_values = ds[dv_metric].values[navigation]
        dv_values = dv_values[np.isfinite(dv_values)]
        lowest = (
            f"the lowest {label(dv_metric)} among them is {format_value(dv_metric, dv_values.min())} against "
            f"the bound of {dv_limit:g}"
            if dv_values.size
            else f"none of them has a {label(dv_metric)}"
        )
        why = (
            f"{int(navigation.sum())} of {n} designs meet the navigation bounds; {lowest}: the Delta-V and "
            "stability bounds decide feasibility."
            if not feasible.any()
            else f"a campaign of {ds.attrs.get('generations_done', '?')} generations finds fewer than the paper's "
            f"{EVALUATIONS} evaluations; the designs meeting every bound are in the Pareto figures."
        )
        found.append(
            Finding(
                f"Designs meeting Table 3 ({kind}, {name})",
                f"{FEASIBLE_DESIGNS} of at most {EVALUATIONS} evaluations",
                f"{int(feasible.sum())} of {n} unique designs",
                why,
                links,
            )
        )
        target_pct = SMALLEST_CONSTELLATION["availability_pct"]
        pick = (
            feasible
            if feasible.any()
            else satisfies(ds, [c for c in constraints if c[0] != dv_metric])
        )
        if "impact" in ds:
            pick &= ~ds["impact"].values.astype(bool)
        i = smallest_constellation(ds, pick, dv_metric, availability_min_pct=target_pct)
        rule = (
            f"the fewest satellites with PDOP and HDOP availability >= {target_pct:g} %, ties: the lowest "
            f"{label(dv_metric)} (the rule of Table 6's first row and Figure 16)"
        )
        if i is not None:
            ours = (
                f"{int(ds['n_sat'].values[i])} satellites, {label(dv_metric)} "
                f"{format_value(dv_metric, ds[dv_metric].values[i])} ({design_text(ds.isel(design=i))})"
            )
            why = (
                (
                    f"meets every Table 3 bound; {rule}"
                    if feasible.any()
                    else f"no design meets every bound: among those meeting every bound but the Delta-V's, {rule}"
                )
                + (
                    "; the paper's Delta-V comes from its capped singular inverse (notebook 04)"
                    if dv_metric == "dv_total_kms_per_year"
                    else f"; the Delta-V bound applies to the {label(dv_metric)}, the campaign's estimate of what an operator "
                    "would fly (flown in closed loop: the headline row, when the front was validated)"
                )
                + "."
            )
        else:
            ours, why = "none", f"no design of this campaign qualifies for {rule}."
        found.append(
            Finding(
                f"Smallest constellation ({kind}, {name})",
                f"{SMALL_CONSTELLATION_SATS[0]}-{SMALL_CONSTELLATION_SATS[1]} satellites within the bounds",
                ours,
                why,
                _figure(root, "07_table6") + _notebook(root, "07"),
            )
        )
    return found


def design_life_findings(root: Path) -> list[Finding]:
    """The designs of notebook 08's validation flown over the design life (``08_validation.csv``), per region: how
    many keep every satellite within the paper's bound (the rule of
    :func:`lnss_lib.studies.design_life.region_summary`), how many keep every satellite at all, and what the
    controller burned, which is not the eq. 45 Delta-V of Table 4 and the campaigns."""
    path = root / "tables" / "08_validation.csv"
    bound = TABLE_6["dv_total_max_kms_per_year"]
    if not path.is_file():
        return [
            _missing(
                "Design life",
                f"Delta-V <= {bound:g} km/s/yr per satellite",
                "08",
                "the design-life validation",
            )
        ]
    rows = _read_csv(path)
    found = []
    for region in dict.fromkeys(r.get("region", "") for r in rows):
        chosen = [r for r in rows if r.get("region", "") == region]
        lost = [r for r in chosen if math.isfinite(_number(r.get("impact_day")))]
        within = [
            r for r in chosen if r not in lost and _number(r.get("sk_dv_max_kms_per_year")) <= bound
        ]
        dv = sorted(
            {
                format_value("sk_dv_kms_per_year", v)
                for v in (_number(r.get("sk_dv_kms_per_year")) for r in chosen)
                if math.isfinite(v)
            },
            key=float,
        )
        days = max(_number(r.get("life_days")) for r in chosen)
        ours = (
            f"{len(within)} of {len(chosen)} within {bound:g} km/s/yr on every satellite, none lost; "
            f"{len(chosen) - len(lost)} of {len(chosen)} keep every satellite over {days:.0f} days"
            + (
                f"; the controller burned {dv[0]}"
                + (f" to {dv[-1]}" if len(dv) > 1 else "")
                + " km/s/yr per satellite"
                if dv
                else ""
            )
        )
        why = (
            "flown in closed loop with the full force model over the design life, where the paper judges a "
            "10-day arc; the closed-loop cost is what the controller burns to hold the constellation, not the "
            "paper's eq. 45 Delta-V (Table 4, the campaigns)"
            + (
                f"; lost on day {', '.join(format(_number(r['impact_day']), '.0f') for r in lost)}"
                if lost
                else ""
            )
        )
        found.append(
            Finding(
                f"Design life: {region} ({len(chosen)} designs flown in closed loop)",
                f"Delta-V <= {bound:g} km/s/yr per satellite (Table 3, judged on a 10-day arc)",
                ours,
                why,
                _figure(root, "08_estimate_vs_closed_loop") + _notebook(root, "08"),
            )
        )
    return found


def headline_findings(root: Path) -> list[Finding]:
    """The paper's headline answered from designs flown in closed loop (``07_headline_validated.csv``, written when
    the operational front was validated: :mod:`lnss_lib.studies.front_validation`); none when there is no such table."""
    path = root / "tables" / "07_headline_validated.csv"
    if not path.is_file():
        return []
    rows = {r.get("row", ""): r for r in _read_csv(path)}
    smallest = rows.get("smallest", {})
    flown, failed = _number(smallest.get("flown")), _number(smallest.get("failed or error"))
    paper = (
        f"{SMALLEST_CONSTELLATION['n_sat']} satellites, over {SMALLEST_CONSTELLATION['availability_pct']:g} % "
        f"availability, below {SMALLEST_CONSTELLATION['dv_below_kms_per_year']:g} km/s/yr"
    )
    if smallest.get("result") == "validated":
        ours = (
            f"{int(_number(smallest['n_sat']))} satellites, "
            f"{format_value('pdop_avail_pct_life', _number(smallest['pdop_avail_pct_life']))} % over the life, "
            f"{format_value('closed_loop_dv_max_kms_per_year', _number(smallest['closed_loop_dv_max_kms_per_year']))}"
            f" km/s/yr worst satellite ({design_text(smallest)})"
        )
    else:
        ours = "no validated design meets both"
    sizes = ", ".join(
        f"{name.split()[0]}: "
        + (
            format_value(
                "closed_loop_dv_max_kms_per_year", _number(r["closed_loop_dv_max_kms_per_year"])
            )
            if r.get("result") == "validated"
            else "none"
        )
        for name, r in rows.items()
        if name.endswith("satellites")
    )
    why = (
        f"flown in closed loop over the design life with the service controller, every satellite "
        f"({flown:.0f} designs flown, {failed:.0f} lost a satellite or failed); worst-satellite km/s/yr by size: "
        f"{sizes}."
    )
    return [
        Finding(
            "The paper's headline, flown in closed loop (operational)",
            paper,
            ours,
            why,
            _figure(root, "07_headline_validated") + _notebook(root, "07"),
        )
    ]


DELTAV_TABLE = "07_deltav_vs_closed_loop"  # notebook 07: the eq. 45 Delta-V and the closed loop of the designs flown


def _span(values) -> str:
    """``"a to b"`` (or ``"a"``) of the finite values in the format of closed-loop Delta-V, ``"-"`` when none."""
    finite = sorted(v for v in values if math.isfinite(v))
    if not finite:
        return "-"
    low, high = (format_value("dv_total_kms_per_year", v) for v in (finite[0], finite[-1]))
    return low if low == high else f"{low} to {high}"


def deltav_findings(root: Path) -> list[Finding]:
    """The paper's eq. 45 Delta-V and the closed-loop cost of the same designs: the designs of the front flown in
    closed loop (notebook 07's ``07_deltav_vs_closed_loop``) and the Table 4 ELFO (eq. 45 from notebook 05's
    ``05_table4``, closed loop from notebook 08's ``08_validation``); none when neither pair is in the run."""
    parts, links = [], ()
    table = root / "tables" / f"{DELTAV_TABLE}.csv"
    if table.is_file():
        rows = [r for r in _read_csv(table) if r.get("status") == "kept"]
        if rows:
            parts.append(
                f"{len(rows)} designs of the operational front flown: eq. 45 total "
                f"{_span(_number(r['dv_total_kms_per_year']) for r in rows)}, closed loop "
                f"{_span(_number(r['closed_loop_dv_kms_per_year']) for r in rows)} (worst satellite "
                f"{_span(_number(r['closed_loop_dv_max_kms_per_year']) for r in rows)})"
            )
            links += _notebook(root, "07")
    table4, life = root / "tables" / "05_table4.csv", root / "tables" / "08_validation.csv"
    if table4.is_file() and life.is_file():
        eq45 = dict(zip(TABLE_4, _read_csv(table4))).get("dv_total_kms_per_year", {})
        elfo = [r for r in _read_csv(life) if r.get("region") == "standalone ELFO"]
        if eq45 and elfo:
            parts.append(
                f"the Table 4 ELFO: eq. 45 total {_span([_number(eq45.get('this workbook'))])}, closed loop "
                f"{_span([_number(elfo[0].get('sk_dv_kms_per_year'))])} ({elfo[0].get('element_frame', '')})"
            )
            links += _figure(root, "05_fig6_thrust") + _notebook(root, "08")
    if not parts:
        return []
    return [
        Finding(
            "Station-keeping Delta-V: the paper's eq. 45 model and the closed loop, same designs (km/s/yr per "
            "satellite)",
            f"eq. 45 only: {TABLE_4['dv_total_kms_per_year']:g} for the Table 4 ELFO, below "
            f"{SMALLEST_CONSTELLATION['dv_below_kms_per_year']:g} for its best designs; nothing flown",
            "; ".join(parts),
            "two different quantities: eq. 45 integrates the whole perturbing acceleration over a 10-day arc "
            "(what cancelling every perturbation would cost), the closed loop burns only what keeps each orbit and "
            "the service within their tolerances over the design life.",
            links,
        )
    ]


def published_findings(root: Path) -> list[Finding]:
    """The published constellations measured on one yardstick (``10_published_comparison.csv``)."""
    path = root / "tables" / "10_published_comparison.csv"
    if not path.is_file():
        return [
            _missing(
                "Published constellations", "published figures", "10", "the published comparison"
            )
        ]
    found = []
    for row in _read_csv(path):
        ours = _number(row.get("ours"))
        if not row.get("published figure", "").endswith("availability_pct") or not math.isfinite(
            ours
        ):
            continue
        mask = (
            row["published figure"]
            .split(".")[0]
            .replace("elevation_mask_", "")
            .replace("deg", " deg mask")
        )
        found.append(
            Finding(
                f"{row.get('constellation', '')}: availability ({mask}, %)",
                format_value("pdop_avail_pct", _number(row.get("published"))),
                format_value("pdop_avail_pct", ours),
                row.get("why they differ", ""),
                _figure(root, "10_benchmark_scatter") + _notebook(root, "10"),
            )
        )
    return found


def collect(profile_name: str, companion: str | None = None) -> list[Finding]:
    """Every finding of the run under ``outputs/<profile>/``, in reading order."""
    root = profile_dir(profile_name)
    return (
        table4_findings(root)
        + campaign_findings(root, profile_name, companion)
        + headline_findings(root)
        + deltav_findings(root)
        + design_life_findings(root)
        + published_findings(root)
    )


def _run_line(summary: dict) -> str:
    failed = [name for name, status in summary["notebooks"].items() if status != "ok"]
    return (
        f"profile {summary['profile']}, commit {summary['git_revision']}, written {summary['written_utc']}, "
        f"{len(summary['notebooks'])} notebook(s) in {summary['wall_s']:.0f} s"
        + (f"; failed: {', '.join(failed)}" if failed else "")
    )


def _headline_figure(profile_name: str) -> str | None:
    """The first of :data:`HEADLINE_FIGURES` the run drew as PNG, or None."""
    figures = profile_dir(profile_name) / "figures"
    return next((stem for stem in HEADLINE_FIGURES if (figures / f"{stem}.png").is_file()), None)


def findings_markdown(profile_name: str, findings: list[Finding]) -> str:
    """``FINDINGS.md``: the run, then one table row per finding with its links (relative to the file)."""

    def cell(text: str) -> str:
        return " ".join(str(text).split()).replace("|", "\\|")

    answer, headline = study_answer(), _headline_figure(profile_name)
    lines = [f"# Findings: profile {profile_name}", ""]
    if answer is not None:
        lines += [answer.markdown(), "", f"From the full-size campaigns ({ANSWER_SOURCE}).", ""]
    if headline is not None:
        lines += [f"![{headline}](figures/{headline}.png)", ""]
    lines += [
        f"Run: {_run_line(run_summary(profile_name))}.",
        "",
        "Generated from this run's outputs and the shipped results; the paper's values from "
        "`lnss_lib/paper.py`.",
        "",
        "| result | paper | this workbook | why they differ | shown in |",
        "|---|---|---|---|---|",
    ]
    for f in findings:
        links = ", ".join(
            f"[{text}]({'index.html' + href if href.startswith('#') else href})"
            for text, href in f.links
        )
        lines.append(
            f"| {cell(f.topic)} | {cell(f.paper)} | {cell(f.workbook)} | {cell(f.why)} | {links} |"
        )
    return "\n".join(lines) + "\n"


def findings_html(profile_name: str, findings: list[Finding]) -> str:
    """The findings section that opens ``index.html`` (``id="findings"``)."""

    def links(finding: Finding) -> str:
        return " ".join(
            f'<a href="{html.escape(href)}">{html.escape(text)}</a>' for text, href in finding.links
        )

    rows = "".join(
        f"<tr><td class='text'>{html.escape(f.topic)}</td><td class='text'>{html.escape(f.paper)}</td>"
        f"<td class='text'><b>{html.escape(f.workbook)}</b></td><td class='text why'>{html.escape(f.why)}</td>"
        f"<td class='text'>{links(f)}</td></tr>"
        for f in findings
    )
    answer, headline = study_answer(), _headline_figure(profile_name)
    opening = (
        ""
        if answer is None
        else f'<section id="answer"><h2>The answer</h2>{answer.html()}'
        f"<p class='files'>From the full-size campaigns ({html.escape(ANSWER_SOURCE)}).</p>"
        + (
            ""
            if headline is None
            else f'<a href="figures/{headline}.html"><img class="headline" src="figures/{headline}.png" '
            f'alt="{html.escape(headline)}"></a>'
        )
        + "</section>"
    )
    return opening + (
        f'<section id="findings"><h2>Findings</h2><p>Run: {html.escape(_run_line(run_summary(profile_name)))}. '
        f"Generated from this run's outputs beside the paper's values (<a href=\"{FINDINGS_FILE}\">{FINDINGS_FILE}</a>).</p>"
        "<table class='findings'><tr><th>result</th><th>paper</th><th>this workbook</th><th>why they differ</th>"
        f"<th>shown in</th></tr>{rows}</table></section>"
    )


def write_findings(profile_name: str, companion: str | None = None) -> tuple[Path, str]:
    """Write ``outputs/<profile>/FINDINGS.md``; return its path and the HTML section for the index."""
    from .atomicio import write_text_atomic

    findings = collect(profile_name, companion)
    path = write_text_atomic(
        profile_dir(profile_name) / FINDINGS_FILE, findings_markdown(profile_name, findings)
    )
    return path, findings_html(profile_name, findings)
