"""Progress inside a long notebook cell: a bar JupyterLab shows live, cleared when the work is done.

In a Jupyter kernel the outermost :class:`CellProgress` displays one output (an HTML ``<progress>`` line and
its text) and updates it in place, at most every :data:`MIN_INTERVAL_S`; bars opened while it runs (a design
life inside a validation loop) add their line to it instead of opening outputs of their own. When the
outermost bar closes, the output is emptied, so an executed notebook keeps one empty display record: no
widget state, no stderr. Outside a kernel (the command line, tests) a bar does nothing; the command line has
its own tqdm bars (:mod:`lnss_lib.campaign.callbacks`).
"""

from __future__ import annotations

import html
import time

__all__ = ["CellProgress", "steps", "in_kernel", "MIN_INTERVAL_S"]

MIN_INTERVAL_S = 0.5  # shortest time between two redraws of a bar
_open: list[CellProgress] = []  # bars of the running cell, outermost first


def in_kernel() -> bool:
    """True inside a Jupyter kernel (JupyterLab, papermill, nbval, voila): where a cell's bar can be shown."""
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in shell.config


def _execution_count() -> int | None:
    from IPython import get_ipython

    return getattr(get_ipython(), "execution_count", None)


def _display(bundle: dict):
    """Display ``bundle`` (a mimebundle) with a display id; returns the handle that updates it in place."""
    from IPython.display import display

    return display(bundle, raw=True, display_id=True)


def _elapsed(seconds: float) -> str:
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes}:{secs:02d}"


class CellProgress:
    """``n`` of ``total`` ``unit`` done for ``desc``, shown below the running cell (nothing outside a kernel).

    :meth:`update` advances it and sets a ``note`` (what the step is doing); :meth:`close` removes its line
    (the outermost bar's close empties the output). Usable as a context manager.
    """

    def __init__(self, total: int, desc: str, unit: str = "steps", initial: int = 0):
        self.total, self.desc, self.unit, self.n, self.note = (
            int(total),
            desc,
            unit,
            int(initial),
            "",
        )
        self.start = time.perf_counter()
        self._handle = None
        self._drawn = 0.0
        self.closed = not in_kernel()
        if self.closed:
            return
        count = _execution_count()
        if _open and _open[0]._count != count:  # left open by a cell that raised: not this cell's
            _open.clear()
        self._count = count
        _open.append(self)
        if len(_open) == 1:
            self._handle = _display(self.bundle())
            self._drawn = time.perf_counter()
        else:
            self._redraw(force=True)

    def line(self) -> tuple[str, str]:
        """(HTML, text) of this bar's line: bar, count, elapsed time, the time left at the rate so far, the note."""
        elapsed = time.perf_counter() - self.start
        left = (
            f", about {_elapsed(elapsed / self.n * (self.total - self.n))} left"
            if 0 < self.n < self.total
            else ""
        )
        text = (
            f"{self.desc}: {self.n}/{self.total} {self.unit}, {_elapsed(elapsed)} elapsed{left}"
            + (f"; {self.note}" if self.note else "")
        )
        return (
            f"<progress value='{self.n}' max='{max(self.total, 1)}' style='width:12em'></progress> "
            f"{html.escape(text)}",
            text,
        )

    def bundle(self) -> dict:
        """The output's mimebundle: one line per open bar, outermost first."""
        lines = [bar.line() for bar in _open]
        return {
            "text/html": "<div style='font-family:monospace;font-size:90%'>"
            + "<br>".join(h for h, _ in lines)
            + "</div>",
            "text/plain": "\n".join(t for _, t in lines),
        }

    def update(self, advance: int = 1, note: str | None = None) -> None:
        """Advance by ``advance`` (``self.n`` is clipped to ``total``) and set the note; redraws when due."""
        if self.closed:
            return
        self.n = min(self.n + int(advance), self.total)
        if note is not None:
            self.note = note
        self._redraw(force=self.n == self.total)

    def _redraw(self, force: bool = False) -> None:
        root = _open[0] if _open else None
        now = time.perf_counter()
        if (
            root is None
            or root._handle is None
            or (not force and now - root._drawn < MIN_INTERVAL_S)
        ):
            return
        root._handle.update(root.bundle(), raw=True)
        root._drawn = now

    def close(self) -> None:
        """Remove this bar's line (and those of bars opened inside it); the outermost bar empties the output."""
        if self.closed:
            return
        self.closed = True
        if self in _open:
            del _open[_open.index(self) :]
        if self._handle is not None:
            self._handle.update({"text/plain": ""}, raw=True)
        else:
            self._redraw(force=True)

    def __enter__(self) -> CellProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def steps(items, desc: str, unit: str = "steps", total: int | None = None):
    """``items`` one by one under a :class:`CellProgress` that advances after each (closed at the end,
    also when the loop stops early)."""
    items = range(items) if isinstance(items, int) else items
    with CellProgress(len(items) if total is None else total, desc, unit) as bar:
        for item in items:
            yield item
            bar.update()
