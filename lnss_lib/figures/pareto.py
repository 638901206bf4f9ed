"""Notebook 07: Pareto fronts of a campaign against every evaluated design (paper Figures 8-15)."""

from __future__ import annotations

import numpy as np
import plotly
import plotly.graph_objects as go

from ..keys import LABELS  # labels with units, one registry (re-exported by lnss_lib.figures)


def _hover(ds) -> list[str]:
    return [
        f"a {a:.0f} km, e {e:.2f}, i {i:.0f}, AOP {w:.0f}, {p}x{s}"
        for a, e, i, w, p, s in zip(
            ds["sma_km"].values,
            ds["ecc"].values,
            ds["inc_deg"].values,
            ds["aop_deg"].values,
            ds["n_planes"].values,
            ds["sats_per_plane"].values,
        )
    ]


def pareto_3d(
    front, x: str, y: str, z: str, *, title: str, z_bound: float | None = None
) -> go.Figure:
    """Four-objective view of a front: three metrics in 3D, one colour per number of satellites (a count, so a
    legend entry each, not a continuous scale; Figures 8, 9), and with ``z_bound`` the campaign's bound on the z
    metric as a translucent plane (designs above it are infeasible)."""
    fig = go.Figure()
    counts = front["n_sat"].values
    palette = plotly.colors.qualitative.Dark24
    for k, n in enumerate(np.unique(counts)):
        part = front.isel(design=np.flatnonzero(counts == n))
        fig.add_trace(
            go.Scatter3d(
                x=part[x].values,
                y=part[y].values,
                z=part[z].values,
                mode="markers",
                name=f"{int(n)} satellites",
                text=_hover(part),
                marker={"size": 5, "color": palette[k % len(palette)]},
                hovertemplate="%{text}<br>"
                + f"{LABELS[x]} %{{x:.3g}}<br>{LABELS[y]} %{{y:.3g}}<br>{LABELS[z]} %{{z:.3g}}<extra></extra>",
            )
        )
    if z_bound is not None and np.isfinite(z_bound) and front.sizes["design"]:
        xs = [float(np.nanmin(front[x].values)), float(np.nanmax(front[x].values))]
        ys = [float(np.nanmin(front[y].values)), float(np.nanmax(front[y].values))]
        fig.add_trace(
            go.Surface(
                x=xs,
                y=ys,
                z=[[z_bound, z_bound], [z_bound, z_bound]],
                opacity=0.25,
                showscale=False,
                colorscale=[[0, "grey"], [1, "grey"]],
                name=f"bound: {LABELS[z]} = {z_bound:g}",
                showlegend=True,
                hoverinfo="name",
            )
        )
    axis = {"title_font": {"size": 12}, "tickfont": {"size": 10}}
    fig.update_layout(
        title=title,
        template="plotly_white",
        height=700,
        margin={"l": 10, "r": 10, "t": 60, "b": 10},
        scene={
            "xaxis": {**axis, "title": LABELS[x]},
            "yaxis": {**axis, "title": LABELS[y]},
            "zaxis": {**axis, "title": LABELS[z]},
            "aspectmode": "cube",
            "domain": {"x": [0.0, 0.9], "y": [0.0, 1.0]},
            "camera": {"eye": {"x": 1.6, "y": 1.6, "z": 1.1}},
        },
    )  # pulled back: no clipped axis titles
    return fig


def _paper_ranges(fig: go.Figure, claims: dict | None, x: str, ys: tuple[str, ...]) -> None:
    """Shade the ranges the paper's text gives (``claims``: metric -> (low, high), :data:`lnss_lib.paper.FRONT_CLAIMS`)
    for the x metric and for each subplot's y metric (subplots in one row, in the order of ``ys``; data coordinates,
    also on log axes)."""
    style = {"fillcolor": "orange", "opacity": 0.15, "line_width": 0}
    for col, y in enumerate(ys, start=1):
        where = {"row": 1, "col": col} if len(ys) > 1 else {}
        if y in (claims or {}):
            fig.add_hrect(
                y0=claims[y][0], y1=claims[y][1], **style, **where
            )  # no label: misplaced on log axes
        if x in (claims or {}):
            fig.add_vrect(
                x0=claims[x][0], x1=claims[x][1], annotation_text="paper's range", **style, **where
            )


def dop_against_availability(
    front, evaluations, dop: str, *, title: str, paper_ranges: dict | None = None
) -> go.Figure:
    """A DOP metric against its availability: every evaluated design in grey, the front coloured by
    number of satellites (Figures 10, 11); the ranges the paper gives (``paper_ranges``) shaded."""
    avail = dop.replace("_mean_3sigma", "_avail_pct")
    fig = go.Figure()
    fig.add_trace(
        go.Scatter(
            x=evaluations[avail].values,
            y=evaluations[dop].values,
            mode="markers",
            name="evaluated",
            marker={"size": 4, "color": "#c8c8c8"},
            text=_hover(evaluations),
        )
    )
    fig.add_trace(
        go.Scatter(
            x=front[avail].values,
            y=front[dop].values,
            mode="markers",
            name="front",
            text=_hover(front),
            marker={
                "size": 8,
                "color": front["n_sat"].values,
                "colorscale": "Viridis",
                "colorbar": {"title": "satellites"},
                "line": {"width": 0.5, "color": "black"},
            },
        )
    )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title=LABELS[avail],
        yaxis_title=LABELS[dop],
        legend={"orientation": "h", "y": -0.2},
    )
    fig.update_yaxes(type="log")
    _paper_ranges(fig, paper_ranges, avail, (dop,))
    return fig


def variable_relationships(
    front, evaluations, variable: str, *, title: str, paper_ranges: dict | None = None
) -> go.Figure:
    """A design variable against PDOP availability, Delta-V and GPS-LNSS PDOP (Figures 12-15); the ranges the
    paper gives (``paper_ranges``) shaded."""
    from plotly.subplots import make_subplots

    metrics = ("pdop_avail_pct", "dv_total_kms_per_year", "gps_pdop_mean")
    fig = make_subplots(
        rows=1, cols=3, subplot_titles=[LABELS[m] for m in metrics], horizontal_spacing=0.08
    )
    for col, metric in enumerate(metrics, start=1):
        fig.add_trace(
            go.Scatter(
                x=evaluations[variable].values,
                y=evaluations[metric].values,
                mode="markers",
                marker={"size": 4, "color": "#c8c8c8"},
                name="evaluated",
                showlegend=col == 1,
                text=_hover(evaluations),
            ),
            row=1,
            col=col,
        )
        fig.add_trace(
            go.Scatter(
                x=front[variable].values,
                y=front[metric].values,
                mode="markers",
                name="front",
                showlegend=col == 1,
                text=_hover(front),
                marker={
                    "size": 7,
                    "color": front["n_sat"].values,
                    "colorscale": "Viridis",
                    "cmin": 1,
                    "cmax": 20,
                    "showscale": col == 3,
                    "colorbar": {"title": "satellites"},
                },
            ),
            row=1,
            col=col,
        )
        fig.update_xaxes(title_text=LABELS[variable], row=1, col=col)
    fig.update_yaxes(type="log", row=1, col=3)
    fig.update_layout(
        title=title, template="plotly_white", height=500, legend={"orientation": "h", "y": -0.25}
    )
    _paper_ranges(fig, paper_ranges, variable, metrics)
    return fig
