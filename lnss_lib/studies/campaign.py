"""Notebook 06: the NSGA-II campaign of Section 5 (Tables 3 and 5) and what it costs.

Question: does a pymoo NSGA-II on the eq. 43-44 grid, with Table 5's settings, find feasible
Walker designs under Table 3's bounds, and what would the paper's 120 x 1000 campaign cost on
this machine?

Verdict: the campaign machinery is the paper's (Table 5's population, generations, crossover
fraction and a fixed seed; the operator differences are listed in :func:`settings_table`), and
feasibility is decided by Table 3's Delta-V bound: with the least-squares GVE station-keeping
model the evaluated designs need several km/s per satellite per year, above the bound, while many
meet the navigation bounds, so the paper's count of feasible designs (which rests on its Delta-V
values) is not reproduced and the difference is reported rather than the bound loosened. The
paper's 120 x 1000 campaign takes hours on two cores, dominated by propagation.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import xarray as xr

from ..campaign import (
    CampaignPlan,
    CellProgressBar,
    campaign_timing,
    concurrent_workers,
    export_results,
    load_run,
    read_cache_records,
    run_campaign,
)
from ..campaign.fitness import ALL_BOUNDS, bound_masks
from ..campaign.rundir import CHECKPOINT_FILE
from ..keys import NON_NAVIGATION_METRICS
from ..paper import EVALUATIONS, FEASIBLE_DESIGNS, TABLE_5
from ..settings import Settings

__all__ = [
    "settings_table",
    "design_grid_table",
    "latest_run_dir",
    "CampaignRun",
    "load_or_run",
    "shipped_reference",
    "shown_campaign",
    "campaign_source",
    "validated_of",
    "designs_evaluated",
    "designs_shown",
    "feasible_designs",
    "constraint_table",
    "steady_designs_per_s",
    "throughput_table",
    "run_throughput_table",
    "companion_of",
    "comparison_table",
    "NON_NAVIGATION_METRICS",
]


def settings_table(settings: CampaignPlan):
    """Table 5 (NSGA-II settings of the paper) next to this profile's pymoo counterparts, with notes."""
    s = settings
    return pd.DataFrame(
        [
            ("Population size", TABLE_5["population"], s.population, "same"),
            (
                "No. of generations",
                TABLE_5["generations"],
                s.generations,
                "generation 1 is the initial population",
            ),
            (
                "Total evaluations",
                TABLE_5["total_evaluations"],
                s.population * s.generations,
                "upper bound; duplicates are evaluated once (cache)",
            ),
            (
                "Crossover fraction",
                TABLE_5["crossover_fraction"],
                s.crossover_prob,
                f"SBX (eta {s.crossover_eta:g}) applied to a mating pair "
                "with this probability, rounded to the grid",
            ),
            (
                "Mutation function",
                "adaptive",
                f"polynomial, eta {s.mutation_eta:g}",
                "rounded to the integer grid; per-variable probability "
                + (f"{s.mutation_prob_var:g}" if s.mutation_prob_var else "1/6"),
            ),
            (
                "Pareto fraction",
                TABLE_5["pareto_fraction"],
                "-",
                "no counterpart in pymoo: rank-and-crowding survival keeps the whole first fronts",
            ),
            (
                "Function tolerance",
                TABLE_5["function_tolerance"],
                s.ftol if s.ftol else "off",
                f"pymoo objective-space tolerance over {s.ftol_period} generations"
                if s.ftol
                else "fixed generations",
            ),
            ("Seed", "fixed", s.seed, "same seed, same run (also after kill and resume)"),
        ],
        columns=["parameter", "paper", "this profile", "note"],
    ).set_index("parameter")


def design_grid_table(settings: CampaignPlan):
    """Table 3 design-variable bounds with the eq. 43-44 step sizes and the number of grid values."""
    grid = settings.grid
    return pd.DataFrame(
        {"lower": grid.lower, "upper": grid.upper, "step": grid.step, "levels": grid.n_levels + 1},
        index=pd.Index(["a (km)", "e", "AOP (deg)", "i (deg)", "Np", "Ns"], name="variable"),
    )


def _runs(campaign_dir) -> list[Path]:
    """The ``run_*`` folders with a checkpoint under ``campaign_dir``, oldest first."""
    return sorted(p for p in Path(campaign_dir).glob("run_*") if (p / CHECKPOINT_FILE).is_file())


