"""The design evaluator: eq. 45 keys, consistency with the parts, infeasible designs flagged."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from lnss_lib.config import PROJECT_DIR
from lnss_lib.evaluator import METRIC_KEYS, context_for, evaluate_constellation, evaluate_design
from lnss_lib.keys import RESULT_KEYS, VERDICT_KEYS
from lnss_lib.settings import load_settings

CLI_KEYS = {
    "n_sat",
    "mean_visible_sats",
    "pdop_mean_3sigma",
    "pdop_avail_pct",
    "hdop_mean_3sigma",
    "hdop_avail_pct",
    "dv_total_kms_per_year",
    "dv_opt_kms_per_year",
    "gps_visible_mean",
    "gps_pdop_mean",
    "deltav_model",
    "evaluated",
    "reason",
    "wall_s",
    "meets_bounds",
    "violated_bounds",
}


@pytest.fixture(scope="module")
def context():
    return context_for(load_settings("ci"))


def test_elfo_metrics_are_physical(context):
    result = evaluate_design(context, 6143.0, 0.6, 90.0, 51.7, 2, 8)
    assert result["evaluated"] and result["n_sat"] == 16
    assert 9.0 < result["mean_visible_sats"] <= 16.0
    assert (
        1.0 < result["pdop_mean_3sigma"] < 5.0
        and result["hdop_mean_3sigma"] < result["pdop_mean_3sigma"]
    )
    assert result["pdop_avail_pct"] == pytest.approx(100.0) and result[
        "hdop_avail_pct"
    ] == pytest.approx(100.0)
    assert 0.0 < result["dv_opt_kms_per_year"] <= result["dv_total_kms_per_year"]
    assert 0.0 < result["gps_visible_mean"] < 31.0 and result["gps_pdop_mean"] > 1.0
    assert set(METRIC_KEYS) <= set(result)


def test_constellation_and_design_agree(context):
    from lnss_lib.constellation import WalkerDesign

    elements = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 2).elements_deg()
    a = evaluate_constellation(context, elements)
    b = evaluate_design(context, 6143.0, 0.6, 90.0, 51.7, 2, 2)
    for key in METRIC_KEYS:
        assert a[key] == pytest.approx(b[key], nan_ok=True)


def test_too_few_satellites_gives_no_coverage_not_an_error(context):
    result = evaluate_design(context, 6143.0, 0.6, 90.0, 51.7, 1, 2)
    assert (
        result["evaluated"]
        and result["pdop_avail_pct"] == 0.0
        and math.isnan(result["pdop_mean_3sigma"])
    )


def test_infeasible_designs_are_flagged_not_raised(context):
    result = evaluate_design(context, 2000.0, 0.5, 90.0, 51.7, 2, 2)
    assert result["evaluated"] is False and result["reason"].startswith("invalid elements")
    assert all(math.isnan(result[k]) for k in METRIC_KEYS if k != "n_sat")


@pytest.mark.parametrize(
    "design, key",
    [
        ((6143.0, 1.2, 90.0, 51.7, 2, 2), "e = 1.2"),
        ((6143.0, 0.6, 90.0, 51.7, 0, 2), "n_planes = 0"),
        ((float("nan"), 0.6, 90.0, 51.7, 2, 2), "sma_km = nan"),
        ((6143.0, 0.6, 90.0, 181.0, 2, 2), "inc_deg = 181"),
    ],
)
def test_invalid_input_is_an_error_not_an_infeasible_design(context, design, key):
    from lnss_lib.errors import ConfigError

    with pytest.raises(ConfigError, match=key):
        evaluate_design(context, *design)


def test_cli_json_has_exactly_the_documented_keys():
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "lnss_lib",
            "evaluate",
            "--sma-km",
            "6143",
            "--ecc",
            "0.6",
            "--aop-deg",
            "90",
            "--inc-deg",
            "51.7",
            "--planes",
            "2",
            "--sats-per-plane",
            "2",
            "--profile",
            "ci",
            "--json",
        ],
        cwd=PROJECT_DIR,
        capture_output=True,
        text=True,
        check=True,
    )
    result = json.loads(out.stdout)
    assert set(result) == CLI_KEYS == set(RESULT_KEYS + VERDICT_KEYS)
    assert (
        result["n_sat"] == 4
        and result["evaluated"] is True
        and result["reason"] == ""
        and np.isfinite(result["wall_s"])
    )
    # 4 satellites: PDOP availability far below Table 3's 70 %; "evaluated" is no verdict on the bounds
    assert result["meets_bounds"] is False and any(
        b.startswith("pdop_avail_pct = ") and b.endswith("< min 70")
        for b in result["violated_bounds"]
    )


def test_metrics_come_from_the_right_parts(context):
    """Each eq. 45 key holds the matching quantity of its own module (a swapped key would fail here).

    A sparse design, so that PDOP and HDOP availabilities and means all differ from each other.
    """
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.dop import summary_for_settings
    from lnss_lib.evaluator import analyse_constellation
    from lnss_lib.gps import gps_link_summary

    study = analyse_constellation(
        context, WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 3).elements_deg()
    )
    metrics = study["metrics"]
    grid = summary_for_settings(context.dop, study["dop"])
    assert grid["pdop_avail_pct"] != grid["hdop_avail_pct"]
    assert metrics["pdop_avail_pct"] == grid["pdop_avail_pct"]
    assert metrics["hdop_avail_pct"] == grid["hdop_avail_pct"]
    assert metrics["pdop_mean_3sigma"] == grid["pdop_mean_3sigma"] != metrics["hdop_mean_3sigma"]
    assert metrics["mean_visible_sats"] == grid["mean_visible_sats"]
    assert metrics["dv_total_kms_per_year"] == study["deltav"].attrs["dv_total_kms_per_year"]
    assert metrics["dv_opt_kms_per_year"] == study["deltav"].attrs["dv_opt_kms_per_year"]
    link = gps_link_summary(study["gps_link"])
    assert (metrics["gps_visible_mean"], metrics["gps_pdop_mean"]) == (
        link["gps_visible_mean"],
        link["gps_pdop_mean"],
    )
    # the DOP grid is evaluated on the propagated orbits rotated into the Moon-fixed frame
    assert study["dop"].sizes["time"] == study["propagation"].sizes["time"]


def test_campaign_path_matches_study_path_and_reuses_run_geometry(context, monkeypatch):
    """The campaign's compiled DOP path gives the study path's metrics (to summation rounding), and an
    evaluation neither rebuilds the Moon-fixed rotations nor the surface grid (built once per run)."""
    from lnss_lib import evaluator, surface_grid
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.evaluator import analyse_constellation

    elements = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 3).elements_deg()
    study = analyse_constellation(context, elements)["metrics"]

    def forbidden(*args, **kwargs):
        raise AssertionError("run geometry rebuilt inside an evaluation")

    monkeypatch.setattr(evaluator, "rotation", forbidden)
    monkeypatch.setattr(surface_grid, "surface_grid", forbidden)
    monkeypatch.setattr(surface_grid.SurfaceGrid, "from_settings", forbidden)
    campaign = evaluate_constellation(context, elements)
    assert context_for(load_settings("ci")) is context
    for key in METRIC_KEYS:
        assert campaign[key] == pytest.approx(study[key], rel=1e-11, nan_ok=True), key


def test_campaign_metrics_are_the_dataset_paths_bit_for_bit(context):
    """campaign_metrics (arrays, satellite 0's Delta-V model alone) gives analyse_states(datasets=False)'s metrics
    exactly, and the same ImpactError for a constellation with a satellite falling into the Moon."""
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.errors import ImpactError
    from lnss_lib.evaluator import analyse_states, campaign_metrics
    from lnss_lib.propagator import elements_deg_to_states

    for walker in (
        WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 3),
        WalkerDesign(12000.0, 0.3, 250.0, 80.0, 3, 1),
    ):
        elements = walker.elements_deg()
        states = elements_deg_to_states(context.dynamics, elements, context.t0_tdb_s)
        lean = campaign_metrics(context, elements, states)
        study = analyse_states(context, elements, states, datasets=False)["metrics"]
        assert (
            lean.keys() == study.keys()
            and lean["evaluated"]
            and lean["deltav_model"] == context.deltav.model
        )
        for key in METRIC_KEYS:
            assert lean[key] == study[key] or (math.isnan(lean[key]) and math.isnan(study[key])), (
                key
            )
    falling = np.vstack(
        [states[0], [3000.0, 0.0, 0.0, -1.0, 0.1, 0.0]]
    )  # radial fall: below the surface in ~1 h
    messages = []
    for path in (
        lambda: campaign_metrics(context, elements[:2], falling),
        lambda: analyse_states(context, elements[:2], falling, datasets=False),
    ):
        with pytest.raises(ImpactError, match="satellite 1 hits the Moon after 0.0") as info:
            path()
        messages.append((str(info.value), info.value.sat, info.value.t_tdb_s))
    assert messages[0] == messages[1]
