"""Figure builders (plotly) and the one place figures are written to disk.

Builders take datasets and return ``plotly.graph_objects.Figure``; notebooks call them and
:func:`save_figure`, which writes interactive HTML always and PNG when kaleido finds a Chromium.
"""

from __future__ import annotations

import asyncio
import atexit
import os
import threading
import warnings
from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from .pipeline import output_dir, write_caption

PNG_ENV = "LNSS_PNG"                 # set to "off" to skip PNG export (HTML only)
PNG_TIMEOUT_S = 120.0                 # start-up of Chromium, and rendering of one figure
_PNG_WARNED = False
_EXPORTER = None


def chromium_path() -> str | None:
    """The Chrome/Chromium kaleido would use for PNG export, or None.

    ``$BROWSER_PATH`` when set (and a file), else choreographer's search: Chrome/Chromium on
    ``PATH`` and the usual install paths (Debian's ``chromium`` package gives ``/usr/bin/chromium``).
    Nothing is downloaded.
    """
    override = os.environ.get("BROWSER_PATH")
    if override:
        return override if Path(override).is_file() else None
    from choreographer.browsers.chromium import Chromium

    return Chromium.find_browser(skip_local=False)


class _PngExporter:
    """One headless Chromium (kaleido) kept open for the whole process: about 2 s a figure instead of
    about 7 s for a fresh browser each time. Every call has a time limit, so a broken browser can
    only cost one timeout; MathJax is off, so the page needs no network."""

    def __init__(self, browser: str) -> None:
        import kaleido

        self.pid = os.getpid()
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="lnss-png-export", daemon=True)
        self._thread.start()

        async def open_browser():
            k = kaleido.Kaleido(path=browser, mathjax=False, timeout=PNG_TIMEOUT_S)
            await k.open()
            return k

        try:
            self._kaleido = self._run(open_browser())
        except BaseException:
            self._loop.call_soon_threadsafe(self._loop.stop)
            raise
        atexit.register(self.close)

    def _run(self, coroutine):
        return asyncio.run_coroutine_threadsafe(coroutine, self._loop).result(timeout=PNG_TIMEOUT_S)

    def png(self, fig: go.Figure, width: int, height: int) -> bytes:
        """PNG bytes of ``fig`` at ``width`` x ``height`` pixels."""
        return self._run(self._kaleido.calc_fig(fig.to_plotly_json(),
                                                opts={"format": "png", "width": width, "height": height}))

    def close(self) -> None:
        """Close the browser and stop the event loop (registered with ``atexit``)."""
        try:
            self._run(self._kaleido.close())
        except BaseException:
            pass
        self._loop.call_soon_threadsafe(self._loop.stop)


def _png_unavailable(reason: str) -> None:
    global _PNG_WARNED
    if not _PNG_WARNED:
        warnings.warn(
            f"PNG export skipped ({reason}); HTML written. For PNG figures install Chromium "
            "(Debian/Ubuntu: apt-get install chromium) or point BROWSER_PATH at a Chrome/Chromium executable.",
            RuntimeWarning,
            stacklevel=3,
        )
        _PNG_WARNED = True


def _write_png(fig: go.Figure, path: Path, width: int, height: int) -> bool:
    """Write ``fig`` as PNG with a persistent kaleido browser; False (one warning) when not possible."""
    global _EXPORTER
    if os.environ.get(PNG_ENV, "").lower() in ("off", "0", "no", "false"):
        _png_unavailable(f"{PNG_ENV}={os.environ[PNG_ENV]}")
        return False
    if _EXPORTER == "unavailable":
        return False
    try:
        if _EXPORTER is None or _EXPORTER.pid != os.getpid():
            browser = chromium_path()
            if browser is None:
                _EXPORTER = "unavailable"
                _png_unavailable("no Chrome/Chromium found")
                return False
            _EXPORTER = _PngExporter(browser)
        path.write_bytes(_EXPORTER.png(fig, width, height))
        return True
    except Exception as error:  # kaleido and choreographer raise several types when the browser fails
        _EXPORTER = "unavailable"
        _png_unavailable(f"{type(error).__name__}: {error}")
        return False


def figure_title(fig: go.Figure) -> str:
    """The figure's title as plain text (HTML tags dropped), or an empty string."""
    import re

    text = fig.layout.title.text or ""
    return " ".join(re.sub(r"<[^>]+>", " ", text).split())


def save_figure(fig: go.Figure, profile_name: str, name: str, *, width: int = 1000, height: int = 600,
                caption: str | None = None) -> dict[str, Path]:
    """Write ``fig`` as ``outputs/<profile>/figures/<name>.html`` and ``.png``; return the written paths.

    PNG export needs kaleido and a Chromium (Debian package ``chromium``; see :func:`chromium_path`);
    without one the HTML is still written and one warning says how to get PNGs. ``caption`` (default:
    the figure's title) goes to the sidecar ``<name>.meta.json`` that
    :func:`lnss_lib.pipeline.write_index` reads.
    """
    folder = output_dir(profile_name, "figures")
    written = {"html": folder / f"{name}.html"}
    fig.write_html(written["html"], include_plotlyjs="cdn")
    png = folder / f"{name}.png"
    if _write_png(fig, png, width, height):
        written["png"] = png
    elif png.is_file():
        png.unlink()
    written["meta"] = write_caption(folder, name, caption or figure_title(fig) or name,
                                    [p for k, p in written.items() if k != "meta"])
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


def _days(ds) -> np.ndarray:
    times = ds["time"].values.astype(float)
    return (times - times[0]) / 86400.0


