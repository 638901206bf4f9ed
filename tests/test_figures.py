"""Figure writing (figures.export): PNG through kaleido's bundled renderer, HTML fallback, offline HTML; the builders'
package layout and one builder's data."""

import os
import shutil
import struct
import warnings
from pathlib import Path

import plotly.graph_objects as go
import pytest

import lnss_lib.figures as figures
import lnss_lib.figures.export as export
import lnss_lib.outputs


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    monkeypatch.setattr(lnss_lib.outputs, "OUTPUTS_DIR", tmp_path)
    return tmp_path


def _figure():
    return go.Figure(
        go.Scatter(x=[0, 1, 2], y=[1, 3, 2]), layout={"title": {"text": "a <b>test</b> figure"}}
    )


def _hide_chromium(monkeypatch, tmp_path):
    """A PATH with every program of the current one except Chrome/Chromium (the renderer's start-up script
    still finds bash and dirname)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for folder in os.environ["PATH"].split(os.pathsep):
        for program in Path(folder).glob("*") if Path(folder).is_dir() else ():
            target = bin_dir / program.name
            if "chrom" not in program.name and not target.exists():
                target.symlink_to(program)
    monkeypatch.setenv("PATH", str(bin_dir))
    assert shutil.which("chromium") is None and shutil.which("dirname") is not None


def test_png_written_without_a_browser_on_path(outputs, monkeypatch, tmp_path):
    monkeypatch.delenv(figures.PNG_ENV, raising=False)
    monkeypatch.setattr(export, "_EXPORTER", None)
    _hide_chromium(monkeypatch, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a skipped PNG would warn
        written = figures.save_figure(_figure(), "t", "fig_png", width=400, height=300)
    png = written["png"].read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", png[16:24]) == (400, 300)  # IHDR: width and height as asked
    assert written["html"].is_file()
    export._EXPORTER.close()
    monkeypatch.setattr(export, "_EXPORTER", None)


def test_html_fallback_warns_once(outputs, monkeypatch):
    monkeypatch.setenv(figures.PNG_ENV, "off")
    monkeypatch.setattr(export, "_PNG_WARNED", False)
    with pytest.warns(RuntimeWarning, match="PNG export skipped .LNSS_PNG=off.; HTML written"):
        written = figures.save_figure(_figure(), "t", "fig_html")
    assert written["html"].is_file() and "png" not in written
    assert not (outputs / "t" / "figures" / "fig_html.png").exists()


def test_failed_renderer_gives_html_and_one_warning(outputs, monkeypatch):
    class BrokenRenderer:
        def __init__(self):
            raise OSError("renderer would not start")

    monkeypatch.delenv(figures.PNG_ENV, raising=False)
    monkeypatch.setattr(export, "_PngExporter", BrokenRenderer)
    monkeypatch.setattr(export, "_EXPORTER", None)
    monkeypatch.setattr(export, "_PNG_WARNED", False)
    stale = outputs / "t" / "figures" / "fig_b.png"
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"old")
    with pytest.warns(RuntimeWarning, match="renderer would not start") as record:
        first = figures.save_figure(_figure(), "t", "fig_b")
        second = figures.save_figure(_figure(), "t", "fig_c")
    assert len([w for w in record if issubclass(w.category, RuntimeWarning)]) == 1
    assert first["html"].is_file() and second["html"].is_file()
    assert (
        "png" not in first and not stale.exists()
    )  # a PNG from an earlier run would not match the HTML


def test_a_timed_out_renderer_is_restarted_once_with_a_longer_limit(outputs, monkeypatch):
    """A renderer too slow to start on a loaded machine costs one retry, not the notebook's PNGs; two timeouts in a
    row give HTML and one warning, and no later figure waits for the renderer again."""
    limits, slow_starts = [], [1]

    class SlowStart:
        pid = os.getpid()

        def png(self, fig, width, height, timeout_s):
            limits.append(timeout_s)
            if len(limits) <= len(slow_starts):
                raise TimeoutError(f"no PNG after {timeout_s:.0f} s")
            return b"\x89PNG\r\n\x1a\n"

    monkeypatch.delenv(figures.PNG_ENV, raising=False)
    monkeypatch.setattr(export, "_PngExporter", SlowStart)
    monkeypatch.setattr(export, "_EXPORTER", None)
    monkeypatch.setattr(export, "_PNG_WARNED", False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert "png" in figures.save_figure(_figure(), "t", "fig_slow")
    assert limits == [export.PNG_TIMEOUT_S, export.PNG_RETRY_FACTOR * export.PNG_TIMEOUT_S]
    limits.clear()
    slow_starts.append(2)  # now both tries time out
    monkeypatch.setattr(export, "_EXPORTER", None)
    with pytest.warns(RuntimeWarning, match="no PNG after 240 s") as record:
        first = figures.save_figure(_figure(), "t", "fig_stalled")
        second = figures.save_figure(_figure(), "t", "fig_after")
    assert len(limits) == 2 and "png" not in first and "png" not in second
    assert len([w for w in record if issubclass(w.category, RuntimeWarning)]) == 1


def test_constellation_3d_draws_moon_and_every_orbit():
    import numpy as np
    import xarray as xr

    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.elements import elements_to_state

    el = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 3).elements_deg()
    series = np.repeat(
        np.concatenate([el[:, :2], np.radians(el[:, 2:])], axis=1)[:, None, :], 50, axis=1
    )
    series[..., 5] += np.linspace(0.0, 2 * np.pi, 50)
    r = elements_to_state(series, 4902.8)[..., :3]
    ds = xr.Dataset(
        {"r_mci_km": (("sat", "time", "xyz"), r), "elements_deg": (("sat", "element"), el)}
    )
    fig = figures.constellation_3d(ds, title="t", moon_radius_km=1737.4)
    moon = fig.data[0]
    assert isinstance(moon, go.Surface)
    assert np.allclose(np.sqrt(moon.x**2 + moon.y**2 + moon.z**2), 1737.4)
    orbits = [t for t in fig.data[1:] if t.mode == "lines"]
    assert len(orbits) == 6 and len(fig.data) == 1 + 2 * 6
    assert np.allclose(orbits[0].x, r[0, :, 0])
    colours = [t.line.color for t in orbits]
    assert (
        len(set(colours[:3])) == 1 and len(set(colours[3:])) == 1 and colours[0] != colours[3]
    )  # one colour per plane


def test_html_is_offline_with_one_local_plotly_js(outputs, monkeypatch):
    monkeypatch.setenv(export.PNG_ENV, "off")
    monkeypatch.setattr(export, "_PNG_WARNED", True)
    first = figures.save_figure(_figure(), "t", "fig_a")["html"]
    second = figures.save_figure(_figure(), "t", "fig_b")["html"]
    for page in (first, second):
        text = page.read_text()
        assert '<script charset="utf-8" src="plotly.min.js"></script>' in text
        assert "cdn.plot.ly" not in text and "https://" not in text.split("<body>")[0]
    bundle = first.parent / "plotly.min.js"
    assert bundle.stat().st_size > 1_000_000 and b"Plotly" in bundle.read_bytes()[:2000]


def test_no_cdn_reference_in_the_package():
    from pathlib import Path

    package = Path(figures.__file__).resolve().parents[1]
    hits = [p for p in package.rglob("*.py") if "cdn.plot" + ".ly" in p.read_text()]
    assert hits == []


def test_package_reexports_every_builder():
    import inspect
    import pkgutil

    modules = [m.name for m in pkgutil.iter_modules(figures.__path__)]
    assert {"export", "charts", "propagation", "dop", "gps", "deltav", "campaign", "pareto"} <= set(
        modules
    )
    for name in modules:
        module = __import__(f"lnss_lib.figures.{name}", fromlist=["_"])
        builders = [
            n
            for n, obj in vars(module).items()
            if inspect.isfunction(obj)
            and obj.__module__ == module.__name__
            and not n.startswith("_")
            and inspect.signature(obj).return_annotation in ("go.Figure", go.Figure)
        ]
        missing = [
            n
            for n in builders
            if n not in figures.__all__ or getattr(figures, n) is not getattr(module, n)
        ]
        assert missing == [], (name, missing)
    assert {"save_figure", "LABELS"} <= set(figures.__all__)
    assert all(hasattr(figures, n) for n in figures.__all__)


def _pole_maps(scale_by_frame: dict):
    import numpy as np
    import xarray as xr

    lat, lon = np.array([-90.0, -80.0, -70.0, -60.0]), np.arange(0.0, 360.0, 30.0)
    ramp = np.linspace(1.0, 2.0, lat.size * lon.size).reshape(lat.size, lon.size)
    variables = [var for _, var, _ in figures.DOP_MAP_PANELS]
    return {
        frame: xr.Dataset(
            {
                var: (("lat", "lon"), (50.0 * ramp if var.endswith("_pct") else scale * ramp))
                for var in variables
            },
            coords={"lat": lat, "lon": lon},
        )
        for frame, scale in scale_by_frame.items()
    }


def _colour_range(fig, row: int, col: int) -> tuple[float, float]:
    index = (row - 1) * len(figures.DOP_MAP_PANELS) + col
    axis = fig.layout[f"coloraxis{index if index > 1 else ''}"]
    return axis.cmin, axis.cmax


def test_dop_maps_share_a_scale_where_compared_and_give_a_panel_its_own_where_unreadable():
    variables = [var for _, var, _ in figures.DOP_MAP_PANELS]
    pdop, hdop_mf, hdop_enu = (
        variables.index(v) + 1 for v in ("median_pdop", "median_hdop_moon_fixed", "median_hdop_enu")
    )
    maps = _pole_maps({"lunar_equator_of_epoch": 1.0, "j2000": 500.0, "moon_op": 1.5})
    apart = figures.dop_polar_maps(maps, title="t")
    # the lunar-equator (1-2) and moon_op (1.5-3) rows share a scale and keep their contrast, j2000 has its own
    assert (
        _colour_range(apart, 1, pdop) == _colour_range(apart, 3, pdop) == pytest.approx((1.0, 3.0))
    )
    assert _colour_range(apart, 2, pdop) == pytest.approx((500.0, 1000.0))
    # the two HDOP conventions are read against each other: both columns share, j2000's two among themselves
    assert (
        _colour_range(apart, 1, hdop_enu)
        == _colour_range(apart, 3, hdop_mf)
        == pytest.approx((1.0, 3.0))
    )
    assert (
        _colour_range(apart, 2, hdop_mf)
        == _colour_range(apart, 2, hdop_enu)
        == pytest.approx((500.0, 1000.0))
    )
    caption = figures.colour_scale_caption(maps)
    assert "median PDOP: lunar_equator_of_epoch, moon_op share one; j2000 its own" in caption
    assert "PDOP availability (%): one scale (0-100 %) for every panel" in caption
    assert (
        "lunar_equator_of_epoch (both), moon_op (both) share one; j2000 (both) share one" in caption
    )
    # a narrow panel leaves the shared scale: 1-2 would span 20 % of 1-6
    narrow = _pole_maps({"lunar_equator_of_epoch": 1.0, "moon_op": 3.0})
    scales = figures.colour_scales(narrow)
    assert scales[("lunar_equator_of_epoch", "median_pdop")] == pytest.approx((1.0, 2.0))
    assert scales[("moon_op", "median_pdop")] == pytest.approx((3.0, 6.0))
    close = figures.colour_scales(_pole_maps({"lunar_equator_of_epoch": 1.0, "moon_op": 2.0}))
    assert close[("lunar_equator_of_epoch", "median_pdop")] == close[("moon_op", "median_pdop")]
    availability = len(figures.DOP_MAP_PANELS)
    assert _colour_range(apart, 3, availability) == (0.0, 100.0)  # bounded: fixed scale
    assert list(apart.layout.polar.radialaxis.ticktext) == [
        "-90°",
        "-80°",
        "-70°",
        "-60°",
    ]  # labelled latitudes
    assert "elements: moon_op" in apart.layout.annotations[-1].text  # every row names its frame


def test_monthly_availability_is_drawn_on_a_fixed_0_100_axis():
    import numpy as np
    import xarray as xr

    nav = xr.Dataset(
        {
            k: (("run", "month"), np.array([[100.0, 99.99999999999999], [100.0, 100.0]]))
            for k in ("pdop_avail_pct", "hdop_avail_pct", "pdop_mean_3sigma", "hdop_mean_3sigma")
        },
        coords={"run": ["controlled", "natural"], "month": [0, 1]},
    )
    fig = figures.monthly_dop(nav, title="t")
    assert tuple(fig.layout.yaxis.range) == (0, 102) and tuple(fig.layout.yaxis2.range) == (0, 102)
    assert fig.layout.yaxis3.range is None  # DOP is unbounded: autoscaled


def test_monthly_runs_that_coincide_stay_apart_by_line_and_marker():
    import numpy as np
    import xarray as xr

    nav = xr.Dataset(
        {
            k: (("run", "month"), np.full((2, 3), 100.0))
            for k in ("pdop_avail_pct", "hdop_avail_pct", "pdop_mean_3sigma", "hdop_mean_3sigma")
        },
        coords={"run": ["controlled", "natural"], "month": [0, 1, 2]},
    )
    controlled, natural = figures.monthly_dop(nav, title="t").data[::4][:2]
    assert controlled.name == "controlled" and natural.name == "natural"
    assert (
        controlled.line.dash != natural.line.dash
        and controlled.marker.symbol != natural.marker.symbol
    )


def test_estimate_chart_keeps_designs_that_burned_nothing():
    import numpy as np
    import pandas as pd

    table = pd.DataFrame(
        {
            "region": ["ELFO", "ELFO", "polar", "polar"],
            "sma_km": [6143.0] * 4,
            "ecc": [0.6] * 4,
            "inc_deg": [51.7] * 4,
            "aop_deg": [90.0] * 4,
            "sk_dv_kms_per_year": [0.0, 0.4, 0.8, 1.2],
            "sk_dv_estimate_kms_per_year": [0.1, 0.5, 0.7, 2.0],
            "impact_day": [np.nan, np.nan, np.nan, 161.0],
        }
    )
    table["ratio"] = np.where(
        np.isfinite(table["impact_day"]),
        np.nan,
        table["sk_dv_estimate_kms_per_year"] / table["sk_dv_kms_per_year"],
    )
    fig = figures.estimate_vs_closed_loop(table, title="t")
    designs = [t for t in fig.data if t.mode == "markers"]
    assert sum(len(t.x) for t in designs) == 3  # the lost design is out, the zero-cost one is in
    (zero,) = [t for t in designs if "drawn at the floor" in t.name]
    assert zero.name == "ELFO: 1 at zero, drawn at the floor" and zero.marker.symbol.endswith(
        "-open"
    )
    assert zero.x[0] == 0.1 / 2 and all(v > 0 for t in designs for v in list(t.x) + list(t.y))


def test_convergence_says_when_nothing_was_feasible():
    import numpy as np
    import xarray as xr

    def history(feasible):
        g = np.arange(3)
        return xr.Dataset(
            {
                "hypervolume": ("generation", np.zeros(3)),
                "min_cv_pop": ("generation", [3.0, 2.0, 1.0]),
                "n_evaluations_cum": ("generation", [6, 12, 18]),
                "n_feasible_cum": ("generation", feasible),
                "n_feasible_pop": ("generation", feasible),
            },
            coords={"generation": g},
        )

    none = figures.campaign_convergence(history([0, 0, 0]), "t")
    assert any("no feasible design in 3 generation(s)" in a.text for a in none.layout.annotations)
    some = figures.campaign_convergence(history([0, 1, 2]), "t")
    assert not any("no feasible" in a.text for a in some.layout.annotations)


def test_benchmark_labels_do_not_overlap():
    from lnss_lib.figures.benchmark import LABEL_OFFSETS

    x, y = [1, 3, 3, 3, 16, 16, 8], [0.0, 0.0, 0.0, 0.5, 99.3, 99.9, 50.0]
    texts = [
        "lupnt_pathfinder",
        "ely2005_elfo_3sat",
        "ely2005_elfo_3sat_phased",
        "lupnt_example_isl_3sat",
        "table4_elfo",
        "bhamidipati2023_case_c",
        "alone",
    ]
    positions = figures.label_positions(x, y, texts, x_min=-2.0)
    boxes = []
    for xi, yi, text, position in zip(x, y, texts, positions):
        fx, fy = LABEL_OFFSETS[position]
        width = 0.22 * len(text)
        boxes.append((xi + fx * width, yi + 3.0 * fy, xi + fx * width + width, yi + 3.0 * fy + 3.0))
    for i, a in enumerate(boxes):
        assert a[0] >= -2.0, texts[i]  # not beyond the axis' left edge
        for b in boxes[:i]:
            assert min(a[2], b[2]) <= max(a[0], b[0]) or min(a[3], b[3]) <= max(a[1], b[1]), (
                texts[i],
                positions,
            )
    assert positions[-1] == "top center"  # far from the others: the default side


def test_pareto_axes_use_the_label_registry():
    import numpy as np
    import xarray as xr

    from lnss_lib.keys import label

    front = xr.Dataset(
        {
            k: ("design", np.arange(3.0) + 1)
            for k in (
                "hdop_mean_3sigma",
                "pdop_mean_3sigma",
                "dv_total_kms_per_year",
                "n_sat",
                "sma_km",
                "ecc",
                "inc_deg",
                "aop_deg",
                "n_planes",
                "sats_per_plane",
            )
        }
    )
    fig = figures.pareto_3d(
        front, "hdop_mean_3sigma", "pdop_mean_3sigma", "dv_total_kms_per_year", title="t"
    )
    assert fig.layout.scene.xaxis.title.text == label("hdop_mean_3sigma") == "HDOP (3-sigma mean)"
    assert fig.layout.scene.zaxis.title.text == "Delta-V total (km/s/yr)"
    bounded = figures.pareto_3d(
        front,
        "hdop_mean_3sigma",
        "pdop_mean_3sigma",
        "dv_total_kms_per_year",
        title="t",
        z_bound=1.0,
    )
    counts = sorted(set(front["n_sat"].values.tolist()))
    assert [t.name for t in bounded.data] == [f"{int(n)} satellites" for n in counts] + [
        "bound: Delta-V total (km/s/yr) = 1"
    ]
    assert (
        sum(len(t.x) for t in bounded.data[:-1]) == front.sizes["design"]
    )  # each design once, by its count
    assert np.all(np.asarray(bounded.data[-1].z) == 1.0)
