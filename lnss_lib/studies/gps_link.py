"""Notebook 03: how many GPS satellites does an LNSS satellite see, and with what PDOP? (paper Section 2.2,
eq. 15-24, Table 1, Table 4, Figure 7)

Question: with real GPS orbits (SGP4 from TLEs), the published transmit gain patterns and the link
budget of Table 1, how many GPS satellites are visible from the first satellite of the standalone
ELFO, what is the GPS-LNSS PDOP, and which assumptions (noise temperature, gain pattern, sidelobes,
beam mask, atmospheric margin, ellipsoid test, clock column, filter, GPS phase, orbit model) move
them?

Verdict: the visible count is close to the paper's, and most visible links arrive through the
transmit sidelobes; the PDOP is dominated by the error along the Earth direction, where nearly
parallel lines of sight and the receiver clock cannot be told apart, so it is large whatever the
setting; the paper's PDOP would need lines of sight less spread in angle at the same count than
the real GPS geometry gives. The notebook prints the numbers behind each statement.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import xarray as xr

from ..constants import BOLTZMANN_J_K, SECONDS_PER_DAY
from ..constellation import two_body_positions_mci
from ..gain_pattern import gain_for_settings
from ..geometry import filtered_mean
from ..gps import (
    cn0_dbhz,
    free_space_loss_db,
    gps_link,
    gps_link_summary,
    pdop_along_axis,
)
from ..gps_states import gps_states_mci
from ..paper import TABLE_4, TABLE_4_LABEL
from ..propagator import propagate_elements

if TYPE_CHECKING:
    from ..settings import BodyConstants, GpsSettings, Settings

__all__ = [
    "GAIN_COLUMNS",
    "GPS_ORBIT_RADIUS_KM",
    "MEAN_EARTH_MOON_KM",
    "LINK_STATUS",
    "catalogue_table",
    "link_budget_table",
    "gps_link_sensitivity",
    "off_boresight_limits",
    "cn0_curves",
    "earth_plane_projection",
    "link_status",
    "link_test_counts",
    "visible_share_by_prn",
    "main_lobe_share",
    "paper_comparison_table",
    "decomposition_table",
    "pdop_split",
    "pdop_decomposition",
    "sensitivity_variants",
    "sensitivity_table",
    "per_satellite_summary",
    "pdop_at_visible_count",
    "sensitivity_findings",
]

GAIN_COLUMNS = (
    "improved_panel_dbi",
    "legacy_iir_dbi",
    "iirm_dbavg_dbi",
    "iirm_min_dbi",
    "iirm_max_dbi",
)


GPS_ORBIT_RADIUS_KM = 26560.0  # nominal, for the off-boresight schematic


MEAN_EARTH_MOON_KM = 384400.0  # mean Earth-Moon distance of the link-budget tables


LINK_STATUS = (
    "Moon blocks",
    "Earth (+margin) blocks",
    "outside beam",
    "C/N0 < 15 dB-Hz",
    "visible",
)


def catalogue_table(catalogue: list[dict], start_tdb: str) -> pd.DataFrame:
    """:func:`lnss_lib.tle.gps_catalogue`'s selection rows as a table with ``days_back_from_tle`` (TLE epoch - simulation start date, days:
    how far SGP4 runs backwards) and the dates as ISO text."""
    start = pd.Timestamp(start_tdb[:10])
    out = pd.DataFrame(catalogue)
    out["days_back_from_tle"] = [
        (pd.Timestamp(e) - start).total_seconds() / SECONDS_PER_DAY for e in out["tle_epoch_utc"]
    ]
    out["tle_epoch_utc"] = [
        pd.Timestamp(e).strftime("%Y-%m-%d %H:%M:%S") for e in out["tle_epoch_utc"]
    ]  # to the second
    return out.astype({"launch_date": str})


def link_budget_table(
    gps: GpsSettings, theta_off_deg, distance_km: float, **overrides
) -> pd.DataFrame:
    """Table 1 / eq. 22-24 budget terms against off-boresight angle at one GPS-LNSS distance.

    Columns: gain_dbi, eirp_dbw, fsl_db, g_rx_dbi, ktn_dbw_hz (10 log10 k T), cn0_dbhz and
    receivable (C/N0 >= threshold). ``gps``: the ``[gps]`` section; ``overrides``: ``[gps]`` keys as in
    :func:`gps_link`.
    """
    names = [item.name for item in dataclasses.fields(gps) if item.init]
    unknown = set(overrides) - set(names)
    if unknown:
        raise ValueError(f"unknown GPS link setting(s) {sorted(unknown)}; allowed: {sorted(names)}")
    cfg = dataclasses.replace(gps, **overrides)
    theta = np.atleast_1d(np.asarray(theta_off_deg, dtype=float))
    gain = gain_for_settings(cfg)(theta)
    losses = float(cfg.l_tx_db) + float(cfg.l_pol_db)
    freq = float(cfg.frequency_mhz) * 1e6
    cn0 = cn0_dbhz(
        gain,
        distance_km,
        p_tx_dbw=float(cfg.p_tx_dbw),
        losses_db=losses,
        g_rx_dbi=float(cfg.g_rx_dbi),
        frequency_hz=freq,
        noise_temperature_k=float(cfg.noise_temperature_k),
    )
    return pd.DataFrame(
        {
            "off_boresight_deg": theta,
            "gain_dbi": gain,
            "eirp_dbw": float(cfg.p_tx_dbw) - losses + gain,
            "fsl_db": free_space_loss_db(np.full(theta.shape, float(distance_km)), freq),
            "g_rx_dbi": float(cfg.g_rx_dbi),
            "ktn_dbw_hz": 10.0 * np.log10(BOLTZMANN_J_K * float(cfg.noise_temperature_k)),
            "cn0_dbhz": cn0,
            "receivable": np.nan_to_num(cn0, nan=-np.inf) >= float(cfg.cn0_threshold_dbhz),
        }
    ).set_index("off_boresight_deg")


def gps_link_sensitivity(
    gps: GpsSettings,
    constants: BodyConstants,
    gps_states: xr.Dataset,
    lnss,
    variants: dict[str, dict],
    *,
    sats="first",
) -> pd.DataFrame:
    """Summary (:func:`gps_link_summary`) of :func:`gps_link` for each named set of ``[gps]`` overrides.

    ``variants`` maps a label to overrides (``{}`` = the ``[gps]`` settings); a ``pdop_filter`` key
    changes only the summary's filter. Returns one row per variant.
    """
    rows = []
    for label, over in variants.items():
        over = dict(over)
        method = over.pop("pdop_filter", None)
        ds = gps_link(gps, constants, gps_states, lnss, sats=sats, **over)
        rows.append({"variant": label, **gps_link_summary(ds, method)})
    return pd.DataFrame(rows).set_index("variant")


def off_boresight_limits(
    gps: GpsSettings,
    constants: BodyConstants,
    distance_km: float = MEAN_EARTH_MOON_KM,
    r_gps_km: float = GPS_ORBIT_RADIUS_KM,
    step_deg: float = 0.1,
) -> dict[str, float]:
    """Angles (deg) that split the GPS transmit cone for a receiver at ``distance_km`` (eq. 19-24).

    ``earth_limb_deg`` asin(R_earth / r_GPS), ``limb_with_margin_deg`` (+ the atmospheric margin,
    eq. 21), ``sidelobe_from_deg``, ``last_receivable_deg`` (largest angle inside the beam mask with
    C/N0 >= threshold on a ``step_deg`` grid over 0-90 deg) and ``beam_mask_deg``; also the radii
    ``r_gps_km`` and ``r_earth_km``.
    """
    r_earth = constants.r_earth_km
    alpha = np.degrees(np.arcsin(r_earth / r_gps_km))
    fine = np.arange(0.0, 90.01, step_deg)
    receivable = link_budget_table(gps, fine, distance_km)["receivable"].values
    inside = (fine <= gps.beam_mask_deg) & receivable
    if not inside.any():
        raise ValueError(
            f"no off-boresight angle inside the {gps.beam_mask_deg} deg beam mask reaches "
            f"{gps.cn0_threshold_dbhz} dB-Hz at {distance_km} km"
        )
    return {
        "earth_limb_deg": float(alpha),
        "limb_with_margin_deg": float(alpha + gps.atmosphere_margin_deg),
        "sidelobe_from_deg": gps.sidelobe_from_deg,
        "last_receivable_deg": float(fine[inside].max()),
        "beam_mask_deg": gps.beam_mask_deg,
        "r_gps_km": float(r_gps_km),
        "r_earth_km": r_earth,
    }


def cn0_curves(
    gps: GpsSettings, theta_off_deg, distance_km: float, variants: dict[str, dict]
) -> pd.DataFrame:
    """C/N0 (dB-Hz, eq. 22-24) against off-boresight angle (index) for each named set of ``[gps]`` overrides."""
    theta = np.atleast_1d(np.asarray(theta_off_deg, dtype=float))
    curves = {
        label: link_budget_table(gps, theta, distance_km, **over)["cn0_dbhz"].values
        for label, over in variants.items()
    }
    return pd.DataFrame(curves, index=pd.Index(theta, name="off_boresight_deg"))


def earth_plane_projection(
    r_gps_mci_km: np.ndarray, earth_mci_km: np.ndarray, r_lnss_mci_km: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GPS positions seen from an LNSS satellite, projected on the plane through the Earth's centre
    perpendicular to the LNSS -> Earth direction: (x_km, y_km) (time, gps) and that direction (time, 3).

    Inputs Moon-centred J2000 km: ``r_gps_mci_km`` (time, gps, 3), ``earth_mci_km`` and
    ``r_lnss_mci_km`` (time, 3). x is along e_hat x z_J2000, y completes the right-handed pair.
    """
    to_earth = np.asarray(earth_mci_km, dtype=float) - np.asarray(r_lnss_mci_km, dtype=float)
    e_hat = to_earth / np.linalg.norm(to_earth, axis=-1, keepdims=True)
    u1 = np.cross(e_hat, [0.0, 0.0, 1.0])
    u1 /= np.linalg.norm(u1, axis=-1, keepdims=True)
    u2 = np.cross(e_hat, u1)
    rel = np.asarray(r_gps_mci_km, dtype=float) - np.asarray(earth_mci_km, dtype=float)[:, None, :]
    return np.einsum("tgi,ti->tg", rel, u1), np.einsum("tgi,ti->tg", rel, u2), e_hat


