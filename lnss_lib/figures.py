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