def latest_run_dir(
    campaign_dir, profile_name: str, settings: Settings | None = None
) -> tuple[Path, list[str]]:
    """The run to show for ``settings`` (default: profile ``profile_name`` as it stands) and why it is not that
    profile's campaign ([] when it is): the newest ``run_*`` directory with a checkpoint under
    ``campaign_dir`` whose settings are the profile's, else the newest one. FileNotFoundError naming the
    command that makes one when there is none."""
    from ..campaign.publication import run_differences
    from ..settings import load_settings

    runs = _runs(campaign_dir)
    if not runs:
        raise FileNotFoundError(
            f"no campaign in {campaign_dir}. Run it first (hours on 2 cores for paper, checkpointed every "
            f"generation):\n    python -m lnss_lib campaign --profile {profile_name}\n"
            "continue an interrupted run with --resume <run dir>, or use a Dask cluster with "
            "--scheduler-address tcp://HOST:8786; then execute the notebook again"
        )
    settings = settings if settings is not None else load_settings(profile_name)
    reasons = {run: run_differences(load_run(run)["profile"], settings) for run in runs}
    matching = [run for run in runs if not reasons[run]]
    run = matching[-1] if matching else runs[-1]
    return run, reasons[run]


def companion_of(profile_name: str) -> str:
    """The profile's ``campaign.companion_profile`` ("" when none), checked to load and to name no companion itself."""
    from ..settings import load_settings

    companion = load_settings(profile_name).campaign.companion_profile
    if companion and load_settings(companion).campaign.companion_profile:
        raise ValueError(
            f"profile {profile_name!r}: its companion {companion!r} names a companion itself; "
            "companions are one level deep"
        )
    return companion


@dataclass(frozen=True)
class CampaignRun:
    """The campaign a notebook shows: the run, its own settings (from ``run.json``), why it is shown (``note``),
    its datasets (:func:`~lnss_lib.campaign.rundir.export_results`) and journal records."""

    run_dir: Path
    settings: Settings
    note: str
    evaluations: xr.Dataset
    front: xr.Dataset
    history: xr.Dataset
    records: list[dict]
    validated: xr.Dataset | None = (
        None  # the front flown in closed loop (validated.nc), when the run has one
    )


def validated_of(run_dir: Path) -> xr.Dataset | None:
    """The run's ``validated.nc`` (:mod:`lnss_lib.campaign.validation`), or None when it has none."""
    from ..campaign.validation import VALIDATED_FILE

    path = Path(run_dir) / VALIDATED_FILE
    return xr.load_dataset(path, engine="h5netcdf") if path.is_file() else None


def load_or_run(profile_name: str, overrides: dict | str | None = None) -> CampaignRun:
    """The campaign of ``profile_name`` with ``overrides`` (what ``reproduce --set`` passes).

    With ``campaign.notebook_mode = "run"`` (``quick``, ``ci`` and their companions) the campaign runs
    here (:func:`run_campaign`); with ``"load"`` (``paper``, ``operational``) the run in
    ``outputs/<profile>/campaign/`` chosen by :func:`latest_run_dir` is shown, read from its journal and
    last checkpoint (so a run still going is covered), unless no run there is the profile's and the shipped
    reference results are (:func:`shipped_reference`): then those are shown, and nothing is run. Either way the run is published
    (:mod:`lnss_lib.campaign.publication`) only when its settings are the profile's, and ``note`` says
    which run is shown and, when it is not the profile's campaign, why.
    """
    from ..campaign.publication import publish_run, run_differences
    from ..outputs import display_path, output_dir
    from ..settings import load_settings, settings_from_profile

    profile = load_settings(profile_name, overrides=overrides)
    campaign_dir = output_dir(profile_name, "campaign")
    if profile.campaign.notebook_mode == "load":
        shipped = shipped_reference(profile_name, profile, campaign_dir)
        if shipped is not None:
            return shipped
        run_dir, reasons = latest_run_dir(campaign_dir, profile_name, profile)
        how = f"loaded {display_path(run_dir)}"
    else:
        result = run_campaign(
            profile_name, overrides=overrides, progress=False, callbacks=[CellProgressBar()]
        )
        run_dir = result.run_dir
        how = (
            f"ran {display_path(run_dir)}: {result.generations} generations, {result.n_evaluations} unique designs in "
            f"{result.session_wall_s:.1f} s"
        )
        reasons = run_differences(load_run(run_dir)["profile"], profile)
    run_settings = settings_from_profile(load_run(run_dir)["profile"])
    datasets = export_results(run_dir)
    own = run_differences(run_settings, load_settings(profile_name))
    if reasons:
        note = (
            f"{how}; it is NOT the campaign of profile {profile_name!r} as set here (no run in {campaign_dir} "
            f"is): {'; '.join(reasons)}. Everything below is that run's, with its own settings"
        )
    elif own:
        note = (
            f"{how}: profile {profile_name!r} with the --set overrides, not published as the campaign of the "
            f"profile ({'; '.join(own)})"
        )
    else:
        note = f"{how}: the campaign of profile {profile_name!r}, published ({display_path(publish_run(run_dir, campaign_dir, datasets))})"
    return CampaignRun(
        run_dir, run_settings, note, *datasets, read_cache_records(run_dir), validated_of(run_dir)
    )


