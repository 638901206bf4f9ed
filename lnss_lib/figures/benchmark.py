"""Notebook 10: every catalogue constellation on one yardstick, and the epoch sensitivity."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

__all__ = ["benchmark_scatter", "epoch_sensitivity_lines", "label_positions"]

LABEL_POSITIONS = ("top center", "bottom center", "middle right", "middle left", "top right", "bottom left",
                   "bottom right", "top left")


def label_positions(x, y, *, x_near: float = 4.0, y_near: float = 4.0) -> np.ndarray:
    """A text position per point so that neighbours' labels go to different sides: a point within
    ``x_near`` (x units: a label is about four satellites wide on the benchmark's axis) and ``y_near``
    (y units) of k earlier points gets :data:`LABEL_POSITIONS` [k]."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    out = np.empty(x.size, dtype=object)
    for i in range(x.size):
        near = np.abs(x[:i] - x[i]) <= x_near
        near &= np.abs(y[:i] - y[i]) <= y_near
        out[i] = LABEL_POSITIONS[int(near.sum()) % len(LABEL_POSITIONS)]
    return out


def benchmark_scatter(table, panels, colour: str, colour_label: str, *, title: str) -> go.Figure:
    """Satellites (x) against south-pole availability (y), one labelled point per constellation.

    ``table``: the yardstick (a DataFrame with ``constellation`` and ``n_sat``); ``panels``: sequence of
    (panel title, availability column); ``colour``: the column that colours the points (e.g. the
    station-keeping cost), rows without it drawn as open grey circles. Campaign picks are labelled
    P1, P2, ... (paper-faithful) and O1, ... (operational), catalogue entries by name.
    """
    panels = list(panels)
    names = table["constellation"].to_numpy(str)
    tags = np.array([_tag(name) for name in names])
    fig = make_subplots(rows=1, cols=len(panels), subplot_titles=[p[0] for p in panels], shared_yaxes=True,
                        horizontal_spacing=0.06)
    values = table[colour].to_numpy(float)
    finite = np.isfinite(values)
    span = (float(np.min(values[finite])), float(np.max(values[finite]))) if finite.any() else (0.0, 1.0)
    for col, (_, column) in enumerate(panels, start=1):
        y = table[column].to_numpy(float)
        for mask, marker, name in ((finite, {"size": 12, "color": values[finite], "colorscale": "Viridis",
                                             "cmin": span[0], "cmax": span[1], "showscale": col == len(panels),
                                             "colorbar": {"title": colour_label},
                                             "line": {"width": 0.5, "color": "black"}}, "cost known"),
                                   (~finite, {"size": 12, "color": "rgba(0,0,0,0)",
                                              "line": {"width": 1.5, "color": "grey"}}, "no cost")):
            keep = mask & np.isfinite(y)
            if not keep.any():
                continue
            x = table["n_sat"].to_numpy(float)
            fig.add_trace(go.Scatter(
                x=x[keep], y=y[keep], mode="markers+text", name=name, marker=marker, text=tags[keep],
                customdata=names[keep], textposition=label_positions(x, y)[keep], textfont={"size": 9},
                showlegend=False,
                hovertemplate="%{customdata}<br>%{x} satellites<br>availability %{y:.1f}%<extra></extra>"),
                row=1, col=col)
        fig.update_xaxes(title_text="satellites", row=1, col=col)
    fig.update_yaxes(title_text="PDOP availability over the south-pole grid (%)", row=1, col=1)
    fig.update_layout(title=title, template="plotly_white", height=650)
    return fig


def _tag(name: str) -> str:
    """Short point label: campaign picks as P1.. (paper-faithful) and O1.. (operational); the full name
    is in the hover text."""
    for prefix, short in (("paper-faithful campaign #", "P"), ("operational campaign #", "O")):
        if name.startswith(prefix):
            return short + name[len(prefix):].split(":")[0]
    return name


def epoch_sensitivity_lines(table, metrics, labels, *, title: str) -> go.Figure:
    """One panel per metric against the start epoch (decimal year), one line per constellation.

    ``table``: rows with ``year``, ``constellation`` and the ``metrics`` columns; ``labels``: panel titles.
    """
    metrics = list(metrics)
    fig = make_subplots(rows=len(metrics), cols=1, shared_xaxes=True, subplot_titles=list(labels), vertical_spacing=0.06)
    for k, name in enumerate(dict.fromkeys(table["constellation"])):
        group = table[table["constellation"] == name]
        for row, metric in enumerate(metrics, start=1):
            fig.add_trace(go.Scatter(x=group["year"], y=group[metric], mode="lines+markers", name=name,
                                     legendgroup=name, showlegend=row == 1,
                                     line={"color": f"hsl({(k * 137) % 360},60%,40%)"}), row=row, col=1)
    fig.update_xaxes(title_text="start epoch (year, TDB)", row=len(metrics), col=1)
    fig.update_layout(title=title, template="plotly_white", height=max(400, 230 * len(metrics)),
                      legend={"orientation": "h", "y": -0.08})
    return fig
