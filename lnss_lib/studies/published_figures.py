"""Notebook 10: the published performance figures of the catalogue's constellations beside ours.

Question: where a study published performance figures (the catalogue's ``[published]`` tables), how
far are ours from them and why; and do Bhamidipati et al.'s published position errors come back with
their UERE and mask?

Verdict: the published figures are not reproduced one for one: metric definitions, epoch, user grid
and span differ or were not given, and the comparison table names each cause beside each number
rather than tuning. In metres, with every satellite at their 3.86 m UERE and their mask, the
node-mean horizontal and vertical RMSEs of case A at 5 deg and case C at 5 and 20 deg come back
within :data:`BHAMIDIPATI_TOLERANCE_PCT` (ours the higher horizontally); case A at 20 deg has fewer
fixes in our reading (availability below theirs) and case B does not agree (one figure of four
within it on the ci profile's two-day arc, none on the paper profile's ten days), because in our
reading of its elements 16-19 % of the samples have no PDOP < 15 fix (theirs: 100 % availability),
so its geometry is not the one they flew; the worst-node values are set by near-degenerate samples
of grids that differ. The notebook prints the numbers.

Our numbers come from the propagation of :func:`lnss_lib.studies.constellation_benchmark.run_benchmark`
(``bench``: its :class:`~lnss_lib.studies.constellation_benchmark.Benchmark`; ``entry``: one of its
entries).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from ..dop import elevation_deg
from ..evaluator import context_for
from ..navigation_error import position_errors, station_states

__all__ = [
    "BHAMIDIPATI_TOLERANCE_PCT",
    "AGREEMENT_FIGURES",
    "published_comparison",
    "bhamidipati_agreement",
]


OUR_CONDITIONS = "{mask:g} deg mask; 144-node grid lat -90..-60 deg (pole repeated 36 times); {epoch} TDB + {days:g} d"


BHAMIDIPATI_DEFINITIONS = {
    "availability_pct": (
        "share of grid-epoch samples with PDOP < 15 (eq. 14)",
        "their definition (Sec. 3.2.3) was not readable; ours is eq. 14's threshold on PDOP",
    ),
    "coverage_pct": (
        "share of grid-epoch samples with >= 4 satellites above the mask",
        "their definition was not readable; ours counts 4-fold visibility",
    ),
    "failure_tolerance_pct": (
        None,
        "not computed: needs a one-satellite-out analysis whose definition was not readable",
    ),
    "gdop": (
        None,
        "not computed: the workbook's DOP kernel returns PDOP and HDOP, not the time term GDOP needs",
    ),
    "horizontal_position_rmse_mean_m": (
        "RMS over the available samples (PDOP < 15) of the weighted least-squares East-North "
        "sigma_H per node (every satellite their UERE: UERE x HDOP), mean over nodes",
        "equal, uncorrelated ranging errors of their UERE; their estimator is not stated",
    ),
    "horizontal_position_rmse_max_m": (
        "RMS over the available samples (PDOP < 15) of sigma_H per node, worst node",
        "worst node decided by near-degenerate samples; their grid differs",
    ),
    "vertical_position_rmse_mean_m": (
        "RMS over the available samples of the vertical sigma_V per node (UERE x VDOP), "
        "mean over nodes",
        "same reading as the horizontal row",
    ),
    "vertical_position_rmse_max_m": (
        "RMS over the available samples of sigma_V per node, worst node",
        "worst node decided by near-degenerate samples; their grid differs",
    ),
    "receiver_timing_rmse_mean_us": (None, "not computed: no TDOP in the workbook"),
    "receiver_timing_rmse_max_us": (None, "not computed: no TDOP in the workbook"),
}


# node-mean position RMSEs within a quarter of theirs count as agreeing: no closer match can be asked
# while their user grid, epoch, span and OP frame are unknown
BHAMIDIPATI_TOLERANCE_PCT = 25.0
AGREEMENT_FIGURES = ("horizontal_position_rmse_mean_m", "vertical_position_rmse_mean_m")


COMMON_CAUSES = (
    "their epoch, user grid and span are not given (ours: the study's); elements in the Moon "
    "orbital-plane frame built as Ely's / LuPNT's (their OP definition not readable)"
)


def _node_rms(values: np.ndarray) -> np.ndarray:
    """RMS over time (axis 0) of each node's finite samples; NaN where a node has none."""
    finite = np.isfinite(values)
    count = finite.sum(axis=0)
    total = np.sum(np.where(finite, values, 0.0) ** 2, axis=0)
    return np.where(count > 0, np.sqrt(total / np.maximum(count, 1)), np.nan)


