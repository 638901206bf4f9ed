"""Frozen-orbit figures (notebook 08): every family curve and every orbit drawn, bars to the frozen i."""

import numpy as np
import pandas as pd

from lnss_lib.figures import frozen_family_chart, perilune_envelope


def test_frozen_family_chart_draws_each_curve_and_orbit():
    family = pd.DataFrame(
        {
            "sma_km": [5000.0, 9000.0] * 2,
            "curve": ["i at e = 0.6"] * 2 + ["e at i = 56.2 deg"] * 2,
            "inc_deg": [53.9, 52.0, 56.2, 56.2],
            "ecc": [0.6, 0.6, 0.65, 0.69],
        }
    )
    orbits = pd.DataFrame(
        {
            "orbit": ["A", "B"],
            "read_in": ["moon_op", "lunar equator"],
            "epoch": ["study"] * 2,
            "sma_km": [6143.0, 6143.0],
            "ecc_op": [0.6, 0.6],
            "inc_op_deg": [51.7, 128.3],
            "aop_op_deg": [90.0, 98.0],
            "frozen_inc_deg": [52.6, 52.6],
            "ecc_min": [0.58, 0.5],
            "ecc_max": [0.6, 0.65],
            "verdict": ["frozen", "librating"],
        }
    )
    fig = frozen_family_chart(family, orbits, title="t")
    names = [t.name for t in fig.data]
    assert "i at e = 0.6" in names and "e at i = 56.2 deg" in names
    points = [t for t in fig.data if t.mode == "markers"]
    assert len(points) == 4  # two groups, two panels each
    assert (
        max(y for t in points for y in t.y if y is not None) <= 90.0
    )  # retrograde read as 180 - i
    bars = [t for t in fig.data if t.mode == "lines" and t.showlegend is False]
    assert {tuple(np.round(b.y[:2], 1)) for b in bars} == {(51.7, 52.6), (51.7, 52.6)}


def test_frozen_family_chart_labels_its_curves_and_keeps_the_legend_for_the_orbits():
    """A legend entry per orbit group (verdict, frame) and none per family curve (each labelled at its end);
    the log a axis ticked in plain kilometres, never plotly's "10k ... 2"."""
    family = pd.DataFrame(
        {
            "sma_km": np.tile(np.geomspace(2500.0, 25000.0, 5), 3),
            "curve": np.repeat(["i at e = 0.6", "i at e = 0.7", "e at i = 56.2 deg"], 5),
            "inc_deg": np.r_[np.full(5, 53.9), np.full(5, 52.0), np.full(5, 56.2)],
            "ecc": np.r_[np.full(5, 0.6), np.full(5, 0.7), np.full(5, 0.65)],
        }
    )
    orbits = pd.DataFrame(
        {
            "orbit": ["A"],
            "read_in": ["moon_op"],
            "epoch": ["study"],
            "sma_km": [6143.0],
            "ecc_op": [0.6],
            "inc_op_deg": [51.7],
            "aop_op_deg": [90.0],
            "frozen_inc_deg": [52.6],
            "ecc_min": [0.58],
            "ecc_max": [0.6],
            "verdict": ["frozen"],
        }
    )
    fig = frozen_family_chart(family, orbits, title="t")
    legend = [t.name for t in fig.data if t.showlegend is not False]
    assert legend == ["frozen, moon_op"]
    curves = [t for t in fig.data if t.mode == "lines+text"]
    assert [t.text[-1] for t in curves] == ["e 0.6", "e 0.7", "i 56.2 deg"]
    assert all(not label for t in curves for label in t.text[:-1])
    axis = fig.layout.xaxis
    assert axis.type == "log" and list(axis.ticktext) == [
        "3,000",
        "5,000",
        "7,000",
        "10,000",
        "15,000",
        "20,000",
        "30,000",
    ]
    assert 10.0 ** axis.range[1] > 25000.0  # room right of the curves for their labels


def test_perilune_envelope_draws_full_and_mean_per_satellite():
    t = np.linspace(0.0, 365.0, 10)
    fig = perilune_envelope(
        t,
        np.full((2, 10), 300.0),
        t,
        np.full((2, 10), 350.0),
        100.0,
        names=["a", "b"],
        floor_km=100.0,
        title="t",
    )
    assert len(fig.data) == 4 and np.allclose(fig.data[1].y, 250.0)