def dop_time_series(dop_ds, *, title: str) -> go.Figure:
    """Grid-mean visible satellites, PDOP and HDOP against time (paper Figure 4)."""
    from plotly.subplots import make_subplots

    days = _days(dop_ds)
    fig = make_subplots(rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.04,
                        subplot_titles=["mean visible satellites", "grid-mean PDOP", "grid-mean HDOP"])
    for row, name in enumerate(("n_visible", "pdop", "hdop"), start=1):
        fig.add_trace(go.Scatter(x=days, y=dop_ds[name].mean(("lat", "lon")).values, mode="lines", showlegend=False),
                      row=row, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3, col=1)
    fig.update_layout(title=title, template="plotly_white", height=750)
    return fig


def thrust_history(dv_ds, model: str, *, title: str) -> go.Figure:
    """Required thrust acceleration, total and optimised, and its RTN components (paper Figure 6)."""
    from plotly.subplots import make_subplots

    days = _days(dv_ds)
    one = dv_ds.sel(model=model)
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.06,
                        subplot_titles=["|T| total and optimised (km/s^2)", "|T_R|, |T_T|, |T_N| (km/s^2)"])
    fig.add_trace(go.Scatter(x=days, y=one["T_total_kms2"].values, name="total (eq. 36)"), row=1, col=1)
    fig.add_trace(go.Scatter(x=days, y=one["T_opt_kms2"].values, name="optimised (eq. 40-41)"), row=1, col=1)
    for component in ("R", "T", "N"):
        fig.add_trace(go.Scatter(x=days, y=abs(one["T_rtn_kms2"].sel(rtn=component).values), name=f"|T_{component}|"),
                      row=2, col=1)
    fig.update_yaxes(type="log", exponentformat="power")
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(title=title, template="plotly_white", height=700)
    return fig


