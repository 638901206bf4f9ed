"""Design life (notebook 08): mean-element histories, manoeuvre timelines, monthly DOP, the estimate against the
closed loop, and the integrator-convergence check."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from ..keys import label

_COLOURS = {"controlled": "#1f77b4", "natural": "#d62728"}
_DASHES = {"controlled": "solid", "natural": "dot"}  # where the runs coincide, both stay visible
_SYMBOLS = {"controlled": "circle", "natural": "x-thin-open"}
_REGION_SYMBOLS = ["circle", "square", "diamond", "triangle-up", "x", "cross"]


def life_element_histories(runs: dict, *, sat: int = 0, title: str) -> go.Figure:
    """Mean a, e, i, AOP and RAAN minus the constellation's mean RAAN of one satellite, one line per run.

    ``runs``: name -> :func:`lnss_lib.design_life.closed_loop.simulate_life` Dataset (``mean_elements`` in
    deg, ``box_error`` in rad, ``check_day``).
    """
    from plotly.subplots import make_subplots

    panels = [
        ("a_km", "mean a (km)"),
        ("e", "mean e"),
        ("inc_deg", "mean i (deg)"),
        ("aop_deg", "mean AOP (deg)"),
        ("raan_rel", "RAAN - mean RAAN (deg)"),
    ]
    fig = make_subplots(rows=len(panels), cols=1, shared_xaxes=True, vertical_spacing=0.02)
    for name, ds in runs.items():
        day = ds["check_day"].sel(sat=sat).values
        for k, (key, axis_title) in enumerate(panels):
            y = (
                np.degrees(ds["box_error"].sel(sat=sat, box="raan_rel_deg").values)
                if key == "raan_rel"
                else ds["mean_elements"].sel(sat=sat, mean_element=key).values
            )
            fig.add_trace(
                go.Scatter(
                    x=day,
                    y=y,
                    mode="lines",
                    name=name,
                    legendgroup=name,
                    showlegend=k == 0,
                    line={"color": _COLOURS.get(name)},
                ),
                row=k + 1,
                col=1,
            )
            fig.update_yaxes(title_text=axis_title, row=k + 1, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=len(panels), col=1)
    fig.update_layout(
        title=title, template="plotly_white", height=950, legend={"orientation": "h", "y": -0.08}
    )
    return fig


def maneuver_timeline(ds, *, title: str) -> go.Figure:
    """Every manoeuvre of a closed-loop run: day against satellite, marker area by its Delta-V (m/s)."""
    day = ds["maneuver_day"].values
    dv_ms = 1000.0 * np.linalg.norm(np.nan_to_num(ds["maneuver_dv_rtn_kms"].values), axis=-1)
    sat = np.broadcast_to(ds["sat"].values[:, None], day.shape)
    ok = np.isfinite(day)
    size = 4.0 + 16.0 * np.sqrt(dv_ms[ok] / max(float(dv_ms[ok].max()) if ok.any() else 1.0, 1e-12))
    fig = go.Figure(
        go.Scatter(
            x=day[ok],
            y=sat[ok],
            mode="markers",
            marker={
                "size": size,
                "color": dv_ms[ok],
                "colorscale": "Viridis",
                "colorbar": {"title": "dV (m/s)"},
            },
            hovertemplate="day %{x:.2f}, sat %{y}, %{marker.color:.3f} m/s<extra></extra>",
        )
    )
    impact = ds["impact_day"].values
    if np.isfinite(impact).any():
        hit = np.isfinite(impact)
        fig.add_trace(
            go.Scatter(
                x=impact[hit],
                y=ds["sat"].values[hit],
                mode="markers",
                name="impact",
                marker={"symbol": "x", "size": 12, "color": "black"},
            )
        )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title="days since epoch (TDB)",
        yaxis_title="satellite",
        showlegend=bool(np.isfinite(impact).any()),
    )
    return fig


def monthly_dop(nav, *, title: str) -> go.Figure:
    """Month-by-month PDOP/HDOP availability and 3-sigma means (eq. 9-14), one line per run (solid and
    dotted, with different markers, so a run that matches the other is still seen)."""
    from plotly.subplots import make_subplots

    panels = ("pdop_avail_pct", "hdop_avail_pct", "pdop_mean_3sigma", "hdop_mean_3sigma")
    fig = make_subplots(rows=2, cols=2, subplot_titles=[label(key) for key in panels])
    month = nav["month"].values + 1
    for name in nav["run"].values:
        for k, key in enumerate(panels):
            fig.add_trace(
                go.Scatter(
                    x=month,
                    y=nav[key].sel(run=name).values,
                    mode="lines+markers",
                    name=str(name),
                    legendgroup=str(name),
                    showlegend=k == 0,
                    line={"color": _COLOURS.get(str(name)), "dash": _DASHES.get(str(name))},
                    marker={"symbol": _SYMBOLS.get(str(name)), "size": 8},
                ),
                row=k // 2 + 1,
                col=k % 2 + 1,
            )
    for k, key in enumerate(panels):
        if key.endswith(
            "_pct"
        ):  # bounded quantity on a fixed axis: 99.999... % is not a drop from 100 %
            fig.update_yaxes(range=[0, 102], row=k // 2 + 1, col=k % 2 + 1)
    fig.update_xaxes(title_text="month of the design life")
    fig.update_layout(title=title, template="plotly_white", height=700)
    return fig


def estimate_vs_closed_loop(table, *, title: str) -> go.Figure:
    """Campaign-grade estimate against the closed-loop Delta-V (km/s per year), one marker per design kept to the
    end of its life, y = x dashed, log axes. A design that burned nothing (or is estimated at nothing) cannot sit on
    a log axis: it is drawn open at the axis floor, half the smallest positive value, and the legend says so."""
    closed = table["sk_dv_kms_per_year"].astype(float).to_numpy()
    estimate = table["sk_dv_estimate_kms_per_year"].astype(float).to_numpy()
    kept = np.isfinite(table["ratio"].astype(float).to_numpy()) | (
        (closed == 0)
        & ~np.isfinite(table["impact_day"].astype(float).to_numpy())
        & np.isfinite(estimate)
    )
    values = np.concatenate([closed[kept], estimate[kept]])
    positive = values[values > 0]
    floor = positive.min() / 2.0 if positive.size else 1e-3
    fig = go.Figure()
    for k, region in enumerate(dict.fromkeys(table.loc[kept, "region"])):
        rows = kept & (table["region"] == region).to_numpy()
        for at_floor in (False, True):
            part = rows & (((closed <= 0) | (estimate <= 0)) == at_floor)
            if not part.any():
                continue
            symbol = _REGION_SYMBOLS[k % len(_REGION_SYMBOLS)]
            fig.add_trace(
                go.Scatter(
                    x=np.maximum(closed[part], floor),
                    y=np.maximum(estimate[part], floor),
                    mode="markers",
                    name=f"{region}: {int(part.sum())} at zero, drawn at the floor"
                    if at_floor
                    else str(region),
                    marker={"size": 10, "symbol": f"{symbol}-open" if at_floor else symbol},
                    text=[
                        f"a {r.sma_km:g} e {r.ecc:g} i {r.inc_deg:g} AOP {r.aop_deg:g}"
                        for r in table[part].itertuples()
                    ],
                    customdata=np.column_stack([closed[part], estimate[part]]),
                    hovertemplate="%{text}<br>closed %{customdata[0]:.3g}, estimate %{customdata[1]:.3g}<extra></extra>",
                )
            )
    if positive.size:
        lo, hi = floor, positive.max() * 2.0
        fig.add_trace(
            go.Scatter(
                x=[lo, hi],
                y=[lo, hi],
                mode="lines",
                name="estimate = closed loop",
                line={"dash": "dash", "color": "grey"},
            )
        )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title="closed loop, mean per satellite (km/s/yr)",
        yaxis_title="campaign-grade estimate (km/s/yr)",
    )
    fig.update_xaxes(type="log")
    fig.update_yaxes(type="log")
    return fig


def integrator_convergence_chart(conv, *, sat: int = 0, title: str) -> go.Figure:
    """Position difference (km) of each integrator setting against the tight reference, log scale."""
    fig = go.Figure()
    day = conv["day"].values
    for setting in conv["setting"].values:
        y = conv["pos_diff_km"].sel(setting=setting, sat=sat).values
        fig.add_trace(
            go.Scatter(x=day, y=np.where(y > 0, y, np.nan), mode="lines", name=str(setting))
        )
    fig.update_layout(
        title=title,
        template="plotly_white",
        xaxis_title="days since epoch (TDB)",
        yaxis_title=f"position difference to {conv.attrs.get('reference', 'reference')} (km)",
    )
    fig.update_yaxes(type="log", exponentformat="power")
    return fig
