"""Figure builders (plotly) and the one place figures are written to disk.

Builders take datasets and return ``plotly.graph_objects.Figure``; notebooks call them and
:func:`save_figure`, which writes interactive HTML always and PNG when kaleido finds a Chromium.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import plotly.graph_objects as go

from .pipeline import output_dir

_PNG_WARNED = False


def save_figure(fig: go.Figure, profile_name: str, name: str, *, width: int = 1000, height: int = 600) -> dict[str, Path]:
    """Write ``fig`` as ``outputs/<profile>/figures/<name>.html`` and ``.png``; return the written paths.

    PNG export needs kaleido and a Chromium (Debian package ``chromium``); without one the HTML is
    still written and a warning says how to get PNGs.
    """
    global _PNG_WARNED
    folder = output_dir(profile_name, "figures")
    written = {"html": folder / f"{name}.html"}
    fig.write_html(written["html"], include_plotlyjs="cdn")
    try:
        fig.write_image(folder / f"{name}.png", width=width, height=height)
        written["png"] = folder / f"{name}.png"
    except Exception as error:  # kaleido raises several types when no browser is available
        if not _PNG_WARNED:
            warnings.warn(
                f"PNG export skipped ({type(error).__name__}: {error}); HTML written. "
                "Install Chromium (apt-get install chromium) for PNG figures.",
                RuntimeWarning,
                stacklevel=2,
            )
            _PNG_WARNED = True
    return written
