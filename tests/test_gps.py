"""Tests of lnss_lib.gps: TLE validation, TEME -> J2000, occultation, link budget, PDOP."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest
import spiceypy as spice

from lnss_lib import gain_pattern, gps, gps_states, tle
from lnss_lib.config import data_path
from lnss_lib.ephemeris import tdb_seconds

R_EARTH_KM = 6378.137
R_MOON_KM = 1737.4


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


def test_sgp4_radius_at_tle_epoch_and_states_dataset(profile):
    records, _ = tle.gps_catalogue(profile.gps, profile.epoch.start_tdb)
    epochs = np.array(
        [(r.epoch_utc - dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0 for r in records]
    )
    jd = 2451545.0 + np.floor(epochs)
    r = np.stack(
        [
            gps_states.propagate_teme([rec], jd[k : k + 1], (epochs - np.floor(epochs))[k : k + 1])[
                0, 0
            ]
            for k, rec in enumerate(records)
        ]
    )
    assert np.all(np.abs(np.linalg.norm(r, axis=-1) - 26560.0) < 500.0)
    t = tdb_seconds(profile.epoch.start_tdb) + np.array([0.0, 900.0])
    ds = gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, t)
    assert ds["r_mci_km"].dims == ("gps", "time", "xyz") and 21 not in ds["prn"].values
    earth = spice.spkpos("EARTH", t.tolist(), "J2000", "NONE", "MOON")[0]
    assert np.allclose(
        ds["r_mci_km"].values - ds["r_eci_km"].values, np.asarray(earth)[None], atol=1e-9
    )
    assert np.allclose(
        np.linalg.norm(ds["r_eci_km"], axis=-1), np.linalg.norm(ds["r_teme_km"], axis=-1)
    )
    assert gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, t) is ds


# ------------------------------------------------------------------------------- geometry


def test_earth_occultation_behind_and_just_outside_limb():
    r_gps = np.array([26560.0, 0.0, 0.0])
    behind = np.array([-384400.0, 0.0, 0.0])  # the Earth lies exactly between
    theta = gps.off_boresight_deg(r_gps, behind)
    assert theta == pytest.approx(0.0, abs=1e-9)
    assert gps.earth_occultation(theta, r_gps, R_EARTH_KM, 0.5)
    limb = math.degrees(math.asin(R_EARTH_KM / 26560.0)) + 0.5  # eq. 21 threshold, ~14.4 deg
    for offset, blocked in ((+0.05, False), (-0.05, True)):
        ang = math.radians(limb + offset)
        target = r_gps + 400000.0 * np.array([-math.cos(ang), math.sin(ang), 0.0])
        th = gps.off_boresight_deg(r_gps, target)
        assert th == pytest.approx(limb + offset, abs=1e-9)
        assert bool(gps.earth_occultation(th, r_gps, R_EARTH_KM, 0.5)) is blocked
        assert not gps.ray_hits_ellipsoid(r_gps, target)  # passes > 6378 km from the centre


def test_ray_ellipsoid_flattening():
    """A ray at 6365 km from the centre misses the WGS-84 ellipsoid over the pole, hits it at the equator."""
    over_pole = gps.ray_hits_ellipsoid(
        np.array([-30000.0, 0.0, 6365.0]), np.array([30000.0, 0.0, 6365.0])
    )
    over_equator = gps.ray_hits_ellipsoid(
        np.array([-30000.0, 6365.0, 0.0]), np.array([30000.0, 6365.0, 0.0])
    )
    short = gps.ray_hits_ellipsoid(np.array([26560.0, 0.0, 0.0]), np.array([10000.0, 0.0, 0.0]))
    assert not over_pole and over_equator and not short


def test_line_of_sight_through_moon_is_blocked():
    r_lnss = np.array([0.0, 0.0, 5000.0])
    through = gps.lunar_occultation(r_lnss, np.array([0.0, 0.0, -384400.0]), R_MOON_KM)
    sideways = gps.lunar_occultation(r_lnss, np.array([384400.0, 0.0, 0.0]), R_MOON_KM)
    assert through and not sideways
    # alpha_moon = asin(1737.4 / 5000) = 20.3 deg: a direction 21 deg off the nadir clears the limb.
    off = math.radians(21.0)
    clear = gps.lunar_occultation(
        r_lnss, r_lnss + 4e5 * np.array([0.0, math.sin(off), -math.cos(off)]), R_MOON_KM
    )
    hit = gps.lunar_occultation(
        r_lnss,
        r_lnss + 4e5 * np.array([0.0, math.sin(off - 0.02), -math.cos(off - 0.02)]),
        R_MOON_KM,
    )
    assert not clear and hit


# ------------------------------------------------------------------------------ link budget


def test_cn0_hand_computed():
    """Table 1 link at 30 deg off boresight and 384 400 km, with the textbook FSL in km and MHz."""
    pattern = gain_pattern.load_gain_pattern(
        data_path("data/gps/gps_block_iir_l1_gain_0-90deg.csv"), "improved_panel_dbi"
    )
    gain = float(pattern(30.0))
    assert gain == pytest.approx(-2.81)
    d_km, f_mhz, t_k = 384400.0, 1575.42, 190.0
    fsl = 20 * math.log10(d_km) + 20 * math.log10(f_mhz) + 32.4478
    expected = 15.0 - 5.0 + gain + 15.0 - fsl - (-228.5991 + 10 * math.log10(t_k))
    got = gps.cn0_dbhz(
        gain,
        d_km,
        p_tx_dbw=15.0,
        losses_db=5.0,
        g_rx_dbi=15.0,
        frequency_hz=f_mhz * 1e6,
        noise_temperature_k=t_k,
    )
    assert float(got) == pytest.approx(expected, abs=1e-3)
    with pytest.raises(ValueError, match="noise temperature"):
        gps.cn0_dbhz(
            gain,
            d_km,
            p_tx_dbw=15,
            losses_db=5,
            g_rx_dbi=15,
            frequency_hz=1.5e9,
            noise_temperature_k=0,
        )


def test_gain_pattern_interpolation_and_errors():
    path = data_path("data/gps/gps_block_iir_l1_gain_0-90deg.csv")
    pattern = gain_pattern.load_gain_pattern(path, "legacy_iir_dbi")
    assert float(pattern(21.0)) == pytest.approx((0.68 + -8.16) / 2)
    assert np.isnan(pattern(95.0))
    lobes = pattern.with_sidelobes(23.0, -3.0)
    assert float(lobes(10.0)) == float(pattern(10.0)) and float(lobes(40.0)) == pytest.approx(
        float(pattern(40.0)) - 3
    )
    with pytest.raises(ValueError, match="unknown gain column 'nope'"):
        gain_pattern.load_gain_pattern(path, "nope")


# ----------------------------------------------------------------------------------- PDOP


def _symmetric_los(elev_deg: float) -> np.ndarray:
    e = math.radians(elev_deg)
    rows = [[0.0, 0.0, 1.0]] + [
        [math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)]
        for a in np.radians([0.0, 120.0, 240.0])
    ]
    return np.array(rows)


@pytest.mark.parametrize("elev_deg", [10.0, 30.0, 60.0])
def test_pdop_symmetric_geometry_closed_form(elev_deg):
    """Zenith + three at elevation E, 120 deg apart: PDOP^2 = 4/(3 cos^2 E) + 4/(3 (1 - sin E)^2) with clock."""
    c, s = math.cos(math.radians(elev_deg)), math.sin(math.radians(elev_deg))
    los = _symmetric_los(elev_deg)
    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    with_clock = gps.pdop_kernel(los @ rot.T, np.ones(4, bool))
    assert with_clock == pytest.approx(
        math.sqrt(4 / (3 * c * c) + 4 / (3 * (1 - s) ** 2)), rel=1e-10
    )
    without = gps.pdop_kernel(los, np.ones(4, bool), clock_column=False)
    assert without == pytest.approx(math.sqrt(4 / (3 * c * c) + 1 / (1 + 3 * s * s)), rel=1e-10)
    # The same against a direct (G^T G)^-1 with the clock column, and < 4 visible gives no PDOP.
    g = np.hstack([los, np.ones((4, 1))])
    assert with_clock == pytest.approx(
        math.sqrt(np.trace(np.linalg.inv(g.T @ g)[:3, :3])), rel=1e-10
    )
    assert np.isnan(gps.pdop_kernel(los, np.array([True, True, True, False])))


def test_invisible_rows_do_not_count():
    los = np.vstack([_symmetric_los(30.0), [[0.6, 0.0, 0.8]]])
    mask = np.array([True, True, True, True, False])
    assert gps.pdop_kernel(los, mask) == pytest.approx(
        gps.pdop_kernel(los[:4], np.ones(4, bool)), rel=1e-12
    )


# ---------------------------------------------------------------------------- end to end


def test_gps_link_masks_consistent(profile):
    t = tdb_seconds(profile.epoch.start_tdb) + 900.0 * np.arange(8)
    states = gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, t)
    # An LNSS satellite 8000 km from the Moon's centre, rotating about the Moon.
    ang = np.linspace(0.0, 2.0, t.size)
    r_lnss = 8000.0 * np.stack([np.cos(ang), np.sin(ang), 0.3 * np.ones_like(ang)], axis=-1)
    ds = gps.gps_link(profile.gps, profile.constants, states, r_lnss[None])
    assert ds["visible"].dims == ("sat", "time", "gps") and ds.sizes["sat"] == 1
    vis = ds["visible"].values
    theta = ds["theta_off_deg"].values
    assert np.all(theta[vis] <= 70.0) and np.all(theta[vis] >= 14.3)
    assert np.all(ds["cn0_dbhz"].values[vis] >= 15.0)
    assert np.array_equal(ds["n_visible"].values, vis.sum(-1))
    assert np.array_equal(np.isfinite(ds["pdop"].values), ds["n_visible"].values >= 4)
    colder = gps.gps_link(
        profile.gps, profile.constants, states, r_lnss[None], noise_temperature_k=100.0
    )
    assert np.all(colder["visible"].values >= vis)  # a lower T only adds links
    summary = gps.gps_link_summary(ds)
    assert summary["gps_visible_mean"] == pytest.approx(vis.sum(-1).mean())
    with pytest.raises(ValueError, match="unknown GPS link setting"):
        gps.gps_link(profile.gps, profile.constants, states, r_lnss[None], noise_temp=1.0)
    with pytest.raises(ValueError, match="shape"):
        gps.gps_link(profile.gps, profile.constants, states, r_lnss[None, :3])


def test_pdop_along_axis_splits_the_trace():
    los = _symmetric_los(30.0)
    along, across = gps.pdop_along_axis(los, np.ones(4, bool), np.array([0.0, 0.0, 1.0]))
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    assert along == pytest.approx(math.sqrt(4 / (3 * (1 - s) ** 2)), rel=1e-10)
    assert across == pytest.approx(math.sqrt(4 / (3 * c * c)), rel=1e-10)
    assert np.isnan(
        gps.pdop_along_axis(los, np.array([1, 1, 1, 0], bool), np.array([0.0, 0.0, 1.0]))[0]
    )


def test_campaign_link_metrics_equal_the_dataset_summary():
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.evaluator import analyse_states, context_for
    from lnss_lib.gps import gps_link, gps_link_metrics, gps_link_summary
    from lnss_lib.propagator import elements_deg_to_states
    from lnss_lib.settings import load_settings

    context = context_for(load_settings("ci"))
    elements = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 2).elements_deg()
    ds = analyse_states(
        context,
        elements,
        elements_deg_to_states(context.settings.dynamics, elements, context.t0_tdb_s),
    )["propagation"]
    reference = gps_link_summary(
        gps_link(context.gps, context.dynamics.constants, context.gps_states, ds, sats="first")
    )
    for _ in range(2):  # second call: cached gain pattern and GPS arrays
        new = gps_link_metrics(
            context.gps, context.dynamics.constants, context.gps_states, ds["r_mci_km"].values
        )
        assert set(new) == set(reference)
        for key, value in reference.items():
            assert new[key] == pytest.approx(value, rel=1e-11, nan_ok=True), key
    assert reference["gps_visible_mean"] > 0.0


def test_sgp4_failure_names_the_satellite_the_epochs_and_the_setting(profile):
    """SGP4 past the range of a TLE's mean elements (27 years before its epoch) is named: satellite, catalogue number,
    file line, the UTC epoch and its distance from the TLE's epoch, SGP4's reason, and for a study the setting
    (it said "SGP4 error code 3 for GPS BIIR-2 (PRN 13) at UTC JD ...")."""
    from lnss_lib.errors import ConfigError

    record = tle.read_tle(data_path(profile.gps.tle_file))[0]
    days_back = 10_000.0
    at = (record.epoch_utc - dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0 - days_back
    with pytest.raises(ValueError) as raised:
        gps_states.propagate_teme(
            [record], np.array([2451545.0 + math.floor(at)]), np.array([at - math.floor(at)])
        )
    message = str(raised.value)
    for needle in (
        record.name,
        f"catalogue number {record.satnum}",
        f"line {record.file_line}",
        f"{(record.epoch_utc - dt.timedelta(days=days_back)):%Y-%m-%dT%H:%M}",
        "-10,000.0 days",
        f"TLE epoch {record.epoch_utc:%Y-%m-%dT%H:%M:%S} UTC",
        "perturbed eccentricity",
        "SGP4 error 3",
    ):
        assert needle in message, needle
    start = "1998-06-01T00:00:00"
    with pytest.raises(
        ConfigError,
        match=r"gps.tle_file = .* epoch.start_tdb = '1998-06-01T00:00:00'.*SGP4 "
        r"cannot propagate .*1998-05-31T23:58:56 UTC",
    ) as raised:
        gps_states.gps_states_mci(profile.gps, start, tdb_seconds(start) + np.array([0.0, 900.0]))
    assert raised.value.key == "gps.tle_file"