def gps_visibility_pdop(link_ds, *, title: str, sat: int = 0) -> go.Figure:
    """Visible GPS satellites and GPS-LNSS PDOP (log scale) of one LNSS satellite (paper Figure 7)."""
    from plotly.subplots import make_subplots

    days = _days(link_ds)
    one = link_ds.isel(sat=sat)
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.06,
                        subplot_titles=["visible GPS satellites", "GPS-LNSS PDOP"])
    fig.add_trace(go.Scatter(x=days, y=one["n_visible"].values, mode="lines", line_shape="hv", showlegend=False),
                  row=1, col=1)
    fig.add_trace(go.Scatter(x=days, y=one["pdop"].values, mode="markers", marker={"size": 3}, showlegend=False),
                  row=2, col=1)
    fig.update_yaxes(type="log", exponentformat="power", row=2, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(title=title, template="plotly_white", height=650)
    return fig


def constellation_3d(prop_ds, *, title: str, moon_radius_km: float = 1737.4) -> go.Figure:
    """Orbits of a propagated constellation in Moon-centred J2000 around a lunar sphere (paper Figures 3, 16)."""
    u, v = np.mgrid[0:2 * np.pi:40j, 0:np.pi:20j]
    fig = go.Figure(go.Surface(x=moon_radius_km * np.cos(u) * np.sin(v), y=moon_radius_km * np.sin(u) * np.sin(v),
                               z=moon_radius_km * np.cos(v), colorscale=[[0, "#9a9a9a"], [1, "#d0d0d0"]],
                               showscale=False, opacity=0.9, name="Moon", hoverinfo="skip"))
    r = prop_ds["r_mci_km"].transpose("sat", "time", "xyz").values
    raan = prop_ds["elements_deg"].values[:, 3] if "elements_deg" in prop_ds else np.arange(r.shape[0])
    planes = {value: p for p, value in enumerate(np.unique(np.round(raan, 6)))}
    palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
    for k in range(r.shape[0]):
        plane = planes[np.round(raan[k], 6)]
        fig.add_trace(go.Scatter3d(x=r[k, :, 0], y=r[k, :, 1], z=r[k, :, 2], mode="lines",
                                   line={"width": 2, "color": palette[plane % len(palette)]},
                                   name=f"sat {k + 1} (plane {plane + 1})", showlegend=r.shape[0] <= 20))
        fig.add_trace(go.Scatter3d(x=r[k, :1, 0], y=r[k, :1, 1], z=r[k, :1, 2], mode="markers",
                                   marker={"size": 4, "color": palette[plane % len(palette)]}, showlegend=False,
                                   hovertext=f"sat {k + 1} at the epoch"))
    fig.update_layout(title=title, template="plotly_white", height=700,
                      scene={"aspectmode": "data", "xaxis_title": "x (km)", "yaxis_title": "y (km)", "zaxis_title": "z (km)"})
    return fig


# ---------------------------------------------------------------------------------------------
# Notebook 02: south-pole DOP grid, element frames and line-of-sight axes (paper Table 4, Figure 4)
# ---------------------------------------------------------------------------------------------

def dop_grid_points(grid) -> go.Figure:
    """The receiver grid of eq. 1-2 (a :class:`lnss_lib.dop.SurfaceGrid`) in a polar plot around the south pole."""
    lat2d, lon2d = np.meshgrid(grid.lat_deg, grid.lon_deg, indexing="ij")
    fig = go.Figure(go.Scatterpolar(r=(90.0 + lat2d).ravel(), theta=lon2d.ravel(), mode="markers",
                                    marker={"size": 7},
                                    text=[f"lat {a:.0f}, lon {o:.0f}" for a, o in zip(lat2d.ravel(), lon2d.ravel())]))
    fig.update_layout(title="South-pole receiver grid (radius: colatitude from the south pole, deg; angle: longitude)",
                      polar={"radialaxis": {"range": [0, 32]}}, height=500, width=550)
    return fig


def _polar_wedges(values, lat_deg, lon_deg, name: str, coloraxis: str) -> go.Barpolar:
    lat2d, lon2d = np.meshgrid(lat_deg, lon_deg, indexing="ij")
    colat = 90.0 + lat2d
    base = np.maximum(colat - 5.0, 0.0)
    top = np.minimum(colat + 5.0, 30.0)
    return go.Barpolar(r=(top - base).ravel(), base=base.ravel(), theta=lon2d.ravel(), width=10.0,
                       marker={"color": np.asarray(values).ravel(), "coloraxis": coloraxis, "line_width": 0},
                       name=name, hovertemplate="lat %{customdata[0]:.0f} lon %{theta:.0f}: %{marker.color:.3g}<extra></extra>",
                       customdata=np.stack([lat2d.ravel(), lon2d.ravel()], axis=1))


DOP_MAP_PANELS = (("mean visible", "mean_visible", "Viridis"), ("median PDOP", "median_pdop", "Plasma"),
                  ("median HDOP (Moon-fixed x, y)", "median_hdop_moon_fixed", "Plasma"),
                  ("median HDOP (ENU)", "median_hdop_enu", "Plasma"),
                  ("PDOP availability (%)", "pdop_availability_pct", "Viridis"))


def dop_polar_maps(maps: dict, *, title: str) -> go.Figure:
    """Polar maps over the south-pole grid, one row per element frame (notebook 02; paper Table 4 metrics).

    ``maps``: element frame -> :func:`lnss_lib.dop.time_statistics_maps` Dataset. Each wedge is one
    grid node; the centre disc is the pole. Every column shares one colour scale across frames.
    """
    from plotly.subplots import make_subplots

    frames = list(maps)
    ncol = len(DOP_MAP_PANELS)
    fig = make_subplots(rows=len(frames), cols=ncol, specs=[[{"type": "polar"}] * ncol] * len(frames),
                        subplot_titles=[f"{label}<br>{frame}" for frame in frames for label, _, _ in DOP_MAP_PANELS],
                        vertical_spacing=0.12)
    for row, frame in enumerate(frames, start=1):
        ds = maps[frame]
        for col, (label, var, _) in enumerate(DOP_MAP_PANELS, start=1):
            fig.add_trace(_polar_wedges(ds[var].values, ds["lat"].values, ds["lon"].values, f"{label} ({frame})",
                                        f"coloraxis{col if col > 1 else ''}"), row=row, col=col)
    for col, (_, var, scale) in enumerate(DOP_MAP_PANELS, start=1):
        values = np.concatenate([np.ravel(maps[f][var].values) for f in frames])
        fig.update_layout({f"coloraxis{col if col > 1 else ''}": {
            "colorscale": scale, "cmin": float(np.nanmin(values)), "cmax": float(np.nanmax(values)),
            "colorbar": {"orientation": "h", "x": (col - 0.5) / ncol, "y": -0.08, "len": 0.8 / ncol, "thickness": 12}}})
    fig.update_polars(radialaxis={"range": [0, 30], "showticklabels": False}, angularaxis={"showticklabels": False})
    fig.update_layout(height=750, width=1400, showlegend=False, title=title)
    return fig


def dop_time_series_by_frame(dop: dict, *, title: str) -> go.Figure:
    """Grid-mean visible count, PDOP and HDOP (both axes conventions) against time, one colour per element
    frame (paper Figure 4). ``dop``: (element frame, los axes) -> :func:`lnss_lib.dop.dop_grid` Dataset."""
    from plotly.subplots import make_subplots

    fig = make_subplots(rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.05,
                        subplot_titles=["mean visible satellites", "grid-mean PDOP", "grid-mean HDOP"])
    palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"]
    frames = list(dict.fromkeys(frame for frame, _ in dop))
    for k, frame in enumerate(frames):
        color = palette[k % len(palette)]
        ds_mf, ds_enu = dop[(frame, "moon_fixed")], dop[(frame, "enu")]
        days = _days(ds_mf)
        for row, var, ds, name, dash in ((1, "n_visible", ds_mf, "visible", None), (2, "pdop", ds_mf, "PDOP", None),
                                         (3, "hdop", ds_mf, "HDOP Moon-fixed", None), (3, "hdop", ds_enu, "HDOP ENU", "dot")):
            fig.add_trace(go.Scatter(x=days, y=ds[var].mean(("lat", "lon")).values, name=f"{frame}: {name}",
                                     line={"color": color, "dash": dash}), row=row, col=1)
    fig.update_yaxes(type="log", row=2, col=1)
    fig.update_yaxes(type="log", row=3, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3, col=1)
    fig.update_layout(height=850, width=1000, title=title)
    return fig


# ---------------------------------------------------------------------------------------------
# Notebook 03: GPS-LNSS link (paper Figure 1 geometry, Table 1 budget, Figure 7, Table 4)
# ---------------------------------------------------------------------------------------------

def off_boresight_geometry(limits: dict, *, length_km: float = 70000.0) -> go.Figure:
    """Schematic of the off-boresight regions at a GPS satellite (as paper Figure 1, to scale around the Earth).

    ``limits``: :func:`lnss_lib.gps.off_boresight_limits` (angles in deg, radii in km).
    """
    r_gps, r_e = limits["r_gps_km"], limits["r_earth_km"]
    alpha, limb, last = limits["earth_limb_deg"], limits["limb_with_margin_deg"], limits["last_receivable_deg"]
    mask = limits["beam_mask_deg"]
    regions = [(0.0, limb, "blocked by the Earth + margin (eq. 21)", "rgba(200,0,0,0.35)"),
               (limb, limits["sidelobe_from_deg"], "main-lobe edge: receivable", "rgba(0,150,0,0.55)"),
               (limits["sidelobe_from_deg"], last, "sidelobes: receivable at 384 400 km", "rgba(0,200,0,0.25)"),
               (last, mask, "inside beam mask but C/N0 < 15 dB-Hz", "rgba(255,150,0,0.3)"),
               (mask, 90.0, "outside the 70 deg beam mask", "rgba(120,120,120,0.25)")]
    fig = go.Figure()
    for lo, hi, label, colour in regions:
        for side in (1, -1):
            ang = np.radians(np.linspace(lo, hi, 30))
            xs = np.concatenate([[0.0], side * length_km * np.sin(ang), [0.0]])
            ys = np.concatenate([[r_gps], r_gps - length_km * np.cos(ang), [r_gps]])
            fig.add_trace(go.Scatter(x=xs, y=ys, fill="toself", fillcolor=colour, line={"width": 0}, name=label,
                                     legendgroup=label, showlegend=side == 1, hoverinfo="name"))
    phi = np.linspace(0, 2 * np.pi, 200)
    fig.add_trace(go.Scatter(x=r_e * np.cos(phi), y=r_e * np.sin(phi), fill="toself", fillcolor="royalblue",
                             line={"color": "navy"}, name="Earth (6378 km)"))
    fig.add_trace(go.Scatter(x=r_gps * np.cos(phi), y=r_gps * np.sin(phi), line={"dash": "dot", "color": "grey"},
                             name="GPS orbit (26 560 km)"))
    fig.add_trace(go.Scatter(x=[0, 0], y=[r_gps, 0], line={"color": "black", "dash": "dash"}, name="boresight (eq. 19)"))
    fig.add_trace(go.Scatter(x=[0], y=[r_gps], mode="markers+text", marker={"size": 12, "color": "black", "symbol": "diamond"},
                             text=["GPS"], textposition="top center", name="GPS satellite"))
    for theta, label in ((alpha, f"limb {alpha:.1f} deg"), (limb, f"limb + margin {limb:.1f} deg"),
                         (last, f"C/N0 = 15 dB-Hz at {last:.1f} deg"), (mask, f"beam mask {mask:.0f} deg")):
        fig.add_annotation(x=length_km * np.sin(np.radians(theta)), y=r_gps - length_km * np.cos(np.radians(theta)),
                           text=label, showarrow=False, xanchor="left", font={"size": 11})
    fig.update_layout(title="Off-boresight geometry at a GPS satellite (to the Moon: beyond the Earth, along the rays)",
                      xaxis={"title": "km", "range": [-75000, 95000], "scaleanchor": "y"},
                      yaxis={"title": "km", "range": [-50000, 32000]}, height=650, width=1000)
    return fig


def gps_view_from_lnss(x_km, y_km, status, prn, r_earth_km: float, *, epoch: int = 0, sat_label: str = "1") -> go.Figure:
    """GPS satellites seen from an LNSS satellite, projected across the Earth direction (notebook 03).

    ``x_km``, ``y_km`` (time, gps) from :func:`lnss_lib.gps.earth_plane_projection`; ``status``
    (time, gps) from :func:`lnss_lib.gps.link_status`; ``prn`` (gps,). Faint dots: every visible link
    over the run; large dots: every GPS satellite at ``epoch``, coloured by the test that fails.
    """
    status = np.asarray(status)
    visible = status == "visible"
    prn = np.asarray(prn)
    fig = go.Figure()
    fig.add_trace(go.Scattergl(x=x_km[visible], y=y_km[visible], mode="markers",
                               marker={"size": 2, "color": "rgba(0,150,0,0.15)"}, name="visible, all epochs"))
    colours = {"visible": "green", "Earth (+margin) blocks": "red", "C/N0 < 15 dB-Hz": "orange", "outside beam": "grey",
               "Moon blocks": "black"}
    for label, colour in colours.items():
        m = status[epoch] == label
        fig.add_trace(go.Scatter(x=x_km[epoch, m], y=y_km[epoch, m], mode="markers+text", marker={"size": 10, "color": colour},
                                 text=[f"{p}" for p in prn[m]], textposition="top center",
                                 name=f"{label} (epoch {epoch}: {int(m.sum())})"))
    phi = np.linspace(0, 2 * np.pi, 200)
    fig.add_trace(go.Scatter(x=r_earth_km * np.cos(phi), y=r_earth_km * np.sin(phi), line={"color": "navy"}, name="Earth limb"))
    fig.update_layout(title=f"GPS satellites seen from LNSS satellite {sat_label} (epoch {epoch}; labels: PRN). "
                            f"Visible at epoch {epoch}: {int(visible[epoch].sum())}",
                      xaxis={"title": "km, across the Earth direction", "scaleanchor": "y"},
                      yaxis={"title": "km"}, height=650, width=800)
    return fig


def cn0_vs_off_boresight(gain_curves, temperature_curves, limits: dict, *, threshold_dbhz: float,
                         default_column: str) -> go.Figure:
    """GPS L1 C/N0 at the Moon against off-boresight angle (paper Table 1, eq. 22-24): left the gain columns,
    right the noise temperatures; curves from :func:`lnss_lib.gps.cn0_curves` (index: angle, deg)."""
    from plotly.subplots import make_subplots

    fig = make_subplots(rows=1, cols=2, subplot_titles=("gain columns (T = 190 K)", "noise temperature (improved panel)"))
    for col in gain_curves.columns:
        fig.add_trace(go.Scatter(x=gain_curves.index.values, y=gain_curves[col], name=col,
                                 line={"width": 3 if col == default_column else 1.5}), row=1, col=1)
    for label in temperature_curves.columns:
        fig.add_trace(go.Scatter(x=temperature_curves.index.values, y=temperature_curves[label], name=label,
                                 line={"dash": "dot"}), row=1, col=2)
    for c in (1, 2):
        fig.add_hline(y=threshold_dbhz, line={"color": "black", "dash": "dash"}, row=1, col=c)
        fig.add_vrect(x0=0, x1=limits["limb_with_margin_deg"], fillcolor="red", opacity=0.12, line_width=0, row=1, col=c)
        fig.add_vrect(x0=limits["beam_mask_deg"], x1=90, fillcolor="grey", opacity=0.2, line_width=0, row=1, col=c)
        fig.update_xaxes(title_text="off-boresight angle (deg)", row=1, col=c)
    fig.update_yaxes(title_text="C/N0 at 384 400 km (dB-Hz)", row=1, col=1)
    fig.update_layout(title="GPS L1 C/N0 at the Moon vs off-boresight angle (red: Earth + margin; grey: outside beam; "
                            "dashed: 15 dB-Hz)", height=500, width=1100)
    return fig


def gps_visibility_pdop_vs_paper(link_one, filtered_mean_pdop: float, paper_pdop: float, *, title: str) -> go.Figure:
    """Visible GPS satellites and GPS-LNSS PDOP (log scale) of one LNSS satellite with our filtered mean and the
    paper's value (paper Figure 7, Table 4). ``link_one``: one satellite of :func:`lnss_lib.gps.gps_link`."""
    from plotly.subplots import make_subplots

    days = _days(link_one)
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.06,
                        subplot_titles=("visible GPS satellites", "GPS-LNSS PDOP"))
    fig.add_trace(go.Scatter(x=days, y=link_one["n_visible"], mode="lines", line_shape="hv", name="visible"), row=1, col=1)
    fig.add_trace(go.Scatter(x=days, y=link_one["pdop"], mode="markers", marker={"size": 3}, name="PDOP"), row=2, col=1)
    fig.add_hline(y=filtered_mean_pdop, line={"dash": "dash", "color": "green"}, row=2, col=1,
                  annotation_text=f"filtered mean {filtered_mean_pdop:.0f}")
    fig.add_hline(y=paper_pdop, line={"dash": "dot", "color": "red"}, row=2, col=1, annotation_text=f"paper {paper_pdop:.0f}")
    fig.update_yaxes(type="log", row=2, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(height=650, width=1000, title=title)
    return fig


def gps_visible_links(theta_visible_deg, share_by_prn, limits: dict, main_share: float) -> go.Figure:
    """Histogram of the off-boresight angles of the visible links and the share of epochs each PRN is visible
    (notebook 03). ``share_by_prn``: :func:`lnss_lib.gps.visible_share_by_prn`; ``limits``:
    :func:`lnss_lib.gps.off_boresight_limits`; ``main_share``: :func:`lnss_lib.gps.main_lobe_share`."""
    from plotly.subplots import make_subplots

    fig = make_subplots(rows=1, cols=2, subplot_titles=("theta_off of visible links", "share of epochs each PRN is visible"))
    fig.add_trace(go.Histogram(x=theta_visible_deg, xbins={"start": 0, "end": 72, "size": 2}, name="visible links"), row=1, col=1)
    for x, label in ((limits["limb_with_margin_deg"], "limb + margin"), (limits["sidelobe_from_deg"], "main lobe edge"),
                     (limits["last_receivable_deg"], "C/N0 cut-off")):
        fig.add_vline(x=x, line={"dash": "dash"}, annotation_text=label, row=1, col=1)
    fig.add_trace(go.Bar(x=[f"PRN {p}" for p in share_by_prn.index], y=share_by_prn.values, name="share of epochs"),
                  row=1, col=2)
    fig.update_xaxes(title_text="off-boresight angle (deg)", row=1, col=1)
    fig.update_layout(height=450, width=1100, showlegend=False,
                      title=f"Visible links: {100 * main_share:.1f}% in the main-lobe edge, "
                            f"{100 * (1 - main_share):.1f}% in sidelobes")
    return fig


GPS_SENSITIVITY_GROUPS = {"noise temperature": ("T = ",), "gain column": ("gain ",), "sidelobe level": ("sidelobes",),
                          "beam mask": ("beam",), "orbit / GPS phase": ("Keplerian", "elements", "GPS phase")}


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
        fig.add_trace(go.Scatter(x=sub["gps_visible_mean"], y=sub["gps_pdop_mean"], mode="markers", name=label,
                                 text=sub.index, marker={"size": 9}))
    fig.add_trace(go.Scatter(x=[paper["gps_visible_mean"]], y=[paper["gps_pdop_mean"]], mode="markers+text",
                             marker={"size": 14, "symbol": "star", "color": "red"}, text=["paper"],
                             textposition="top center", name="paper Table 4"))
    fig.add_hline(y=prototype_pdop, line={"dash": "dot", "color": "grey"}, annotation_text=f"prototype ~{prototype_pdop:.0f}")
    fig.update_layout(title="Mean GPS-LNSS PDOP against mean visible GPS count, all variants (ELFO satellite 1)",
                      xaxis_title="mean visible GPS satellites",
                      yaxis={"title": "95th-percentile-filtered mean PDOP", "type": "log"}, height=550, width=950)
    return fig


# ---------------------------------------------------------------------------------------------
# Notebook 04: station-keeping Delta-V model (paper Figures 5 and 6, Table 4, Section 3.1)
# ---------------------------------------------------------------------------------------------

def deltav_elements_and_rates(res, *, title: str) -> go.Figure:
    """Osculating a, e, i, RAAN, AOP (left) and their central-difference rates (right) of a
    :func:`lnss_lib.deltav.deltav_from_propagation` result (paper Figure 5)."""
    from plotly.subplots import make_subplots

    days = _days(res)
    deg = np.degrees(1.0)
    names = [("a_km", "a (km)", 1.0), ("ecc", "e", 1.0), ("inc_rad", "i (deg)", deg),
             ("raan_rad", "RAAN (deg)", deg), ("aop_rad", "AOP (deg)", deg)]
    rate_units = [("km/day", 86400.0), ("1/day", 86400.0), ("deg/day", np.degrees(86400.0)),
                  ("deg/day", np.degrees(86400.0)), ("deg/day", np.degrees(86400.0))]
    fig = make_subplots(rows=5, cols=2, shared_xaxes=True, horizontal_spacing=0.1, vertical_spacing=0.03,
                        subplot_titles=[label if c == 0 else f"d/dt {label.split(' ')[0]} ({rate_units[r][0]})"
                                        for r, (_, label, _) in enumerate(names) for c in range(2)])
    for r, ((var, label, scale), (_, rate_scale)) in enumerate(zip(names, rate_units)):
        fig.add_trace(go.Scatter(x=days, y=res[var].values * scale, mode="lines", name=label, showlegend=False),
                      row=r + 1, col=1)
        fig.add_trace(go.Scatter(x=days, y=res["rate"].values[:, r] * rate_scale, mode="lines", name=f"rate {label}",
                                 showlegend=False), row=r + 1, col=2)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=5)
    fig.update_layout(height=1100, width=1000, title=title)
    return fig


