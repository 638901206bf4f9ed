"""Notebook 10: every catalogue constellation on one yardstick, and the epoch sensitivity."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

__all__ = ["benchmark_scatter", "epoch_sensitivity_lines", "label_positions"]

X_PAD = 4.0  # satellites of room beside the outermost points, for their labels
LABEL_OFFSETS = {  # text position -> (x, y) of the label box's lower-left corner, in box widths and heights
    "top center": (-0.5, 0.5),
    "bottom center": (-0.5, -1.5),
    "middle right": (0.1, -0.5),
    "middle left": (-1.1, -0.5),
    "top right": (0.1, 0.5),
    "bottom right": (0.1, -1.5),
    "top left": (-1.1, 0.5),
    "bottom left": (-1.1, -1.5),
}


def label_positions(
    x, y, texts, *, char_width: float = 0.22, line_height: float = 3.0, x_min: float = -np.inf
) -> np.ndarray:
    """A text position per point (:data:`LABEL_OFFSETS`) so that labels do not overlap: each label, in
    order, takes the first position whose box (``len(text) * char_width`` x units wide, ``line_height``
    y units tall) overlaps no marker and no label placed before and stays right of ``x_min``; else the
    least overlapping."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    finite = np.isfinite(x) & np.isfinite(y)
    placed = [
        (a - 0.3, b - 1.0, a + 0.3, b + 1.0) for a, b in zip(x[finite], y[finite])
    ]  # the markers
    out = np.empty(len(texts), dtype=object)

    def box(i: int, position: str) -> tuple[float, float, float, float]:
        width, (fx, fy) = len(str(texts[i])) * char_width, LABEL_OFFSETS[position]
        left, bottom = x[i] + fx * width, y[i] + fy * line_height
        return left, bottom, left + width, bottom + line_height

    def overlap(a, b) -> float:
        return max(0.0, min(a[2], b[2]) - max(a[0], b[0])) * max(
            0.0, min(a[3], b[3]) - max(a[1], b[1])
        )

    for i in range(len(texts)):
        if not finite[i]:
            out[i] = "top center"
            continue
        cost = {
            p: sum(overlap(box(i, p), b) for b in placed) + (box(i, p)[0] < x_min) * 1e6
            for p in LABEL_OFFSETS
        }
        out[i] = min(LABEL_OFFSETS, key=cost.get)  # the first position without overlap, if any
        placed.append(box(i, out[i]))
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
    fig = make_subplots(
        rows=1,
        cols=len(panels),
        subplot_titles=[p[0] for p in panels],
        shared_yaxes=True,
        horizontal_spacing=0.06,
    )
    values = table[colour].to_numpy(float)
    finite = np.isfinite(values)
    span = (
        (float(np.min(values[finite])), float(np.max(values[finite])))
        if finite.any()
        else (0.0, 1.0)
    )
    for col, (_, column) in enumerate(panels, start=1):
        y = table[column].to_numpy(float)
        for mask, marker, name in (
            (
                finite,
                {
                    "size": 12,
                    "color": values[finite],
                    "colorscale": "Viridis",
                    "cmin": span[0],
                    "cmax": span[1],
                    "showscale": col == len(panels),
                    "colorbar": {"title": colour_label},
                    "line": {"width": 0.5, "color": "black"},
                },
                "cost known",
            ),
            (
                ~finite,
                {"size": 12, "color": "rgba(0,0,0,0)", "line": {"width": 1.5, "color": "grey"}},
                "no cost",
            ),
        ):
            keep = mask & np.isfinite(y)
            if not keep.any():
                continue
            x = table["n_sat"].to_numpy(float)
            fig.add_trace(
                go.Scatter(
                    x=x[keep],
                    y=y[keep],
                    mode="markers+text",
                    name=name,
                    marker=marker,
                    text=tags[keep],
                    customdata=names[keep],
                    textposition=label_positions(x, y, tags, x_min=np.nanmin(x) - X_PAD)[keep],
                    textfont={"size": 9},
                    showlegend=False,
                    hovertemplate="%{customdata}<br>%{x} satellites<br>availability %{y:.1f}%<extra></extra>",
                ),
                row=1,
                col=col,
            )
        fig.update_xaxes(
            title_text="satellites",
            row=1,
            col=col,  # room for a label beside an edge point
            range=[
                np.nanmin(table["n_sat"].to_numpy(float)) - X_PAD,
                np.nanmax(table["n_sat"].to_numpy(float)) + X_PAD,
            ],
        )
    fig.update_yaxes(title_text="PDOP availability over the south-pole grid (%)", row=1, col=1)
    fig.update_layout(title=title, template="plotly_white", height=650)
    return fig


def _tag(name: str) -> str:
    """Short point label: campaign picks as P1.. (paper-faithful) and O1.. (operational); the full name
    is in the hover text."""
    for prefix, short in (("paper-faithful campaign #", "P"), ("operational campaign #", "O")):
        if name.startswith(prefix):
            return short + name[len(prefix) :].split(":")[0]
    return name


def epoch_sensitivity_lines(table, metrics, labels, *, title: str) -> go.Figure:
    """One panel per metric against the start epoch (decimal year), one line per constellation.

    ``table``: rows with ``year``, ``constellation`` and the ``metrics`` columns; ``labels``: panel titles.
    """
    metrics = list(metrics)
    fig = make_subplots(
        rows=len(metrics),
        cols=1,
        shared_xaxes=True,
        subplot_titles=list(labels),
        vertical_spacing=0.06,
    )
    for k, name in enumerate(dict.fromkeys(table["constellation"])):
        group = table[table["constellation"] == name]
        for row, metric in enumerate(metrics, start=1):
            fig.add_trace(
                go.Scatter(
                    x=group["year"],
                    y=group[metric],
                    mode="lines+markers",
                    name=name,
                    legendgroup=name,
                    showlegend=row == 1,
                    line={"color": f"hsl({(k * 137) % 360},60%,40%)"},
                ),
                row=row,
                col=1,
            )
    fig.update_xaxes(title_text="start epoch (year, TDB)", row=len(metrics), col=1)
    fig.update_layout(
        title=title,
        template="plotly_white",
        height=max(400, 230 * len(metrics)),
        legend={"orientation": "h", "y": -0.08},
    )
    return fig
