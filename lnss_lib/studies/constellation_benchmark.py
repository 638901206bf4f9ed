"""Notebook 10: every published lunar navigation constellation on one yardstick.

Question: measured the same way (the eq. 45 metrics over the paper's south-pole grid and the study's
epoch span, at the paper's 5 deg elevation mask and at Bhamidipati et al.'s 20 deg, with the
design-life stability screen and the geometry-keeping station-keeping estimate), how do the
catalogue constellations (``params/constellations/``), the paper's Table 4 ELFO and the campaign's
best designs compare; where a study published performance figures, how far are ours from them and
why (:mod:`lnss_lib.studies.published_figures`); what position error in metres does each give a user (the
profile's ``[navigation_error]`` budget); and how much does the study epoch (2025-05-01) matter across the
Moon's 18.6-year nodal cycle?

Verdict: the Table 4 ELFO and Bhamidipati's case C (the same ELFO with its elements in the Moon's
orbital-plane frame) give near-complete south-pole availability at 5 deg; cases A and B and the
cislunar-nav designs fall short, and the three-satellite and single-satellite entries never give a
four-satellite fix over the grid. The 20 deg mask lowers every availability, the sparse designs'
most. The cislunar-nav designs, read in J2000 axes at the study epoch, fail the year-long stability
screen. The published figures are not reproduced one for one (the verdict of
:mod:`lnss_lib.studies.published_figures`, which compares them). Across the nodal
cycle the availabilities and visible counts barely move, the filtered mean DOPs move where a geometry has near-degenerate windows, and the year-long perilune
history and the station-keeping estimate move most: the 2025-05-01 epoch matters for the design life,
hardly for the navigation geometry. The notebook prints the numbers.

Design-life metrics come from the campaign-grade estimate (:mod:`lnss_lib.design_life.estimate`) and the
stability screen (:mod:`lnss_lib.design_life.screen`); :func:`add_closed_loop_life` adds the closed-loop
metrics of :mod:`lnss_lib.design_life.evaluation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..catalogue import (
    FILE_FRAMES,
    analyse_catalogue,
    constellation_states_mci,
    list_catalogue,
    load_constellation,
)
from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..constellation import WalkerDesign, standalone_elfo
from ..design_life.estimate import sk_estimate_from_propagation
from ..design_life.screen import screen_states
from ..dop import dop_for_settings, summary_for_settings
from ..ephemeris import body_states_mci, ensure_kernels, rotation, tdb_seconds
from ..errors import ImpactError
from ..evaluator import analyse_constellation, context_for
from ..frames import rotate_to_moon_fixed, rotate_with
from ..keys import METRIC_KEYS, NAVIGATION_ERROR_KEYS
from ..outputs import display_path, output_dir
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import load_settings
from ..surface_grid import SurfaceGrid

__all__ = [
    "TABLE4_KEY",
    "DOP_KEYS",
    "DESIGN_LIFE_KEYS",
    "Entry",
    "Benchmark",
    "mask_key",
    "catalogue_entries",
    "paper_entry",
    "campaign_entries",
    "run_benchmark",
    "add_closed_loop_life",
    "epoch_sensitivity",
    "epoch_spread",
    "epoch_findings",
    "yardstick_findings",
]

TABLE4_KEY = "table4_elfo"
DOP_KEYS = (
    "mean_visible_sats",
    "pdop_mean_3sigma",
    "pdop_avail_pct",
    "hdop_mean_3sigma",
    "hdop_avail_pct",
)
DESIGN_LIFE_KEYS = (
    "life_days",
    "impact_day",
    "sk_dv_kms_per_year",
    "sk_dv_max_kms_per_year",
    "n_maneuvers",
    "box_held",
    "pdop_avail_pct_life",
    "hdop_avail_pct_life",
    "sk_dv_estimate_kms_per_year",
    "stable_screen",
)


def mask_key(key: str, mask_deg: float) -> str:
    """Column name of a DOP metric at an extra elevation mask, e.g. ``pdop_avail_pct_mask20deg``."""
    return f"{key}_mask{float(mask_deg):g}deg"


@dataclass
class Entry:
    """One constellation of the yardstick: ``elements_deg`` (n, 6) in ``element_frame`` (None: not evaluated)."""

    label: str
    kind: str  # "catalogue", "paper" or "campaign"
    n_sat: int
    elements_deg: np.ndarray | None
    element_frame: str | None
    note: str = ""
    catalogue: object = None  # the CatalogueConstellation of a catalogue entry

    @property
    def evaluated(self) -> bool:
        return self.elements_deg is not None


@dataclass
class Benchmark:
    """The yardstick: ``table`` (one row per entry), ``analysis`` (label -> evaluator's analysis dict),
    the profile and the entries."""

    profile_name: str
    profile: dict
    entries: list
    table: pd.DataFrame
    analysis: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def catalogue_entries(profile: dict, names=None) -> list[Entry]:
    """Every catalogue file (or those named) as an :class:`Entry`; approximate ones listed with the reason
    they are not evaluated."""
    keys = [row["key"] for row in list_catalogue(profile.dynamics)]
    unknown = sorted(set(names or ()) - set(keys))
    if unknown:
        raise ValueError(
            f"unknown catalogue constellation(s) {unknown}; catalogue: {', '.join(keys)}"
        )
    entries = []
    for row in (r for r in list_catalogue(profile.dynamics) if names is None or r["key"] in names):
        c = load_constellation(row["key"], profile.dynamics)
        if c.approximate:
            entries.append(
                Entry(
                    c.key,
                    "catalogue (approximate)",
                    c.n_sat,
                    None,
                    None,
                    "not evaluated: approximate entry, its sources give no eccentricity, inclination, "
                    "node, perilune or phasing",
                    c,
                )
            )
        else:
            epoch = "none" if c.epoch is None else f"{c.epoch} {c.time_scale}"
            entries.append(
                Entry(
                    c.key,
                    "catalogue",
                    c.n_sat,
                    c.elements_deg,
                    c.element_frame,
                    f"elements in {c.element_frame} at the study epoch (file epoch {epoch})",
                    c,
                )
            )
    return entries


def paper_entry(profile: dict) -> Entry:
    """The paper's Table 4 standalone ELFO, elements in the profile's element frame."""
    elements = standalone_elfo(profile.standalone_elfo, profile.dynamics)
    return Entry(
        TABLE4_KEY,
        "paper",
        elements.shape[0],
        elements,
        profile.frames.element_frame,
        "Malik & Yang Table 4 (2 planes x 8)",
    )


def _campaigns(profile_name: str) -> list[tuple[str, Path, object, object]]:
    """(label, folder, evaluations, front) of the campaign published as the profile's (paper-faithful), of
    its companion's (``operational``) and of any other subfolder holding a ``front.nc``."""
    import xarray as xr

    from ..campaign.publication import PUBLISHED_DIR, load_published
    from .campaign import companion_of

    base = output_dir(profile_name, "campaign")
    companion = companion_of(profile_name)
    campaigns = []
    for label, folder in [("paper-faithful", base)] + (
        [("operational", output_dir(companion, "campaign"))] if companion else []
    ):
        published = load_published(folder)
        if published is not None:
            campaigns.append((label, published.folder, published.evaluations, published.front))
    for sub in sorted(base.iterdir()) if base.is_dir() else []:
        if (
            sub.is_dir()
            and not sub.name.startswith("run_")
            and sub.name != PUBLISHED_DIR
            and (sub / "front.nc").is_file()
        ):
            campaigns.append(
                (
                    sub.name,
                    sub,
                    xr.load_dataset(sub / "evaluations.nc", engine="h5netcdf"),
                    xr.load_dataset(sub / "front.nc", engine="h5netcdf"),
                )
            )
    return campaigns


def campaign_entries(profile_name: str) -> tuple[list[Entry], list[str]]:
    """Table 6 picks (:func:`lnss_lib.studies.pareto.table6`) of the campaign published as the profile's
    (``outputs/<profile>/campaign/published.json``; other campaigns in subfolders holding a ``front.nc``)
    and of the profile's companion (the operational campaign, under its own Delta-V metric and bound), and
    notes.

    The picks use the front with the Delta-V bound relaxed when no front design meets it (notebook 07's
    reading). A missing campaign gives a note, not an error.
    """
    from .pareto import analysis_front, deltav_constraint, table6

    entries, notes = [], []
    campaigns = _campaigns(profile_name)
    if not campaigns:
        notes.append(
            f"no campaign published under {display_path(output_dir(profile_name, 'campaign'))}: campaign designs "
            f"skipped; run `python -m lnss_lib campaign --profile {profile_name}`"
        )
    for name, folder, evaluations, front in campaigns:
        metric, limit = deltav_constraint(
            evaluations
        )  # the paper's Delta-V, or the operational estimate
        picks = table6(front, dv_max_kms_per_year=limit, dv_metric=metric)
        if not len(picks):
            relaxed, _ = analysis_front(evaluations, front.isel(design=slice(0, 0)))
            picks = table6(relaxed, dv_max_kms_per_year=math.inf, dv_metric=metric)
            notes.append(
                f"{name} campaign: no front design meets every bound; Table 6 picks from the front with the "
                "Delta-V bound relaxed"
            )
        if not len(picks):
            notes.append(
                f"{name} campaign ({display_path(folder)}): no design qualifies for Table 6; none added"
            )
        for k, row in picks.iterrows():
            design = WalkerDesign(
                row.sma_km,
                row.ecc,
                row.aop_deg,
                row.inc_deg,
                int(row.n_planes),
                int(row.sats_per_plane),
            )
            label = (
                f"{name} campaign #{k + 1}: {int(row.n_planes)}x{int(row.sats_per_plane)}, a {row.sma_km:.0f} km, "
                f"e {row.ecc:.2f}, i {row.inc_deg:.0f}, AOP {row.aop_deg:.0f}"
            )
            entries.append(
                Entry(
                    label,
                    "campaign",
                    design.n_sat,
                    design.elements_deg(),
                    None,
                    row["why selected"],
                )
            )
    return entries, notes


def _nan_row(entry: Entry, masks) -> dict:
    row = {
        "constellation": entry.label,
        "kind": entry.kind,
        "n_sat": entry.n_sat,
        "status": entry.note,
    }
    row.update({k: math.nan for k in METRIC_KEYS + NAVIGATION_ERROR_KEYS if k != "n_sat"})
    row.update({mask_key(k, m): math.nan for m in masks for k in DOP_KEYS})
    row.update(
        screen_min_perilune_alt_km=math.nan,
        stable_screen=None,
        screen_impact_day=math.nan,
        sk_dv_estimate_kms_per_year=math.nan,
        sk_dv_estimate_max_kms_per_year=math.nan,
    )
    return row


def _profile_for(profile: dict, entry: Entry) -> dict:
    if entry.kind == "catalogue":
        return profile.with_overrides(
            {"frames": {"element_frame": FILE_FRAMES[entry.element_frame]}}
        )
    return profile


def _evaluate_entry(context, entry: Entry, masks) -> tuple[dict, dict | None]:
    profile = context.settings
    row = _nan_row(entry, masks)
    if not entry.evaluated:
        return row, None
    try:
        if entry.kind == "catalogue":
            study = analyse_catalogue(context, entry.catalogue)
            states = study["states"].states_mci
        else:
            study = analyse_constellation(context, entry.elements_deg)
            states = elements_deg_to_states(profile.dynamics, entry.elements_deg, context.t0_tdb_s)
    except ImpactError as error:
        row["status"] = f"{entry.note}; {error}"
        return row, None
    row.update({k: study["metrics"][k] for k in METRIC_KEYS})
    r_mf = rotate_with(context.rot_to_moon_fixed, study["propagation"].r_mci_km.values)
    study["r_mf_km"] = r_mf
    metres = context.position_errors(study["propagation"].r_mci_km.values, r_mf).metrics(
        profile.navigation_error, context.grid
    )
    row.update({k: metres[k] for k in NAVIGATION_ERROR_KEYS})
    for mask in masks:
        masked = profile.with_overrides({"dop": {"elevation_mask_deg": float(mask)}})
        summary = summary_for_settings(
            masked.dop, dop_for_settings(masked.dop, r_mf, context.times, context.grid)
        )
        row.update({mask_key(k, mask): summary[k] for k in DOP_KEYS})
    screen = screen_states(profile.stability, profile.dynamics, states, context.t0_tdb_s)
    row.update(
        screen_min_perilune_alt_km=screen.attrs["min_perilune_alt_km"],
        stable_screen=screen.attrs["stable"],
        screen_impact_day=screen.attrs["impact_day"],
    )
    try:
        sk = sk_estimate_from_propagation(
            profile.sk_estimate, profile.dynamics, study["propagation"]
        )
        row.update(
            sk_dv_estimate_kms_per_year=sk["sk_dv_estimate_kms_per_year"],
            sk_dv_estimate_max_kms_per_year=sk["sk_dv_estimate_max_kms_per_year"],
        )
    except ValueError as error:
        row["status"] = f"{entry.note}; no station-keeping estimate: {error}"
    return row, study


def run_benchmark(
    profile_name: str, *, campaigns: bool | None = None, names=None, overrides=None
) -> Benchmark:
    """Evaluate every entry (catalogue, Table 4 ELFO, campaign picks) over the profile's grid and epoch span.

    Columns: ``constellation``, ``kind``, ``n_sat``, ``status``, the eq. 45 metrics of
    :data:`lnss_lib.keys.METRIC_KEYS` at the profile's mask (the evaluator's, as ``evaluate
    --constellation``), :data:`DOP_KEYS` at each ``[benchmark] extra_masks_deg`` (:func:`mask_key`), the
    stability screen (``screen_min_perilune_alt_km``, ``stable_screen``, ``screen_impact_day``) and the
    geometry-keeping estimate (``sk_dv_estimate_kms_per_year`` mean over satellites, ``..._max_...``) and the
    user's position error in metres of :data:`lnss_lib.keys.NAVIGATION_ERROR_KEYS` (the profile's
    ``[navigation_error]`` budget at its mask).
    ``campaigns`` overrides ``[benchmark] campaign_picks``; ``names`` restricts the catalogue (default: all).
    """
    profile = load_settings(profile_name, overrides=overrides)
    cfg = profile.benchmark
    context = context_for(profile)
    entries = [paper_entry(profile)] + catalogue_entries(profile, names)
    notes = []
    if cfg.campaign_picks if campaigns is None else campaigns:
        picked, notes = campaign_entries(profile_name)
        entries += picked
    rows, analysis = [], {}
    for entry in entries:
        row, study = _evaluate_entry(context, entry, cfg.extra_masks_deg)
        rows.append(row)
        if study is not None:
            analysis[entry.label] = study
    return Benchmark(profile_name, profile, entries, pd.DataFrame(rows), analysis, notes)


def add_closed_loop_life(
    bench: Benchmark, life_days: float | None = None
) -> tuple[pd.DataFrame, str]:
    """The yardstick with the closed-loop design-life metrics of ``lnss_lib.design_life.evaluation`` added (prefixed
    ``life_``), and a note. With ``[benchmark] closed_loop_life = false`` the table comes back unchanged with a
    note saying why."""
    from ..design_life.evaluation import evaluate_design_life

    if not bench.profile.benchmark.closed_loop_life:
        return (
            bench.table,
            "[benchmark] closed_loop_life = false: closed-loop design-life metrics not added",
        )
    life = bench.profile.design_life.life_days if life_days is None else float(life_days)
    table = bench.table.copy()
    for entry in bench.entries:
        if entry.label not in bench.analysis:
            continue
        result = evaluate_design_life(_profile_for(bench.profile, entry), entry.elements_deg, life)
        index = table.index[table["constellation"] == entry.label][0]
        for key in DESIGN_LIFE_KEYS:
            table.loc[index, f"life_{key}"] = result.get(key, math.nan)
    return (
        table,
        f"closed-loop design-life metrics over {life:g} days (lnss_lib.design_life.evaluation)",
    )


# ---------------------------------------------------------------- epoch sensitivity


def _moon_node_deg(t_tdb_s: float) -> float:
    """Longitude (deg) of the ascending node of the Moon's geocentric orbit on the J2000 ecliptic."""
    state = body_states_mci("EARTH", np.array([t_tdb_s]))[0]
    h = np.cross(
        state[:3], state[3:]
    )  # Earth about the Moon: the same normal as the Moon about the Earth
    h = rotation("J2000", "ECLIPJ2000", np.array([t_tdb_s]))[0] @ h
    return float(np.degrees(np.arctan2(h[0], -h[1])) % 360.0)


def _epoch_states(profile: dict, name: str, t0: float) -> np.ndarray:
    if name == TABLE4_KEY:
        return elements_deg_to_states(
            profile.dynamics, standalone_elfo(profile.standalone_elfo, profile.dynamics), t0
        )
    return constellation_states_mci(
        profile.dynamics, profile.epoch.start_tdb, load_constellation(name, profile.dynamics)
    ).states_mci


def epoch_sensitivity(
    profile_name: str, *, epochs=None, names=None, overrides=None
) -> pd.DataFrame:
    """Lunar-surface metrics of the same constellations started at each epoch (``[benchmark] epochs_tdb``).

    The constellation keeps its geometry relative to the Moon: Table 4's elements in the lunar equator
    of each epoch, catalogue elements in their frame built at each epoch. One row per (epoch,
    constellation): the DOP metrics at the profile's mask and the extra masks, the stability screen and
    the geometry-keeping estimate; ``moon_node_deg`` is the phase of the 18.6-year nodal cycle. The
    GPS link is left out: its TLEs (2025) do not reach other epochs.
    """
    base = load_settings(profile_name, overrides=overrides)
    cfg = base.benchmark
    epochs = cfg.epochs_tdb if epochs is None else epochs
    names = cfg.epoch_constellations if names is None else names
    rows = []
    for epoch in epochs:
        profile = base.with_overrides({"epoch": {"start_tdb": epoch}})
        ensure_kernels(profile.ephemeris)
        t0 = tdb_seconds(epoch, "TDB")
        duration = profile.epoch.duration_days * SECONDS_PER_DAY
        for name in names:
            states = _epoch_states(profile, name, t0)
            ds = propagate_states(
                profile.dynamics, states, t0, duration, profile.epoch.step_s, batch=True
            )
            row = {
                "epoch_tdb": epoch,
                "year": 2000.0 + (t0 / SECONDS_PER_DAY) / DAYS_PER_JULIAN_YEAR,
                "moon_node_deg": _moon_node_deg(t0),
                "constellation": name,
                "n_sat": states.shape[0],
                "impact": bool(ds.impact.any()),
            }
            if not row["impact"]:
                times = ds["time"].values.astype(float)
                r_mf = rotate_to_moon_fixed(profile.dynamics, ds["r_mci_km"].values, times)
                for mask in [profile.dop.elevation_mask_deg] + [
                    float(m) for m in cfg.extra_masks_deg
                ]:
                    masked = profile.with_overrides({"dop": {"elevation_mask_deg": mask}})
                    summary = summary_for_settings(
                        masked.dop,
                        dop_for_settings(
                            masked.dop,
                            r_mf,
                            times,
                            SurfaceGrid.from_settings(masked.dop, masked.constants.r_moon_mean_km),
                        ),
                    )
                    row.update({mask_key(k, mask): summary[k] for k in DOP_KEYS})
                row["sk_dv_estimate_kms_per_year"] = sk_estimate_from_propagation(
                    profile.sk_estimate, profile.dynamics, ds
                )["sk_dv_estimate_kms_per_year"]
            screen = screen_states(profile.stability, profile.dynamics, states, t0)
            row.update(
                screen_min_perilune_alt_km=screen.attrs["min_perilune_alt_km"],
                stable_screen=screen.attrs["stable"],
            )
            rows.append(row)
    return pd.DataFrame(rows)


def epoch_spread(table: pd.DataFrame, reference_epoch: str | None = None) -> pd.DataFrame:
    """Per constellation and metric: the value at ``reference_epoch`` (default: the first epoch), the
    minimum, maximum and the spread (max - min) across the epochs, and the largest departure from the
    reference in per cent."""
    reference_epoch = table["epoch_tdb"].iloc[0] if reference_epoch is None else reference_epoch
    metrics = [
        c
        for c in table.columns
        if c
        not in (
            "epoch_tdb",
            "year",
            "moon_node_deg",
            "constellation",
            "n_sat",
            "impact",
            "stable_screen",
        )
    ]
    rows = []
    for name, group in table.groupby("constellation", sort=False):
        ref = group[group["epoch_tdb"] == reference_epoch]
        for metric in metrics:
            values = group[metric].to_numpy(float)
            ref_value = float(ref[metric].iloc[0]) if len(ref) else math.nan
            with np.errstate(invalid="ignore", divide="ignore"):
                departure = (
                    float(np.nanmax(np.abs(values / ref_value - 1.0)) * 100.0)
                    if ref_value
                    else math.nan
                )
            rows.append(
                {
                    "constellation": name,
                    "metric": metric,
                    f"at {reference_epoch}": ref_value,
                    "min": float(np.nanmin(values)),
                    "max": float(np.nanmax(values)),
                    "spread": float(np.nanmax(values) - np.nanmin(values)),
                    "largest departure from the reference (%)": departure,
                }
            )
    return pd.DataFrame(rows)


def epoch_findings(spread: pd.DataFrame) -> list[str]:
    """Markdown bullet lines: per constellation, the largest departure of a DOP metric and of the other metrics."""
    lines = []
    column = "largest departure from the reference (%)"
    for name, group in spread.groupby("constellation", sort=False):
        dop = group[group["metric"].str.contains("dop|visible")]
        other = group[~group["metric"].str.contains("dop|visible")]
        worst = dop.loc[dop[column].idxmax()] if dop[column].notna().any() else None
        text = (
            f"- {name}: DOP metrics move by at most {worst[column]:.2f}% ({worst['metric']})"
            if worst is not None
            else f"- {name}: no DOP metric"
        )
        for _, row in other.iterrows():
            text += f"; {row['metric']} from {row['min']:.4g} to {row['max']:.4g}"
        lines.append(text)
    return lines


def yardstick_findings(table: pd.DataFrame, masks) -> list[str]:
    """Markdown bullet lines read from the yardstick: what was evaluated, and how each extra mask moves
    the PDOP availability of every evaluated constellation."""
    evaluated = table[np.isfinite(table["pdop_avail_pct"].to_numpy(float))]
    lines = [
        f"- {len(evaluated)} of {len(table)} constellations evaluated; not evaluated: "
        + (
            ", ".join(
                f"{r.constellation} ({r.status})"
                for r in table[~table.index.isin(evaluated.index)].itertuples()
            )
            or "none"
        )
    ]
    for mask in masks:
        drop = evaluated["pdop_avail_pct"] - evaluated[mask_key("pdop_avail_pct", mask)]
        lines.append(
            f"- {float(mask):g} deg mask: PDOP availability lower than at the profile's mask by "
            f"{drop.min():.1f} to {drop.max():.1f} points; "
            + ", ".join(
                f"{r.constellation} {r.pdop_avail_pct:.1f}% -> {a:.1f}%"
                for r, a in zip(evaluated.itertuples(), evaluated[mask_key("pdop_avail_pct", mask)])
            )
        )
    return lines