def _reference_run(reference, how: str) -> CampaignRun:
    """A :class:`CampaignRun` of shipped reference results (no journal records: their ``run_dir`` is the folder)."""
    from ..outputs import display_path
    from ..settings import settings_from_profile

    attrs = reference.history.attrs
    state = (
        f"a complete run of {attrs['generations_done']} generations"
        if reference.finished
        else f"a PARTIAL run: {attrs['generations_done']} generations, exported before it finished"
    )
    note = (
        f"{how}; shown: the shipped reference results {display_path(reference.folder)} ({state}; profile hash "
        f"{attrs['profile_hash']}, exported at commit {attrs['export_commit']}; of its "
        f"{reference.evaluations.attrs['n_designs_evaluated']} designs it ships those Figures 8-16 and Table 6 read, "
        f"{reference.evaluations.attrs['selection']}: {reference.evaluations.attrs['n_kept']} kept of "
        f"{reference.evaluations.attrs['n_selected']})"
    )
    return CampaignRun(
        reference.folder,
        settings_from_profile(reference.profile),
        note,
        reference.evaluations,
        reference.front,
        reference.history,
        [],
    )


def shipped_reference(profile_name: str, settings: Settings, campaign_dir) -> CampaignRun | None:
    """The shipped reference results of ``profile_name`` (:func:`~lnss_lib.campaign.reference.load_reference`)
    as a :class:`CampaignRun`, when no run in ``campaign_dir`` has the settings ``profile`` and the reference
    has them (the publication rule: :func:`~lnss_lib.campaign.publication.run_differences` empty); None
    otherwise. FileNotFoundError when there is no run at all and the reference is not the profile's (stale)."""
    from ..campaign.publication import run_differences
    from ..campaign.reference import load_reference
    from ..outputs import display_path

    runs = _runs(campaign_dir)
    if any(not run_differences(load_run(run)["profile"], settings) for run in runs):
        return None
    reference = load_reference(profile_name)
    if reference is None:
        return None
    reasons = run_differences(reference.profile, settings)
    if reasons and not runs:
        raise FileNotFoundError(
            f"no campaign in {campaign_dir}, and the shipped results {display_path(reference.folder)} are not the "
            f"campaign of profile {profile_name!r} as set here: {'; '.join(reasons)}. Run it:\n    python -m "
            f"lnss_lib campaign --profile {profile_name}\nthen export it: python -m lnss_lib campaign "
            f"--export-reference RUN_DIR"
        )
    if reasons:
        return None
    return _reference_run(
        reference,
        f"no run in {display_path(campaign_dir)} is the campaign of profile {profile_name!r}",
    )