def link_status(link_one: xr.Dataset) -> np.ndarray:
    """Label (:data:`LINK_STATUS`) of every (time, gps) link of one satellite of :func:`gps_link`: the first
    test that fails (Moon, Earth or ellipsoid, beam, C/N0), else ``visible``."""
    return np.select(
        [
            link_one["moon_blocked"].values,
            (link_one["earth_blocked"] | link_one["ellipsoid_blocked"]).values,
            link_one["outside_beam"].values,
            ~link_one["above_threshold"].values,
        ],
        list(LINK_STATUS[:4]),
        LINK_STATUS[4],
    )


def link_test_counts(link_one: xr.Dataset) -> pd.Series:
    """How many (gps, epoch) pairs of one satellite each test removes, and how many stay visible."""
    visible = link_one["visible"].values
    return pd.Series(
        {
            "all (gps, epoch) pairs": visible.size,
            "Moon blocks": int(link_one["moon_blocked"].sum()),
            "Earth + margin blocks (eq. 21)": int(link_one["earth_blocked"].sum()),
            "WGS-84 ray test blocks (beyond eq. 21)": int(
                (link_one["ellipsoid_blocked"] & ~link_one["earth_blocked"]).sum()
            ),
            "outside beam mask": int(link_one["outside_beam"].sum()),
            "C/N0 below threshold (geometry ok)": int(
                (
                    ~link_one["above_threshold"]
                    & ~link_one["moon_blocked"]
                    & ~link_one["earth_blocked"]
                    & ~link_one["outside_beam"]
                ).sum()
            ),
            "visible": int(visible.sum()),
        }
    )


