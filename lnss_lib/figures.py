"""Figure builders (plotly) and the one place figures are written to disk.

Builders take datasets and return ``plotly.graph_objects.Figure``; notebooks call them and
:func:`save_figure`, which writes interactive HTML always and PNG when kaleido finds a Chromium.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import plotly.graph_objects as go

from .pipeline import output_dir

_PNG_WARNED = False


def save_figure(fig: go.Figure, profile_name: str, name: str, *, width: int = 1000, height: int = 600) -> dict[str, Path]:
    """Write ``fig`` as ``outputs/<profile>/figures/<name>.html`` and ``.png``; return the written paths.

    PNG export needs kaleido and a Chromium (Debian package ``chromium``); without one the HTML is
    still written and a warning says how to get PNGs.
    """
    global _PNG_WARNED
    folder = output_dir(profile_name, "figures")
    written = {"html": folder / f"{name}.html"}
    fig.write_html(written["html"], include_plotlyjs="cdn")
    try:
        fig.write_image(folder / f"{name}.png", width=width, height=height)
        written["png"] = folder / f"{name}.png"
    except Exception as error:  # kaleido raises several types when no browser is available
        if not _PNG_WARNED:
            warnings.warn(
                f"PNG export skipped ({type(error).__name__}: {error}); HTML written. "
                "Install Chromium (apt-get install chromium) for PNG figures.",
                RuntimeWarning,
                stacklevel=2,
            )
            _PNG_WARNED = True
    return written


def line_chart(x, series: dict, *, title: str, x_label: str, y_label: str, log_y: bool = False) -> go.Figure:
    """One line per entry of ``series`` (label -> y values) against ``x``."""
    fig = go.Figure()
    for label, y in series.items():
        fig.add_trace(go.Scatter(x=x, y=y, mode="lines", name=str(label)))
    fig.update_layout(title=title, xaxis_title=x_label, yaxis_title=y_label, template="plotly_white",
                      legend={"orientation": "h", "y": -0.2})
    if log_y:
        fig.update_yaxes(type="log", exponentformat="power")
    return fig


def elements_history(t_days, elements_deg, *, title: str) -> go.Figure:
    """Osculating a, e, i, RAAN, AOP (paper Figure 5 style) in five stacked panels.

    ``elements_deg``: (n, 6) [a_km, e, i, RAAN, AOP, M] with angles in degrees.
    """
    from plotly.subplots import make_subplots

    labels = ["SMA (km)", "eccentricity", "inclination (deg)", "RAAN (deg)", "AOP (deg)"]
    fig = make_subplots(rows=5, cols=1, shared_xaxes=True, vertical_spacing=0.02)
    for k, label in enumerate(labels):
        fig.add_trace(go.Scatter(x=t_days, y=elements_deg[:, k], mode="lines", name=label, showlegend=False),
                      row=k + 1, col=1)
        fig.update_yaxes(title_text=label, row=k + 1, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=5, col=1)
    fig.update_layout(title=title, template="plotly_white", height=900)
    return fig


def bar_chart(labels, values, *, title: str, y_label: str, log_y: bool = False) -> go.Figure:
    """A bar per label."""
    fig = go.Figure(go.Bar(x=list(labels), y=list(values), text=[f"{v:.3g}" for v in values], textposition="outside"))
    fig.update_layout(title=title, yaxis_title=y_label, template="plotly_white")
    if log_y:
        fig.update_yaxes(type="log", exponentformat="power")
    return fig