def shown_campaign(profile_name: str) -> CampaignRun:
    """The campaign notebook 07 reads for ``profile_name``: the one published as the profile's
    (:mod:`lnss_lib.campaign.publication`, which notebook 06 writes) when its profile hash is the profile's, else the
    shipped reference results when they are the profile's, else the publication as it is. FileNotFoundError
    naming the command that makes one when there is neither."""
    from ..campaign.publication import load_published, run_differences
    from ..campaign.reference import load_reference
    from ..outputs import display_path, output_dir
    from ..settings import load_settings, settings_from_profile

    folder = output_dir(profile_name, "campaign")
    published, reference = load_published(folder), load_reference(profile_name)
    profile = load_settings(profile_name) if reference is not None else None
    if (
        reference is not None
        and (published is None or published.pointer["profile_hash"] != profile.hash)
        and not run_differences(reference.profile, profile)
    ):
        why = (
            "nothing is published"
            if published is None
            else f"the run published in {display_path(folder)} is not the profile's"
        )
        return _reference_run(reference, f"{why} for profile {profile_name!r}")
    if published is None:
        raise FileNotFoundError(
            f"no campaign published for profile {profile_name!r} (no published.json in {folder}) and no shipped "
            f"reference results; run: python -m lnss_lib campaign --profile {profile_name}"
        )
    run_settings = settings_from_profile(json.loads(published.evaluations.attrs["parameters"]))
    note = f"the campaign published for profile {profile_name!r}: {display_path(published.folder)} ({published.pointer['run_dir']})"
    return CampaignRun(
        published.folder,
        run_settings,
        note,
        published.evaluations,
        published.front,
        published.history,
        [],
        published.validated,
    )


def campaign_source(profile_name: str, overrides: dict | None = None) -> str:
    """Where notebook 06 takes the campaign of ``profile_name`` from, in one line ("" when it runs the campaign
    itself): the shipped reference results (:func:`shipped_reference`), or the local run :func:`latest_run_dir`
    picks and why it is not the profile's; what is missing when there is neither."""
    from ..outputs import display_path, output_dir
    from ..settings import load_settings

    profile = load_settings(profile_name, overrides=overrides)
    if profile.campaign.notebook_mode != "load":
        return ""
    campaign_dir = output_dir(profile_name, "campaign")
    try:
        shipped = shipped_reference(profile_name, profile, campaign_dir)
        if shipped is not None:
            return shipped.note
        run_dir, reasons = latest_run_dir(campaign_dir, profile_name, profile)
    except FileNotFoundError as error:
        return " ".join(str(error).split())
    return f"the local run {display_path(run_dir)}, " + (
        f"NOT the campaign of profile {profile_name!r}: {'; '.join(reasons)}"
        if reasons
        else "the profile's campaign"
    )


def designs_evaluated(evaluations: xr.Dataset) -> int:
    """Unique designs the campaign evaluated: the rows of ``evaluations``, or, for thinned reference results,
    the count over every design (attribute ``n_designs_evaluated``)."""
    return int(evaluations.attrs.get("n_designs_evaluated", evaluations.sizes["design"]))


def designs_shown(evaluations: xr.Dataset) -> str:
    """Which designs ``evaluations`` holds, in words: every unique design the run evaluated, or, for shipped
    reference results, the thinned set Figures 8-16 and Table 6 read (attributes ``selection``, ``n_kept``)."""
    total = designs_evaluated(evaluations)
    if "n_kept" not in evaluations.attrs:
        return f"every unique design the run evaluated ({total})"
    return (
        f"{int(evaluations.attrs['n_kept'])} of the {total} unique designs the run evaluated: the shipped "
        f"results keep those Figures 8-16 and Table 6 read ({evaluations.attrs['selection']})"
    )


def feasible_designs(evaluations: xr.Dataset) -> int:
    """Unique feasible designs: counted over ``evaluations``, or, for thinned reference results, over every design
    evaluated (attribute ``designs_meeting_bounds``)."""
    if "designs_meeting_bounds" in evaluations.attrs:
        return int(json.loads(evaluations.attrs["designs_meeting_bounds"])[ALL_BOUNDS])
    return int(evaluations["feasible"].sum())


def constraint_table(evaluations: xr.Dataset, constraints):
    """Designs meeting each campaign bound (Table 3) separately, with count and share of all designs.

    Rows: the masks of :func:`~lnss_lib.campaign.fitness.bound_masks` (evaluated without impact, each
    (metric, kind, limit) of ``constraints``, navigation bounds only, feasible). Shipped reference results
    (:mod:`lnss_lib.campaign.reference`) hold a thinned set of designs: their counts over every design
    evaluated are read from the attribute ``designs_meeting_bounds``.
    """
    if "designs_meeting_bounds" in evaluations.attrs:
        counts = json.loads(evaluations.attrs["designs_meeting_bounds"])
        n = int(evaluations.attrs["n_designs_evaluated"])
    else:
        counts = {k: int(v.sum()) for k, v in bound_masks(evaluations, constraints).items()}
        n = evaluations.sizes["design"]
    table = pd.DataFrame(
        {"designs": counts, "share (%)": {k: 100.0 * v / max(n, 1) for k, v in counts.items()}}
    )
    table.index.name = "bound"
    return table


