"""Notebooks 03 and 05: what does each GNSS add at the Moon? (the paper's closing remark, Section 7)

Question: with Galileo, BeiDou-3 (MEO, IGSO, GEO) and GLONASS at their published nominal slots, each
given the GPS budget of Table 1 shifted to its own ICD minimum received power (:mod:`lnss_lib.gnss`),
how many satellites of each system does the first satellite of the standalone ELFO see, what is the
GNSS-LNSS PDOP of each system and of GPS + Galileo and all four (one clock offset per system), and
how do both move with the receiver's noise temperature?

Verdict: every system adds links through the same sidelobe window as GPS, so the visible count
roughly adds up; the PDOP falls with the count but stays in the hundreds, because every GNSS
satellite seen from the Moon lies within a few degrees of the Earth's direction and each added
system brings its own clock, which absorbs the common range along that direction just as GPS's
does. A colder receiver raises every system's count. The notebooks print the numbers.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..gnss import (
    combined_pdop,
    gnss_link_arrays,
    gnss_link_summary,
    gnss_states_mci,
    system_transmitters,
)
from ..keys import GNSS_NAMES

if TYPE_CHECKING:
    from ..settings import Settings

__all__ = [
    "SYSTEMS",
    "SYSTEM_LABELS",
    "COMBINATIONS",
    "TEMPERATURES_K",
    "first_satellite_link",
    "system_table",
    "time_series",
    "noise_temperature_sweep",
    "table4_gnss_rows",
    "gnss_findings",
]

SYSTEMS = ("gps", "galileo", "beidou", "glonass")
SYSTEM_LABELS = GNSS_NAMES
COMBINATIONS = {"GPS + Galileo": ("gps", "galileo"), "all four": SYSTEMS}
TEMPERATURES_K = (100.0, 150.0, 190.0, 230.0, 300.0, 400.0)  # around the 190 K default (LuPNT)


def first_satellite_link(
    settings: Settings, prop: xr.Dataset, systems=SYSTEMS, **gps_overrides
) -> dict:
    """Per-epoch visible count (time, system) and centred scatter (time, system, 6) of the first satellite of a
    propagation to every satellite of ``systems``, with ``[gps]`` changed by ``gps_overrides`` (e.g.
    ``noise_temperature_k``); also ``systems``, ``time`` (TDB s) and the ``[gps]`` section used."""
    gps = dataclasses.replace(settings.gps, **gps_overrides)
    gnss = dataclasses.replace(settings.gnss, systems=tuple(systems))
    times = prop["time"].values
    states = gnss_states_mci(gnss, settings.gps, settings.epoch.start_tdb, times)
    counts, scatter = gnss_link_arrays(
        gps,
        settings.constants,
        states,
        system_transmitters(gnss, gps, states),
        prop["r_mci_km"].values[0],
    )
    return {
        "counts": counts,
        "scatter": scatter,
        "systems": tuple(systems),
        "time": times,
        "gps": gps,
    }


def _groups(systems) -> dict[str, tuple[str, ...]]:
    """Each system alone, then the :data:`COMBINATIONS` whose systems are all present (labels -> members)."""
    groups = {SYSTEM_LABELS[s]: (s,) for s in systems}
    groups.update(
        {label: members for label, members in COMBINATIONS.items() if set(members) <= set(systems)}
    )
    return groups


def system_table(link: dict) -> pd.DataFrame:
    """Mean visible satellites, filtered mean PDOP (the ``[gps]`` filter) and the share of epochs with a PDOP of
    each system and combination (:func:`lnss_lib.gnss.gnss_link_summary`)."""
    gps = link["gps"]
    groups = _groups(link["systems"])
    summary = gnss_link_summary(
        link["counts"], link["scatter"], link["systems"], groups, gps.pdop_filter, gps.clock_column
    )
    return pd.DataFrame(
        [summary[label] for label in groups], index=pd.Index(list(groups), name="systems")
    )


def time_series(link: dict) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(visible count, PDOP) at every epoch (index: days since the first) for each system and combination."""
    days = pd.Index((link["time"] - link["time"][0]) / SECONDS_PER_DAY, name="days")
    systems = list(link["systems"])
    visible, pdop = {}, {}
    for label, members in _groups(systems).items():
        visible[label] = link["counts"][:, [systems.index(m) for m in members]].sum(axis=1)
        pdop[label] = combined_pdop(
            link["counts"], link["scatter"], systems, members, link["gps"].clock_column
        )
    return pd.DataFrame(visible, index=days), pd.DataFrame(pdop, index=days)


def noise_temperature_sweep(
    settings: Settings, prop: xr.Dataset, temperatures_k=TEMPERATURES_K
) -> pd.DataFrame:
    """:func:`system_table` for each receiver noise temperature (rows: temperature K, systems)."""
    tables = {
        t: system_table(first_satellite_link(settings, prop, noise_temperature_k=float(t)))
        for t in temperatures_k
    }
    return pd.concat(tables, names=["noise_temperature_k"])


def table4_gnss_rows(table: pd.DataFrame) -> pd.DataFrame:
    """Table 4's GPS rows extended to every GNSS (no paper value: the paper has GPS only): mean visible satellites
    and PDOP of all four systems and of GPS + Galileo, from :func:`system_table`."""
    rows = []
    for label in ("all four", "GPS + Galileo"):
        rows.append(
            {
                "metric": f"Mean GNSS visibility ({label})",
                "paper": np.nan,
                "this workbook": table.loc[label, "visible_mean"],
                "why": "Not in the paper, which asks for it in its conclusion; nominal slots and the GPS budget "
                "shifted to each system's ICD minimum power (notebook 03).",
            }
        )
        rows.append(
            {
                "metric": f"Mean GNSS-LNSS PDOP ({label}, one clock per system)",
                "paper": np.nan,
                "this workbook": table.loc[label, "pdop_mean"],
                "why": "Filtered as the GPS row ([gps] pdop_filter); each system's clock offset is unknown.",
            }
        )
    return pd.DataFrame(rows)


def gnss_findings(table: pd.DataFrame, sweep: pd.DataFrame) -> list[str]:
    """Markdown lines with this run's numbers: the count and PDOP of GPS and of all four, and the count range over
    the noise-temperature sweep."""
    gps, every = table.loc["GPS"], table.loc["all four"]
    span = sweep.xs("all four", level="systems")["visible_mean"]
    return [
        f"All four systems: **{every['visible_mean']:.2f}** visible satellites on average against GPS's "
        f"**{gps['visible_mean']:.2f}**; filtered mean PDOP **{every['pdop_mean']:.0f}** against "
        f"**{gps['pdop_mean']:.0f}** (ratio {every['pdop_mean'] / gps['pdop_mean']:.2f}).",
        f"Over receiver noise temperatures {span.index.min():.0f}-{span.index.max():.0f} K the four systems' "
        f"mean count runs from {span.max():.2f} to {span.min():.2f}.",
    ]
