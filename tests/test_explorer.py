"""The design explorer: callbacks driven in-process, the export, and the page served by voila."""

import asyncio
import contextlib
import importlib.util
import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ipywidgets")

from lnss_lib.__main__ import build_parser, main  # noqa: E402
from lnss_lib.constellation import standalone_elfo, walker_design  # noqa: E402
from lnss_lib.evaluator import context_for, evaluate_design  # noqa: E402
from lnss_lib.explorer import DesignExplorer, initial_design, snap_to_grid, table4_design  # noqa: E402
from lnss_lib.keys import (  # noqa: E402
    METRIC_KEYS,
    format_value,
    label,  # noqa: E402
)
from lnss_lib.settings import VariableBounds, load_settings  # noqa: E402

PROFILE = "ci"
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "09_design_explorer.ipynb"
IMPACTING = {
    "sma_km": 4000.0,
    "ecc": 0.56,
    "aop_deg": 45.0,
    "inc_deg": 60.0,
    "n_planes": 2,
    "sats_per_plane": 1,
}


@pytest.fixture
def explorer(tmp_path):
    return DesignExplorer(PROFILE, outputs_dir=tmp_path)


def _set(explorer, **values):
    for key, value in values.items():
        explorer.sliders[key].value = value


def _reference(design, overrides=None):
    context = context_for(load_settings(PROFILE, overrides=overrides))
    return evaluate_design(
        context,
        design["sma_km"],
        design["ecc"],
        design["aop_deg"],
        design["inc_deg"],
        design["n_planes"],
        design["sats_per_plane"],
    )


def _assert_same_metrics(ours, reference):
    for key in METRIC_KEYS:
        if isinstance(reference[key], float) and math.isnan(reference[key]):
            assert math.isnan(ours[key]), key
        else:
            assert ours[key] == pytest.approx(reference[key], rel=1e-12, abs=0.0), key


def test_snap_to_grid_follows_table3_steps():
    spec = VariableBounds(lower=4000.0, upper=24000.0, step=100.0)
    assert snap_to_grid(6143.0, spec) == 6100.0
    assert snap_to_grid(99999.0, spec) == 24000.0
    assert snap_to_grid(0.6000000001, VariableBounds(lower=0.0, upper=0.8, step=0.01)) == 0.6
    planes = VariableBounds(lower=2, upper=5, step=1)
    assert (
        snap_to_grid(7, planes) == 5
        and snap_to_grid(3.2, planes) == 3
        and isinstance(snap_to_grid(3.2, planes), int)
    )
    with pytest.raises(ValueError, match="nan"):
        snap_to_grid(float("nan"), spec)


def test_initial_state_is_the_grid_design_nearest_the_elfo_and_matches_evaluate(explorer):
    profile = load_settings(PROFILE)
    assert explorer.design() == initial_design(profile.standalone_elfo, profile.campaign.variables)
    for key, slider in explorer.sliders.items():
        spec = profile.campaign.variables[key]
        assert (slider.min, slider.max, slider.step) == (spec.lower, spec.upper, spec.step), key
    assert explorer.current.feasible and explorer.previous is None
    _assert_same_metrics(explorer.current.metrics, _reference(explorer.design()))


def test_start_says_it_is_not_table4_and_how_it_differs(explorer):
    """Table 3 caps satellites per plane below Table 4's 8: the first design is the nearest grid design, and the
    page says so, naming every variable that differs (with Table 4's value) and both satellite counts."""
    profile = load_settings(PROFILE)
    table4, start = table4_design(profile.standalone_elfo), explorer.design()
    assert table4["sats_per_plane"] > profile.campaign.variables["sats_per_plane"].upper
    differ = [key for key in table4 if not math.isclose(start[key], table4[key], abs_tol=1e-9)]
    assert {"sats_per_plane", "sma_km", "inc_deg"} <= set(differ)
    text = explorer.start_text
    assert "NOT Table 4 itself" in text and "snapped" not in text
    for key in differ:
        assert (
            f"{label(key)} {format_value(key, start[key])} (Table 4: {format_value(key, table4[key])}"
            in text
        ), key
    n_table4 = table4["n_planes"] * table4["sats_per_plane"]
    assert f"{explorer.current.metrics['n_sat']} satellites instead of {n_table4}" in text
    assert "outside this profile's Table 3 range" in text
    assert text.replace("'", "&#x27;") in explorer.start_html.value


