"""Notebook 02: south-pole DOP grid, polar maps per element frame and DOP time series (paper Table 4,
Figure 4)."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from .charts import days_since_start


def dop_time_series(dop_ds, *, title: str) -> go.Figure:
    """Grid-mean visible satellites, PDOP and HDOP against time (paper Figure 4)."""
    from plotly.subplots import make_subplots

    days = days_since_start(dop_ds)
    fig = make_subplots(
        rows=3,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.04,
        subplot_titles=["mean visible satellites", "grid-mean PDOP", "grid-mean HDOP"],
    )
    for row, name in enumerate(("n_visible", "pdop", "hdop"), start=1):
        fig.add_trace(
            go.Scatter(
                x=days, y=dop_ds[name].mean(("lat", "lon")).values, mode="lines", showlegend=False
            ),
            row=row,
            col=1,
        )
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3, col=1)
    fig.update_layout(title=title, template="plotly_white", height=750)
    return fig


POLE_AXES = {  # polar axes of the south-pole maps: radius = colatitude from the pole, labelled as latitude
    "radialaxis": {
        "range": [0, 30],
        "tickvals": [0, 10, 20, 30],
        "ticktext": ["-90°", "-80°", "-70°", "-60°"],
        "tickfont": {"size": 9},
        "angle": 45,
        "showline": False,
    },
    "angularaxis": {
        "tickvals": [0, 90, 180, 270],
        "ticktext": ["0°E", "90°E", "180°", "270°E"],
        "tickfont": {"size": 9},
        "direction": "counterclockwise",
    },
}


def dop_grid_points(grid) -> go.Figure:
    """The receiver grid of eq. 1-2 (a :class:`lnss_lib.surface_grid.SurfaceGrid`) in a polar plot
    around the south pole."""
    lat2d, lon2d = np.meshgrid(grid.lat_deg, grid.lon_deg, indexing="ij")
    fig = go.Figure(
        go.Scatterpolar(
            r=(90.0 + lat2d).ravel(),
            theta=lon2d.ravel(),
            mode="markers",
            marker={"size": 7},
            text=[f"lat {a:.0f}, lon {o:.0f}" for a, o in zip(lat2d.ravel(), lon2d.ravel())],
        )
    )
    fig.update_layout(
        title="South-pole receiver grid (radius: latitude; angle: longitude)",
        polar={**POLE_AXES, "radialaxis": {**POLE_AXES["radialaxis"], "range": [0, 32]}},
        height=500,
        width=550,
    )
    return fig


def polar_wedges(values, lat_deg, lon_deg, name: str, coloraxis: str) -> go.Barpolar:
    """One wedge per south-pole grid node (radius: colatitude from the pole), coloured by ``values`` (lat, lon)."""
    lat2d, lon2d = np.meshgrid(lat_deg, lon_deg, indexing="ij")
    colat = 90.0 + lat2d
    base = np.maximum(colat - 5.0, 0.0)
    top = np.minimum(colat + 5.0, 30.0)
    return go.Barpolar(
        r=(top - base).ravel(),
        base=base.ravel(),
        theta=lon2d.ravel(),
        width=10.0,
        marker={"color": np.asarray(values).ravel(), "coloraxis": coloraxis, "line_width": 0},
        name=name,
        hovertemplate="lat %{customdata[0]:.0f} lon %{theta:.0f}: %{marker.color:.3g}<extra></extra>",
        customdata=np.stack([lat2d.ravel(), lon2d.ravel()], axis=1),
    )


DOP_MAP_PANELS = (
    ("mean visible", "mean_visible", "Viridis"),
    ("median PDOP", "median_pdop", "Plasma"),
    ("median HDOP (Moon-fixed x, y)", "median_hdop_moon_fixed", "Plasma"),
    ("median HDOP (ENU)", "median_hdop_enu", "Plasma"),
    ("PDOP availability (%)", "pdop_availability_pct", "Viridis"),
)
COMPARED_PANELS = (("median_hdop_moon_fixed", "median_hdop_enu"),)
"""Map columns read against each other, so they share colour scales like the rows of one column: the two HDOP axes
conventions (they agree at the pole and part towards -60 deg)."""
READABLE_SHARE = 0.25
"""A panel shares a colour scale only while its own values span at least this share of the scale: below it the
panel is one colour, and it gets a scale of its own."""


def _span(values) -> tuple[float, float]:
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    return (float(finite.min()), float(finite.max())) if finite.size else (np.nan, np.nan)


def _compared_groups() -> list[tuple[str, ...]]:
    """The map columns whose panels are compared: each of :data:`COMPARED_PANELS`, then every other column alone."""
    variables = [var for _, var, _ in DOP_MAP_PANELS]
    groups = [g for g in COMPARED_PANELS if set(g) <= set(variables)]
    return groups + [(v,) for v in variables if not any(v in g for g in groups)]


def colour_scales(maps: dict) -> dict[tuple[str, str], tuple[float, float]]:
    """(cmin, cmax) of each panel of :func:`dop_polar_maps`, keyed (element frame, variable).

    Comparing the element frames (rows) is the point of the maps, and for the columns of :data:`COMPARED_PANELS`
    comparing the columns too: such panels share one scale, so equal colours mean equal values, as long as each
    stays readable (:data:`READABLE_SHARE`). Where values differ widely, the panel with the widest range leaves
    the shared scale first, and the panels that left share among themselves by the same rule. Percentages keep
    0-100 in every panel.
    """
    scales = {}
    for group in _compared_groups():
        ranges = {(f, v): _span(maps[f][v].values) for f in maps for v in group}
        if all(v.endswith("_pct") for v in group):
            scales.update(dict.fromkeys(ranges, (0.0, 100.0)))
            continue
        widths = {k: hi - lo for k, (lo, hi) in ranges.items()}
        left = [k for k, (lo, _) in ranges.items() if np.isfinite(lo)]
        scales.update({k: (0.0, 1.0) for k in ranges if k not in left})  # no value: an empty panel
        while left:
            shared = list(left)
            while len(shared) > 1:
                lo, hi = min(ranges[k][0] for k in shared), max(ranges[k][1] for k in shared)
                if all(widths[k] >= READABLE_SHARE * (hi - lo) for k in shared):
                    break
                shared.remove(max(shared, key=widths.get))
            lo, hi = min(ranges[k][0] for k in shared), max(ranges[k][1] for k in shared)
            scales.update(dict.fromkeys(shared, (lo, hi if hi > lo else lo + 1.0)))
            left = [k for k in left if k not in shared]
    return scales


def colour_scale_caption(maps: dict) -> str:
    """Which panels of :func:`dop_polar_maps` share a colour scale (:func:`colour_scales`), in words."""
    scales, labels = colour_scales(maps), {var: label for label, var, _ in DOP_MAP_PANELS}
    parts = []
    for group in _compared_groups():
        shared: dict[tuple[float, float], dict[str, list[str]]] = {}
        for frame in maps:
            for var in (
                group
            ):  # a column of a group of several by its convention: "Moon-fixed x, y", "ENU"
                column = labels[var].rpartition("(")[2].rstrip(")")
                shared.setdefault(scales[(frame, var)], {}).setdefault(frame, []).append(column)
        columns = " and ".join(labels[v] for v in group)
        if len(shared) == 1:
            fixed = " (0-100 %)" if all(v.endswith("_pct") for v in group) else ""
            parts.append(f"{columns}: one scale{fixed} for every panel")
            continue
        clusters = []
        for frames in shared.values():
            panels = ", ".join(
                frame
                if len(group) == 1
                else f"{frame} ({'both' if len(cols) == len(group) else ', '.join(cols)})"
                for frame, cols in frames.items()
            )
            alone = len(frames) == 1 and len(next(iter(frames.values()))) == 1
            clusters.append(f"{panels} {'its own' if alone else 'share one'}")
        parts.append(f"{columns}: " + "; ".join(clusters))
    return (
        "Colour scales: panels compared share one (equal colours, equal values) while each spans at least "
        f"{READABLE_SHARE:.0%} of it; where one would not, the widest-ranging panel moves to a scale of its own. "
        + "; ".join(parts)
        + "."
    )


def dop_polar_maps(maps: dict, *, title: str) -> go.Figure:
    """Polar maps over the south-pole grid, one row per element frame (notebook 02; paper Table 4 metrics).

    ``maps``: element frame -> :func:`lnss_lib.dop.time_statistics_maps` Dataset. Each wedge is one
    grid node; the centre disc is the pole; radius labelled in latitude. Panels compared share a colour
    scale while each stays readable (:func:`colour_scales`; :func:`colour_scale_caption` says which);
    each panel has its colour bar below it.
    """
    from plotly.subplots import make_subplots

    frames = list(maps)
    ncol, nrow = len(DOP_MAP_PANELS), len(frames)
    fig = make_subplots(
        rows=nrow,
        cols=ncol,
        specs=[[{"type": "polar"}] * ncol] * nrow,
        subplot_titles=[
            f"{label}<br>elements: {frame}" for frame in frames for label, _, _ in DOP_MAP_PANELS
        ],
        vertical_spacing=0.16 / nrow * 2,
        horizontal_spacing=0.04,
    )
    scales = colour_scales(maps)
    for col, (label, var, scale) in enumerate(DOP_MAP_PANELS, start=1):
        for row, frame in enumerate(frames, start=1):
            (cmin, cmax), ds, index = scales[(frame, var)], maps[frame], (row - 1) * ncol + col
            axis = f"coloraxis{index if index > 1 else ''}"
            fig.add_trace(
                polar_wedges(
                    ds[var].values, ds["lat"].values, ds["lon"].values, f"{label} ({frame})", axis
                ),
                row=row,
                col=col,
            )
            domain = fig.layout[f"polar{index if index > 1 else ''}"].domain
            fig.update_layout(
                {
                    axis: {
                        "colorscale": scale,
                        "cmin": cmin,
                        "cmax": cmax,
                        "colorbar": {
                            "orientation": "h",
                            "x": sum(domain.x) / 2,
                            "y": domain.y[0] - 0.02,
                            "yanchor": "top",
                            "len": 0.8 * (domain.x[1] - domain.x[0]),
                            "thickness": 8,
                            "tickfont": {"size": 9},
                        },
                    }
                }
            )
    fig.update_polars(**POLE_AXES)
    fig.update_layout(
        height=330 * nrow + 80,
        width=1400,
        showlegend=False,
        title=title,
        margin={"t": 110, "b": 50},
    )
    return fig


def dop_time_series_by_frame(dop: dict, *, title: str) -> go.Figure:
    """Grid-mean visible count, PDOP and HDOP (both axes conventions) against time, one colour per element
    frame (paper Figure 4). ``dop``: (element frame, los axes) -> :func:`lnss_lib.dop.dop_grid` Dataset."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=3,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.05,
        subplot_titles=["mean visible satellites", "grid-mean PDOP", "grid-mean HDOP"],
    )
    palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"]
    frames = list(dict.fromkeys(frame for frame, _ in dop))
    for k, frame in enumerate(frames):
        color = palette[k % len(palette)]
        ds_mf, ds_enu = dop[(frame, "moon_fixed")], dop[(frame, "enu")]
        days = days_since_start(ds_mf)
        for row, var, ds, name, dash in (
            (1, "n_visible", ds_mf, "visible", None),
            (2, "pdop", ds_mf, "PDOP", None),
            (3, "hdop", ds_mf, "HDOP Moon-fixed", None),
            (3, "hdop", ds_enu, "HDOP ENU", "dot"),
        ):
            fig.add_trace(
                go.Scatter(
                    x=days,
                    y=ds[var].mean(("lat", "lon")).values,
                    name=f"{frame}: {name}",
                    line={"color": color, "dash": dash},
                ),
                row=row,
                col=1,
            )
    fig.update_yaxes(type="log", row=2, col=1)
    fig.update_yaxes(type="log", row=3, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3, col=1)
    fig.update_layout(height=850, width=1000, title=title)
    return fig