def comparison_table(campaigns: dict) -> pd.DataFrame:
    """Campaigns side by side: ``{name: (evaluations, constraints)}`` -> designs meeting each bound
    (:func:`constraint_table` of each; <NA> where a campaign has no such bound), after the number of
    unique designs evaluated; the bounds in order of first appearance, the summary rows last."""
    columns = {}
    for name, (evaluations, constraints) in campaigns.items():
        designs = constraint_table(evaluations, constraints)["designs"]
        total = pd.Series({"unique designs evaluated": designs_evaluated(evaluations)})
        columns[name] = pd.concat([total, designs])
    rows = list(dict.fromkeys(row for series in columns.values() for row in series.index))
    last = [row for row in rows if row.startswith(("navigation bounds only", "all Table 3 bounds"))]
    rows = [row for row in rows if row not in last] + last
    table = pd.DataFrame({name: series.reindex(rows) for name, series in columns.items()}).astype(
        "Int64"
    )
    table.index.name = "designs meeting"
    return table


def steady_designs_per_s(history: xr.Dataset, n_evaluations: int) -> float:
    """Designs evaluated per second of generation wall time from generation 2 on (generation 1 holds the
    worker warm-up); the overall rate when the run has one generation."""
    later = history.where(history.generation > 1, drop=True)
    if later.sizes["generation"]:
        return float(later.n_evaluated.sum() / later.wall_s.sum())
    return n_evaluations / float(history.wall_s.sum())


def throughput_table(history: xr.Dataset, n_feasible: int, timing: dict, workers: int):
    """Campaign counts, throughput and worker-time shares, with the projection of the paper's
    120 x 1000 campaign at the steady rate: with no cache hits, and with this run's share of hits (a
    converging search repeats designs, which the journal answers without evaluating).

    ``timing`` is :func:`lnss_lib.campaign.timing.campaign_timing` of the run (keys n_evaluations,
    worker_budget_s, propagation_s, metrics_s, in_task_overhead_s, campaign_overhead_s); wall time
    is the sum of ``history.wall_s`` (generations only).
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1; got {workers!r}")
    wall = float(history.wall_s.sum())
    steady = steady_designs_per_s(history, timing["n_evaluations"])
    budget = timing["worker_budget_s"]
    hits = float(history.n_cache_hits.sum() / history.n_designs.sum())
    return pd.DataFrame(
        {
            "value": [
                timing["n_evaluations"],
                n_feasible,
                FEASIBLE_DESIGNS,
                wall,
                timing["n_evaluations"] / wall,
                steady,
                workers,
                100 * timing["propagation_s"] / budget,
                100 * timing["metrics_s"] / budget,
                100 * timing["in_task_overhead_s"] / budget,
                100 * timing["campaign_overhead_s"] / budget,
                100 * hits,
                EVALUATIONS / steady / 3600.0,
                (1.0 - hits) * EVALUATIONS / steady / 3600.0,
            ]
        },
        index=pd.Index(
            [
                "unique designs evaluated",
                "unique feasible designs",
                "unique feasible designs (paper)",
                "campaign wall time (s, generations)",
                "designs per second (overall)",
                "designs per second (generation 2 on)",
                "worker processes",
                "propagation (% of worker time)",
                "DOP, Delta-V, GPS (% of worker time)",
                "in-task overhead (%)",
                "campaign overhead (%)",
                "cache hits (% of requested designs)",
                "projected 120 x 1000 campaign at this profile's fidelity (h, this machine)",
                "... with this run's cache hits (h)",
            ],
            name="quantity",
        ),
    )


def run_throughput_table(
    run_dir, history: xr.Dataset, evaluations: xr.Dataset, records: list[dict]
):
    """:func:`throughput_table` of a run directory: worker processes counted from the cache records,
    time shares from :func:`lnss_lib.campaign.timing.campaign_timing`; for shipped reference results (no
    journal) both as the export recorded them (``history.attrs``: ``workers``, ``worker_time``)."""
    if "worker_time" in history.attrs:
        workers, timing = int(history.attrs["workers"]), json.loads(history.attrs["worker_time"])
    else:
        workers = concurrent_workers(records)
        timing = campaign_timing(run_dir, workers, float(history.wall_s.sum()))
    return throughput_table(history, feasible_designs(evaluations), timing, workers)
