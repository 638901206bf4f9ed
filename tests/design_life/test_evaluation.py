"""Design-life evaluation: CLI keys, monthly navigation, validation table."""

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy.stats import rankdata

from lnss_lib.__main__ import main
from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.constellation import WalkerDesign
from lnss_lib.design_life.evaluation import LIFE_KEYS, life_availability, life_navigation
from lnss_lib.dop import dop_for_settings, dop_summary, summary_for_settings
from lnss_lib.frames import rotate_to_moon_fixed
from lnss_lib.propagator import elements_deg_to_states, propagate_states
from lnss_lib.settings import load_settings
from lnss_lib.studies.design_life import compare, validate_design, validation_table
from lnss_lib.surface_grid import SurfaceGrid

ELFO_2X1 = [
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
    "1",
]


def test_evaluate_design_life_json_keys_and_types(capsys):
    assert (
        main(["evaluate", *ELFO_2X1, "--profile", "ci", "--design-life-days", "20", "--json"]) == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert set(LIFE_KEYS) <= set(out) and out["reason"] == "" and out["evaluated"] is True
    assert out["life_days"] == 20.0
    for key in ("impact_day", "natural_impact_day"):
        assert out[key] is None or isinstance(out[key], float)
    assert isinstance(out["n_maneuvers"], int) and out["n_maneuvers"] >= 0
    assert isinstance(out["box_held"], bool) and isinstance(out["stable_screen"], bool)
    for key in (
        "sk_dv_kms_per_year",
        "sk_dv_max_kms_per_year",
        "sk_dv_estimate_kms_per_year",
        "screen_min_perilune_alt_km",
    ):
        assert isinstance(out[key], float) and np.isfinite(out[key])
    assert 0.0 <= out["sk_dv_kms_per_year"] <= out["sk_dv_max_kms_per_year"]
    for key in ("pdop_avail_pct_life", "hdop_avail_pct_life"):
        assert 0.0 <= out[key] <= 100.0
    assert out["controller"] == "service" and out["element_frame"] == "lunar_equator_of_epoch"
    assert sum(out["sk_dv_split"].values()) == pytest.approx(
        out["sk_dv_kms_per_year"], rel=1e-9, abs=1e-15
    )
    assert sum(out["sk_dv_split_by_location"].values()) == pytest.approx(
        out["sk_dv_kms_per_year"], rel=1e-9, abs=1e-15
    )
    assert (
        0.0 < out["natural_min_perilune_alt_km"] < 6143 * (1 - 0.6) - 1737.4 + 1.0
    )  # below the design's 720 km
    assert out["lost_satellites"] == [] and out["natural_lost_satellites"] == []
    for key in ("pdop_avail_pct_monthly", "hdop_avail_pct_monthly"):
        assert set(out[key]) == {"controlled", "natural"} and len(out[key]["controlled"]) >= 1
    tol, svc = out["relative_tolerances_deg"], load_settings("ci").design_life.service
    assert svc.raan_rel_bounds_deg[0] <= tol["raan_rel"] <= svc.raan_rel_bounds_deg[1]
    assert svc.u_rel_bounds_deg[0] <= tol["u_rel"] <= svc.u_rel_bounds_deg[1]


def test_evaluate_prints_reason_of_infeasible_design(capsys):
    assert (
        main(
            [
                "evaluate",
                "--sma-km",
                "6143",
                "--ecc",
                "0.85",
                "--aop-deg",
                "90",
                "--inc-deg",
                "51.7",
                "--planes",
                "2",
                "--sats-per-plane",
                "1",
                "--profile",
                "ci",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["evaluated"] is False and "perilune" in out["reason"]
    assert "life_days" not in out
    assert (
        main(
            [
                "evaluate",
                "--sma-km",
                "6143",
                "--ecc",
                "0.85",
                "--aop-deg",
                "90",
                "--inc-deg",
                "51.7",
                "--planes",
                "2",
                "--sats-per-plane",
                "1",
                "--profile",
                "ci",
                "--json",
                "--design-life-days",
                "20",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["reason"] and all(out[key] is None for key in LIFE_KEYS)
    assert main(["evaluate", *ELFO_2X1, "--profile", "ci", "--design-life-days", "-3"]) == 2


@pytest.fixture(scope="module")
def sampled_life(ci_profile, epoch_tdb_s):
    """A stand-in for a sampled simulate_life Dataset: 2 ELFO satellites over 3 days at 900 s, satellite 1 'lost' on day 2."""
    t0 = epoch_tdb_s
    el = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 1).elements_deg()
    ds = propagate_states(
        ci_profile.dynamics,
        elements_deg_to_states(ci_profile.dynamics, el, t0),
        t0,
        3 * SECONDS_PER_DAY,
        900.0,
        batch=True,
    )
    t = ds["time"].values
    r = ds["r_mci_km"].transpose("sat", "time", "xyz").values.copy()
    r[1, t - t0 > 2 * SECONDS_PER_DAY] = np.nan
    life = xr.Dataset(
        {"r_mci_km": (("sat", "sample", "xyz"), r)},
        coords={
            "sample_t_tdb_s": ("sample", t),
            "sample_day": ("sample", (t - t0) / SECONDS_PER_DAY),
        },
    )
    return life, t, r


def test_life_navigation_months_match_direct_dop_summary(ci_profile, sampled_life):
    life, t, r = sampled_life
    nav = life_navigation(ci_profile.dop, ci_profile.dynamics, {"controlled": life}, month_days=1.0)
    assert nav.sizes["month"] == 3
    day = (t - t[0]) / SECONDS_PER_DAY
    bounds = [
        (0.0, 1.0, False),
        (1.0, 2.0, False),
        (2.0, 3.0, True),
    ]  # the last epoch closes the last month
    total = 0
    grid = SurfaceGrid.from_settings(ci_profile.dop, ci_profile.constants.r_moon_mean_km)
    for m, (lo, hi, closed) in enumerate(bounds):
        idx = np.flatnonzero(
            (day >= lo - 1e-9) & ((day <= hi + 1e-9) if closed else (day < hi - 1e-9))
        )
        direct = summary_for_settings(
            ci_profile.dop,
            dop_for_settings(
                ci_profile.dop,
                rotate_to_moon_fixed(ci_profile.dynamics, r[:, idx], t[idx]),
                t[idx],
                grid,
            ),
        )
        for key in (
            "pdop_avail_pct",
            "hdop_avail_pct",
            "pdop_mean_3sigma",
            "hdop_mean_3sigma",
            "mean_visible_sats",
        ):
            assert nav[key].sel(run="controlled", month=m).item() == pytest.approx(
                direct[key], rel=1e-12, nan_ok=True
            )
        assert nav["n_epochs"].sel(run="controlled", month=m).item() == idx.size
        total += idx.size
    assert total == t.size
    whole = dop_summary(
        dop_for_settings(ci_profile.dop, rotate_to_moon_fixed(ci_profile.dynamics, r, t), t, grid),
        threshold=float(ci_profile.dop.availability_threshold),
    )
    for key in ("pdop_avail_pct", "hdop_avail_pct"):
        assert life_availability(nav, "controlled", key) == pytest.approx(whole[key], rel=1e-12)


def test_validation_table_ratio_and_rank_correlation(ci_profile):
    designs = [(6143.0, 0.6, 90.0, 51.7, 2, 1), (5000.0, 0.05, 180.0, 1.0, 2, 1)]
    rows = [
        validate_design(ci_profile, d, 12.0, max_sats_per_plane=1, region="test") for d in designs
    ]
    table = validation_table(rows)
    for row in table.itertuples():
        assert row.n_sat_flown == 2
        flew = (
            np.isnan(row.impact_day) and row.sk_dv_kms_per_year > 0.0
        )  # no manoeuvre in the span: no ratio
        expected = row.sk_dv_estimate_kms_per_year / row.sk_dv_kms_per_year if flew else np.nan
        assert row.ratio == pytest.approx(expected, nan_ok=True)
        natural_stable = np.isnan(row.natural_impact_day)
        assert (row.screen_call == "agree") == (row.stable_screen == natural_stable)
    synthetic = pd.DataFrame(
        {
            "sk_dv_kms_per_year": [0.1, 0.4, 0.2, 0.8, 0.3],
            "sk_dv_estimate_kms_per_year": [0.3, 0.5, 0.9, 1.0, 0.2],
            "impact_day": [np.nan] * 4 + [12.0],
            "natural_impact_day": np.nan,
            "stable_screen": True,
        }
    )
    stats = compare(validation_table(synthetic))
    assert stats["n_compared"] == 4
    ranks_est, ranks_closed = rankdata([0.3, 0.5, 0.9, 1.0]), rankdata([0.1, 0.4, 0.2, 0.8])
    assert stats["spearman_rho"] == pytest.approx(np.corrcoef(ranks_est, ranks_closed)[0, 1])
    assert stats["ratio_median"] == pytest.approx(np.median([3.0, 1.25, 4.5, 1.25]))


def test_life_evaluation_settings_are_checked(ci_profile):
    from lnss_lib.errors import ConfigError

    assert ci_profile.life_evaluation.sample_step_s == 900.0
    with pytest.raises(ConfigError, match="life_evaluation.smaple_step_s"):
        ci_profile.with_overrides({"life_evaluation": {"smaple_step_s": 1.0}})
    with pytest.raises(ConfigError, match="life_evaluation.month_days"):
        ci_profile.with_overrides({"life_evaluation": {"month_days": -1.0}})
    with pytest.raises(
        ConfigError, match=r"life_evaluation.frame_rerun_designs = -1 is out of range"
    ):
        ci_profile.with_overrides({"life_evaluation": {"frame_rerun_designs": -1}})


def test_frame_rerun_takes_every_design_or_the_first_n():
    """The validation re-run in another element frame: paper and ci every design and the campaign's; quick the first
    five (the standalone ELFO and the frozen family), without the campaign's."""
    from lnss_lib.studies.design_life import frame_rerun, region_of

    for name, n_designs, keeps_campaign in (
        ("paper", 15, True),
        ("ci", 3, True),
        ("quick", 5, False),
    ):
        settings = load_settings(name)
        rerun, campaign = frame_rerun(settings, "moon_op", "campaign-folder")
        assert (
            rerun.frames.element_frame == "moon_op"
            and settings.frames.element_frame == "lunar_equator_of_epoch"
        )
        assert (
            rerun.life_evaluation.validation_designs
            == settings.life_evaluation.validation_designs[:n_designs]
        )
        assert (campaign == "campaign-folder") == keeps_campaign
    regions = {
        region_of(d)
        for d in frame_rerun(load_settings("quick"), "moon_op")[
            0
        ].life_evaluation.validation_designs
    }
    assert regions == {"standalone ELFO", "frozen family"}
