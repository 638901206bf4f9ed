"""Notebook 03: GPS-LNSS link (paper Figure 1 geometry, Table 1 budget, Figure 7, Table 4)."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from .charts import days_since_start


def gps_visibility_pdop(link_ds, *, title: str, sat: int = 0) -> go.Figure:
    """Visible GPS satellites and GPS-LNSS PDOP (log scale) of one LNSS satellite (paper Figure 7)."""
    from plotly.subplots import make_subplots

    days = days_since_start(link_ds)
    one = link_ds.isel(sat=sat)
    fig = make_subplots(
        rows=2,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.06,
        subplot_titles=["visible GPS satellites", "GPS-LNSS PDOP"],
    )
    fig.add_trace(
        go.Scatter(
            x=days, y=one["n_visible"].values, mode="lines", line_shape="hv", showlegend=False
        ),
        row=1,
        col=1,
    )
    fig.add_trace(
        go.Scatter(
            x=days, y=one["pdop"].values, mode="markers", marker={"size": 3}, showlegend=False
        ),
        row=2,
        col=1,
    )
    fig.update_yaxes(type="log", exponentformat="power", row=2, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(title=title, template="plotly_white", height=650)
    return fig


def off_boresight_geometry(limits: dict, *, length_km: float = 70000.0) -> go.Figure:
    """Schematic of the off-boresight regions at a GPS satellite (as paper Figure 1, to scale around the Earth).

    ``limits``: :func:`lnss_lib.gps.off_boresight_limits` (angles in deg, radii in km).
    """
    r_gps, r_e = limits["r_gps_km"], limits["r_earth_km"]
    alpha, limb, last = (
        limits["earth_limb_deg"],
        limits["limb_with_margin_deg"],
        limits["last_receivable_deg"],
    )
    mask = limits["beam_mask_deg"]
    regions = [
        (0.0, limb, "blocked by the Earth + margin (eq. 21)", "rgba(200,0,0,0.35)"),
        (limb, limits["sidelobe_from_deg"], "main-lobe edge: receivable", "rgba(0,150,0,0.55)"),
        (
            limits["sidelobe_from_deg"],
            last,
            "sidelobes: receivable at 384 400 km",
            "rgba(0,200,0,0.25)",
        ),
        (last, mask, "inside beam mask but C/N0 < 15 dB-Hz", "rgba(255,150,0,0.3)"),
        (mask, 90.0, "outside the 70 deg beam mask", "rgba(120,120,120,0.25)"),
    ]
    fig = go.Figure()
    for lo, hi, label, colour in regions:
        for side in (1, -1):
            ang = np.radians(np.linspace(lo, hi, 30))
            xs = np.concatenate([[0.0], side * length_km * np.sin(ang), [0.0]])
            ys = np.concatenate([[r_gps], r_gps - length_km * np.cos(ang), [r_gps]])
            fig.add_trace(
                go.Scatter(
                    x=xs,
                    y=ys,
                    fill="toself",
                    fillcolor=colour,
                    line={"width": 0},
                    name=label,
                    legendgroup=label,
                    showlegend=side == 1,
                    hoverinfo="name",
                )
            )
    phi = np.linspace(0, 2 * np.pi, 200)
    fig.add_trace(
        go.Scatter(
            x=r_e * np.cos(phi),
            y=r_e * np.sin(phi),
            fill="toself",
            fillcolor="royalblue",
            line={"color": "navy"},
            name="Earth (6378 km)",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=r_gps * np.cos(phi),
            y=r_gps * np.sin(phi),
            line={"dash": "dot", "color": "grey"},
            name="GPS orbit (26 560 km)",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[0, 0],
            y=[r_gps, 0],
            line={"color": "black", "dash": "dash"},
            name="boresight (eq. 19)",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[0],
            y=[r_gps],
            mode="markers+text",
            marker={"size": 12, "color": "black", "symbol": "diamond"},
            text=["GPS"],
            textposition="top center",
            name="GPS satellite",
        )
    )
    for theta, label in (
        (alpha, f"limb {alpha:.1f} deg"),
        (limb, f"limb + margin {limb:.1f} deg"),
        (last, f"C/N0 = 15 dB-Hz at {last:.1f} deg"),
        (mask, f"beam mask {mask:.0f} deg"),
    ):
        fig.add_annotation(
            x=length_km * np.sin(np.radians(theta)),
            y=r_gps - length_km * np.cos(np.radians(theta)),
            text=label,
            showarrow=False,
            xanchor="left",
            font={"size": 11},
        )
    fig.update_layout(
        title="Off-boresight geometry at a GPS satellite (to the Moon: beyond the Earth, along the rays)",
        xaxis={"title": "km", "range": [-75000, 95000], "scaleanchor": "y"},
        yaxis={"title": "km", "range": [-50000, 32000]},
        height=650,
        width=1000,
    )
    return fig


def gps_view_from_lnss(
    x_km, y_km, status, prn, r_earth_km: float, *, epoch: int = 0, sat_label: str = "1"
) -> go.Figure:
    """GPS satellites seen from an LNSS satellite, projected across the Earth direction (notebook 03).

    ``x_km``, ``y_km`` (time, gps) from :func:`lnss_lib.gps.earth_plane_projection`; ``status``
    (time, gps) from :func:`lnss_lib.gps.link_status`; ``prn`` (gps,). Faint dots: every visible link
    over the run; large dots: every GPS satellite at ``epoch``, coloured by the test that fails.
    """
    status = np.asarray(status)
    visible = status == "visible"
    prn = np.asarray(prn)
    fig = go.Figure()
    fig.add_trace(
        go.Scattergl(
            x=x_km[visible],
            y=y_km[visible],
            mode="markers",
            marker={"size": 2, "color": "rgba(0,150,0,0.15)"},
            name="visible, all epochs",
        )
    )
    colours = {
        "visible": "green",
        "Earth (+margin) blocks": "red",
        "C/N0 < 15 dB-Hz": "orange",
        "outside beam": "grey",
        "Moon blocks": "black",
    }
    for label, colour in colours.items():
        m = status[epoch] == label
        fig.add_trace(
            go.Scatter(
                x=x_km[epoch, m],
                y=y_km[epoch, m],
                mode="markers+text",
                marker={"size": 10, "color": colour},
                text=[f"{p}" for p in prn[m]],
                textposition="top center",
                name=f"{label} (epoch {epoch}: {int(m.sum())})",
            )
        )
    phi = np.linspace(0, 2 * np.pi, 200)
    fig.add_trace(
        go.Scatter(
            x=r_earth_km * np.cos(phi),
            y=r_earth_km * np.sin(phi),
            line={"color": "navy"},
            name="Earth limb",
        )
    )
    fig.update_layout(
        title=f"GPS satellites seen from LNSS satellite {sat_label} (epoch {epoch}; labels: PRN). "
        f"Visible at epoch {epoch}: {int(visible[epoch].sum())}",
        xaxis={"title": "km, across the Earth direction", "scaleanchor": "y"},
        yaxis={"title": "km"},
        height=650,
        width=800,
    )
    return fig


def cn0_vs_off_boresight(
    gain_curves, temperature_curves, limits: dict, *, threshold_dbhz: float, default_column: str
) -> go.Figure:
    """GPS L1 C/N0 at the Moon against off-boresight angle (paper Table 1, eq. 22-24): left the gain columns,
    right the noise temperatures; curves from :func:`lnss_lib.gps.cn0_curves` (index: angle, deg)."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=("gain columns (T = 190 K)", "noise temperature (improved panel)"),
    )
    for col in gain_curves.columns:
        fig.add_trace(
            go.Scatter(
                x=gain_curves.index.values,
                y=gain_curves[col],
                name=col,
                line={"width": 3 if col == default_column else 1.5},
            ),
            row=1,
            col=1,
        )
    for label in temperature_curves.columns:
        fig.add_trace(
            go.Scatter(
                x=temperature_curves.index.values,
                y=temperature_curves[label],
                name=label,
                line={"dash": "dot"},
            ),
            row=1,
            col=2,
        )
    for c in (1, 2):
        fig.add_hline(y=threshold_dbhz, line={"color": "black", "dash": "dash"}, row=1, col=c)
        fig.add_vrect(
            x0=0,
            x1=limits["limb_with_margin_deg"],
            fillcolor="red",
            opacity=0.12,
            line_width=0,
            row=1,
            col=c,
        )
        fig.add_vrect(
            x0=limits["beam_mask_deg"],
            x1=90,
            fillcolor="grey",
            opacity=0.2,
            line_width=0,
            row=1,
            col=c,
        )
        fig.update_xaxes(title_text="off-boresight angle (deg)", row=1, col=c)
    fig.update_yaxes(title_text="C/N0 at 384 400 km (dB-Hz)", row=1, col=1)
    fig.update_layout(
        title="GPS L1 C/N0 at the Moon vs off-boresight angle (red: Earth + margin; grey: outside beam; "
        "dashed: 15 dB-Hz)",
        height=500,
        width=1100,
    )
    return fig