def visible_share_by_prn(link_one: xr.Dataset) -> pd.Series:
    """Share of epochs at which each GPS satellite (index: PRN, sorted) is visible to one LNSS satellite."""
    return pd.Series(
        link_one["visible"].values.mean(axis=0), index=link_one["prn"].values
    ).sort_index()


def main_lobe_share(link_one: xr.Dataset, sidelobe_from_deg: float) -> float:
    """Share of the visible links of one satellite with theta_off below ``sidelobe_from_deg`` (main-lobe edge)."""
    theta = link_one["theta_off_deg"].values[link_one["visible"].values]
    return float(np.mean(theta < sidelobe_from_deg))


def paper_comparison_table(summary: dict, paper: dict | None = None) -> pd.DataFrame:
    """Mean visible GPS and filtered mean PDOP (:func:`gps_link_summary`) beside Table 4, with their ratio."""
    paper = TABLE_4 if paper is None else paper
    table = pd.DataFrame(
        {
            "this work": [summary["gps_visible_mean"], summary["gps_pdop_mean"]],
            TABLE_4_LABEL: [paper["gps_visible_mean"], paper["gps_pdop_mean"]],
        },
        index=["mean visible GPS", "mean PDOP (95th-percentile filter)"],
    )
    table["ratio"] = table["this work"] / table[TABLE_4_LABEL]
    return table