def deltav_thrust_components(res, *, title: str, models=("lsq", "paper"), budget_model: str = "lsq") -> go.Figure:
    """|T_R|, |T_T|, |T_N| of the osculating models and T_total (eq. 36) and T_opt (eq. 40) of ``budget_model``
    against time, log scale (paper Figure 6). ``res``: :func:`lnss_lib.deltav.deltav_from_propagation`."""
    from plotly.subplots import make_subplots

    days = _days(res)
    fig = make_subplots(rows=4, cols=1, shared_xaxes=True, vertical_spacing=0.04,
                        subplot_titles=["|T_R| (km/s^2)", "|T_T| (km/s^2)", "|T_N| (km/s^2)",
                                        f"T_total and T_opt of {budget_model} (km/s^2)"])
    dashes = ("solid", "dot", "dash")
    for k, comp in enumerate("RTN"):
        for model, dash in zip(models, dashes):
            fig.add_trace(go.Scatter(x=days, y=np.abs(res["T_rtn_kms2"].sel(model=model, rtn=comp).values), mode="lines",
                                     line={"dash": dash}, name=f"{model} |T_{comp}|", legendgroup=model), row=k + 1, col=1)
    fig.add_trace(go.Scatter(x=days, y=res["T_total_kms2"].sel(model=budget_model).values, mode="lines",
                             name=f"{budget_model} T_total"), row=4, col=1)
    fig.add_trace(go.Scatter(x=days, y=res["T_opt_kms2"].sel(model=budget_model).values, mode="lines",
                             name=f"{budget_model} T_opt (eq. 40)"), row=4, col=1)
    fig.update_yaxes(type="log", exponentformat="e")
    fig.update_xaxes(title_text="days since epoch (TDB)", row=4)
    fig.update_layout(height=1000, width=1000, title=title)
    return fig


