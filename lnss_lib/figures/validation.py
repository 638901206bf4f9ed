"""The validated front (notebooks 06-07): the campaign's estimate against the closed loop, and
the closed-loop Delta-V against the number of satellites with the headline's bound and the paper's claim."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

STATUS_COLOURS = {"kept": "#1f77b4", "failed": "#d62728", "error": "#7f7f7f"}


def _hover(frame) -> list[str]:
    return [f"{r.n_planes} x {r.sats_per_plane}, a {r.sma_km:g} km, e {r.ecc:g}, i {r.inc_deg:g}, AOP {r.aop_deg:g} "
            f"({r.selected_for}, {r.status})" for r in frame.itertuples()]


def front_estimate_vs_closed_loop(table, *, estimate: str, closed: str, title: str, floor_kms_per_year: float) -> go.Figure:
    """Estimate (y) against closed loop (x), log-log, one marker per design with both (coloured by status), with
    y = x and the factor-2 lines; values below ``floor_kms_per_year`` (a free design) are drawn at the floor."""
    fig = go.Figure()
    both = np.isfinite(table[estimate].astype(float)) & np.isfinite(table[closed].astype(float))
    for status, colour in STATUS_COLOURS.items():
        part = table[both & (table["status"] == status)]
        if not len(part):
            continue
        x = np.maximum(part[closed].astype(float), floor_kms_per_year)
        y = np.maximum(part[estimate].astype(float), floor_kms_per_year)
        fig.add_trace(go.Scatter(x=x, y=y, mode="markers", name=status, marker={"size": 10, "color": colour},
                                 text=_hover(part), hovertemplate="%{text}<br>closed loop %{x:.3g}, estimate %{y:.3g}"
                                                                  "<extra></extra>"))
    values = table[[estimate, closed]].to_numpy(dtype=float)
    values = np.maximum(values[np.isfinite(values)], floor_kms_per_year)
    lo, hi = (values.min() / 2.0, values.max() * 2.0) if values.size else (floor_kms_per_year, 1.0)
    for factor, name, dash in ((1.0, "estimate = closed loop", "dash"), (2.0, "factor 2", "dot"), (0.5, None, "dot")):
        fig.add_trace(go.Scatter(x=[lo, hi], y=[factor * lo, factor * hi], mode="lines", name=name or "factor 1/2",
                                 showlegend=name is not None, line={"dash": dash, "color": "grey"}))
    fig.update_layout(title=title, template="plotly_white", xaxis_title="closed loop (km/s per satellite and year)",
                      yaxis_title="campaign estimate (km/s per satellite and year)")
    fig.update_xaxes(type="log")
    fig.update_yaxes(type="log")
    return fig


def headline_chart(frame, *, dv_max_kms_per_year: float, paper: dict, title: str) -> go.Figure:
    """Worst-satellite closed-loop Delta-V against the number of satellites (``frame``: validated designs with
    ``n_sat``, ``status``, ``closed_loop_dv_max_kms_per_year``, ``pdop_avail_pct_life``), the headline's bound as a
    line and the paper's claim (``paper``: n_sat and its Delta-V) as a star."""
    fig = go.Figure()
    for status, colour in STATUS_COLOURS.items():
        part = frame[frame["status"] == status]
        if len(part):
            fig.add_trace(go.Scatter(x=part["n_sat"], y=part["closed_loop_dv_max_kms_per_year"], mode="markers",
                                     name=status, marker={"size": 10, "color": colour},
                                     text=[f"{t}; PDOP availability over the life {a:.1f} %" for t, a in
                                           zip(_hover(part), part["pdop_avail_pct_life"])],
                                     hovertemplate="%{text}<br>%{y:.3g} km/s/yr<extra></extra>"))
    fig.add_hline(y=dv_max_kms_per_year, line_dash="dash", line_color="grey",
                  annotation_text=f"bound {dv_max_kms_per_year:g} km/s/yr (worst satellite)")
    fig.add_trace(go.Scatter(x=[paper["n_sat"]], y=[paper["dv_below_kms_per_year"]], mode="markers",
                             name=f"paper: {paper['n_sat']} satellites, < {paper['dv_below_kms_per_year']:g} km/s/yr",
                             marker={"symbol": "star", "size": 16, "color": "#2ca02c"}))
    fig.update_layout(title=title, template="plotly_white", xaxis_title="satellites",
                      yaxis_title="closed-loop Delta-V, worst satellite (km/s/yr)")
    return fig