def test_start_is_table4_itself_where_the_grid_holds_it(tmp_path):
    """On a grid that holds Table 4 the first design is the standalone ELFO: the same 16 satellites (eq. 42 RAANs,
    M from 0) and the same metrics as evaluating :func:`standalone_elfo` directly."""
    grid = {
        "campaign": {
            "variables": {
                "sma_km": {"lower": 4000.0, "upper": 24000.0, "step": 1.0},
                "inc_deg": {"lower": 1.0, "upper": 90.0, "step": 0.1},
                "sats_per_plane": {"lower": 1, "upper": 8, "step": 1},
            }
        }
    }
    explorer = DesignExplorer(PROFILE, outputs_dir=tmp_path, overrides=grid)
    profile = load_settings(PROFILE, overrides=grid)
    design = explorer.design()
    assert design == table4_design(profile.standalone_elfo)
    elements = walker_design(
        profile.dynamics,
        design["sma_km"],
        design["ecc"],
        design["aop_deg"],
        design["inc_deg"],
        design["n_planes"],
        design["sats_per_plane"],
    ).elements_deg()
    np.testing.assert_allclose(
        elements, standalone_elfo(profile.standalone_elfo, profile.dynamics), rtol=0.0, atol=1e-9
    )
    assert (
        "which lies on this profile's grid" in explorer.start_text
        and "NOT" not in explorer.start_text
    )
    assert explorer.current.metrics["n_sat"] == 16
    _assert_same_metrics(explorer.current.metrics, _reference(design, grid))


def test_slider_change_updates_metrics_keeps_previous_and_equals_evaluate(explorer):
    first = dict(explorer.current.metrics)
    _set(explorer, ecc=0.5, inc_deg=70.0, sats_per_plane=3)
    design = explorer.design()
    assert design["ecc"] == 0.5 and design["inc_deg"] == 70.0 and design["sats_per_plane"] == 3
    assert explorer.current.metrics["n_sat"] == design["n_planes"] * 3
    assert explorer.current.metrics["pdop_mean_3sigma"] != first["pdop_mean_3sigma"]
    _assert_same_metrics(explorer.current.metrics, _reference(design))
    rows = {row["metric"]: row for row in explorer.metrics_rows()}
    assert rows["pdop_mean_3sigma"]["delta"] == pytest.approx(
        explorer.current.metrics["pdop_mean_3sigma"] - explorer.previous.metrics["pdop_mean_3sigma"]
    )
    assert (
        format_value("pdop_mean_3sigma", explorer.current.metrics["pdop_mean_3sigma"])
        in explorer.metrics_html.value
    )
    assert (
        "PDOP (3-sigma mean)" in explorer.metrics_html.value
        and "pdop_mean_3sigma" not in explorer.metrics_html.value
    )
    for name in ("availability", "time_series", "constellation"):
        assert "application/vnd.plotly.v1+json" in explorer.outputs[name].outputs[0]["data"], name


def test_availability_map_averages_to_the_eq14_metric(explorer):
    """Uniform grid weights ("none"): the node mean of the per-node availability is eq. 14's percentage."""
    fig = explorer.figures["availability"]
    pdop_map, hdop_map = (np.asarray(trace.marker.color, dtype=float) for trace in fig.data)
    assert ((pdop_map >= 0) & (pdop_map <= 100)).all()
    assert pdop_map.mean() == pytest.approx(explorer.current.metrics["pdop_avail_pct"], rel=1e-9)
    assert hdop_map.mean() == pytest.approx(explorer.current.metrics["hdop_avail_pct"], rel=1e-9)


def test_frame_and_model_choice_use_their_own_context(explorer):
    _set(explorer, inc_deg=60.0)
    explorer.frame_choice.value = "j2000"
    explorer.model_choice.value = "paper"
    overrides = {"frames": {"element_frame": "j2000"}, "deltav": {"model": "paper"}}
    assert explorer.current.metrics["deltav_model"] == "paper"
    assert explorer.context().settings.frames.element_frame == "j2000"
    _assert_same_metrics(explorer.current.metrics, _reference(explorer.design(), overrides))
    assert explorer.current.metrics["pdop_mean_3sigma"] != pytest.approx(
        _reference(explorer.design())["pdop_mean_3sigma"]
    )
    assert len(explorer._contexts) == 3


