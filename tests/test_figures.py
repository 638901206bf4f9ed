"""Figure and table writers: PNG through a system Chromium, HTML fallback, the outputs index."""

import pandas as pd
import plotly.graph_objects as go
import pytest

import lnss_lib.figures as figures
import lnss_lib.pipeline as pipeline


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    monkeypatch.setattr(pipeline, "OUTPUTS_DIR", tmp_path)
    return tmp_path


def _figure():
    return go.Figure(go.Scatter(x=[0, 1, 2], y=[1, 3, 2]), layout={"title": {"text": "a <b>test</b> figure"}})


@pytest.mark.skipif(figures.chromium_path() is None, reason="no Chrome/Chromium installed (apt-get install chromium)")
def test_png_written_with_system_chromium(outputs, monkeypatch):
    monkeypatch.delenv(figures.PNG_ENV, raising=False)
    written = figures.save_figure(_figure(), "t", "fig_png", width=400, height=300)
    assert written["png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert written["html"].is_file()


def test_html_fallback_warns_once(outputs, monkeypatch):
    monkeypatch.setenv(figures.PNG_ENV, "off")
    monkeypatch.setattr(figures, "_PNG_WARNED", False)
    with pytest.warns(RuntimeWarning, match="apt-get install chromium"):
        written = figures.save_figure(_figure(), "t", "fig_html")
    assert written["html"].is_file() and "png" not in written
    assert not (outputs / "t" / "figures" / "fig_html.png").exists()


def test_index_links_every_figure_and_table(outputs, monkeypatch):
    monkeypatch.setenv(figures.PNG_ENV, "off")
    monkeypatch.setattr(figures, "_PNG_WARNED", True)
    figures.save_figure(_figure(), "t", "fig_a")
    pipeline.save_table(pd.DataFrame({"x": [1.0, 2.5]}), "t", "table_a", caption="Table A: two numbers")
    page = pipeline.write_index("t").read_text()
    assert 'href="figures/fig_a.html"' in page and "a test figure" in page
    assert 'href="tables/table_a.csv"' in page and 'href="tables/table_a.md"' in page and "Table A: two numbers" in page
    markdown = (outputs / "t" / "tables" / "table_a.md").read_text()
    assert markdown.startswith("Table A: two numbers") and "| 2.5 |" in markdown