def decomposition_table(pdop, along, across, pdop_no_clock) -> pd.DataFrame:
    """Median, 95th-percentile-filtered mean and unfiltered mean of the PDOP (eq. 5-7), its parts along
    and across the Earth direction (:func:`pdop_along_axis`) and the PDOP without the clock column."""
    series = [np.asarray(v, dtype=float) for v in (pdop, along, across, pdop_no_clock)]
    return pd.DataFrame(
        {
            "median": [np.nanmedian(v) for v in series],
            "95th-percentile-filtered mean": [filtered_mean(v)[0] for v in series],
            "unfiltered mean": [np.nanmean(v) for v in series],
        },
        index=[
            "PDOP (eq. 5-7, clock column)",
            "  error along the Earth direction",
            "  error across it",
            "PDOP without clock column",
        ],
    )


def pdop_split(
    gps: GpsSettings,
    constants: BodyConstants,
    gps_states: xr.Dataset,
    lnss: xr.Dataset,
    link: xr.Dataset | None = None,
) -> dict[str, np.ndarray]:
    """PDOP of the first LNSS satellite of a propagation at every epoch (``pdop``), its parts ``along`` and
    ``across`` the LNSS -> Earth direction (:func:`pdop_along_axis`) and ``pdop_no_clock`` (eq. 5-7 without
    the clock column); ``link``: its :func:`gps_link` (computed when not given)."""
    link = gps_link(gps, constants, gps_states, lnss) if link is None else link
    first = link.isel(sat=0)
    r_lnss = lnss["r_mci_km"].transpose("sat", "time", "xyz").values[0]
    to_earth = gps_states["earth_mci_km"].values - r_lnss
    e_hat = to_earth / np.linalg.norm(to_earth, axis=-1, keepdims=True)
    los = gps_states["r_mci_km"].transpose("time", "gps", "xyz").values - r_lnss[:, None, :]
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    along, across = pdop_along_axis(los, first["visible"].values, e_hat)
    no_clock = gps_link(gps, constants, gps_states, lnss, clock_column=False)
    return {
        "pdop": first["pdop"].values,
        "along": along,
        "across": across,
        "pdop_no_clock": no_clock["pdop"].values[0],
    }