@pytest.mark.parametrize(
    "design, words",
    [
        ({"sma_km": 4000.0, "ecc": 0.8}, "perilune"),
        (IMPACTING, "impact"),
    ],
)
def test_infeasible_design_shows_its_reason(explorer, design, words):
    _set(explorer, **design)
    reference = _reference(explorer.design())
    assert not reference["evaluated"] and not explorer.current.feasible
    assert words in explorer.current.reason
    assert reference["reason"].endswith(explorer.current.reason.removeprefix("invalid design: "))
    assert "infeasible" in explorer.status.value and words in explorer.status.value
    assert "Traceback" not in explorer.status.value
    assert all(math.isnan(explorer.current.metrics[k]) for k in METRIC_KEYS if k != "n_sat")
    assert explorer.figures == {} and all(out.outputs == () for out in explorer.outputs.values())
    explorer.sliders["ecc"].value = 0.3
    assert explorer.current.feasible and not explorer.previous.feasible


def test_an_evaluation_that_raises_is_an_error_not_an_infeasible_design(explorer, monkeypatch):
    import lnss_lib.explorer as module

    def broken(context, elements):
        raise RuntimeError("integrator blew up")

    before = explorer.current
    monkeypatch.setattr(module, "analyse_constellation", broken)
    with pytest.raises(RuntimeError, match="integrator blew up"):
        explorer.sliders["inc_deg"].value = 70.0
    assert "error" in explorer.status.value and "not an infeasible design" in explorer.status.value
    assert explorer.current is before


def test_comparison_button_appends_rows(explorer):
    explorer.add_button.click()
    _set(explorer, n_planes=3)
    explorer.add_button.click()
    assert [row["n_planes"] for row in explorer.comparison] == [2, 3]
    assert explorer.comparison[1]["n_sat"] == explorer.current.metrics["n_sat"]
    assert explorer.comparison_html.value.count("<tr>") == 3


