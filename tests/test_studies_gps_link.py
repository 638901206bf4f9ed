"""Notebook 03's study (lnss_lib.studies.gps_link): link-budget tables, sensitivity sweeps, PDOP decomposition."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from lnss_lib import gps, gps_states, tle
from lnss_lib.ephemeris import tdb_seconds
from lnss_lib.studies import gps_link as gl


def _synthetic_link():
    dims = ("time", "gps")
    moon = np.array([[True, False, False, False, False], [False, False, False, False, False]])
    earth = np.array([[True, True, False, False, False], [False, False, False, False, False]])
    ellipsoid = np.array([[False, False, True, False, False], [False, False, False, False, False]])
    outside = np.array([[False, False, False, True, False], [False, False, False, False, True]])
    strong = np.array([[True, True, True, False, True], [False, True, True, True, True]])
    visible = ~moon & ~earth & ~ellipsoid & ~outside & strong
    theta = np.array([[5.0, 10.0, 14.0, 75.0, 30.0], [40.0, 20.0, 25.0, 50.0, 80.0]])
    return xr.Dataset(
        {
            "moon_blocked": (dims, moon),
            "earth_blocked": (dims, earth),
            "ellipsoid_blocked": (dims, ellipsoid),
            "outside_beam": (dims, outside),
            "above_threshold": (dims, strong),
            "visible": (dims, visible),
            "theta_off_deg": (dims, theta),
        },
        coords={"time": [0.0, 900.0], "gps": np.arange(5), "prn": ("gps", [7, 3, 12, 1, 5])},
    )


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


def test_link_budget_table_adds_up(profile):
    table = gl.link_budget_table(
        profile.gps, [10.0, 30.0, 60.0], 384400.0, noise_temperature_k=250.0
    )
    total = table["eirp_dbw"] + table["g_rx_dbi"] - table["fsl_db"] - table["ktn_dbw_hz"]
    assert np.allclose(total, table["cn0_dbhz"])
    assert table.loc[30.0, "ktn_dbw_hz"] == pytest.approx(
        -228.5991 + 10 * math.log10(250.0), abs=1e-4
    )
    assert list(table["receivable"]) == list(table["cn0_dbhz"] >= 15.0)


def test_off_boresight_limits_and_cn0_curves(profile):
    limits = gl.off_boresight_limits(profile.gps, profile.constants)
    alpha = math.degrees(math.asin(profile.constants.r_earth_km / 26560.0))
    assert limits["earth_limb_deg"] == pytest.approx(alpha) and limits[
        "limb_with_margin_deg"
    ] == pytest.approx(alpha + 0.5)
    last = limits["last_receivable_deg"]
    edge = gl.link_budget_table(profile.gps, [last, last + 0.1], 384400.0)["cn0_dbhz"].values
    assert edge[0] >= 15.0 > edge[1]  # the C/N0 cut-off, inside the 70 deg mask
    assert limits["sidelobe_from_deg"] < last < limits["beam_mask_deg"]
    deaf = profile.with_overrides({"gps": {"cn0_threshold_dbhz": 100.0}})
    with pytest.raises(ValueError, match="reaches 100.0 dB-Hz"):
        gl.off_boresight_limits(deaf.gps, deaf.constants)
    curves = gl.cn0_curves(
        profile.gps,
        [10.0, 40.0],
        384400.0,
        {"cold": {"noise_temperature_k": 100.0}, "warm": {"noise_temperature_k": 400.0}},
    )
    np.testing.assert_allclose(
        curves["cold"] - curves["warm"], 10.0 * math.log10(4.0)
    )  # -10 log10(k T)
    assert curves.index.tolist() == [10.0, 40.0]


def test_earth_plane_projection_closed_form():
    earth = np.array([[384400.0, 0.0, 0.0]])
    lnss = np.array([[0.0, 0.0, 5000.0]])
    e_dir = earth[0] - lnss[0]
    e_dir /= np.linalg.norm(e_dir)
    offsets = np.array(
        [[0.0, 3000.0, 0.0], [7000.0 * e_dir[0], 7000.0 * e_dir[1], 7000.0 * e_dir[2]]]
    )
    x, y, e_hat = gl.earth_plane_projection(earth[:, None, :] + offsets[None], earth, lnss)
    np.testing.assert_allclose(e_hat[0], e_dir)
    assert math.hypot(x[0, 0], y[0, 0]) == pytest.approx(3000.0)  # perpendicular offset kept
    assert abs(x[0, 1]) < 1e-6 and abs(y[0, 1]) < 1e-6  # offset along the line of sight vanishes
    assert x[0, 0] == pytest.approx(-3000.0)  # x along e_hat x z


def test_link_status_counts_and_shares():
    link = _synthetic_link()
    status = gl.link_status(link)
    assert status[0].tolist() == [
        "Moon blocks",
        "Earth (+margin) blocks",
        "Earth (+margin) blocks",
        "outside beam",
        "visible",
    ]
    assert status[1].tolist() == [
        "C/N0 < 15 dB-Hz",
        "visible",
        "visible",
        "visible",
        "outside beam",
    ]
    assert np.array_equal(status == "visible", link["visible"].values)
    counts = gl.link_test_counts(link)
    assert (
        counts["all (gps, epoch) pairs"] == 10
        and counts["visible"] == 4
        and counts["Moon blocks"] == 1
    )
    assert (
        counts["WGS-84 ray test blocks (beyond eq. 21)"] == 1
        and counts["C/N0 below threshold (geometry ok)"] == 1
    )
    share = gl.visible_share_by_prn(link)
    assert share.index.tolist() == [1, 3, 5, 7, 12] and share.tolist() == [0.5, 0.5, 0.5, 0.0, 0.5]
    assert gl.main_lobe_share(link, 23.0) == pytest.approx(
        0.25
    )  # visible at 30, 20, 25, 50 deg: one below 23


def test_comparison_catalogue_and_per_satellite_tables(profile):
    table = gl.paper_comparison_table({"gps_visible_mean": 7.0, "gps_pdop_mean": 1000.0})
    np.testing.assert_allclose(table["ratio"], [7.0 / 7.74, 1000.0 / 6238.0])
    _, catalogue = tle.gps_catalogue(profile.gps, profile.epoch.start_tdb)
    days = gl.catalogue_table(catalogue, "2025-05-01T00:00:00")
    first = catalogue[0]["tle_epoch_utc"]
    assert days.iloc[0]["days_back_from_tle"] == pytest.approx(
        (first - dt.datetime(2025, 5, 1)).total_seconds() / 86400.0
    )
    assert isinstance(days.iloc[0]["launch_date"], str)
    assert days.iloc[0]["tle_epoch_utc"] == first.strftime("%Y-%m-%d %H:%M:%S")  # to the second
    t = tdb_seconds(profile.epoch.start_tdb) + 900.0 * np.arange(6)
    states = gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, t)
    ang = np.linspace(0.0, 1.0, t.size)
    r_lnss = np.stack(
        [
            8000.0 * np.stack([np.cos(ang + p), np.sin(ang + p), 0.3 * np.ones_like(ang)], axis=-1)
            for p in (0.0, 2.0, 4.0)
        ]
    )
    per_sat = gl.per_satellite_summary(
        gps.gps_link(profile.gps, profile.constants, states, r_lnss, sats="all")
    )
    assert per_sat.index.name == "satellite" and not isinstance(
        per_sat.index, pd.RangeIndex
    )  # tables keep the index
    one = gps.gps_link(profile.gps, profile.constants, states, r_lnss, sats=[2])
    assert per_sat.loc[2, "gps_visible_mean"] == pytest.approx(one["n_visible"].values.mean())


@pytest.fixture(scope="module")
def elfo_link(profile):
    from lnss_lib.constellation import standalone_elfo
    from lnss_lib.propagator import propagate_elements

    elements = standalone_elfo(profile.standalone_elfo, profile.dynamics)[:1]
    prop = propagate_elements(profile.dynamics, profile.epoch, elements)
    return (
        elements,
        prop,
        gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, prop["time"].values),
    )


def test_pdop_split_adds_up_and_clock_column_only_adds_error(profile, elfo_link):
    _, prop, states = elfo_link
    split = gl.pdop_split(profile.gps, profile.constants, states, prop)
    both = np.isfinite(split["pdop"]) & np.isfinite(split["along"])
    assert both.sum() > 10
    np.testing.assert_allclose(
        split["along"][both] ** 2 + split["across"][both] ** 2, split["pdop"][both] ** 2, rtol=1e-6
    )
    with_clock = np.isfinite(split["pdop"])
    assert np.all(split["pdop_no_clock"][with_clock] <= split["pdop"][with_clock] * (1 + 1e-9))
    table = gl.pdop_decomposition(profile.gps, profile.constants, states, prop)
    assert table.loc["PDOP (eq. 5-7, clock column)", "median"] == pytest.approx(
        np.nanmedian(split["pdop"])
    )


def test_sensitivity_variants_and_table(profile, elfo_link):
    variants = gl.sensitivity_variants(profile.gps)
    assert variants["default"] == {} and f"gain {profile.gps.gain_column}" not in variants
    for label, over in variants.items():
        assert len(over) <= 1 and set(over) <= {f.name for f in dataclasses.fields(profile.gps)}, (
            label
        )  # one setting at a time
    elements, prop, states = elfo_link
    sens = gl.sensitivity_table(profile, states, prop, elements, phase_shifts_days=(7.0,))
    assert list(sens.index[: len(variants)]) == list(variants)
    assert sens.index[-1] == "GPS phase: SGP4 at t +7 d"
    default = gps.gps_link_summary(gps.gps_link(profile.gps, profile.constants, states, prop))
    assert sens.loc["default", "gps_pdop_mean"] == pytest.approx(default["gps_pdop_mean"])
    # A colder receiver or stronger sidelobes only add links; main lobe only removes them.
    visible = sens["gps_visible_mean"]
    assert visible["T = 100 K"] >= visible["default"] >= visible["T = 400 K"]
    assert (
        sens.loc["sidelobes +3 dB", "gps_visible_mean"] >= sens.loc["default", "gps_visible_mean"]
    )
    assert sens.loc["main lobe only", "gps_visible_mean"] <= sens.loc["default", "gps_visible_mean"]
    np.testing.assert_allclose(sens["pdop_ratio_to_paper"], sens["gps_pdop_mean"] / 6238.0)
    lines = gl.sensitivity_findings(
        sens, gl.pdop_decomposition(profile.gps, profile.constants, states, prop), 0.25
    )
    assert f"**{default['gps_visible_mean']:.2f}**" in lines[0] and "25.0%" in lines[1]


def test_pdop_at_visible_count_interpolates_in_log():
    vis = np.array([4.0, 6.0, 9.0, 12.0])
    sens = pd.DataFrame(
        {"gps_visible_mean": vis, "gps_pdop_mean": np.exp(10.0 - 0.5 * vis)},
        index=["T = 400 K", "T = 300 K", "default", "gain other"],
    )
    # log PDOP is linear in the count here, so the interpolation is exact; "gain other" is not in the sweep.
    assert gl.pdop_at_visible_count(sens, 7.74) == pytest.approx(math.exp(10.0 - 0.5 * 7.74))
    assert gl.pdop_at_visible_count(sens, 11.0) == pytest.approx(
        math.exp(10.0 - 0.5 * 9.0)
    )  # clamped at the sweep's end
