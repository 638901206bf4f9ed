"""Notebook 02: does the standalone ELFO give the south pole the geometry of Table 4? (paper Section 2.1,
eq. 1-14; NOTES.md "Frames")

Question: the paper does not say in which frame its Keplerian elements are given, nor in which axes
its HDOP is taken. Propagating the standalone ELFO with its elements in each element frame and
evaluating the DOP grid in each line-of-sight convention: which choice reproduces Table 4's visible
count, filtered PDOP and HDOP and availability, where over the grid and when in time do the
samples without a usable DOP occur, and why?

Verdict: with the elements referred to the lunar equator of epoch the grid reproduces the paper's
visible count and filtered PDOP closely; referred to the J2000 equator the apolunes move away from
the south pole and the geometry degrades. PDOP does not depend on the HDOP axes, HDOP does. The
samples without a usable DOP are those that see the satellites of one plane only, close to the
plane's own direction (a degenerate geometry), not a lack of satellites. The notebook prints the
numbers behind each statement.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import xarray as xr

from ..constellation import two_body_positions_mci
from ..dop import (
    check_positions,
    dop_for_settings,
    dop_from_propagation,
    elevation_deg,
    summary_for_settings,
)
from ..elements import orbital_period_s
from ..frames import ELEMENT_FRAMES, latitude_deg, rotate_to_moon_fixed
from ..paper import TABLE_4, TABLE_4_LABEL
from ..propagator import propagate_elements
from ..sections import LOS_AXES
from ..settings import load_settings
from ..surface_grid import SurfaceGrid

__all__ = [
    "SUMMARY_LABELS",
    "summary_table",
    "latitude_statistics",
    "time_statistics_maps",
    "plane_visibility",
    "degenerate_geometry_rows",
    "FrameStudy",
    "element_frame_study",
    "apolune_latitude_table",
    "frame_study_summaries",
    "latitude_table",
    "degenerate_geometry_table",
    "frame_findings",
]

SUMMARY_LABELS = {
    "mean_visible_sats": "mean visible satellites",
    "pdop_mean_3sigma": "PDOP (3-sigma mean)",
    "hdop_mean_3sigma": "HDOP (3-sigma mean)",
    "pdop_avail_pct": "PDOP availability (%)",
    "hdop_avail_pct": "HDOP availability (%)",
    "availability_pct": "PDOP and HDOP < 15 (%)",
    "fewer_than_4_pct": "samples with < 4 visible (%)",
    "pdop_mean_raw": "PDOP (unfiltered mean)",
    "hdop_mean_raw": "HDOP (unfiltered mean)",
}


def summary_table(
    summaries: dict[str, dict],
    reference: str,
    *,
    paper: dict | None = None,
    labels: dict | None = None,
) -> pd.DataFrame:
    """Metrics (rows, ``labels``) of each named :func:`dop_summary` (columns) beside the paper's Table 4.

    Columns: ``"paper (Table 4)"``, then ``summaries`` in order, then ``"default vs paper (%)"``:
    100 (reference - paper) / paper. Metrics a summary lacks are NaN (the paper gives five).
    """
    if reference not in summaries:
        raise ValueError(
            f"reference column {reference!r} is not among the summaries: {', '.join(summaries)}"
        )
    labels = SUMMARY_LABELS if labels is None else labels
    columns = {TABLE_4_LABEL: TABLE_4 if paper is None else paper, **summaries}
    table = pd.DataFrame(
        {
            name: {labels[k]: values.get(k, np.nan) for k in labels}
            for name, values in columns.items()
        }
    )
    table["default vs paper (%)"] = (
        100.0 * (table[reference] - table[TABLE_4_LABEL]) / table[TABLE_4_LABEL]
    )
    return table


def latitude_statistics(
    ds_moon_fixed: xr.Dataset, ds_enu: xr.Dataset, threshold: float = 15.0
) -> pd.DataFrame:
    """Per latitude row of the grid: share of samples with PDOP >= ``threshold`` or none (eq. 14), median
    PDOP and HDOP in both line-of-sight conventions (eq. 7-8) and mean visible satellites (eq. 4).

    ``ds_moon_fixed`` and ``ds_enu``: :func:`dop_grid` results of one propagation with ``los_axes``
    ``moon_fixed`` and ``enu``. Medians skip the samples without a DOP.
    """
    rows = []
    for lat in ds_moon_fixed["lat"].values:
        p = ds_moon_fixed["pdop"].sel(lat=lat).values
        rows.append(
            {
                "lat (deg)": lat,
                "PDOP unavailable (%)": 100.0 * np.mean(~(p < threshold)),
                "median PDOP": np.nanmedian(p),
                "median HDOP Moon-fixed": np.nanmedian(ds_moon_fixed["hdop"].sel(lat=lat).values),
                "median HDOP ENU": np.nanmedian(ds_enu["hdop"].sel(lat=lat).values),
                "mean visible": float(ds_moon_fixed["n_visible"].sel(lat=lat).mean()),
            }
        )
    return pd.DataFrame(rows)


def time_statistics_maps(
    ds_moon_fixed: xr.Dataset, ds_enu: xr.Dataset, threshold: float = 15.0
) -> xr.Dataset:
    """Per receiver (lat, lon): time mean of the visible count, time medians of PDOP and of HDOP in both
    conventions (NaN samples skipped), and the PDOP availability (%, eq. 14; no DOP counts as unavailable)."""
    return xr.Dataset(
        {
            "mean_visible": ds_moon_fixed["n_visible"].mean("time"),
            "median_pdop": ds_moon_fixed["pdop"].median("time"),
            "median_hdop_moon_fixed": ds_moon_fixed["hdop"].median("time"),
            "median_hdop_enu": ds_enu["hdop"].median("time"),
            "pdop_availability_pct": 100.0 * (ds_moon_fixed["pdop"] < threshold).mean("time"),
        }
    )


def plane_visibility(
    r_mf_km, normal_mf, grid: SurfaceGrid, elevation_mask_deg: float, sats_per_plane: int
) -> tuple[np.ndarray, np.ndarray]:
    """Visible satellites per orbital plane and receiver-plane angles, each (plane, time, lat, lon).

    ``r_mf_km`` (sat, time, 3) Moon-fixed positions, satellites ordered plane by plane with
    ``sats_per_plane`` each; ``normal_mf`` (sat, time, 3) unit orbit normals in the same axes (the
    first satellite of each plane stands for its plane). The angle is the one between the
    receiver's position vector and the orbital plane: asin |h_hat . up| (deg).
    """
    r = check_positions(r_mf_km)
    n = int(sats_per_plane)
    if n <= 0 or r.shape[0] % n:
        raise ValueError(
            f"sats_per_plane must be a positive divisor of the {r.shape[0]} satellites; got {sats_per_plane!r}"
        )
    normal = np.asarray(normal_mf, dtype=float)
    if normal.shape != r.shape:
        raise ValueError(f"normal_mf must have the shape of r_mf_km {r.shape}; got {normal.shape}")
    visible = elevation_deg(r, grid) >= elevation_mask_deg
    counts = np.stack([visible[k : k + n].sum(axis=0) for k in range(0, r.shape[0], n)])
    angle = np.stack(
        [
            np.degrees(np.arcsin(np.abs(np.einsum("tk,ijk->tij", normal[k], grid.up))))
            for k in range(0, r.shape[0], n)
        ]
    )
    return counts, angle


def degenerate_geometry_rows(
    pdop, plane_counts, plane_angle_deg, threshold: float = 15.0
) -> list[dict]:
    """Samples with PDOP >= ``threshold`` (or none) against the rest: their share, mean visible count per
    plane, share seeing only one plane, and median angle between the receiver and the plane that supplies
    most visible satellites (ties: the first plane). Arrays from :func:`plane_visibility`; ``pdop``
    (time, lat, lon). An empty class gives no row.
    """
    counts = np.asarray(plane_counts)
    angle = np.asarray(plane_angle_deg, dtype=float)
    p = np.asarray(pdop, dtype=float)
    if counts.shape[1:] != p.shape or angle.shape != counts.shape:
        raise ValueError(
            f"plane arrays {counts.shape}, {angle.shape} do not match pdop {p.shape} (plane, *pdop shape)"
        )
    majority = np.take_along_axis(angle, np.argmax(counts, axis=0)[None], axis=0)[0]
    one_plane = (counts > 0).sum(axis=0) == 1
    bad = ~(p < threshold)
    rows = []
    for label, mask in ((f"PDOP >= {threshold:g} or none", bad), (f"PDOP < {threshold:g}", ~bad)):
        if mask.any():
            rows.append(
                {
                    "samples": label,
                    "share (%)": 100.0 * mask.mean(),
                    **{
                        f"visible from plane {k + 1}": counts[k][mask].mean()
                        for k in range(counts.shape[0])
                    },
                    "samples seeing one plane only (%)": 100.0 * np.mean(one_plane[mask]),
                    "median angle receiver-majority plane (deg)": np.median(majority[mask]),
                }
            )
    return rows


@dataclass
class FrameStudy:
    """One constellation propagated with its elements in each element frame, DOP in each LOS convention.

    ``profiles`` and ``propagation``: element frame -> profile and propagator Dataset; ``dop``:
    (element frame, los axes) -> :func:`dop_grid` Dataset; ``grid``: the profile's receiver grid.
    """

    profile_name: str
    elements_deg: np.ndarray
    profiles: dict
    propagation: dict
    dop: dict
    grid: SurfaceGrid

    @property
    def frames(self) -> tuple[str, ...]:
        return tuple(self.profiles)


def element_frame_study(
    profile_name: str, elements_deg, *, frames=ELEMENT_FRAMES, los_axes=LOS_AXES
) -> FrameStudy:
    """Propagate ``elements_deg`` (nsat, 6) with the elements referred to each element frame (the profile
    otherwise unchanged) and compute the DOP grid (eq. 1-8) for each line-of-sight convention."""
    for frame in frames:
        if frame not in ELEMENT_FRAMES:
            raise ValueError(
                f"unknown element frame {frame!r}; allowed: {', '.join(ELEMENT_FRAMES)}"
            )
    profiles = {
        frame: load_settings(profile_name, overrides={"frames": {"element_frame": frame}})
        for frame in frames
    }
    propagation = {
        frame: propagate_elements(profiles[frame].dynamics, profiles[frame].epoch, elements_deg)
        for frame in frames
    }
    dop = {
        (frame, axes): dop_from_propagation(
            profiles[frame].dop, profiles[frame].dynamics, propagation[frame], los_axes=axes
        )
        for frame in frames
        for axes in los_axes
    }
    settings = load_settings(profile_name)
    return FrameStudy(
        profile_name,
        np.asarray(elements_deg, dtype=float),
        profiles,
        propagation,
        dop,
        SurfaceGrid.from_settings(settings.dop, settings.constants.r_moon_mean_km),
    )


def apolune_latitude_table(study: FrameStudy, sats_per_plane: int) -> pd.DataFrame:
    """Selenographic latitude (deg) of each plane's apolune, half a Keplerian period after the epoch, for
    each element frame of ``study`` (the first satellite of each plane starts at perilune)."""
    el = study.elements_deg
    leaders = list(range(0, el.shape[0], int(sats_per_plane)))
    rows = []
    for frame, profile in study.profiles.items():
        t0 = float(study.propagation[frame]["time"].values[0])
        times = np.array([t0, t0 + 0.5 * orbital_period_s(el[0, 0], profile.gravity.gm_km3_s2)])
        r_mf = rotate_to_moon_fixed(
            profile, two_body_positions_mci(profile.dynamics, el[leaders], times), times
        )[:, 1]
        lat = latitude_deg(r_mf)
        rows.append(
            {
                "element frame": frame,
                **{f"apolune latitude plane {k + 1} (deg)": lat[k] for k in range(len(leaders))},
            }
        )
    return pd.DataFrame(rows)


def frame_study_summaries(
    study: FrameStudy, default_frame: str = "lunar_equator_of_epoch"
) -> dict[str, dict]:
    """:func:`lnss_lib.dop.summary_for_settings` of every (frame, axes) of ``study``, then three checks on the default
    frame with the profile's axes: a two-body (Keplerian) orbit, the ``cell_area`` weighting and the
    ``converged`` integrator setting. Keys ``"<frame> / <axes>[, check]"``."""
    if default_frame not in study.profiles:
        raise ValueError(
            f"default frame {default_frame!r} is not in the study: {', '.join(study.profiles)}"
        )
    out = {
        f"{frame} / {axes}": summary_for_settings(study.profiles[frame].dop, ds)
        for (frame, axes), ds in study.dop.items()
    }
    base = study.profiles[default_frame]
    label = f"{default_frame} / {base.dop.los_axes}"
    times = study.propagation[study.frames[0]]["time"].values
    r_two_body = rotate_to_moon_fixed(
        base, two_body_positions_mci(base.dynamics, study.elements_deg, times), times
    )
    out[f"{label}, two-body"] = summary_for_settings(
        base.dop, dop_for_settings(base.dop, r_two_body, times, study.grid)
    )
    weighted = load_settings(
        study.profile_name,
        overrides={
            "frames": {"element_frame": default_frame},
            "dop": {"area_weighting": "cell_area"},
        },
    )
    out[f"{label}, cell-area weighted"] = summary_for_settings(
        weighted.dop,
        dop_from_propagation(weighted.dop, weighted.dynamics, study.propagation[default_frame]),
    )
    converged = propagate_elements(
        base.dynamics, base.epoch, study.elements_deg, setting="converged"
    )
    out[f"{label}, converged integrator"] = summary_for_settings(
        base.dop, dop_from_propagation(base.dop, base.dynamics, converged, grid=study.grid)
    )
    return out


def latitude_table(study: FrameStudy) -> pd.DataFrame:
    """:func:`latitude_statistics` for every element frame of ``study``, one block of rows per frame."""
    blocks = []
    for frame, profile in study.profiles.items():
        block = latitude_statistics(
            study.dop[(frame, "moon_fixed")],
            study.dop[(frame, "enu")],
            profile.dop.availability_threshold,
        )
        block.insert(0, "element frame", frame)
        blocks.append(block)
    return pd.concat(blocks, ignore_index=True)


def degenerate_geometry_table(study: FrameStudy, sats_per_plane: int) -> pd.DataFrame:
    """:func:`degenerate_geometry_rows` for every element frame of ``study`` (orbit normals h = r x v of
    the propagated states, rotated to the Moon-fixed frame)."""
    rows = []
    for frame, profile in study.profiles.items():
        prop = study.propagation[frame]
        t = prop["time"].values
        r_mci = prop["r_mci_km"].transpose("sat", "time", "xyz").values
        v_mci = prop["v_mci_kms"].transpose("sat", "time", "xyz").values
        r_mf = rotate_to_moon_fixed(profile.dynamics, r_mci, t)
        h_mf = rotate_to_moon_fixed(profile.dynamics, np.cross(r_mci, v_mci), t)
        h_mf /= np.linalg.norm(h_mf, axis=-1, keepdims=True)
        counts, angle = plane_visibility(
            r_mf, h_mf, study.grid, profile.dop.elevation_mask_deg, sats_per_plane
        )
        pdop = study.dop[(frame, "moon_fixed")]["pdop"].values
        for row in degenerate_geometry_rows(
            pdop, counts, angle, profile.dop.availability_threshold
        ):
            rows.append({"element frame": frame, **row})
    return pd.DataFrame(rows)


def frame_findings(
    table: pd.DataFrame,
    apolune: pd.DataFrame,
    *,
    reference: str = "lunar_equator_of_epoch / moon_fixed",
    enu: str = "lunar_equator_of_epoch / enu",
    literal: str = "j2000 / moon_fixed",
) -> list[str]:
    """Markdown bullet lines with the numbers notebook 02 discusses, read from :func:`summary_table` (of
    :func:`frame_study_summaries`) and :func:`apolune_latitude_table`: the largest difference from Table 4,
    HDOP in both axes, the J2000 reading's PDOP and availability, the apolune latitudes and how far the
    two-body, cell-area and converged checks move the default."""
    for column in (reference, enu, literal):
        if column not in table.columns:
            raise ValueError(
                f"column {column!r} is not in the summary table: {', '.join(table.columns)}"
            )
    lab = SUMMARY_LABELS
    quoted = table.index[np.isfinite(table[TABLE_4_LABEL].to_numpy(float))]
    diff = table.loc[quoted, "default vs paper (%)"].abs()
    hdop_xy, hdop_en = (
        table.loc[lab["hdop_mean_3sigma"], reference],
        table.loc[lab["hdop_mean_3sigma"], enu],
    )
    lines = [
        f"- {reference}: largest difference from Table 4 {diff.max():.1f}% ({diff.idxmax()})",
        f"- HDOP: Moon-fixed x, y {hdop_xy:.3f} (Table 4: {table.loc[lab['hdop_mean_3sigma'], TABLE_4_LABEL]:g}); "
        f"local East-North {hdop_en:.3f}, {100.0 * (hdop_en / hdop_xy - 1.0):+.1f}%; PDOP "
        f"{table.loc[lab['pdop_mean_3sigma'], reference]:.3f} in both",
        f"- {literal}: PDOP (3-sigma mean) {table.loc[lab['pdop_mean_3sigma'], literal]:.1f}, PDOP availability "
        f"{table.loc[lab['pdop_avail_pct'], literal]:.1f}%, i.e. {100.0 - table.loc[lab['pdop_avail_pct'], literal]:.1f}% "
        "of the grid-epoch samples without a usable PDOP",
    ]
    orbit_plane = "moon_op / moon_fixed"
    if orbit_plane in table.columns:
        rows = [
            lab[k]
            for k in ("mean_visible_sats", "pdop_mean_3sigma", "hdop_mean_3sigma", "pdop_avail_pct")
        ]
        change = 100.0 * (table.loc[rows, orbit_plane] / table.loc[rows, reference] - 1.0)
        moved = ", ".join(
            f"{name} {table.loc[name, orbit_plane]:.3f} ({change[name]:+.1f}% against the lunar equator)"
            for name in rows
        )
        lines.append(
            f"- {orbit_plane} (Table 4 elements in the Moon's orbital-plane frame, Bhamidipati case C): {moved}"
        )
    for _, row in apolune.iterrows():
        lats = [f"{v:.1f}" for k, v in row.items() if k != "element frame"]
        lines.append(
            f"- apolune latitudes with elements in {row['element frame']}: {' / '.join(lats)} deg"
        )
    metrics = [
        lab[k]
        for k in ("mean_visible_sats", "pdop_mean_3sigma", "hdop_mean_3sigma", "pdop_avail_pct")
    ]
    for check in (c for c in table.columns if c.startswith(reference + ",")):
        move = (
            (100.0 * (table.loc[metrics, check] / table.loc[metrics, reference] - 1.0)).abs().max()
        )
        lines.append(f"- {check.split(', ', 1)[1]}: the DOP metrics move by at most {move:.2f}%")
    return lines