def lsq_recovery_series(t_tdb_s, truth_rtn_kms2, out: dict, *, title: str, max_days: float = 2.0) -> go.Figure:
    """RTN perturbing acceleration of the force model (truth) against the ``lsq`` and corrected ``paper`` inverses
    over the first ``max_days`` (notebook 04); inputs from :func:`lnss_lib.deltav.lsq_recovery`."""
    from plotly.subplots import make_subplots

    t = np.asarray(t_tdb_s, dtype=float)
    days = (t - t[0]) / 86400.0
    window = days <= min(max_days, days[-1])
    fig = make_subplots(rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.05,
                        subplot_titles=[f"T_{c} (km/s^2)" for c in "RTN"])
    for k in range(3):
        fig.add_trace(go.Scatter(x=days[window], y=truth_rtn_kms2[window, k], mode="lines", name="force model (truth)",
                                 line={"color": "black"}, showlegend=k == 0), row=k + 1, col=1)
        fig.add_trace(go.Scatter(x=days[window], y=out["T_rtn_lsq"][window, k], mode="markers", marker={"size": 4},
                                 name="lsq inverse", marker_color="#d62728", showlegend=k == 0), row=k + 1, col=1)
        fig.add_trace(go.Scatter(x=days[window], y=out["T_rtn_paper"][window, k], mode="markers",
                                 marker={"size": 4, "symbol": "x"}, name="paper (corrected)", marker_color="#1f77b4",
                                 showlegend=k == 0), row=k + 1, col=1)
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3)
    fig.update_layout(height=800, width=1000, title=title)
    return fig


