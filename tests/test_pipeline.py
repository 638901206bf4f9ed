"""Running the workbook: the outputs index (findings first, thumbnails, inline tables, offline), IPC kernels for papermill,
and a written HTML figure rendered by headless Chromium with the network disabled."""

import base64
import json
import shutil
import struct
import subprocess
import sys
import zlib

import numpy as np
import pandas as pd
import plotly.graph_objects as go
import pytest
import xarray as xr

import lnss_lib.figures as figures
import lnss_lib.figures.export as export
import lnss_lib.outputs
import lnss_lib.pipeline as pipeline
from lnss_lib import findings
from lnss_lib.keys import format_value, label
from lnss_lib.paper import FEASIBLE_DESIGNS, TABLE_4

CHROMIUM = (
    shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
)
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on PATH (apt-get install chromium)"
)


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    monkeypatch.setattr(lnss_lib.outputs, "OUTPUTS_DIR", tmp_path)
    monkeypatch.setenv(export.PNG_ENV, "off")
    monkeypatch.setattr(export, "_PNG_WARNED", True)
    return tmp_path


def _figure(title="a <b>test</b> figure"):
    return go.Figure(
        go.Scatter(x=[0, 1, 2], y=[1, 3, 2], line={"width": 8}), layout={"title": {"text": title}}
    )


def test_index_links_every_figure_and_table(outputs):
    figures.save_figure(_figure(), "t", "fig_a")
    lnss_lib.outputs.save_table(
        pd.DataFrame({"x": [1.0, 2.5]}), "t", "table_a", caption="Table A: two numbers"
    )
    page = pipeline.write_index("t").read_text()
    assert 'href="figures/fig_a.html"' in page and "a test figure" in page
    assert (
        'href="tables/table_a.csv"' in page
        and 'href="tables/table_a.md"' in page
        and "Table A: two numbers" in page
    )
    markdown = (outputs / "t" / "tables" / "table_a.md").read_text()
    assert markdown.startswith("Table A: two numbers") and "| 2.5 |" in markdown


def test_index_groups_by_notebook_with_thumbnails_and_inline_tables(outputs):
    figures.save_figure(_figure("orbit"), "t", "05_orbit")
    figures.save_figure(_figure("dop"), "t", "02_dop")
    (outputs / "t" / "figures" / "05_orbit.png").write_bytes(
        b"\x89PNG\r\n\x1a\n"
    )  # as kaleido would write it
    lnss_lib.outputs.save_table(
        pd.DataFrame({"metric": ["pdop", "a<b"], "value": [2.123456789, 40]}),
        "t",
        "05_metrics",
        caption="metrics of the design",
    )
    page = pipeline.write_index("t").read_text()
    assert (
        page.index("02 dop grid")
        < page.index("02_dop")
        < page.index("05 standalone elfo")
        < page.index("05_orbit")
    )
    assert '<a href="figures/05_orbit.html"><img src="figures/05_orbit.png" alt="orbit"' in page
    assert (
        '<a href="figures/02_dop.html"><div class="noimg">' in page
    )  # no PNG: still a link to the HTML
    assert (
        "<td>2.123</td>" in page
        and '<td class="text">a&lt;b</td>' in page
        and "<td>40</td>" in page
    )
    assert "http://" not in page and "https://" not in page


def test_index_shows_the_first_rows_of_a_long_table(outputs, monkeypatch):
    monkeypatch.setattr(pipeline, "INDEX_TABLE_MAX_ROWS", 3)
    lnss_lib.outputs.save_table(pd.DataFrame({"k": range(10)}), "t", "01_long", caption="long")
    page = pipeline.write_index("t").read_text()
    section = page[page.index('id="nb-01"') :]  # after the findings
    assert section.count("<tr>") == 4 and "first 3 of 10 rows" in section


def _table4(ours_factor: float) -> pd.DataFrame:
    ours = {k: v * ours_factor for k, v in TABLE_4.items()}
    return pd.DataFrame(
        {
            "metric": [label(k) for k in TABLE_4],
            "paper": list(TABLE_4.values()),
            "this workbook": list(ours.values()),
            "difference (%)": [100.0 * (ours_factor - 1.0)] * len(TABLE_4),
            "why": [f"reason for {k}" for k in TABLE_4],
        }
    )