def test_export_command_reproduces_the_design(explorer, capsys):
    _set(explorer, sma_km=8000.0, ecc=0.5, aop_deg=90.0, inc_deg=60.0, n_planes=3, sats_per_plane=3)
    exported = explorer.export()
    assert exported["command"].startswith("python -m lnss_lib evaluate ")
    args = build_parser().parse_args(exported["argv"])
    parsed = {
        "sma_km": args.sma_km,
        "ecc": args.ecc,
        "aop_deg": args.aop_deg,
        "inc_deg": args.inc_deg,
        "n_planes": args.planes,
        "sats_per_plane": args.sats_per_plane,
    }
    assert args.profile == PROFILE and parsed == explorer.design()
    assert tomllib.loads(exported["toml"])["design"] == explorer.design()
    assert main(exported["argv"] + ["--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    _assert_same_metrics(explorer.current.metrics, printed)


def test_export_passes_changed_settings_and_writes_atomically(explorer, tmp_path):
    explorer.model_choice.value = "secular"
    exported = explorer.export(write=True)
    assert 'deltav.model="secular"' in exported["argv"] and not any(
        "element_frame" in a for a in exported["argv"]
    )
    written = tomllib.loads(exported["path"].read_text())
    assert exported["path"].is_relative_to(tmp_path / PROFILE / "explorer")
    assert written["deltav"]["model"] == "secular" and written["design"] == explorer.design()
    assert exported["toml"] in explorer.export_text.value
    _, unknown = build_parser().parse_known_args(exported["argv"])
    if unknown:
        pytest.skip("`evaluate` has no --set yet: the design part is checked above")
    args = build_parser().parse_args(exported["argv"])
    assert args.set == ['deltav.model="secular"']


def test_overrides_reach_every_evaluation_and_the_export(tmp_path, capsys):
    """`reproduce --set` overrides (JSON, as notebook 09 receives them) apply to the explorer's profile,
    its evaluations and the exported command line."""
    overrides = {"dop": {"elevation_mask_deg": 15.0}}
    explorer = DesignExplorer(PROFILE, outputs_dir=tmp_path, overrides=json.dumps(overrides))
    assert explorer.context().settings.dop.elevation_mask_deg == 15.0
    _assert_same_metrics(explorer.current.metrics, _reference(explorer.design(), overrides))
    exported = explorer.export()
    assert "dop.elevation_mask_deg=15.0" in exported["argv"]
    assert main(exported["argv"] + ["--json"]) == 0
    _assert_same_metrics(explorer.current.metrics, json.loads(capsys.readouterr().out))


def test_profile_switch_keeps_the_design(explorer):
    _set(explorer, n_planes=3)
    explorer.profile_choice.value = "quick"
    assert explorer.current.profile_name == "quick" and explorer.design()["n_planes"] == 3
    assert explorer.context().settings.profile.name == "quick"


def test_profile_switch_brings_the_profiles_element_frame(explorer):
    """The operational study reads its designs in moon_op: switching to it reads them there."""
    explorer.profile_choice.value = "ci_operational"
    assert explorer.frame_choice.value == "moon_op" and explorer.current.frame == "moon_op"
    assert explorer.context().settings.frames.element_frame == "moon_op"
    explorer.profile_choice.value = PROFILE
    assert explorer.frame_choice.value == "lunar_equator_of_epoch"


# ---- the page served by voila, loaded in headless Chromium -------------------------------------
# The widgets render only after the page's widget manager has talked to the kernel over a websocket
# in real time, which --virtual-time-budget skips ("Loading widget..."), so the test drives Chromium
# over its DevTools protocol and polls the page until the metrics table appears.


def _chromium() -> str | None:
    return next(
        (
            path
            for name in ("chromium", "chromium-browser", "google-chrome")
            if (path := shutil.which(name))
        ),
        None,
    )


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _wait_for_port(port: int, process: subprocess.Popen, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), timeout=2):
            return
        assert process.poll() is None, f"process exited with {process.returncode}"
        assert time.monotonic() < deadline, f"nothing listens on port {port} after {timeout_s} s"
        time.sleep(0.5)


async def _browse(
    url: str, chromium: str, screenshot: Path, timeout_s: float = 240.0
) -> tuple[str, str]:
    """Load ``url``, wait for the metrics table, click "add to comparison", wait for the comparison table,
    choose the secular Delta-V model and wait for the re-evaluation; return the page's HTML at the start
    and at the end and write a screenshot of the whole page."""
    import base64
    import urllib.request

    import websockets

    port = _free_port()
    # Chromium's helper processes may still write to the profile while it closes: the group is killed and
    # waited for, and a late write into the throw-away profile is no test failure
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile_dir:
        browser = subprocess.Popen(
            [
                chromium,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--no-first-run",
                "--disable-component-update",
                "--disable-sync",
                f"--user-data-dir={profile_dir}",
                f"--remote-debugging-port={port}",
                "--remote-debugging-address=127.0.0.1",
                "--remote-allow-origins=*",
                "--window-size=1400,4200",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            _wait_for_port(port, browser, 60)
            targets = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=10))
            page = next(t["webSocketDebuggerUrl"] for t in targets if t["type"] == "page")
            async with websockets.connect(page, max_size=2**28) as ws:
                ids = iter(range(1, 10**6))

                async def call(method, **params):
                    message_id = next(ids)
                    await ws.send(
                        json.dumps({"id": message_id, "method": method, "params": params})
                    )
                    while (reply := json.loads(await ws.recv())).get("id") != message_id:
                        pass
                    return reply["result"]

                async def value(expression):
                    return (
                        await call("Runtime.evaluate", expression=expression, returnByValue=True)
                    )["result"].get("value")

                async def wait_for(selector):
                    deadline = time.monotonic() + timeout_s
                    while not await value(
                        f"document.querySelector({json.dumps(selector)}) !== null"
                    ):
                        assert time.monotonic() < deadline, (
                            f"{selector} not shown after {timeout_s} s"
                        )
                        await asyncio.sleep(1)

                await call("Page.enable")
                await call("Page.navigate", url=url)
                await wait_for(".lnss-explorer-metrics")
                before = await value("document.documentElement.outerHTML")
                await value(
                    "[...document.querySelectorAll('button')].find(b => b.textContent.includes("
                    "'add to comparison')).click()"
                )
                await wait_for(".lnss-explorer-comparison")
                await value(
                    "(s => { s.value = [...s.options].find(o => o.text === 'secular').value; "
                    "s.dispatchEvent(new Event('change', {bubbles: true})); })([...document.querySelectorAll('select')]"
                    ".find(s => [...s.options].some(o => o.text === 'secular')))"
                )
                deadline = time.monotonic() + timeout_s
                while "secular Delta-V" not in await value("document.body.innerText"):
                    assert time.monotonic() < deadline, (
                        "choosing the secular Delta-V model changed nothing"
                    )
                    await asyncio.sleep(1)
                await asyncio.sleep(3)
                size = (await call("Page.getLayoutMetrics"))["cssContentSize"]
                shot = await call(
                    "Page.captureScreenshot",
                    format="png",
                    captureBeyondViewport=True,
                    clip={
                        "x": 0,
                        "y": 0,
                        "width": size["width"],
                        "height": size["height"],
                        "scale": 1,
                    },
                )
                screenshot.write_bytes(base64.b64decode(shot["data"]))
                return before, await value("document.documentElement.outerHTML")
        finally:
            try:
                os.killpg(browser.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                browser.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(browser.pid, signal.SIGKILL)


@pytest.mark.skipif(
    _chromium() is None or importlib.util.find_spec("voila") is None,
    reason="needs voila and Chromium",
)
def test_voila_page_shows_the_metrics(tmp_path):
    pytest.importorskip("websockets")
    port = _free_port()
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
        "LNSS_PNG": "off",
    }
    log_path = tmp_path / "voila.log"
    with log_path.open("w") as log:
        server = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "voila",
                "--no-browser",
                f"--port={port}",
                "--Voila.ip=127.0.0.1",
                "--Voila.port_retries=0",
                str(NOTEBOOK),
            ],
            cwd=ROOT,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        try:
            _wait_for_port(port, server, 60)
            before, after = asyncio.run(
                asyncio.wait_for(
                    _browse(f"http://127.0.0.1:{port}/", _chromium(), tmp_path / "voila.png"),
                    timeout=420,
                )
            )
        finally:
            server.terminate()
            try:
                server.wait(timeout=20)
            except subprocess.TimeoutExpired:
                server.kill()
    for text in (
        "mean visible satellites",
        "PDOP (3-sigma mean)",
        "HDOP availability (%)",
        "feasible",
    ):
        assert text in before, text
    assert "Traceback" not in after and "error</b>" not in after, log_path.read_text()[-3000:]
    assert "lnss-explorer-comparison" not in before and "lnss-explorer-comparison" in after
    assert "secular Delta-V" in after and "previous design" in after
    assert (tmp_path / "voila.png").stat().st_size > 50_000


