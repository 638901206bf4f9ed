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


def test_no_browser_gives_html_and_one_warning(outputs, monkeypatch):
    monkeypatch.delenv(figures.PNG_ENV, raising=False)
    monkeypatch.setenv("BROWSER_PATH", str(outputs / "no-such-chrome"))
    monkeypatch.setattr(figures, "_EXPORTER", None)
    monkeypatch.setattr(figures, "_PNG_WARNED", False)
    stale = outputs / "t" / "figures" / "fig_b.png"
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"old")
    with pytest.warns(RuntimeWarning, match="no Chrome/Chromium found") as record:
        first = figures.save_figure(_figure(), "t", "fig_b")
        second = figures.save_figure(_figure(), "t", "fig_c")
    assert len([w for w in record if issubclass(w.category, RuntimeWarning)]) == 1
    assert first["html"].is_file() and second["html"].is_file()
    assert "png" not in first and not stale.exists()  # a PNG from an earlier run would not match the HTML


def test_constellation_3d_draws_moon_and_every_orbit():
    import numpy as np
    import xarray as xr

    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.elements import elements_to_state

    el = WalkerDesign(6143.0, 0.6, 51.7, 90.0, 2, 3).elements_deg()
    series = np.repeat(np.concatenate([el[:, :2], np.radians(el[:, 2:])], axis=1)[:, None, :], 50, axis=1)
    series[..., 5] += np.linspace(0.0, 2 * np.pi, 50)
    r = elements_to_state(series, 4902.8)[..., :3]
    ds = xr.Dataset({"r_mci_km": (("sat", "time", "xyz"), r), "elements_deg": (("sat", "element"), el)})
    fig = figures.constellation_3d(ds, title="t", moon_radius_km=1737.4)
    moon = fig.data[0]
    assert isinstance(moon, go.Surface)
    assert np.allclose(np.sqrt(moon.x ** 2 + moon.y ** 2 + moon.z ** 2), 1737.4)
    orbits = [t for t in fig.data[1:] if t.mode == "lines"]
    assert len(orbits) == 6 and len(fig.data) == 1 + 2 * 6
    assert np.allclose(orbits[0].x, r[0, :, 0])
    colours = [t.line.color for t in orbits]
    assert len(set(colours[:3])) == 1 and len(set(colours[3:])) == 1 and colours[0] != colours[3]  # one colour per plane


def test_markdown_table_cells_and_index_ignores_sidecars(outputs):
    import numpy as np

    frame = pd.DataFrame({"n": [3, 12], "pdop": [2.123456, np.nan], "why": ["a|b", "c"]},
                         index=pd.Index(["x", "y"], name="design"))
    lines = pipeline.markdown_table(frame, digits=3).splitlines()
    assert lines[0] == "| design | n | pdop | why |" and lines[1] == "|---|---|---|---|"
    assert lines[2] == "| x | 3 | 2.12 | a\\|b |" and lines[3] == "| y | 12 |  | c |"
    pipeline.save_table(frame, "t", "tab", caption="multi\nline  caption")
    assert pd.read_csv(outputs / "t" / "tables" / "tab.csv", index_col=0).index.tolist() == ["x", "y"]
    page = pipeline.write_index("t").read_text()
    assert "multi line caption" in page and ".meta.json" not in page