def _campaign(folder, n_sat, pdop, dv):
    n = len(n_sat)
    ds = xr.Dataset(
        {
            "n_sat": ("design", np.array(n_sat)),
            "pdop_mean_3sigma": ("design", np.array(pdop, float)),
            "dv_total_kms_per_year": ("design", np.array(dv, float)),
            "pdop_avail_pct": ("design", np.full(n, 95.0)),  # every evaluation reports both
            "hdop_avail_pct": ("design", np.full(n, 97.0)),
            "sma_km": ("design", np.full(n, 6143.0)),
            "ecc": ("design", np.full(n, 0.6)),
            "inc_deg": ("design", np.full(n, 51.7)),
            "aop_deg": ("design", np.full(n, 90.0)),
            "n_planes": ("design", np.full(n, 2)),
            "sats_per_plane": ("design", np.array(n_sat) // 2),
        },
        attrs={
            "constraints": "pdop_mean_3sigma <= 10,dv_total_kms_per_year <= 1",
            "generations_done": 1,
        },
    )
    from lnss_lib.campaign.publication import POINTER_FILE, PUBLISHED_DIR
    from lnss_lib.campaign.rundir import RESULT_FILES

    published = (
        folder / PUBLISHED_DIR / "run_1-x"
    )  # a published campaign: the pointer and its folder
    published.mkdir(parents=True)
    for name in RESULT_FILES:  # the findings read evaluations.nc only
        ds.to_netcdf(published / name, engine="h5netcdf")
    (folder / POINTER_FILE).write_text(
        json.dumps({"folder": f"{PUBLISHED_DIR}/{published.name}", "run_dir": "run_1"})
    )


def test_findings_are_generated_from_the_outputs_and_open_the_index(outputs):
    lnss_lib.outputs.save_table(_table4(1.25), "t", "05_table4", caption="Table 4")
    for stem in (
        "07_fig10_pdop_availability",
        "07_fig8_hdop_pdop_deltav",
        "07_fig9_pdop_gpspdop_deltav",
        "05_fig4_dop_time_series",
    ):
        figures.save_figure(
            go.Figure(go.Scatter(x=[0, 1], y=[1, 2]), layout={"title": {"text": stem}}), "t", stem
        )
    _campaign(
        outputs / "t" / "campaign",
        n_sat=[4, 8, 12, 6],
        pdop=[40.0, 3.0, 2.0, 5.0],
        dv=[0.5, 0.9, 0.2, 3.0],
    )
    page = pipeline.write_index("t").read_text()
    start = page.index('id="findings"')
    assert start < page.index('id="nb-05"') < page.index('id="nb-07"') and start < page.index(
        "<figure"
    )
    assert (
        page.index("07_fig8_") < page.index("07_fig9_") < page.index("07_fig10_")
    )  # natural order
    markdown = (outputs / "t" / findings.FINDINGS_FILE).read_text()
    pdop = TABLE_4["pdop_mean_3sigma"]
    row = next(
        line
        for line in markdown.splitlines()
        if line.startswith("| Table 4") and label("pdop_mean_3sigma") in line
    )
    assert (
        f"| {format_value('pdop_mean_3sigma', pdop)} | {format_value('pdop_mean_3sigma', 1.25 * pdop)} (+25.0 %)"
        in row
    )
    assert "reason for pdop_mean_3sigma" in row and "figures/05_fig4_dop_time_series.html" in row
    # the campaign: two designs meet both bounds, the smallest has 8 satellites and its own Delta-V
    feasible = next(
        line for line in markdown.splitlines() if line.startswith("| Designs meeting Table 3")
    )
    assert f"| {FEASIBLE_DESIGNS} of" in feasible and "| 2 of 4 unique designs |" in feasible
    smallest = next(
        line for line in markdown.splitlines() if line.startswith("| Smallest constellation")
    )
    assert (
        f"8 satellites, {label('dv_total_kms_per_year')} {format_value('dv_total_kms_per_year', 0.9)}"
        in smallest
    )
    # outputs this run did not write are named with the notebook that writes them
    life = next(line for line in markdown.splitlines() if line.startswith("| Design life"))
    assert "not in this run" in life and "--only 08" in life


def test_findings_without_outputs_say_what_to_run(outputs):
    found = findings.collect("empty")
    assert found and all(f.workbook == "not in this run" for f in found)
    assert {f.why.split("--only ")[1] for f in found} == {"05", "06", "08", "10"}


def test_kernels_use_ipc_transport():
    manager = pipeline.ipc_kernel_manager_class()(kernel_name="python3")
    assert manager.transport == "ipc" and manager.ip.endswith("-ipc") and "/" in manager.ip


def _notebook_folder(tmp_path, monkeypatch, name: str, *code: str):
    """A notebooks folder in ``tmp_path`` holding ``name``: a papermill parameters cell, then ``code`` cells;
    ``reproduce`` reads it."""
    import nbformat

    books = tmp_path / "notebooks"
    books.mkdir()
    nb = nbformat.v4.new_notebook(
        metadata={
            "kernelspec": {"name": "python3", "language": "python", "display_name": "Python 3"}
        }
    )
    nb.cells = [
        nbformat.v4.new_code_cell("profile_name = 'quick'", metadata={"tags": ["parameters"]}),
        *(nbformat.v4.new_code_cell(text) for text in code),
    ]
    nbformat.write(nb, books / f"{name}.ipynb")
    monkeypatch.setattr(pipeline, "NOTEBOOKS_DIR", books)


def test_reproduce_prints_only_progress_and_summary(outputs, tmp_path, monkeypatch, capfd):
    import nbformat

    _notebook_folder(
        tmp_path,
        monkeypatch,
        "01_tiny",
        "import os\nassert profile_name == os.environ['LNSS_PROFILE'] == 'ci'\nprint('ran')",
    )
    monkeypatch.setenv("PYTHONPATH", "")
    monkeypatch.setenv(
        pipeline.PROFILE_ENV, "quick"
    )  # reproduce's profile wins, and reaches the kernel
    assert pipeline.reproduce("ci") == 0
    err = capfd.readouterr().err
    assert "without encryption" not in err and "WARNING" not in err
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip()]
    assert all(
        line.startswith(("reproduce [ci]", "index of figures", "1 notebook(s) ran"))
        for line in lines
    ), lines
    executed = nbformat.read(outputs / "ci" / "notebooks" / "01_tiny.ipynb", as_version=4)
    assert executed.cells[-1].outputs[0]["text"] == "ran\n"


