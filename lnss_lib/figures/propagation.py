"""Propagated orbits: osculating element histories (paper Figure 5 style) and the 3D constellation
(paper Figures 3, 16)."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go


def elements_history(t_days, elements_deg, *, title: str) -> go.Figure:
    """Osculating a, e, i, RAAN, AOP (paper Figure 5 style) in five stacked panels.

    ``elements_deg``: (n, 6) [sma_km, e, i, RAAN, AOP, M] with angles in degrees.
    """
    from plotly.subplots import make_subplots

    labels = ["SMA (km)", "eccentricity", "inclination (deg)", "RAAN (deg)", "AOP (deg)"]
    fig = make_subplots(rows=5, cols=1, shared_xaxes=True, vertical_spacing=0.02)
    for k, label in enumerate(labels):
        fig.add_trace(
            go.Scatter(x=t_days, y=elements_deg[:, k], mode="lines", name=label, showlegend=False),
            row=k + 1,
            col=1,
        )
        fig.update_yaxes(title_text=label, row=k + 1, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=5, col=1)
    fig.update_layout(title=title, template="plotly_white", height=900)
    return fig


def constellation_3d(prop_ds, *, title: str, moon_radius_km: float = 1737.4) -> go.Figure:
    """Orbits of a propagated constellation in Moon-centred J2000 around a lunar sphere (paper Figures 3, 16)."""
    u, v = np.mgrid[0 : 2 * np.pi : 40j, 0 : np.pi : 20j]
    fig = go.Figure(
        go.Surface(
            x=moon_radius_km * np.cos(u) * np.sin(v),
            y=moon_radius_km * np.sin(u) * np.sin(v),
            z=moon_radius_km * np.cos(v),
            colorscale=[[0, "#9a9a9a"], [1, "#d0d0d0"]],
            showscale=False,
            opacity=0.9,
            name="Moon",
            hoverinfo="skip",
        )
    )
    r = prop_ds["r_mci_km"].transpose("sat", "time", "xyz").values
    raan = (
        prop_ds["elements_deg"].values[:, 3] if "elements_deg" in prop_ds else np.arange(r.shape[0])
    )
    planes = {value: p for p, value in enumerate(np.unique(np.round(raan, 6)))}
    palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
    for k in range(r.shape[0]):
        plane = planes[np.round(raan[k], 6)]
        fig.add_trace(
            go.Scatter3d(
                x=r[k, :, 0],
                y=r[k, :, 1],
                z=r[k, :, 2],
                mode="lines",
                line={"width": 2, "color": palette[plane % len(palette)]},
                name=f"sat {k + 1} (plane {plane + 1})",
                showlegend=r.shape[0] <= 20,
            )
        )
        fig.add_trace(
            go.Scatter3d(
                x=r[k, :1, 0],
                y=r[k, :1, 1],
                z=r[k, :1, 2],
                mode="markers",
                marker={"size": 4, "color": palette[plane % len(palette)]},
                showlegend=False,
                hovertext=f"sat {k + 1} at the epoch",
            )
        )
    fig.update_layout(
        title=title,
        template="plotly_white",
        height=700,
        scene={
            "aspectmode": "data",
            "xaxis_title": "x (km)",
            "yaxis_title": "y (km)",
            "zaxis_title": "z (km)",
        },
    )
    return fig
