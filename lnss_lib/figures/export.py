"""Writing figures to disk: interactive HTML that works offline, and PNG through a system Chromium (kaleido).

:func:`save_figure` is the one place a figure is written: ``outputs/<profile>/figures/<name>.html``
(plotly.js from one local ``plotly.min.js`` in the same folder, no CDN), ``<name>.png`` when kaleido
finds a Chromium, and the caption sidecar the outputs index reads.

In a notebook kernel, figures are displayed by :class:`NotebookRenderer`: the plotly JSON (interactive in
JupyterLab) with a static copy beside it for every other viewer (``nbconvert``, code-hosting sites): the
PNG :func:`save_figure` drew, or HTML carrying plotly.js inline once per notebook when there is no Chromium.
"""

from __future__ import annotations

import asyncio
import atexit
import base64
import hashlib
import os
import re
import threading
import warnings
from pathlib import Path

import plotly.graph_objects as go
import plotly.io as pio
from plotly.io._base_renderers import MimetypeRenderer, PlotlyRenderer

from ..outputs import atomic_path, output_dir, write_bytes_atomic, write_caption

PNG_ENV = "LNSS_PNG"                 # set to "off" to skip PNG export (HTML only)
PNG_TIMEOUT_S = 120.0                 # start-up of Chromium, and rendering of one figure
_PNG_WARNED = False
_EXPORTER = None
NOTEBOOK_RENDERER = "lnss_notebook"
_PNG_BY_FIGURE: dict[str, bytes] = {}  # figure fingerprint -> the PNG save_figure drew, for the notebook display
_PLOTLYJS_SENT = False                  # the HTML fallback carried plotly.js in this kernel already


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


def _png_bytes(fig: go.Figure, width: int, height: int) -> bytes | None:
    """PNG bytes of ``fig`` from a persistent kaleido browser; None (one warning) when not possible."""
    global _EXPORTER
    if os.environ.get(PNG_ENV, "").lower() in ("off", "0", "no", "false"):
        _png_unavailable(f"{PNG_ENV}={os.environ[PNG_ENV]}")
        return None
    if _EXPORTER == "unavailable":
        return None
    try:
        if _EXPORTER is None or _EXPORTER.pid != os.getpid():
            browser = chromium_path()
            if browser is None:
                _EXPORTER = "unavailable"
                _png_unavailable("no Chrome/Chromium found")
                return None
            _EXPORTER = _PngExporter(browser)
        return _EXPORTER.png(fig, width, height)
    except Exception as error:  # kaleido and choreographer raise several types when the browser fails
        _EXPORTER = "unavailable"
        _png_unavailable(f"{type(error).__name__}: {error}")
        return None


def _fingerprint(fig_dict: dict) -> str:
    return hashlib.sha1(pio.to_json(fig_dict, validate=False, remove_uids=False).encode()).hexdigest()


class NotebookRenderer(MimetypeRenderer):
    """Plotly JSON (interactive where a plotly renderer exists, as in JupyterLab) and a static copy for
    every other viewer: the PNG :func:`save_figure` drew (or one drawn now at ``width`` x ``height``), or,
    without a Chromium, HTML whose first figure in the kernel carries plotly.js inline (no CDN; the renderer
    is copied per display, so that state is the module's)."""

    def __init__(self, width: int = 1000, height: int = 600) -> None:
        self.width, self.height = width, height

    def to_mimebundle(self, fig_dict: dict) -> dict:
        global _PLOTLYJS_SENT
        key = _fingerprint(fig_dict)
        bundle = PlotlyRenderer().to_mimebundle(fig_dict)
        png = _PNG_BY_FIGURE.get(key) or _png_bytes(go.Figure(fig_dict), self.width, self.height)
        if png is not None:
            bundle["image/png"] = base64.b64encode(png).decode("ascii")
        else:
            bundle["text/html"] = pio.to_html(fig_dict, include_plotlyjs=not _PLOTLYJS_SENT, full_html=False,
                                              include_mathjax=False, validate=False)
            _PLOTLYJS_SENT = True
        return bundle


def use_notebook_renderer() -> bool:
    """Make :class:`NotebookRenderer` plotly's default when running in a notebook kernel; True if it did."""
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    if shell is None or not hasattr(shell, "kernel"):
        return False
    if NOTEBOOK_RENDERER not in pio.renderers:
        pio.renderers[NOTEBOOK_RENDERER] = NotebookRenderer()
    pio.renderers.default = NOTEBOOK_RENDERER
    return True


def _write_png(fig: go.Figure, path: Path, width: int, height: int) -> bool:
    """Write ``fig`` as PNG (remembered for the notebook display); False when not possible."""
    data = _png_bytes(fig, width, height)
    if data is None:
        return False
    write_bytes_atomic(path, data)
    _PNG_BY_FIGURE[_fingerprint(fig.to_dict())] = data
    return True


def figure_title(fig: go.Figure) -> str:
    """The figure's title as plain text (HTML tags dropped), or an empty string."""
    text = fig.layout.title.text or ""
    return " ".join(re.sub(r"<[^>]+>", " ", text).split())


def save_figure(fig: go.Figure, profile_name: str, name: str, *, width: int = 1000, height: int = 600,
                caption: str | None = None) -> dict[str, Path]:
    """Write ``fig`` as ``outputs/<profile>/figures/<name>.html`` and ``.png``; return the written paths.

    The HTML loads plotly.js from ``plotly.min.js`` beside it (written once per folder), so figures open
    with no network. PNG export needs kaleido and a Chromium (Debian package ``chromium``; see
    :func:`chromium_path`); without one the HTML is still written and one warning says how to get PNGs.
    ``caption`` (default: the figure's title) goes to the sidecar ``<name>.meta.json`` that
    :func:`lnss_lib.pipeline.write_index` reads.
    """
    folder = output_dir(profile_name, "figures")
    written = {"html": folder / f"{name}.html"}
    with atomic_path(written["html"]) as temporary:   # plotly.min.js goes beside it, in the same folder
        fig.write_html(temporary, include_plotlyjs="directory", include_mathjax=False)
    png = folder / f"{name}.png"
    if _write_png(fig, png, width, height):
        written["png"] = png
    elif png.is_file():
        png.unlink()
    written["meta"] = write_caption(folder, name, caption or figure_title(fig) or name,
                                    [p for k, p in written.items() if k != "meta"])
    return written