def _non_white_pixels(png: bytes) -> int:
    """Pixels that are not (near) white in an 8-bit RGB/RGBA PNG, decoded with zlib (no PIL needed)."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks, header = 8, [], None
    while pos < len(png):
        length, kind = struct.unpack(">I4s", png[pos : pos + 8])
        data = png[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", data)
        elif kind == b"IDAT":
            chunks.append(data)
        pos += 12 + length
    width, height, depth, colour = header[:4]
    assert depth == 8 and colour in (2, 6), header
    channels = 3 if colour == 2 else 4
    raw, stride = zlib.decompress(b"".join(chunks)), width * channels
    previous, count = bytearray(stride), 0
    for row in range(height):
        kind, line = (
            raw[row * (stride + 1)],
            bytearray(raw[row * (stride + 1) + 1 : (row + 1) * (stride + 1)]),
        )
        for i in range(stride):
            left = line[i - channels] if i >= channels else 0
            up, corner = previous[i], previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + left) & 255
            elif kind == 2:
                line[i] = (line[i] + up) & 255
            elif kind == 3:
                line[i] = (line[i] + (left + up) // 2) & 255
            elif kind == 4:
                p = left + up - corner
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - corner)
                line[i] = (
                    line[i] + (left if pa <= pb and pa <= pc else up if pb <= pc else corner)
                ) & 255
        count += sum(1 for i in range(0, stride, channels) if min(line[i : i + 3]) < 200)
        previous = line
    return count


def screenshot_offline(page, png, tmp_path, size=(800, 500)):
    """Load ``page`` in headless Chromium with every network request refused; write a screenshot to ``png``."""
    command = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--no-first-run",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        f"--user-data-dir={tmp_path / 'chromium-profile'}",
        "--proxy-server=127.0.0.1:9",
        "--proxy-bypass-list=<-loopback>",
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--virtual-time-budget=10000",
        f"--window-size={size[0]},{size[1]}",
        f"--screenshot={png}",
        page.as_uri(),
    ]
    subprocess.run(command, capture_output=True, timeout=120, check=False)
    assert png.is_file(), "Chromium wrote no screenshot"
    return png.read_bytes()


@needs_chromium
def test_written_figure_renders_offline_in_headless_chromium(outputs, tmp_path):
    page = figures.save_figure(_figure(), "t", "fig_offline")["html"]
    drawn = _non_white_pixels(screenshot_offline(page, tmp_path / "drawn.png", tmp_path))
    blank_page = page.with_name("blank.html")
    blank_page.write_text(
        page.read_text().replace('src="plotly.min.js"', 'src="https://cdn.plot.ly/x.js"')
    )
    blank = _non_white_pixels(screenshot_offline(blank_page, tmp_path / "blank.png", tmp_path))
    assert (
        blank < 100
    )  # the same page loading plotly.js from the network stays white: the network is off
    assert drawn > 5000 and drawn > 50 * max(blank, 1)


def test_png_decoder_counts_dark_pixels():
    def png(rows):
        raw = b"".join(b"\x00" + bytes(v for pixel in row for v in pixel) for row in rows)
        ihdr = struct.pack(">IIBBBBB", len(rows[0]), len(rows), 8, 2, 0, 0, 0)
        chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + b"\0\0\0\0"  # noqa: E731
        return (
            b"\x89PNG\r\n\x1a\n"
            + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b"")
        )

    white, black = (255, 255, 255), (0, 0, 0)
    assert _non_white_pixels(png([[white, black], [black, black]])) == 3
    assert _non_white_pixels(png([[white, white]])) == 0


def test_notebooks_take_their_profile_from_one_place(monkeypatch):
    """Every notebook's papermill parameters cell defaults to notebook_profile(): $LNSS_PROFILE, else quick."""
    import papermill

    from lnss_lib.errors import ConfigError

    for book in pipeline.notebook_paths():
        assert (
            papermill.inspect_notebook(str(book))["profile_name"]["default"] == "notebook_profile()"
        ), book.name
    monkeypatch.delenv(pipeline.PROFILE_ENV, raising=False)
    assert pipeline.notebook_profile() == "quick"
    monkeypatch.setenv(pipeline.PROFILE_ENV, "ci")
    assert pipeline.notebook_profile() == "ci"
    monkeypatch.setenv(pipeline.PROFILE_ENV, "nosuch")
    with pytest.raises(
        ConfigError, match="LNSS_PROFILE = 'nosuch' is not a profile; available: .*ci.*quick"
    ):
        pipeline.notebook_profile()