def deltav_sampling(sampling, paper: dict, *, models=("paper", "lsq", "secular")) -> go.Figure:
    """Delta-V against sampling step for each integrator setting (:func:`lnss_lib.deltav.sampling_sweep`),
    with Table 4's total and optimised budgets (``paper``: ``dv_total``, ``dv_opt``)."""
    fig = go.Figure()
    for setting, dash in zip(dict.fromkeys(sampling.index.get_level_values(0)), ("solid", "dot", "dash")):
        sub = sampling.loc[setting]
        for m in models:
            fig.add_trace(go.Scatter(x=sub.index, y=sub[f"{m} total"], mode="lines+markers", line={"dash": dash},
                                     name=f"{m} total, {setting} tolerances"))
        fig.add_trace(go.Scatter(x=sub.index, y=sub["lsq opt"], mode="lines+markers", line={"dash": dash},
                                 name=f"lsq opt, {setting} tolerances"))
    fig.add_hline(y=paper["dv_total"], line_dash="dash", annotation_text=f"paper total {paper['dv_total']:.2f}")
    fig.add_hline(y=paper["dv_opt"], line_dash="dash", annotation_text=f"paper optimised {paper['dv_opt']:.2f}")
    fig.update_layout(xaxis_title="sampling step (s)", yaxis_title="Delta-V (km/s per year)", xaxis_type="log",
                      title="Delta-V of ELFO satellite 1 against sampling step and integrator tolerances",
                      width=1000, height=550)
    return fig


