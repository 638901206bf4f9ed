"""Writing figures to disk: interactive HTML that works offline, and PNG through kaleido's own renderer.

:func:`save_figure` is the one place a figure is written: ``outputs/<profile>/figures/<name>.html``
(plotly.js from one local ``plotly.min.js`` in the same folder, no CDN), ``<name>.png``, and the caption
sidecar the outputs index reads.

PNGs come from kaleido 0.2.1, which ships its own headless Chromium inside the wheel: ``pip install`` is
the whole set-up, no browser is installed or searched for, and nothing is fetched (the page loads the
``plotly.min.js`` of the installed plotly and MathJax is off). Plotly 7's ``write_image`` accepts only
kaleido 1.x, which drives a Chrome the user must install; so this module calls the 0.2.1 renderer itself.

In a notebook kernel, figures are displayed by :class:`NotebookRenderer`: the plotly JSON (interactive in
JupyterLab) with the PNG beside it for every other viewer (``nbconvert``, code-hosting sites), or HTML
carrying plotly.js inline once per notebook when PNG export is switched off.
"""

from __future__ import annotations

import atexit
import base64
import hashlib
import os
import re
import warnings
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from pathlib import Path

import plotly
import plotly.graph_objects as go
import plotly.io as pio
from plotly.io._base_renderers import MimetypeRenderer, PlotlyRenderer

from ..outputs import atomic_path, notebook_shell, output_dir, write_bytes_atomic, write_caption

PNG_ENV = "LNSS_PNG"  # set to "off" to skip PNG export (HTML only)
PNG_TIMEOUT_S = 120.0  # start-up of the renderer, and rendering of one figure
PNG_RETRY_FACTOR = (
    2.0  # a figure that timed out is tried once more, on a fresh renderer, with this much longer
)
_PNG_WARNED = False
_EXPORTER = None
NOTEBOOK_RENDERER = "lnss_notebook"
_PNG_BY_FIGURE: dict[
    str, bytes
] = {}  # figure fingerprint -> the PNG save_figure drew, for the notebook display
_PLOTLYJS_SENT = False  # the HTML fallback carried plotly.js in this kernel already


def local_plotlyjs() -> Path:
    """The ``plotly.min.js`` installed with plotly (the one the HTML figures copy beside them)."""
    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


class _PngExporter:
    """One kaleido renderer kept open for the whole process (its start-up costs a few seconds, a figure
    then a fraction of one, minutes on a machine loaded many times over). Every call has a time limit: a renderer
    that stops answering is shut down, and :func:`_png_bytes` tries the figure once more on a fresh one, so a
    stalled renderer costs at most one timeout and its retry."""

    def __init__(self) -> None:
        from kaleido.scopes.plotly import PlotlyScope

        self.pid = os.getpid()
        self._scope = PlotlyScope(plotlyjs=str(local_plotlyjs()), mathjax=False)
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lnss-png-export")
        atexit.register(self.close)

    def png(
        self, fig: go.Figure, width: int, height: int, timeout_s: float = PNG_TIMEOUT_S
    ) -> bytes:
        """PNG bytes of ``fig`` at ``width`` x ``height`` pixels, within ``timeout_s``."""
        job = self._worker.submit(
            self._scope.transform, fig.to_plotly_json(), format="png", width=width, height=height
        )
        try:
            return job.result(timeout=timeout_s)
        except FutureTimeout:
            self._scope._proc.kill()  # ends the blocked read in the worker; the scope holds its lock
            raise TimeoutError(f"no PNG after {timeout_s:.0f} s") from None

    def close(self) -> None:
        """Stop the renderer's process (registered with ``atexit``)."""
        self._scope._shutdown_kaleido()
        self._worker.shutdown(wait=False)


def _png_unavailable(reason: str) -> None:
    global _PNG_WARNED
    if not _PNG_WARNED:
        warnings.warn(f"PNG export skipped ({reason}); HTML written.", RuntimeWarning, stacklevel=3)
        _PNG_WARNED = True


def _png_bytes(fig: go.Figure, width: int, height: int) -> bytes | None:
    """PNG bytes of ``fig`` from a persistent kaleido renderer; None (one warning) when not possible."""
    global _EXPORTER
    if os.environ.get(PNG_ENV, "").lower() in ("off", "0", "no", "false"):
        _png_unavailable(f"{PNG_ENV}={os.environ[PNG_ENV]}")
        return None
    if _EXPORTER == "unavailable":
        return None
    for timeout_s in (PNG_TIMEOUT_S, PNG_RETRY_FACTOR * PNG_TIMEOUT_S):
        try:
            if _EXPORTER is None or _EXPORTER.pid != os.getpid():
                _EXPORTER = _PngExporter()
            return _EXPORTER.png(fig, width, height, timeout_s)
        except TimeoutError as error:
            # a slow start on a loaded machine: once more on a fresh renderer, with a longer limit
            _EXPORTER, failure = None, error
        except Exception as error:
            # the renderer reports a failed figure or a dead process as several types
            failure = error
            break
    _EXPORTER = "unavailable"
    _png_unavailable(f"{type(failure).__name__}: {failure}")
    return None


def _fingerprint(fig_dict: dict) -> str:
    return hashlib.sha1(
        pio.to_json(fig_dict, validate=False, remove_uids=False).encode()
    ).hexdigest()


class NotebookRenderer(MimetypeRenderer):
    """Plotly JSON (interactive where a plotly renderer exists, as in JupyterLab) and a static copy for
    every other viewer: the PNG :func:`save_figure` drew (or one drawn now at ``width`` x ``height``), or,
    with PNG export off, HTML whose first figure in the kernel carries plotly.js inline (no CDN; the renderer
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
            bundle["text/html"] = pio.to_html(
                fig_dict,
                include_plotlyjs=not _PLOTLYJS_SENT,
                full_html=False,
                include_mathjax=False,
                validate=False,
            )
            _PLOTLYJS_SENT = True
        return bundle


def use_notebook_renderer() -> bool:
    """Make :class:`NotebookRenderer` plotly's default when running in a notebook kernel; True if it did."""
    if notebook_shell() is None:
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


def save_figure(
    fig: go.Figure,
    profile_name: str,
    name: str,
    *,
    width: int = 1000,
    height: int = 600,
    caption: str | None = None,
) -> dict[str, Path]:
    """Write ``fig`` as ``outputs/<profile>/figures/<name>.html`` and ``.png``; return the written paths.

    The HTML loads plotly.js from ``plotly.min.js`` beside it (written once per folder), so figures open
    with no network. The PNG comes from kaleido's bundled renderer; when it fails (or ``LNSS_PNG=off``) the
    HTML is still written and one warning says why.
    ``caption`` (default: the figure's title) goes to the sidecar ``<name>.meta.json`` that
    :func:`lnss_lib.pipeline.write_index` reads.
    """
    folder = output_dir(profile_name, "figures")
    written = {"html": folder / f"{name}.html"}
    with atomic_path(
        written["html"]
    ) as temporary:  # plotly.min.js goes beside it, in the same folder
        fig.write_html(temporary, include_plotlyjs="directory", include_mathjax=False)
    png = folder / f"{name}.png"
    if _write_png(fig, png, width, height):
        written["png"] = png
    elif png.is_file():
        png.unlink()
    written["meta"] = write_caption(
        folder,
        name,
        caption or figure_title(fig) or name,
        [p for k, p in written.items() if k != "meta"],
    )
    return written