def _run_figure_notebook(tmp_path, monkeypatch):
    """Execute a two-figure notebook (one saved, one only shown) with ``reproduce``; return it converted
    to HTML by ``jupyter nbconvert`` and the executed notebook."""
    import nbformat

    _notebook_folder(
        tmp_path,
        monkeypatch,
        "01_figures",
        "import pathlib\nimport plotly.graph_objects as go\nimport lnss_lib.outputs\n"
        "from lnss_lib.figures import save_figure\n"
        f"lnss_lib.outputs.OUTPUTS_DIR = pathlib.Path({str(tmp_path)!r})\n"
        "fig = go.Figure(go.Scatter(x=[0, 1, 2], y=[1, 3, 2], line={'width': 8}))\n"
        "save_figure(fig, profile_name, '01_line')\nfig",
        "go.Figure(go.Bar(x=[1, 2], y=[2, 1])).show()",
    )
    monkeypatch.setenv("PYTHONPATH", "")
    assert pipeline.reproduce("ci") == 0
    executed = tmp_path / "ci" / "notebooks" / "01_figures.ipynb"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "jupyter",
            "nbconvert",
            "--to",
            "html",
            str(executed),
            "--output-dir",
            str(tmp_path / "html"),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    return (tmp_path / "html" / "01_figures.html").read_text(), nbformat.read(
        executed, as_version=4
    )