def gps_visibility_pdop_vs_paper(
    link_one, filtered_mean_pdop: float, paper_pdop: float, *, title: str
) -> go.Figure:
    """Visible GPS satellites and GPS-LNSS PDOP (log scale) of one LNSS satellite with our filtered mean and the
    paper's value (paper Figure 7, Table 4). ``link_one``: one satellite of :func:`lnss_lib.gps.gps_link`."""
    from plotly.subplots import make_subplots

    days = days_since_start(link_one)
    fig = make_subplots(
        rows=2,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.06,
        subplot_titles=("visible GPS satellites", "GPS-LNSS PDOP"),
    )
    fig.add_trace(
        go.Scatter(x=days, y=link_one["n_visible"], mode="lines", line_shape="hv", name="visible"),
        row=1,
        col=1,
    )
    fig.add_trace(
        go.Scatter(x=days, y=link_one["pdop"], mode="markers", marker={"size": 3}, name="PDOP"),
        row=2,
        col=1,
    )
    fig.add_hline(
        y=filtered_mean_pdop,
        line={"dash": "dash", "color": "green"},
        row=2,
        col=1,
        annotation_text=f"filtered mean {filtered_mean_pdop:.0f}",
    )
    fig.add_hline(
        y=paper_pdop,
        line={"dash": "dot", "color": "red"},
        row=2,
        col=1,
        annotation_text=f"paper {paper_pdop:.0f}",
    )
    fig.update_yaxes(type="log", row=2, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(height=650, width=1000, title=title)
    return fig


def gps_visible_links(
    theta_visible_deg, share_by_prn, limits: dict, main_share: float
) -> go.Figure:
    """Histogram of the off-boresight angles of the visible links and the share of epochs each PRN is visible
    (notebook 03). ``share_by_prn``: :func:`lnss_lib.gps.visible_share_by_prn`; ``limits``:
    :func:`lnss_lib.gps.off_boresight_limits`; ``main_share``: :func:`lnss_lib.gps.main_lobe_share`."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=(
            "off-boresight angle of visible links",
            "share of epochs each PRN is visible",
        ),
    )
    fig.add_trace(
        go.Histogram(
            x=theta_visible_deg, xbins={"start": 0, "end": 72, "size": 2}, name="visible links"
        ),
        row=1,
        col=1,
    )
    for x, label in (
        (limits["limb_with_margin_deg"], "limb + margin"),
        (limits["sidelobe_from_deg"], "main lobe edge"),
        (limits["last_receivable_deg"], "C/N0 cut-off"),
    ):
        fig.add_vline(x=x, line={"dash": "dash"}, annotation_text=label, row=1, col=1)
    fig.add_trace(
        go.Bar(
            x=[f"PRN {p}" for p in share_by_prn.index],
            y=share_by_prn.values,
            name="share of epochs",
        ),
        row=1,
        col=2,
    )
    fig.update_xaxes(title_text="off-boresight angle (deg)", row=1, col=1)
    fig.update_layout(
        height=450,
        width=1100,
        showlegend=False,
        title=f"Visible links: {100 * main_share:.1f}% in the main-lobe edge, "
        f"{100 * (1 - main_share):.1f}% in sidelobes",
    )
    return fig


GPS_SENSITIVITY_GROUPS = {
    "noise temperature": ("T = ",),
    "gain column": ("gain ",),
    "sidelobe level": ("sidelobes",),
    "beam mask": ("beam",),
    "orbit / GPS phase": ("Keplerian", "elements", "GPS phase"),
}


def gps_sensitivity_scatter(sens, paper: dict, prototype_pdop: float = 650.0) -> go.Figure:
    """Mean GPS-LNSS PDOP against mean visible GPS count for every variant of
    :func:`lnss_lib.gps.sensitivity_table`, grouped by the setting changed (with ``default`` in every
    one-setting group), beside the paper's Table 4 point."""
    fig = go.Figure()
    for label, prefixes in GPS_SENSITIVITY_GROUPS.items():
        rows = [k for k in sens.index if k.startswith(prefixes)]
        if label != "orbit / GPS phase":
            rows.append("default")
        sub = sens.loc[rows].dropna(subset=["gps_pdop_mean"])
        fig.add_trace(
            go.Scatter(
                x=sub["gps_visible_mean"],
                y=sub["gps_pdop_mean"],
                mode="markers",
                name=label,
                text=sub.index,
                marker={"size": 9},
            )
        )
    fig.add_trace(
        go.Scatter(
            x=[paper["gps_visible_mean"]],
            y=[paper["gps_pdop_mean"]],
            mode="markers+text",
            marker={"size": 14, "symbol": "star", "color": "red"},
            text=["paper"],
            textposition="top center",
            name="paper Table 4",
        )
    )
    fig.add_hline(
        y=prototype_pdop,
        line={"dash": "dot", "color": "grey"},
        annotation_text=f"prototype ~{prototype_pdop:.0f}",
    )
    fig.update_layout(
        title="Mean GPS-LNSS PDOP against mean visible GPS count, all variants (ELFO satellite 1)",
        xaxis_title="mean visible GPS satellites",
        yaxis={"title": "95th-percentile-filtered mean PDOP", "type": "log"},
        height=550,
        width=950,
    )
    return fig


def gnss_visibility_pdop(visible, pdop, *, title: str) -> go.Figure:
    """Visible satellites and GNSS-LNSS PDOP (log scale) of one LNSS satellite for each system and combination
    (notebook 03); ``visible``, ``pdop``: DataFrames indexed by days, one column each
    (:func:`lnss_lib.studies.gnss_link.time_series`)."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=2,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.06,
        subplot_titles=("visible satellites", "GNSS-LNSS PDOP (one clock per system)"),
    )
    for k, label in enumerate(visible.columns):
        color = f"hsl({(47 * k) % 360}, 65%, 45%)"
        fig.add_trace(
            go.Scatter(
                x=visible.index,
                y=visible[label],
                mode="lines",
                line_shape="hv",
                name=label,
                legendgroup=label,
                line={"color": color},
            ),
            row=1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=pdop.index,
                y=pdop[label],
                mode="markers",
                marker={"size": 3, "color": color},
                name=label,
                legendgroup=label,
                showlegend=False,
            ),
            row=2,
            col=1,
        )
    fig.update_yaxes(type="log", exponentformat="power", row=2, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(title=title, template="plotly_white", height=700)
    return fig