def test_exported_command_passes_the_command_line_checks(tmp_path):
    """The export wrote `--set forces.relativity=False`, which the command line refused: the exported
    command is parsed and its settings checked as `python -m lnss_lib` does it, giving the explorer's profile."""
    import shlex

    from lnss_lib.config import parse_sets

    overrides = {
        "forces": {"relativity": False, "third_bodies": ["SUN", "EARTH"]},
        "dop": {"elevation_mask_deg": 15.0},
    }
    explorer = DesignExplorer(PROFILE, outputs_dir=tmp_path, overrides=overrides)
    explorer.model_choice.value = "secular"
    exported = explorer.export()
    assert shlex.split(exported["command"])[3:] == exported["argv"]
    args = build_parser().parse_args(exported["argv"])
    profile = load_settings(args.profile, overrides=parse_sets(args.set))
    assert profile.forces.relativity is False and profile.forces.third_bodies == ("SUN", "EARTH")
    assert profile == explorer.context().settings


def test_export_of_a_profile_file_names_the_file(tmp_path, monkeypatch):
    """Notebook 09 under `reproduce --profile-file PATH`: the explorer offers that profile and exports
    `--profile-file PATH`, which the command line accepts."""
    from lnss_lib import config

    monkeypatch.setenv(config.PROFILE_FILES_ENV, "{}")
    path = tmp_path / "mine.toml"
    shutil.copy(config.PARAMS_DIR / f"{PROFILE}.toml", path)
    explorer = DesignExplorer(config.use_profile_file(path), outputs_dir=tmp_path)
    exported = explorer.export()
    args = build_parser().parse_args(exported["argv"])
    assert args.profile_file == str(path)
    loaded = load_settings(config.use_profile_file(args.profile_file))
    assert loaded.profile.name == "mine"
    assert loaded.hash == explorer.context().settings.hash  # contexts are shared by hash
