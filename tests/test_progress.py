"""Progress inside long notebook cells: shown live in a kernel, cleared when done, silent elsewhere."""

import json

import nbformat
import pytest

from lnss_lib import progress
from lnss_lib.campaign import CellProgressBar, run_campaign


class FakeHandle:
    """What IPython's ``display(..., display_id=True)`` returns: records every update of the one output."""

    def __init__(self, bundle, shown):
        self.shown = shown
        shown.append(bundle)

    def update(self, bundle, raw=False):
        assert raw
        self.shown.append(bundle)


@pytest.fixture
def kernel(monkeypatch):
    """A pretend kernel: every bundle the outputs show, per output (one list per ``display`` call)."""
    outputs, count = [], {"n": 1}
    monkeypatch.setattr(progress, "in_kernel", lambda: True)
    monkeypatch.setattr(progress, "_execution_count", lambda: count["n"])
    monkeypatch.setattr(
        progress, "_display", lambda bundle: FakeHandle(bundle, outputs.append([]) or outputs[-1])
    )
    monkeypatch.setattr(progress, "MIN_INTERVAL_S", 0.0)
    monkeypatch.setattr(progress, "_open", [])
    return outputs, count


def test_outside_a_kernel_a_bar_shows_nothing_and_loops_run_through(capfd):
    assert not progress.in_kernel()
    assert list(progress.steps(["a", "b", "c"], "letters")) == ["a", "b", "c"]
    with progress.CellProgress(4, "work") as bar:
        bar.update(2, "half")
        assert bar.closed
    assert capfd.readouterr() == ("", "")


def test_nested_bars_share_one_output_that_is_emptied_at_the_end(kernel):
    outputs, _ = kernel
    seen = []
    for design in progress.steps(["d1", "d2"], "validation", "designs"):
        for _ in progress.steps(3, f"life of {design}", "box checks"):
            seen.append(outputs[0][-1]["text/plain"])
    assert len(outputs) == 1, "a bar opened inside another must not open an output of its own"
    assert seen[0].splitlines() == [
        "validation: 0/2 designs, 0:00 elapsed",
        "life of d1: 0/3 box checks, 0:00 elapsed",
    ]
    assert (
        seen[-1].splitlines()[0].startswith("validation: 1/2 designs")
        and "life of d2: 2/3" in seen[-1]
    )
    assert "left" in seen[-1].splitlines()[0]  # the time left, at the rate so far
    html = [b["text/html"] for b in outputs[0] if "text/html" in b]
    assert all(h.count("<progress") == h.count("<br>") + 1 for h in html)
    assert (
        "<progress value='2' max='2'" in html[-1] and "life of" not in html[-1]
    )  # the inner bar's line gone
    assert outputs[0][-1] == {"text/plain": ""}  # cleared: the saved notebook keeps no bar
    assert progress._open == []


def test_redraws_are_throttled_but_the_last_step_is_drawn(kernel, monkeypatch):
    outputs, _ = kernel
    monkeypatch.setattr(progress, "MIN_INTERVAL_S", 3600.0)
    with progress.CellProgress(50, "work") as bar:
        for _ in range(50):
            bar.update()
        assert [b["text/plain"].split(",")[0] for b in outputs[0]] == [
            "work: 0/50 steps",
            "work: 50/50 steps",
        ]


def test_a_bar_left_open_by_a_failed_cell_does_not_swallow_the_next_cell(kernel):
    outputs, count = kernel
    with pytest.raises(ZeroDivisionError):
        for _ in progress.steps(3, "failing"):
            1 / 0
    stale = progress.CellProgress(5, "never closed")  # as after an error a runner does not catch
    count["n"] = 2
    with progress.CellProgress(2, "next cell") as bar:
        assert progress._open == [bar]
    assert len(outputs) == 3 and outputs[2][0]["text/plain"].startswith("next cell: 0/2")
    assert outputs[0][-1] == {"text/plain": ""}  # the loop that raised closed its bar
    assert not stale.closed


def test_campaign_bar_counts_generations_and_designs_then_clears(kernel, tmp_path):
    outputs, _ = kernel
    run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "generations": 3}},
        workers=0,
        run_dir=tmp_path / "run",
        progress=False,
        callbacks=[CellProgressBar()],
    )
    assert len(outputs) == 1
    texts = [b["text/plain"] for b in outputs[0][:-1]]
    assert texts[0].startswith("campaign ") and ": 0/3 generations" in texts[0]
    assert any(
        ": 1/3 generations" in t and "generation 2: " in t and "designs/s" in t for t in texts
    )
    assert ": 3/3 generations" in texts[-1] and "feasible" in texts[-1]
    assert outputs[0][-1] == {"text/plain": ""}


def test_executed_notebook_keeps_no_trace_but_one_empty_output(tmp_path):
    """A real kernel: the bar goes out live as HTML ``<progress>`` updates of one display; the saved cell holds
    one empty display output, no stream output and no widget state."""
    from nbclient import NotebookClient

    source = (
        "from lnss_lib import progress\nprogress.MIN_INTERVAL_S = 0.0\n"
        "for _ in progress.steps(3, 'outer'):\n    for _ in progress.steps(2, 'inner'):\n        pass\n"
    )
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(source)])
    live = []

    class Recording(NotebookClient):
        def process_message(self, msg, cell, cell_index):
            if msg["msg_type"] in ("display_data", "update_display_data"):
                live.append(msg["content"]["data"])
            return super().process_message(msg, cell, cell_index)

    Recording(nb, timeout=120, kernel_name="python3").execute()
    outputs = nb.cells[0].outputs
    assert [o["output_type"] for o in outputs] == ["display_data"] and outputs[0]["data"] == {
        "text/plain": ""
    }
    assert "widgets" not in nb.metadata
    assert any(
        "<progress value='1' max='3'" in d.get("text/html", "")
        and "inner: " in d.get("text/plain", "")
        for d in live
    )
    assert len(json.dumps(outputs)) < 200