def deltav_singularity(singular) -> go.Figure:
    """``paper``-model total Delta-V against the divisor floor (no cap), one line per variant of eq. 32/35
    (:func:`lnss_lib.deltav.singularity_sweep`); a floor of 0 is plotted at 1e-8."""
    fig = go.Figure()
    for label in dict.fromkeys(singular.index.get_level_values("variant")):
        sub = singular.xs(label, level="variant").xs("none", level="cap (km/s^2)")
        x = np.where(sub.index.values > 0, sub.index.values, 1e-8)
        fig.add_trace(go.Scatter(x=x, y=sub["dv total"], mode="lines+markers", name=label))
    fig.update_layout(xaxis_type="log", yaxis_type="log", xaxis_title="divisor floor (0 plotted at 1e-8)",
                      yaxis_title="paper-model Delta-V total (km/s per year)", width=1000, height=500,
                      title="paper model: dependence on the singularity handling (no cap)")
    return fig


LABELS = {
    "n_sat": "satellites", "pdop_mean_3sigma": "PDOP (3-sigma mean)", "hdop_mean_3sigma": "HDOP (3-sigma mean)",
    "pdop_avail_pct": "PDOP availability (%)", "hdop_avail_pct": "HDOP availability (%)",
    "dv_total_kms_per_year": "Delta-V total (km/s/yr)", "dv_opt_kms_per_year": "Delta-V optimised (km/s/yr)",
    "gps_visible_mean": "mean visible GPS", "gps_pdop_mean": "GPS-LNSS PDOP", "sma_km": "SMA (km)", "ecc": "eccentricity",
    "aop_deg": "AOP (deg)", "inc_deg": "inclination (deg)", "mean_visible_sats": "mean visible LNSS satellites",
}


def _hover(ds) -> list[str]:
    return [f"a {a:.0f} km, e {e:.2f}, i {i:.0f}, AOP {w:.0f}, {p}x{s}" for a, e, i, w, p, s in
            zip(ds["sma_km"].values, ds["ecc"].values, ds["inc_deg"].values, ds["aop_deg"].values,
                ds["n_planes"].values, ds["sats_per_plane"].values)]


def pareto_3d(front, x: str, y: str, z: str, *, title: str) -> go.Figure:
    """Four-objective view of a front: three metrics in 3D, colour = number of satellites (Figures 8, 9)."""
    fig = go.Figure(go.Scatter3d(
        x=front[x].values, y=front[y].values, z=front[z].values, mode="markers", text=_hover(front),
        marker={"size": 5, "color": front["n_sat"].values, "colorscale": "Viridis", "colorbar": {"title": "satellites"}},
        hovertemplate="%{text}<br>" + f"{LABELS[x]} %{{x:.3g}}<br>{LABELS[y]} %{{y:.3g}}<br>{LABELS[z]} %{{z:.3g}}<extra></extra>"))
    fig.update_layout(title=title, template="plotly_white", height=700,
                      scene={"xaxis_title": LABELS[x], "yaxis_title": LABELS[y], "zaxis_title": LABELS[z]})
    return fig


def dop_against_availability(front, evaluations, dop: str, *, title: str) -> go.Figure:
    """A DOP metric against its availability: every evaluated design in grey, the front coloured by
    number of satellites (Figures 10, 11)."""
    avail = dop.replace("_mean_3sigma", "_avail_pct")
    fig = go.Figure()
    fig.add_trace(go.Scatter(x=evaluations[avail].values, y=evaluations[dop].values, mode="markers", name="evaluated",
                             marker={"size": 4, "color": "#c8c8c8"}, text=_hover(evaluations)))
    fig.add_trace(go.Scatter(x=front[avail].values, y=front[dop].values, mode="markers", name="front", text=_hover(front),
                             marker={"size": 8, "color": front["n_sat"].values, "colorscale": "Viridis",
                                     "colorbar": {"title": "satellites"}, "line": {"width": 0.5, "color": "black"}}))
    fig.update_layout(title=title, template="plotly_white", xaxis_title=LABELS[avail], yaxis_title=LABELS[dop],
                      legend={"orientation": "h", "y": -0.2})
    fig.update_yaxes(type="log")
    return fig