def test_converted_notebook_keeps_its_figures_as_html_without_chromium(
    outputs, tmp_path, monkeypatch
):
    """Without PNG export the display carries HTML: plotly.js inline in the first figure only, no CDN."""
    import nbformat

    monkeypatch.setattr(export, "_PLOTLYJS_SENT", False)
    renderer = figures.NotebookRenderer()
    bundles = [
        renderer.to_mimebundle(f.to_dict())
        for f in (_figure(), go.Figure(go.Bar(x=[1, 2], y=[2, 1])))
    ]
    assert all(
        {"application/vnd.plotly.v1+json", "text/html"} <= set(b) and "image/png" not in b
        for b in bundles
    )
    assert ["plotly.js v" in b["text/html"] for b in bundles] == [True, False]
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell("fig", outputs=[nbformat.v4.new_output("display_data", data=b)])
        for b in bundles
    ]
    nbformat.write(nb, tmp_path / "figures.ipynb")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "jupyter",
            "nbconvert",
            "--to",
            "html",
            str(tmp_path / "figures.ipynb"),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    page = (tmp_path / "figures.html").read_text()
    assert page.count("Plotly.newPlot(") == 2  # both figures drawn by their HTML copy
    assert 'src="https://cdn.plot.ly' not in page  # plotly.js is not loaded from the network


@needs_chromium
def test_converted_notebook_shows_its_figures_in_headless_chromium(outputs, tmp_path, monkeypatch):
    monkeypatch.delenv(export.PNG_ENV)
    page, executed = _run_figure_notebook(tmp_path, monkeypatch)
    saved = (tmp_path / "ci" / "figures" / "01_line.png").read_bytes()
    bundles = [o["data"] for c in executed.cells for o in c.get("outputs", []) if "data" in o]
    assert len(bundles) == 2 and all("image/png" in b and "text/html" not in b for b in bundles)
    assert (
        base64.b64decode(bundles[0]["image/png"]) == saved
    )  # the PNG save_figure drew, not a second one
    assert page.count('src="data:image/png;base64,') == 2
    html_file = tmp_path / "html" / "01_figures.html"
    drawn = _non_white_pixels(
        screenshot_offline(html_file, tmp_path / "notebook.png", tmp_path, size=(1000, 1400))
    )
    assert (
        drawn > 5000
    )  # a thick line and two bars; the page without figures is code cells on white


def test_notebook_renderer_is_default_only_in_a_kernel():
    import plotly.io as pio

    assert (
        figures.use_notebook_renderer() is False
        and pio.renderers.default != figures.NOTEBOOK_RENDERER
    )


def test_the_headline_finding_reads_the_front_flown_in_closed_loop(outputs):
    import pandas as pd

    assert findings.headline_findings(outputs / "t") == []  # no validated front: no row
    columns = [
        "result",
        "n_sat",
        "n_planes",
        "sats_per_plane",
        "sma_km",
        "ecc",
        "inc_deg",
        "aop_deg",
        "closed_loop_dv_max_kms_per_year",
        "closed_loop_dv_kms_per_year",
        "pdop_avail_pct_life",
        "pdop_avail_pct_worst_month",
        "flown",
        "failed or error",
    ]
    table = pd.DataFrame(
        [
            ["validated", 8, 2, 4, 9800.0, 0.39, 58.0, 56.0, 0.994, 0.976, 92.16, 85.6, 6, 2],
            ["none validated"] + [np.nan] * 11 + [0, 0],
            ["validated", 8, 2, 4, 9800.0, 0.39, 58.0, 56.0, 0.994, 0.976, 92.16, 85.6, 5, 2],
        ],
        columns=columns,
        index=pd.Index(["smallest", "6 satellites", "8 satellites"], name="row"),
    )
    lnss_lib.outputs.save_table(table, "t", "07_headline_validated", caption="headline")
    (found,) = findings.headline_findings(outputs / "t")
    assert found.workbook.startswith(
        "8 satellites, 92.2 % over the life, 0.994 km/s/yr worst satellite"
    )
    assert (
        "6 designs flown, 2 lost a satellite or failed" in found.why
        and "6: none, 8: 0.994" in found.why
    )
    assert found.paper.startswith("6 satellites")