def pdop_decomposition(
    gps: GpsSettings,
    constants: BodyConstants,
    gps_states: xr.Dataset,
    lnss: xr.Dataset,
    link: xr.Dataset | None = None,
) -> pd.DataFrame:
    """:func:`decomposition_table` of :func:`pdop_split`: why the GPS-LNSS PDOP is so large."""
    return decomposition_table(**pdop_split(gps, constants, gps_states, lnss, link))


def sensitivity_variants(gps: GpsSettings) -> dict[str, dict]:
    """The one-at-a-time ``[gps]`` variants of the sensitivity study (labels -> overrides): noise temperature,
    gain column, sidelobe level, beam mask, atmospheric margin, ellipsoid test, clock column and filter."""
    default_column = gps.gain_column
    variants: dict[str, dict] = {"default": {}}
    variants.update(
        {
            f"T = {t:.0f} K": {"noise_temperature_k": t}
            for t in (100.0, 150.0, 230.0, 270.0, 300.0, 350.0, 400.0)
        }
    )
    variants.update({f"gain {c}": {"gain_column": c} for c in GAIN_COLUMNS if c != default_column})
    variants.update(
        {
            f"sidelobes {o:+g} dB": {"sidelobe_offset_db": o}
            for o in (-6.0, -3.0, -1.0, 1.0, 3.0, 6.0)
        }
    )
    variants["main lobe only"] = {"sidelobe_offset_db": -np.inf}
    variants.update(
        {
            f"beam mask {b:.0f} deg": {"beam_mask_deg": b}
            for b in (30.0, 40.0, 50.0, 60.0, 80.0, 90.0)
        }
    )
    variants["no atmospheric margin"] = {"atmosphere_margin_deg": 0.0}
    variants["no ellipsoid test"] = {"ellipsoid_test": False}
    variants["no clock column"] = {"clock_column": False}
    variants["filter: 2-sigma clip"] = {"pdop_filter": "sigma2"}
    variants["filter: none"] = {"pdop_filter": "none"}
    return variants


def sensitivity_table(
    settings: Settings,
    gps: xr.Dataset,
    lnss: xr.Dataset,
    elements_deg,
    *,
    phase_shifts_days=(-30.0, -7.0, 7.0, 30.0),
    paper: dict | None = None,
) -> pd.DataFrame:
    """Summary of the first satellite's link for every :func:`sensitivity_variants` entry, then for a
    Keplerian orbit, the elements referred to the J2000 equator, and GPS phases shifted by running SGP4
    at t + shift; column ``pdop_ratio_to_paper`` divides the mean PDOP by Table 4's.

    ``lnss``: the propagation of ``elements_deg`` (nsat, 6) with ``profile``; ``gps`` on its epochs.
    """
    paper = TABLE_4 if paper is None else paper
    el = np.asarray(elements_deg, dtype=float)
    times = lnss["time"].values
    gps_cfg, constants = settings.gps, settings.constants
    sens = gps_link_sensitivity(gps_cfg, constants, gps, lnss, sensitivity_variants(gps_cfg))
    extra = {
        "Keplerian ELFO orbit": gps_link_summary(
            gps_link(
                gps_cfg, constants, gps, two_body_positions_mci(settings.dynamics, el[:1], times)
            )
        )
    }
    p_j2000 = settings.with_overrides({"frames": {"element_frame": "j2000"}})
    extra["elements in J2000 equator"] = gps_link_summary(
        gps_link(
            gps_cfg, constants, gps, propagate_elements(p_j2000.dynamics, p_j2000.epoch, el[:1])
        )
    )
    for shift_days in phase_shifts_days:
        shifted = gps_states_mci(
            gps_cfg, settings.epoch.start_tdb, times, sgp4_offset_s=shift_days * SECONDS_PER_DAY
        )
        extra[f"GPS phase: SGP4 at t {shift_days:+.0f} d"] = gps_link_summary(
            gps_link(gps_cfg, constants, shifted, lnss)
        )
    sens = pd.concat([sens, pd.DataFrame(extra).T])
    sens["pdop_ratio_to_paper"] = sens["gps_pdop_mean"] / paper["gps_pdop_mean"]
    return sens


