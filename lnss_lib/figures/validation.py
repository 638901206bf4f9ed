"""The validated front (notebooks 06-07): the campaign's estimate against the closed loop, and
the closed-loop Delta-V against the number of satellites with the headline's bound and the paper's claim."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

STATUS_COLOURS = {"kept": "#1f77b4", "failed": "#d62728", "error": "#7f7f7f"}


def _hover(frame) -> list[str]:
    return [
        f"{r.n_planes} x {r.sats_per_plane}, a {r.sma_km:g} km, e {r.ecc:g}, i {r.inc_deg:g}, AOP {r.aop_deg:g} "
        f"({r.selected_for}, {r.status})"
        for r in frame.itertuples()
    ]


def front_estimate_vs_closed_loop(
    table, *, estimate: str, closed: str, title: str, floor_kms_per_year: float
) -> go.Figure:
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
        fig.add_trace(
            go.Scatter(
                x=x,
                y=y,
                mode="markers",
                name=status,
                marker={"size": 10, "color": colour},
                text=_hover(part),
                hovertemplate="%{text}<br>closed loop %{x:.3g}, estimate %{y:.3g}<extra></extra>",
            )
        )
    values = table[[estimate, closed]].to_numpy(dtype=float)
    values = np.maximum(values[np.isfinite(values)], floor_kms_per_year)
    lo, hi = (values.min() / 2.0, values.max() * 2.0) if values.size else (floor_kms_per_year, 1.0)
    for factor, name, dash in (
        (1.0, "estimate = closed loop", "dash"),
        (2.0, "factor 2", "dot"),
        (0.5, None, "dot"),
    ):
        fig.add_trace(
            go.Scatter(
                x=[lo, hi],
                y=[factor * lo, factor * hi],
                mode="lines",
                name=name or "factor 1/2",
                showlegend=name is not None,
                line={"dash": dash, "color": "grey"},
            )
        )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title="closed loop (km/s per satellite and year)",
        yaxis_title="campaign estimate (km/s per satellite and year)",
    )
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
            fig.add_trace(
                go.Scatter(
                    x=part["n_sat"],
                    y=part["closed_loop_dv_max_kms_per_year"],
                    mode="markers",
                    name=status,
                    marker={"size": 10, "color": colour},
                    text=[
                        f"{t}; PDOP availability over the life {a:.1f} %"
                        for t, a in zip(_hover(part), part["pdop_avail_pct_life"])
                    ],
                    hovertemplate="%{text}<br>%{y:.3g} km/s/yr<extra></extra>",
                )
            )
    return _bound_and_claim(
        fig,
        dv_max_kms_per_year,
        f"bound {dv_max_kms_per_year:g} km/s/yr (worst satellite)",
        (paper["n_sat"], paper["dv_below_kms_per_year"]),
        f"paper: {paper['n_sat']} satellites, < {paper['dv_below_kms_per_year']:g} km/s/yr",
        title=title,
        xaxis_title="satellites",
        yaxis_title="closed-loop Delta-V, worst satellite (km/s/yr)",
    )


def _bound_and_claim(
    fig: go.Figure, bound: float, bound_text: str, claim_xy: tuple, claim_name: str, **layout
) -> go.Figure:
    """``fig`` with a bound as a dashed line and the paper's claim as a star, laid out with ``layout``."""
    fig.add_hline(y=bound, line_dash="dash", line_color="grey", annotation_text=bound_text)
    fig.add_trace(
        go.Scatter(
            x=[claim_xy[0]],
            y=[claim_xy[1]],
            mode="markers",
            name=claim_name,
            marker={"symbol": "star", "size": 16, "color": "#2ca02c"},
        )
    )
    fig.update_layout(template="plotly_white", **layout)
    return fig


def size_chart(
    validated_by_size: dict,
    *,
    availability_min_pct: float,
    dv_max_kms_per_year: float,
    paper: dict,
    title: str,
) -> go.Figure:
    """The size question: the worst-month PDOP availability flown (y) of every design of each size-restricted search
    (x: satellites, spread a little to show each design), filled within the worst satellite's Delta-V bound and open
    beyond it, coloured by status; the requirement as a line and the paper's claim as a star."""
    fig = go.Figure()
    for status, colour in STATUS_COLOURS.items():
        for within in (True, False):
            x, y, text = [], [], []
            for size, ds in validated_by_size.items():
                if ds is None:
                    continue
                dv = ds["closed_loop_dv_max_kms_per_year"].values.astype(float)
                with np.errstate(invalid="ignore"):
                    pick = (ds["status"].values == status) & ((dv <= dv_max_kms_per_year) == within)
                n = int(pick.sum())
                x += list(size + np.linspace(-0.25, 0.25, n) if n > 1 else [size] * n)
                y += list(ds["pdop_avail_pct_worst_month"].values[pick])
                text += [
                    f"{p} x {s}, a {a:g} km, e {e:g}, i {i:g}; worst satellite {d:.2f} km/s/yr"
                    for p, s, a, e, i, d in zip(
                        *(
                            ds[k].values[pick]
                            for k in ("n_planes", "sats_per_plane", "sma_km", "ecc", "inc_deg")
                        ),
                        dv[pick],
                    )
                ]
            if x:
                fig.add_trace(
                    go.Scatter(
                        x=x,
                        y=y,
                        mode="markers",
                        text=text,
                        hovertemplate="%{text}<br>worst month %{y:.1f} %<extra></extra>",
                        name=f"{status}, {'within' if within else 'above'} {dv_max_kms_per_year:g} km/s/yr",
                        marker={
                            "size": 10,
                            "color": colour if within else "white",
                            "line": {"color": colour, "width": 2},
                        },
                    )
                )
    _bound_and_claim(
        fig,
        availability_min_pct,
        f"{availability_min_pct:g} % in the worst month",
        (paper["n_sat"], paper["availability_pct"]),
        f"paper: {paper['n_sat']} satellites, over {paper['availability_pct']:g} %",
        title=title,
        xaxis_title="satellites (one search a size)",
        yaxis_title="PDOP availability, worst month of the life (%)",
    )
    return fig.update_xaxes(tickvals=sorted(validated_by_size))
