"""Generic charts: lines and bars against any axis, and the days-since-start axis the topic modules share."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from ..constants import SECONDS_PER_DAY


def line_chart(
    x, series: dict, *, title: str, x_label: str, y_label: str, log_y: bool = False
) -> go.Figure:
    """One line per entry of ``series`` (label -> y values) against ``x``."""
    fig = go.Figure()
    for label, y in series.items():
        fig.add_trace(go.Scatter(x=x, y=y, mode="lines", name=str(label)))
    fig.update_layout(
        title=title,
        xaxis_title=x_label,
        yaxis_title=y_label,
        template="plotly_white",
        legend={"orientation": "h", "y": -0.2},
    )
    if log_y:
        fig.update_yaxes(type="log", exponentformat="power")
    return fig


def bar_chart(labels, values, *, title: str, y_label: str, log_y: bool = False) -> go.Figure:
    """A bar per label."""
    fig = go.Figure(
        go.Bar(
            x=list(labels),
            y=list(values),
            text=[f"{v:.3g}" for v in values],
            textposition="outside",
        )
    )
    fig.update_layout(title=title, yaxis_title=y_label, template="plotly_white")
    if log_y:
        fig.update_yaxes(type="log", exponentformat="power")
    return fig


def days_since_start(ds) -> np.ndarray:
    """Days since the first sample of ``ds["time"]`` (TDB seconds)."""
    times = ds["time"].values.astype(float)
    return (times - times[0]) / SECONDS_PER_DAY