def _error_counterparts(
    profile, study: dict, times: np.ndarray, grid, mask_deg: float, uere_m: float
) -> dict:
    """Availability, coverage and position RMSEs at ``mask_deg`` with every satellite's user range error ``uere_m``
    (constant: no ephemeris ageing, receiver or multipath term) through the weighted position-error pass."""
    masked = profile.with_overrides(
        {
            "dop": {"elevation_mask_deg": float(mask_deg)},
            "navigation_error": {
                "sise_law": "constant",
                "sise_at_upload_m": float(uere_m),
                "receiver_noise_m": 0.0,
                "lunar_multipath_zenith_m": 0.0,
            },
        }
    )
    nav = masked.navigation_error
    r_mci = study["propagation"].r_mci_km.values
    errors = position_errors(
        nav,
        masked.dop,
        grid,
        study["r_mf_km"],
        r_mci,
        times,
        station_states(nav, profile.constants, times),
        profile.constants.r_moon_mean_km,
    )
    with np.errstate(invalid="ignore"):  # eq. 14, a fix is reported: PDOP < 15, sigma_P < 15 UERE
        usable = (
            np.hypot(errors.sigma_h_m, errors.sigma_v_m)
            < profile.dop.availability_threshold * uere_m
        )
    stats = errors.dop_stats
    out = {
        "availability_pct": stats["pdop_avail_pct"],
        "coverage_pct": 100.0 - stats["fewer_than_4_pct"],
    }
    for name, sigma in (("horizontal", errors.sigma_h_m), ("vertical", errors.sigma_v_m)):
        node = _node_rms(np.where(usable, sigma, np.nan))
        finite = node[np.isfinite(node)]
        out[f"{name}_position_rmse_mean_m"] = float(finite.mean()) if finite.size else math.nan
        out[f"{name}_position_rmse_max_m"] = float(finite.max()) if finite.size else math.nan
    return out


def _runs(visible: np.ndarray, value: bool) -> np.ndarray:
    """Lengths (samples) of the runs of ``value`` in a boolean series."""
    edges = np.flatnonzero(
        np.diff(np.concatenate([[False], visible == value, [False]]).astype(int))
    )
    return edges[1::2] - edges[0::2]


def _pole_coverage(elev_deg: np.ndarray, mask_deg: float, fold: int | None, step_h: float) -> dict:
    """Coverage (%), mean pass and gap (h) at the pole station of one satellite (fold None, elev (time,))
    or of the constellation's ``fold``-fold visibility (elev (sat, time))."""
    visible = elev_deg >= mask_deg if fold is None else np.sum(elev_deg >= mask_deg, axis=0) >= fold
    passes, gaps = _runs(visible, True), _runs(visible, False)
    return {
        "coverage_pct": 100.0 * float(np.mean(visible)),
        "mean_pass_h": "Total Span"
        if visible.all()
        else float(np.mean(passes) * step_h)
        if passes.size
        else 0.0,
        "mean_gap_h": float(np.mean(gaps) * step_h) if gaps.size else 0.0,
    }


def _ely_rows(bench, entry, study: dict, our: str) -> list[dict]:
    pub = entry.catalogue.published
    grid = context_for(bench.profile).grid
    pole = int(np.argmin(grid.lat_deg))
    elev = elevation_deg(study["r_mf_km"], grid)[:, :, pole, 0]
    step_h = bench.profile.epoch.step_s / 3600.0
    days = bench.profile.epoch.duration_days
    theirs = f"{pub['conditions']} Epoch 2009-07 (ET; day uncertain, see README)."
    why = (
        f"span: their 10 years against our {days:g} days at {step_h * 60:g} min sampling (passes cut at the span's "
        "ends, pass lengths quantised to the step); epoch: theirs 2009, ours the study epoch; same station (the pole)"
    )
    blocks = []
    for k in range(entry.n_sat):
        blocks.append((f"satellite_{k + 1}", float(pub["elevation_mask_deg"]), None, elev[k]))
    blocks += [
        ("constellation_1_fold", float(pub["elevation_mask_deg"]), 1, elev),
        ("constellation_2_fold", float(pub["elevation_mask_deg"]), 2, elev),
    ]
    rows = []
    for name, mask, fold, values in blocks:
        ours = _pole_coverage(values, mask, fold, step_h)
        for key, value in pub.get(name, {}).items():
            rows.append(
                {
                    "constellation": entry.label,
                    "published figure": f"{name}.{key}",
                    "published": value,
                    "their conditions": theirs,
                    "ours": ours.get(key),
                    "our conditions": our.format(mask=mask) + "; South Pole node only",
                    "our definition": "as theirs (p. 314), from our sampled passes",
                    "why they differ": why,
                }
            )
    for key, fold in (("one_fold_coverage_pct", 1), ("two_fold_coverage_pct", 2)):
        if key in pub.get("elevation_mask_15deg", {}):
            ours = _pole_coverage(elev, 15.0, fold, step_h)["coverage_pct"]
            rows.append(
                {
                    "constellation": entry.label,
                    "published figure": f"elevation_mask_15deg.{key}",
                    "published": pub["elevation_mask_15deg"][key],
                    "their conditions": theirs.replace("10 deg", "15 deg"),
                    "ours": ours,
                    "our conditions": our.format(mask=15.0) + "; South Pole node only",
                    "our definition": f"share of epochs with >= {fold} satellites above 15 deg at the pole",
                    "why they differ": why,
                }
            )
    return rows


