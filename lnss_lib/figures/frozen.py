"""Frozen orbits (notebook 08): the frozen family against a with published orbits placed on it, and a perilune
history against its mean and short-period envelope."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from plotly.colors import sample_colorscale

from ..constants import DAYS_PER_JULIAN_YEAR

_READ_SYMBOLS = {"moon_op": "circle", "lunar equator": "diamond-open"}
_A_TICKS_KM = (1000, 2000, 3000, 5000, 7000, 10000, 15000, 20000, 30000, 50000)
_VERDICT_COLOURS = {
    "frozen": "#2ca02c",
    "librating": "#1f77b4",
    "circulating": "#ff7f0e",
    "reaches the surface": "#d62728",
}


def frozen_family_chart(family, orbits, *, title: str) -> go.Figure:
    """Left: frozen i against a, one line per e; right: frozen e against a, one line per i (``family``:
    :func:`lnss_lib.studies.frozen_orbits.frozen_family`). Orbits (``orbits``: rows of
    :func:`lnss_lib.studies.frozen_orbits.published_orbits`) at (a, i in ``moon_op``) and (a, e), symbol by the
    frame their elements are read in, colour by verdict; a vertical bar on the left joins each to the frozen i
    at its own e."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=1,
        cols=2,
        horizontal_spacing=0.08,
        subplot_titles=("frozen i (to the Earth-Moon plane) against a", "frozen e against a"),
    )
    for col, (prefix, y_key) in enumerate((("i at", "inc_deg"), ("e at", "ecc")), start=1):
        curves = family[family["curve"].str.startswith(prefix)].groupby("curve", sort=False)
        colours = sample_colorscale("Viridis", np.linspace(0.0, 0.85, len(curves)))
        for (curve, rows), colour in zip(curves, colours):
            tag = curve.removeprefix(prefix).strip().replace(" = ", " ")
            fig.add_trace(
                go.Scatter(
                    x=rows["sma_km"],
                    y=rows[y_key],
                    mode="lines+text",
                    name=curve,
                    line={"width": 1.5, "color": colour},
                    text=[""] * (len(rows) - 1) + [tag],
                    textposition="middle right",
                    textfont={"color": colour, "size": 11},
                    showlegend=False,
                    hovertemplate=f"{curve}<extra></extra>",
                ),
                row=1,
                col=col,
            )  # each curve labelled at its end: the legend keeps the orbits alone
    inc = np.where(orbits["inc_op_deg"] <= 90.0, orbits["inc_op_deg"], 180.0 - orbits["inc_op_deg"])
    for (read_in, verdict), rows in orbits.assign(inc_plot=inc).groupby(
        ["read_in", "verdict"], sort=False
    ):
        text = [
            f"{r.orbit} ({r.read_in}, {r.epoch}): e {r.ecc_op:.3f}, i {r.inc_op_deg:.2f}, AOP {r.aop_op_deg:.1f}; "
            f"frozen i {r.frozen_inc_deg:.2f}; e {r.ecc_min:.3f}-{r.ecc_max:.3f}"
            for r in rows.itertuples()
        ]
        marker = {
            "symbol": _READ_SYMBOLS.get(read_in, "square"),
            "size": 10,
            "color": _VERDICT_COLOURS.get(verdict, "grey"),
        }
        name = f"{verdict}, {read_in}"
        fig.add_trace(
            go.Scatter(
                x=rows["sma_km"],
                y=rows["inc_plot"],
                mode="markers",
                marker=marker,
                name=name,
                legendgroup=name,
                text=text,
                hovertemplate="%{text}<extra></extra>",
            ),
            row=1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=rows["sma_km"],
                y=rows["ecc_op"],
                mode="markers",
                marker=marker,
                name=name,
                legendgroup=name,
                showlegend=False,
                text=text,
                hovertemplate="%{text}<extra></extra>",
            ),
            row=1,
            col=2,
        )
        bars_x = np.repeat(rows["sma_km"].to_numpy(), 3)
        bars_y = np.column_stack(
            [rows["inc_plot"], rows["frozen_inc_deg"], np.full(len(rows), np.nan)]
        ).ravel()
        fig.add_trace(
            go.Scatter(
                x=bars_x,
                y=bars_y,
                mode="lines",
                line={"color": marker["color"], "width": 1},
                legendgroup=name,
                showlegend=False,
                hoverinfo="skip",
            ),
            row=1,
            col=1,
        )
    a_km = np.concatenate([family["sma_km"], orbits["sma_km"]])
    ticks = [t for t in _A_TICKS_KM if a_km.min() / 1.2 <= t <= a_km.max() * 1.2]
    fig.update_xaxes(
        title_text="a (km)",
        type="log",
        tickvals=ticks,
        ticktext=[f"{t:,.0f}" for t in ticks],
        range=[
            np.log10(a_km.min() / 1.05),
            np.log10(a_km.max() * 1.35),
        ],  # room for the curves' labels
    )
    fig.update_yaxes(title_text="i in moon_op (deg)", row=1, col=1)
    fig.update_yaxes(title_text="e", row=1, col=2)
    fig.update_layout(
        title=title,
        template="plotly_white",
        height=600,
        legend={"orientation": "h", "y": -0.2, "title": {"text": "verdict, elements read in"}},
    )
    return fig


def perilune_envelope(
    t_days,
    perilune_alt_km,
    mean_t_days,
    mean_perilune_alt_km,
    envelope_km: float,
    *,
    names,
    floor_km: float,
    title: str,
) -> go.Figure:
    """Osculating perilune altitude (sat, time) of the full model against the doubly-averaged one (sat, time) less
    ``envelope_km`` (the short-period allowance), with the altitude floor ``floor_km``."""
    fig = go.Figure()
    years = np.asarray(t_days) / DAYS_PER_JULIAN_YEAR
    mean_years = np.asarray(mean_t_days) / DAYS_PER_JULIAN_YEAR
    for k, name in enumerate(names):
        fig.add_trace(
            go.Scatter(
                x=years,
                y=perilune_alt_km[k],
                mode="lines",
                name=f"{name}: full model",
                line={"width": 0.6},
            )
        )
        fig.add_trace(
            go.Scatter(
                x=mean_years,
                y=mean_perilune_alt_km[k] - envelope_km,
                mode="lines",
                name=f"{name}: averaged - envelope",
                line={"width": 2, "dash": "dot"},
            )
        )
    fig.add_hline(
        y=floor_km, line={"color": "black", "dash": "dash"}, annotation_text=f"{floor_km:g} km"
    )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title="years since the file's epoch (TDB)",
        yaxis_title="perilune altitude (km)",
        legend={"orientation": "h", "y": -0.2},
    )
    return fig
