"""Notebook 03's GNSS study (lnss_lib.studies.gnss_link) on a synthetic link: groups, time series, findings."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from lnss_lib.studies import gnss_link as gnl


class _Receiver:
    pdop_filter = "none"
    clock_column = True


def _link():
    """Two epochs, GPS and Galileo: four and five spread lines of sight at the first, one Galileo at the second."""
    rng = np.random.default_rng(5)
    counts = np.array([[4, 5], [0, 1]])
    scatter = np.zeros((2, 2, 6))
    for s, n in enumerate(counts[0]):
        los = rng.normal(size=(n, 3))
        los /= np.linalg.norm(los, axis=1, keepdims=True)
        d = los - los.mean(axis=0)
        scatter[0, s] = [
            d[:, 0] @ d[:, 0],
            d[:, 1] @ d[:, 1],
            d[:, 2] @ d[:, 2],
            d[:, 0] @ d[:, 1],
            d[:, 0] @ d[:, 2],
            d[:, 1] @ d[:, 2],
        ]
    return {
        "counts": counts,
        "scatter": scatter,
        "systems": ("gps", "galileo"),
        "time": np.array([0.0, 43200.0]),
        "gps": _Receiver(),
    }


def test_groups_table_and_time_series_agree():
    link = _link()
    table = gnl.system_table(link)
    assert list(table.index) == [
        "GPS",
        "Galileo",
        "GPS + Galileo",
    ]  # "all four" needs all four systems
    assert table.loc["GPS + Galileo", "visible_mean"] == pytest.approx(5.0)  # (9 + 1) / 2
    assert (
        table.loc["GPS + Galileo", "pdop_available_fraction"] == 0.5
    )  # one Galileo alone gives no fix
    visible, pdop = gnl.time_series(link)
    assert list(visible.index) == [0.0, 0.5] and visible["GPS + Galileo"].tolist() == [9, 1]
    assert pdop["GPS + Galileo"].iloc[0] < min(
        pdop["GPS"].iloc[0], pdop["Galileo"].iloc[0]
    )  # more lines, lower PDOP
    assert table.loc["GPS", "pdop_mean"] == pytest.approx(pdop["GPS"].iloc[0])


def test_table4_rows_and_findings_print_the_table():
    table = pd.DataFrame(
        {
            "visible_mean": [6.0, 12.0, 18.0],
            "pdop_mean": [1000.0, 700.0, 600.0],
            "pdop_available_fraction": [1.0, 1.0, 1.0],
        },
        index=pd.Index(["GPS", "GPS + Galileo", "all four"], name="systems"),
    )
    rows = gnl.table4_gnss_rows(table).set_index("metric")
    assert rows.loc["Mean GNSS visibility (all four)", "this workbook"] == 18.0
    assert np.isnan(rows["paper"]).all() and rows["why"].notna().all()
    sweep = pd.concat(
        {100.0: table.assign(visible_mean=table["visible_mean"] + 2), 400.0: table},
        names=["noise_temperature_k"],
    )
    lines = gnl.gnss_findings(table, sweep)
    assert "**18.00**" in lines[0] and "**6.00**" in lines[0] and "ratio 0.60" in lines[0]
    assert "100-400 K" in lines[1] and "from 20.00 to 18.00" in lines[1]