def _bhamidipati_rows(bench, entry, study: dict, our: str) -> list[dict]:
    context = context_for(bench.profile)
    rows = []
    for table_key, table in entry.catalogue.published.items():
        if not isinstance(table, Mapping) or "elevation_mask_deg" not in table:
            continue
        mask, uere = float(table["elevation_mask_deg"]), float(table["lunar_uere_m"])
        ours = _error_counterparts(bench.profile, study, context.times, context.grid, mask, uere)
        theirs = f"{table['table']}; {mask:g} deg mask; UERE {uere:g} m; epoch, user grid and duration not given"
        for key, value in table.items():
            if key in ("table", "elevation_mask_deg", "lunar_uere_m"):
                continue
            definition, cause = BHAMIDIPATI_DEFINITIONS.get(
                key, (None, "no counterpart in the workbook")
            )
            rows.append(
                {
                    "constellation": entry.label,
                    "published figure": f"{table_key}.{key}",
                    "published": value,
                    "their conditions": theirs,
                    "ours": ours.get(key, math.nan) if definition else math.nan,
                    "our conditions": our.format(mask=mask) + f"; UERE {uere:g} m",
                    "our definition": definition or "-",
                    "why they differ": f"{cause}; {COMMON_CAUSES}" if definition else cause,
                }
            )
    return rows


def published_comparison(bench) -> pd.DataFrame:
    """One row per published performance figure (the catalogue's ``[published]`` tables) beside our counterpart.

    Columns: ``constellation``, ``published figure`` (table.key), ``published``, ``their conditions``,
    ``ours`` (NaN where the workbook has no counterpart), ``our conditions`` (mask, grid, epoch, span),
    ``our definition`` and ``why they differ``. Our numbers come from the yardstick's propagation.
    """
    profile = bench.profile
    our = OUR_CONDITIONS.replace("{epoch}", profile.epoch.start_tdb).replace(
        "{days:g}", f"{profile.epoch.duration_days:g}"
    )
    rows = []
    for entry in bench.entries:
        if entry.kind != "catalogue" or not entry.catalogue.published:
            continue
        study = bench.analysis.get(entry.label)
        if study is None:
            continue
        if "lunar_uere_m" in str(entry.catalogue.published):
            rows += _bhamidipati_rows(bench, entry, study, our)
        else:
            rows += _ely_rows(bench, entry, study, our)
    return pd.DataFrame(rows)


def bhamidipati_agreement(
    published: pd.DataFrame, tolerance_pct: float = BHAMIDIPATI_TOLERANCE_PCT
) -> pd.DataFrame:
    """The node-mean horizontal and vertical position RMSEs of :func:`published_comparison` (the same UERE, their
    mask) with ``difference (%)`` (100 (ours - theirs) / theirs) and ``agrees`` (within ``tolerance_pct``)."""
    rows = published[published["published figure"].str.endswith(AGREEMENT_FIGURES)]
    difference = (
        100.0
        * (rows["ours"].astype(float) - rows["published"].astype(float))
        / rows["published"].astype(float)
    )
    return pd.DataFrame(
        {
            "constellation": rows["constellation"],
            "published figure": rows["published figure"],
            "published (m)": rows["published"],
            "ours (m)": rows["ours"],
            "difference (%)": difference,
            "agrees": difference.abs() <= tolerance_pct,
        }
    )