def variable_relationships(front, evaluations, variable: str, *, title: str) -> go.Figure:
    """A design variable against PDOP availability, Delta-V and GPS-LNSS PDOP (Figures 12-15)."""
    from plotly.subplots import make_subplots

    metrics = ("pdop_avail_pct", "dv_total_kms_per_year", "gps_pdop_mean")
    fig = make_subplots(rows=1, cols=3, subplot_titles=[LABELS[m] for m in metrics], horizontal_spacing=0.08)
    for col, metric in enumerate(metrics, start=1):
        fig.add_trace(go.Scatter(x=evaluations[variable].values, y=evaluations[metric].values, mode="markers",
                                 marker={"size": 4, "color": "#c8c8c8"}, name="evaluated", showlegend=col == 1,
                                 text=_hover(evaluations)), row=1, col=col)
        fig.add_trace(go.Scatter(x=front[variable].values, y=front[metric].values, mode="markers", name="front",
                                 showlegend=col == 1, text=_hover(front),
                                 marker={"size": 7, "color": front["n_sat"].values, "colorscale": "Viridis",
                                         "cmin": 1, "cmax": 20, "showscale": col == 3,
                                         "colorbar": {"title": "satellites"}}), row=1, col=col)
        fig.update_xaxes(title_text=LABELS[variable], row=1, col=col)
    fig.update_yaxes(type="log", row=1, col=3)
    fig.update_layout(title=title, template="plotly_white", height=500, legend={"orientation": "h", "y": -0.25})
    return fig


def campaign_convergence(history, title: str) -> go.Figure:
    """NSGA-II progress per generation (history.nc of :func:`lnss_lib.optimize.export_results`): hypervolume
    of the feasible archive, smallest population violation (log), unique designs and feasible counts."""
    from plotly.subplots import make_subplots

    g = history.generation.values
    fig = make_subplots(rows=2, cols=2, subplot_titles=(
        "hypervolume of the feasible archive", "smallest constraint violation in the population",
        "unique designs evaluated (cumulative)", "feasible designs: unique so far and in the population"))
    panels = (("hypervolume", "hypervolume", 1, 1), ("min_cv_pop", "min violation", 1, 2),
              ("n_evaluations_cum", "unique evaluated", 2, 1), ("n_feasible_cum", "unique feasible", 2, 2),
              ("n_feasible_pop", "feasible in population", 2, 2))
    for var, name, row, col in panels:
        fig.add_trace(go.Scatter(x=g, y=history[var].values, mode="lines+markers", name=name), row, col)
    fig.update_yaxes(type="log", row=1, col=2)
    fig.update_xaxes(title_text="generation")
    fig.update_layout(title=title, height=650)
    return fig


def designs_pdop_deltav(evaluations, front, dv_bound: float, pdop_bound: float, title: str) -> go.Figure:
    """Every evaluated design with a PDOP: PDOP_3sigma against Delta-V_total (km/s per satellite per year),
    log axes, colour = n_sat, the bounds ``dv_bound`` and ``pdop_bound`` dashed, front designs circled."""
    if dv_bound <= 0 or pdop_bound <= 0:
        raise ValueError(f"bounds must be positive on log axes; got dv_bound {dv_bound!r}, pdop_bound {pdop_bound!r}")
    ev = evaluations
    shown = ~np.isnan(ev.pdop_mean_3sigma.values)
    fig = go.Figure()
    fig.add_trace(go.Scatter(
        x=ev.dv_total_kms_per_year.values[shown], y=ev.pdop_mean_3sigma.values[shown], mode="markers", name="evaluated",
        marker=dict(color=ev.n_sat.values[shown], colorscale="Viridis", showscale=True, colorbar=dict(title="n_sat"),
                    size=7),
        text=[f"a {a:.0f} km, e {e:.2f}, AOP {w:.0f}, i {i:.0f}, {p}x{s}, generation {gen}" for a, e, w, i, p, s, gen in zip(
            ev.sma_km.values[shown], ev.ecc.values[shown], ev.aop_deg.values[shown], ev.inc_deg.values[shown],
            ev.n_planes.values[shown], ev.sats_per_plane.values[shown], ev.generation.values[shown])]))
    if front.sizes["design"]:
        fig.add_trace(go.Scatter(x=front.dv_total_kms_per_year.values, y=front.pdop_mean_3sigma.values, mode="markers",
                                 name="front (feasible)",
                                 marker=dict(size=14, color="rgba(0,0,0,0)", line=dict(width=2, color="red"))))
    fig.add_vline(x=dv_bound, line_dash="dash")
    fig.add_hline(y=pdop_bound, line_dash="dash")
    # annotation coordinates on log axes are log10 values
    fig.add_annotation(x=np.log10(dv_bound), y=1.0, xref="x", yref="paper", text="Delta-V bound", showarrow=False,
                       xanchor="left")
    fig.add_annotation(x=1.0, y=np.log10(pdop_bound), xref="paper", yref="y", text="PDOP bound", showarrow=False,
                       xanchor="right", yanchor="bottom")
    x_all = np.append(ev.dv_total_kms_per_year.values[shown], dv_bound)
    y_all = np.append(ev.pdop_mean_3sigma.values[shown], pdop_bound)
    fig.update_xaxes(title_text="Delta-V_total (km/s per satellite per year)", type="log",
                     range=[np.log10(np.nanmin(x_all)) - 0.1, np.log10(np.nanmax(x_all)) + 0.1])
    fig.update_yaxes(title_text="PDOP_3sigma (south-pole grid)", type="log",
                     range=[np.log10(np.nanmin(y_all)) - 0.1, np.log10(np.nanmax(y_all)) + 0.1])
    fig.update_layout(title=title)
    return fig


def campaign_throughput(history, title: str) -> go.Figure:
    """Designs evaluated per second in each generation of a campaign (history.nc ``designs_per_s``)."""
    fig = go.Figure(go.Bar(x=history.generation.values, y=history.designs_per_s.values, name="designs/s"))
    fig.update_layout(title=title, xaxis_title="generation", yaxis_title="designs / s")
    return fig