def per_satellite_summary(link_all: xr.Dataset) -> pd.DataFrame:
    """:func:`gps_link_summary` of each LNSS satellite of a ``sats="all"`` :func:`gps_link` (index: satellite,
    an explicit integer index so that tables keep it)."""
    sats = [int(s) for s in link_all["sat"].values]
    table = pd.DataFrame({s: gps_link_summary(link_all.sel(sat=[s])) for s in sats}).T
    table.index = pd.Index(sats, dtype="int64", name="satellite")
    return table


def pdop_at_visible_count(sens: pd.DataFrame, n_visible: float, prefix: str = "T = ") -> float:
    """Mean PDOP at ``n_visible`` mean visible GPS satellites, log-linearly interpolated along the sweep of
    :func:`sensitivity_table` rows whose label starts with ``prefix`` (default: the noise temperature) plus
    ``default``."""
    rows = [k for k in sens.index if k.startswith(prefix)] + ["default"]
    sweep = sens.loc[rows].sort_values("gps_visible_mean")
    return float(
        np.exp(np.interp(n_visible, sweep["gps_visible_mean"], np.log(sweep["gps_pdop_mean"])))
    )


def sensitivity_findings(
    sens: pd.DataFrame, decomposition: pd.DataFrame, main_share: float, paper: dict | None = None
) -> list[str]:
    """Markdown bullet lines with the key numbers of a run: visibility and PDOP against Table 4, main-lobe
    share, PDOP decomposition, the gain-column, noise-temperature and filter sensitivities, and the PDOP
    that the noise-temperature sweep gives at the paper's visible count."""
    paper = TABLE_4 if paper is None else paper
    d = sens.loc["default"]
    s = sens["gps_pdop_mean"]
    v = sens["gps_visible_mean"]
    at_paper = pdop_at_visible_count(sens, paper["gps_visible_mean"])
    return [
        f"- mean visible GPS: **{d['gps_visible_mean']:.2f}** (paper {paper['gps_visible_mean']}); mean PDOP "
        f"(95th-percentile filter): **{d['gps_pdop_mean']:.0f}** (paper {paper['gps_pdop_mean']:.0f}, ratio "
        f"{d['gps_pdop_mean'] / paper['gps_pdop_mean']:.2f}); "
        f"epochs with a PDOP: {100 * d['gps_pdop_available_fraction']:.1f}%",
        f"- visible links in the main-lobe edge: {100 * main_share:.1f}%, in sidelobes: {100 * (1 - main_share):.1f}%",
        f"- PDOP error along the Earth direction (median) {decomposition.iloc[1]['median']:.0f}, across it "
        f"{decomposition.iloc[2]['median']:.1f}; without clock column the mean PDOP is {s['no clock column']:.1f}",
        f"- legacy IIR column: {v['gain legacy_iir_dbi']:.2f} visible, PDOP {s['gain legacy_iir_dbi']:.0f} (prototype ~650)",
        f"- T = 100 / 300 / 400 K: visible {v['T = 100 K']:.2f} / {v['T = 300 K']:.2f} / {v['T = 400 K']:.2f}, PDOP "
        f"{s['T = 100 K']:.0f} / {s['T = 300 K']:.0f} / {s['T = 400 K']:.0f}",
        f"- filters: 95th percentile {d['gps_pdop_mean']:.0f}, 2-sigma clip {s['filter: 2-sigma clip']:.0f}, "
        f"none {s['filter: none']:.0f}",
        f"- along the noise-temperature sweep, {paper['gps_visible_mean']} visible satellites go with a mean PDOP of "
        f"about {at_paper:.0f}: the paper's {paper['gps_pdop_mean']:.0f} is {paper['gps_pdop_mean'] / at_paper:.1f} times "
        "that. Since the along-Earth error scales as 1 / (N^(1/2) x spread of rho^2), the paper's PDOP would need the "
        f"visible lines of sight about {np.sqrt(paper['gps_pdop_mean'] / at_paper):.1f} times less spread in angle at "
        "the same count",
    ]
