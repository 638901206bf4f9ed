"""Tests of lnss_lib.gps: TLE validation, TEME -> J2000, occultation, link budget, PDOP."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest
import spiceypy as spice

from lnss_lib import gps
from lnss_lib.config import data_path, load_profile
from lnss_lib.ephemeris import tdb_seconds

R_EARTH_KM = 6378.137
R_MOON_KM = 1737.4


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


@pytest.fixture(scope="module")
def tle_lines():
    return data_path("data/gps/gps-ops_2025-11-14.tle").read_text().splitlines()


def _with_checksum(line: str) -> str:
    return line[:68] + str(gps.tle_checksum(line))


def _write(tmp_path, lines):
    path = tmp_path / "test.tle"
    path.write_text("\n".join(lines) + "\n")
    return path


# ------------------------------------------------------------------------------------ TLE input

def test_tle_file_parses_with_names_and_prns(tle_lines, tmp_path):
    records = gps.read_tle(_write(tmp_path, tle_lines))
    assert len(records) == len(tle_lines) // 3
    first = records[0]
    assert first.name == tle_lines[0].strip()
    assert f"PRN {first.prn:02d}" in first.name
    assert first.satnum == int(tle_lines[1][2:7])
    assert first.designator == "1997-035A" and first.launch_year == 1997 and first.launch_number == 35


def test_bad_checksum_names_file_and_line(tle_lines, tmp_path):
    line1 = tle_lines[1]
    bad = line1[:68] + str((int(line1[68]) + 1) % 10)
    path = _write(tmp_path, [tle_lines[0], bad, tle_lines[2]])
    with pytest.raises(ValueError, match=r"line 2: bad checksum on TLE line 1") as err:
        gps.read_tle(path)
    assert str(path) in str(err.value)


def test_wrong_length_names_line(tle_lines, tmp_path):
    short = tle_lines[2][:30] + tle_lines[2][31:]
    with pytest.raises(ValueError, match=r"line 3: TLE line 2 must be 69 characters long, got 68"):
        gps.read_tle(_write(tmp_path, tle_lines[:2] + [short]))


def test_shifted_columns_are_rejected(tle_lines, tmp_path):
    line1 = tle_lines[1]
    shifted = _with_checksum(line1[:8] + line1[9:18] + " " + line1[18:])   # designator one column left
    with pytest.raises(ValueError, match=r"line 2: TLE line 1 column \d+ must be blank"):
        gps.read_tle(_write(tmp_path, [tle_lines[0], shifted, tle_lines[2]]))


def test_line_number_and_satellite_number_mismatch(tle_lines, tmp_path):
    wrong_number = _with_checksum("3" + tle_lines[2][1:])
    with pytest.raises(ValueError, match=r"line 3: expected TLE line number 2"):
        gps.read_tle(_write(tmp_path, tle_lines[:2] + [wrong_number]))
    other_sat = _with_checksum(tle_lines[2][:2] + "99999" + tle_lines[2][7:])
    with pytest.raises(ValueError, match=r"lines 2-3: satellite number 24876 on line 1 differs from 99999"):
        gps.read_tle(_write(tmp_path, tle_lines[:2] + [other_sat]))


def test_checksum_counts_digits_and_minus_signs():
    line = "1 " + "-" * 3 + "9" * 2 + " " * 61 + "0"
    assert len(line) == 69
    assert gps.tle_checksum(line) == (1 + 3 * 1 + 2 * 9) % 10


def test_prn_and_launch_exclusions(profile, tle_lines, tmp_path):
    records = gps.read_tle(_write(tmp_path, tle_lines))
    kept, table = gps.select_satellites(records, exclude_prn=[13, 21])
    assert {r.prn for r in kept}.isdisjoint({13, 21}) and len(kept) == len(records) - 2
    assert set(table.loc[~table["included"], "prn"]) == {13, 21}
    kept, _ = gps.select_satellites(records, launches_from="2024-242")
    assert {r.prn for r in kept} == {r.prn for r in records} - {1, 21}
    # Profile default: launched after the simulation epoch (2025-05-01) -> GPS BIII-8 (PRN 21, 2025-05-30) out.
    kept, table = gps.gps_catalogue(profile)
    assert 21 not in {r.prn for r in kept} and len(kept) == len(records) - 1
    later = load_profile("ci", {"epoch": {"start_tdb": "2025-06-15T00:00:00"}})
    assert len(gps.gps_catalogue(later)[0]) == len(records)


def test_launch_date_estimate_from_revolution_count(tle_lines, tmp_path):
    """Without a listed date, epoch - revs / mean motion lands within a month of the real launch."""
    records = {r.prn: r for r in gps.read_tle(_write(tmp_path, tle_lines))}
    estimate, source = gps.launch_date(records[21], {})
    assert source == "estimate" and abs((estimate - dt.date(2025, 5, 30)).days) < 30
    listed, source = gps.launch_date(records[21], {"2025-116A": "2025-05-30"})
    assert source == "table" and listed == dt.date(2025, 5, 30)


# -------------------------------------------------------------------------- time and frames

def test_utc_julian_date_matches_spice_calendar(profile):
    et = tdb_seconds("2025-05-01T12:00:00")
    jd, fr = gps.utc_julian_dates(et)
    utc = dt.datetime.fromisoformat(spice.et2utc(et, "ISOC", 6))
    jd_spice = 2451545.0 + (utc - dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0
    assert abs((jd[0] - jd_spice) + fr[0]) * 86400.0 < 1e-4
    # TDB - UTC = 32.184 s + 37 leap seconds (+/- 2 ms periodic terms) in 2025.
    assert abs((2451545.0 + et / 86400.0 - (jd[0] + fr[0])) * 86400.0 - 69.184) < 2e-3


def test_teme_rotation_orthonormal_and_precession_sized(profile):
    t = tdb_seconds("2025-05-01T00:00:00") + np.array([0.0, 5 * 86400.0])
    tc = gps.tt_centuries(t)
    rot = gps.teme_to_j2000(tc)
    assert np.allclose(rot @ np.swapaxes(rot, 1, 2), np.eye(3), atol=1e-14)
    assert np.allclose(np.linalg.det(rot), 1.0, atol=1e-14)
    # The TEME pole is the true pole of date: its angle to the J2000 pole is theta_A of the precession
    # (2004.31 arcsec per century, ~0.141 deg in 25 years) within the nutation (|deps|, |dpsi sin eps| < 10 arcsec).
    pole = rot[:, :, 2]
    tilt_arcsec = np.degrees(np.arccos(pole[:, 2])) * 3600.0
    assert np.all(np.abs(tilt_arcsec - 2004.3109 * tc) < 10.0)
    # Total rotation angle: general precession in longitude, ~50.3 arcsec per year (0.354 deg since J2000).
    angle_deg = np.degrees(np.arccos((np.trace(rot, axis1=1, axis2=2) - 1.0) / 2.0))
    assert np.all(np.abs(angle_deg - 5029.0966 * tc / 3600.0) < 0.01)
    r = np.array([26560.0, -1200.0, 300.0])
    assert np.allclose(np.linalg.norm(rot @ r, axis=-1), np.linalg.norm(r), rtol=1e-14)


def _spice_dynamic_frames():
    """True- and mean-of-date Earth frames of SPICE (full 106-term IAU-1980 nutation, IAU-1976 precession)."""
    pool = []
    for code, name, family in ((1400901, "LNSS_TEST_TOD", "TRUE_EQUATOR_AND_EQUINOX_OF_DATE"),
                               (1400902, "LNSS_TEST_MOD", "MEAN_EQUATOR_AND_EQUINOX_OF_DATE")):
        pool += [f"FRAME_{name} = {code}", f"FRAME_{code}_NAME = '{name}'", f"FRAME_{code}_CLASS = 5",
                 f"FRAME_{code}_CLASS_ID = {code}", f"FRAME_{code}_CENTER = 399",
                 f"FRAME_{code}_RELATIVE = 'J2000'", f"FRAME_{code}_DEF_STYLE = 'PARAMETERIZED'",
                 f"FRAME_{code}_FAMILY = '{family}'", f"FRAME_{code}_PREC_MODEL = 'EARTH_IAU_1976'",
                 f"FRAME_{code}_ROTATION_STATE = 'ROTATING'"]
        if "TRUE" in family:
            pool.append(f"FRAME_{code}_NUT_MODEL = 'EARTH_IAU_1980'")
    spice.lmpool(pool)


def _angle_mas(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle between two nearby rotations (mas), from the antisymmetric part of a b^T (sin theta)."""
    d = a @ b.T
    axial = 0.5 * np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
    return float(np.degrees(np.arcsin(min(np.linalg.norm(axial), 1.0))) * 3.6e6)


def test_precession_nutation_against_spice_frames(profile):
    """Independent cross-check: SPICE's own IAU-1976 / full IAU-1980 frames of date."""
    _spice_dynamic_frames()
    start = tdb_seconds("2025-05-01T00:00:00")
    # The paper's epochs (where dpsi happens to be only ~0.3 arcsec) and one with dpsi ~ 17 arcsec.
    for et in (start, start + 3.3 * 86400.0, start + 9.7 * 86400.0, tdb_seconds("2029-06-01T00:00:00")):
        tc = gps.tt_centuries(et)
        p = gps.precession_iau1976(tc)[0]
        n = gps.nutation_matrix(tc)[0]
        mod_to_j2000 = np.asarray(spice.pxform("LNSS_TEST_MOD", "J2000", et))
        tod_to_j2000 = np.asarray(spice.pxform("LNSS_TEST_TOD", "J2000", et))
        assert _angle_mas(p.T, mod_to_j2000) < 1.0
        # Truncated nutation: bounded by the sum of the skipped terms' amplitudes.
        bound = gps.NUTATION_SKIPPED_DPSI_MAS + gps.NUTATION_SKIPPED_DEPS_MAS
        assert _angle_mas(p.T @ n.T, tod_to_j2000) < bound
        # ... and with all of them left out the error would be the full nutation (~ 10 arcsec), far above it.
        assert _angle_mas(p.T, tod_to_j2000) > 20 * bound
        # TEME = true equator of date rotated about its pole by the equation of the equinoxes
        # EqE = dpsi cos(eps), which is -N[0, 1] of SPICE's mean-to-true nutation matrix.
        n_spice = np.asarray(spice.pxform("LNSS_TEST_MOD", "LNSS_TEST_TOD", et))
        eqe = -n_spice[0, 1]
        c, s = math.cos(eqe), math.sin(eqe)
        teme_to_tod = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])   # r_TOD = R3(-EqE) r_TEME
        assert _angle_mas(gps.teme_to_j2000(tc)[0], tod_to_j2000 @ teme_to_tod) < bound
    assert 2.0 * abs(eqe) * 206264806.2 > 20 * bound       # a sign error in EqE would be resolved


def test_sgp4_radius_at_tle_epoch_and_states_dataset(profile):
    records, _ = gps.gps_catalogue(profile)
    epochs = np.array([(r.epoch_utc - dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0 for r in records])
    jd = 2451545.0 + np.floor(epochs)
    r = np.stack([gps.propagate_teme([rec], jd[k:k + 1], (epochs - np.floor(epochs))[k:k + 1])[0, 0]
                  for k, rec in enumerate(records)])
    assert np.all(np.abs(np.linalg.norm(r, axis=-1) - 26560.0) < 500.0)
    t = tdb_seconds(profile["epoch"]["start_tdb"]) + np.array([0.0, 900.0])
    ds = gps.gps_states_mci(profile, t)
    assert ds["r_mci_km"].dims == ("gps", "time", "xyz") and 21 not in ds["prn"].values
    earth = spice.spkpos("EARTH", t.tolist(), "J2000", "NONE", "MOON")[0]
    assert np.allclose(ds["r_mci_km"].values - ds["r_eci_km"].values, np.asarray(earth)[None], atol=1e-9)
    assert np.allclose(np.linalg.norm(ds["r_eci_km"], axis=-1), np.linalg.norm(ds["r_teme_km"], axis=-1))
    assert gps.gps_states_mci(profile, t) is ds


# ------------------------------------------------------------------------------- geometry

def test_earth_occultation_behind_and_just_outside_limb():
    r_gps = np.array([26560.0, 0.0, 0.0])
    behind = np.array([-384400.0, 0.0, 0.0])          # the Earth lies exactly between
    theta = gps.off_boresight_deg(r_gps, behind)
    assert theta == pytest.approx(0.0, abs=1e-9)
    assert gps.earth_occultation(theta, r_gps, R_EARTH_KM, 0.5)
    limb = math.degrees(math.asin(R_EARTH_KM / 26560.0)) + 0.5   # eq. 21 threshold, ~14.4 deg
    for offset, blocked in ((+0.05, False), (-0.05, True)):
        ang = math.radians(limb + offset)
        target = r_gps + 400000.0 * np.array([-math.cos(ang), math.sin(ang), 0.0])
        th = gps.off_boresight_deg(r_gps, target)
        assert th == pytest.approx(limb + offset, abs=1e-9)
        assert bool(gps.earth_occultation(th, r_gps, R_EARTH_KM, 0.5)) is blocked
        assert not gps.ray_hits_ellipsoid(r_gps, target)           # passes > 6378 km from the centre


def test_ray_ellipsoid_flattening():
    """A ray at 6365 km from the centre misses the WGS-84 ellipsoid over the pole, hits it at the equator."""
    over_pole = gps.ray_hits_ellipsoid(np.array([-30000.0, 0.0, 6365.0]), np.array([30000.0, 0.0, 6365.0]))
    over_equator = gps.ray_hits_ellipsoid(np.array([-30000.0, 6365.0, 0.0]), np.array([30000.0, 6365.0, 0.0]))
    short = gps.ray_hits_ellipsoid(np.array([26560.0, 0.0, 0.0]), np.array([10000.0, 0.0, 0.0]))
    assert not over_pole and over_equator and not short


def test_line_of_sight_through_moon_is_blocked():
    r_lnss = np.array([0.0, 0.0, 5000.0])
    through = gps.lunar_occultation(r_lnss, np.array([0.0, 0.0, -384400.0]), R_MOON_KM)
    sideways = gps.lunar_occultation(r_lnss, np.array([384400.0, 0.0, 0.0]), R_MOON_KM)
    assert through and not sideways
    # alpha_moon = asin(1737.4 / 5000) = 20.3 deg: a direction 21 deg off the nadir clears the limb.
    off = math.radians(21.0)
    clear = gps.lunar_occultation(r_lnss, r_lnss + 4e5 * np.array([0.0, math.sin(off), -math.cos(off)]), R_MOON_KM)
    hit = gps.lunar_occultation(r_lnss, r_lnss + 4e5 * np.array([0.0, math.sin(off - 0.02), -math.cos(off - 0.02)]),
                                R_MOON_KM)
    assert not clear and hit


# ------------------------------------------------------------------------------ link budget

def test_cn0_hand_computed():
    """Table 1 link at 30 deg off boresight and 384 400 km, with the textbook FSL in km and MHz."""
    pattern = gps.load_gain_pattern(data_path("data/gps/gps_block_iir_l1_gain_0-90deg.csv"), "improved_panel_dbi")
    gain = float(pattern(30.0))
    assert gain == pytest.approx(-2.81)
    d_km, f_mhz, t_k = 384400.0, 1575.42, 190.0
    fsl = 20 * math.log10(d_km) + 20 * math.log10(f_mhz) + 32.4478
    expected = 15.0 - 5.0 + gain + 15.0 - fsl - (-228.5991 + 10 * math.log10(t_k))
    got = gps.cn0_dbhz(gain, d_km, p_tx_dbw=15.0, losses_db=5.0, g_rx_dbi=15.0, frequency_hz=f_mhz * 1e6,
                       noise_temperature_k=t_k)
    assert float(got) == pytest.approx(expected, abs=1e-3)
    with pytest.raises(ValueError, match="noise temperature"):
        gps.cn0_dbhz(gain, d_km, p_tx_dbw=15, losses_db=5, g_rx_dbi=15, frequency_hz=1.5e9, noise_temperature_k=0)


def test_gain_pattern_interpolation_and_errors():
    path = data_path("data/gps/gps_block_iir_l1_gain_0-90deg.csv")
    pattern = gps.load_gain_pattern(path, "legacy_iir_dbi")
    assert float(pattern(21.0)) == pytest.approx((0.68 + -8.16) / 2)
    assert np.isnan(pattern(95.0))
    lobes = pattern.with_sidelobes(23.0, -3.0)
    assert float(lobes(10.0)) == float(pattern(10.0)) and float(lobes(40.0)) == pytest.approx(float(pattern(40.0)) - 3)
    with pytest.raises(ValueError, match="unknown gain column 'nope'"):
        gps.load_gain_pattern(path, "nope")


# ----------------------------------------------------------------------------------- PDOP

def _symmetric_los(elev_deg: float) -> np.ndarray:
    e = math.radians(elev_deg)
    rows = [[0.0, 0.0, 1.0]] + [[math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)]
                                for a in np.radians([0.0, 120.0, 240.0])]
    return np.array(rows)


@pytest.mark.parametrize("elev_deg", [10.0, 30.0, 60.0])
def test_pdop_symmetric_geometry_closed_form(elev_deg):
    """Zenith + three at elevation E, 120 deg apart: PDOP^2 = 4/(3 cos^2 E) + 4/(3 (1 - sin E)^2) with clock."""
    c, s = math.cos(math.radians(elev_deg)), math.sin(math.radians(elev_deg))
    los = _symmetric_los(elev_deg)
    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    with_clock = gps.pdop_kernel(los @ rot.T, np.ones(4, bool))
    assert with_clock == pytest.approx(math.sqrt(4 / (3 * c * c) + 4 / (3 * (1 - s) ** 2)), rel=1e-10)
    without = gps.pdop_kernel(los, np.ones(4, bool), clock_column=False)
    assert without == pytest.approx(math.sqrt(4 / (3 * c * c) + 1 / (1 + 3 * s * s)), rel=1e-10)
    # The same against a direct (G^T G)^-1 with the clock column, and < 4 visible gives no PDOP.
    g = np.hstack([los, np.ones((4, 1))])
    assert with_clock == pytest.approx(math.sqrt(np.trace(np.linalg.inv(g.T @ g)[:3, :3])), rel=1e-10)
    assert np.isnan(gps.pdop_kernel(los, np.array([True, True, True, False])))


def test_invisible_rows_do_not_count():
    los = np.vstack([_symmetric_los(30.0), [[0.6, 0.0, 0.8]]])
    mask = np.array([True, True, True, True, False])
    assert gps.pdop_kernel(los, mask) == pytest.approx(gps.pdop_kernel(los[:4], np.ones(4, bool)), rel=1e-12)


def test_filtered_means():
    values = np.concatenate([np.arange(1.0, 101.0), [np.nan]])
    mean, kept = gps.filtered_mean(values, "percentile95")     # 95th percentile 95.05: 1..95 kept
    assert kept == 95 and mean == pytest.approx(48.0)
    mean, kept = gps.filtered_mean(values, "none")
    assert kept == 100 and mean == pytest.approx(50.5)
    spiky = np.array([1.0] * 20 + [100.0])                      # the spike is > 2 sigma away
    assert gps.filtered_mean(spiky, "sigma2") == (1.0, 20)
    with pytest.raises(ValueError, match="unknown PDOP filter"):
        gps.filtered_mean(values, "sigma9")


# ---------------------------------------------------------------------------- end to end

def test_gps_link_masks_consistent(profile):
    t = tdb_seconds(profile["epoch"]["start_tdb"]) + 900.0 * np.arange(8)
    states = gps.gps_states_mci(profile, t)
    # An LNSS satellite 8000 km from the Moon's centre, rotating about the Moon.
    ang = np.linspace(0.0, 2.0, t.size)
    r_lnss = 8000.0 * np.stack([np.cos(ang), np.sin(ang), 0.3 * np.ones_like(ang)], axis=-1)
    ds = gps.gps_link(profile, states, r_lnss[None])
    assert ds["visible"].dims == ("sat", "time", "gps") and ds.sizes["sat"] == 1
    vis = ds["visible"].values
    theta = ds["theta_off_deg"].values
    assert np.all(theta[vis] <= 70.0) and np.all(theta[vis] >= 14.3)
    assert np.all(ds["cn0_dbhz"].values[vis] >= 15.0)
    assert np.array_equal(ds["n_visible"].values, vis.sum(-1))
    assert np.array_equal(np.isfinite(ds["pdop"].values), ds["n_visible"].values >= 4)
    colder = gps.gps_link(profile, states, r_lnss[None], noise_temperature_k=100.0)
    assert np.all(colder["visible"].values >= vis)                 # a lower T only adds links
    summary = gps.gps_link_summary(ds)
    assert summary["gps_visible_mean"] == pytest.approx(vis.sum(-1).mean())
    with pytest.raises(ValueError, match="unknown GPS link setting"):
        gps.gps_link(profile, states, r_lnss[None], noise_temp=1.0)
    with pytest.raises(ValueError, match="shape"):
        gps.gps_link(profile, states, r_lnss[None, :3])


def test_pdop_along_axis_splits_the_trace():
    los = _symmetric_los(30.0)
    along, across = gps.pdop_along_axis(los, np.ones(4, bool), np.array([0.0, 0.0, 1.0]))
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    assert along == pytest.approx(math.sqrt(4 / (3 * (1 - s) ** 2)), rel=1e-10)
    assert across == pytest.approx(math.sqrt(4 / (3 * c * c)), rel=1e-10)
    assert np.isnan(gps.pdop_along_axis(los, np.array([1, 1, 1, 0], bool), np.array([0.0, 0.0, 1.0]))[0])


def test_link_budget_table_adds_up(profile):
    table = gps.link_budget_table(profile, [10.0, 30.0, 60.0], 384400.0, noise_temperature_k=250.0)
    total = table["eirp_dbw"] + table["g_rx_dbi"] - table["fsl_db"] - table["ktn_dbw_hz"]
    assert np.allclose(total, table["cn0_dbhz"])
    assert table.loc[30.0, "ktn_dbw_hz"] == pytest.approx(-228.5991 + 10 * math.log10(250.0), abs=1e-4)
    assert list(table["receivable"]) == list(table["cn0_dbhz"] >= 15.0)


# ------------------------------------------------------------------- analysis (notebook 03)

import pandas as pd  # noqa: E402
import xarray as xr  # noqa: E402


def test_off_boresight_limits_and_cn0_curves(profile):
    limits = gps.off_boresight_limits(profile)
    alpha = math.degrees(math.asin(profile["constants"]["r_earth_km"] / 26560.0))
    assert limits["earth_limb_deg"] == pytest.approx(alpha) and limits["limb_with_margin_deg"] == pytest.approx(alpha + 0.5)
    last = limits["last_receivable_deg"]
    edge = gps.link_budget_table(profile, [last, last + 0.1], 384400.0)["cn0_dbhz"].values
    assert edge[0] >= 15.0 > edge[1]                      # the C/N0 cut-off, inside the 70 deg mask
    assert limits["sidelobe_from_deg"] < last < limits["beam_mask_deg"]
    deaf = {**profile, "gps": {**profile["gps"], "cn0_threshold_dbhz": 100.0}}
    with pytest.raises(ValueError, match="reaches 100.0 dB-Hz"):
        gps.off_boresight_limits(deaf)
    curves = gps.cn0_curves(profile, [10.0, 40.0], 384400.0, {"cold": {"noise_temperature_k": 100.0},
                                                               "warm": {"noise_temperature_k": 400.0}})
    np.testing.assert_allclose(curves["cold"] - curves["warm"], 10.0 * math.log10(4.0))   # -10 log10(k T)
    assert curves.index.tolist() == [10.0, 40.0]


def test_earth_plane_projection_closed_form():
    earth = np.array([[384400.0, 0.0, 0.0]])
    lnss = np.array([[0.0, 0.0, 5000.0]])
    e_dir = earth[0] - lnss[0]
    e_dir /= np.linalg.norm(e_dir)
    offsets = np.array([[0.0, 3000.0, 0.0], [7000.0 * e_dir[0], 7000.0 * e_dir[1], 7000.0 * e_dir[2]]])
    x, y, e_hat = gps.earth_plane_projection(earth[:, None, :] + offsets[None], earth, lnss)
    np.testing.assert_allclose(e_hat[0], e_dir)
    assert math.hypot(x[0, 0], y[0, 0]) == pytest.approx(3000.0)      # perpendicular offset kept
    assert abs(x[0, 1]) < 1e-6 and abs(y[0, 1]) < 1e-6               # offset along the line of sight vanishes
    assert x[0, 0] == pytest.approx(-3000.0)                          # x along e_hat x z


def _synthetic_link():
    dims = ("time", "gps")
    moon = np.array([[True, False, False, False, False], [False, False, False, False, False]])
    earth = np.array([[True, True, False, False, False], [False, False, False, False, False]])
    ellipsoid = np.array([[False, False, True, False, False], [False, False, False, False, False]])
    outside = np.array([[False, False, False, True, False], [False, False, False, False, True]])
    strong = np.array([[True, True, True, False, True], [False, True, True, True, True]])
    visible = ~moon & ~earth & ~ellipsoid & ~outside & strong
    theta = np.array([[5.0, 10.0, 14.0, 75.0, 30.0], [40.0, 20.0, 25.0, 50.0, 80.0]])
    return xr.Dataset({"moon_blocked": (dims, moon), "earth_blocked": (dims, earth), "ellipsoid_blocked": (dims, ellipsoid),
                       "outside_beam": (dims, outside), "above_threshold": (dims, strong), "visible": (dims, visible),
                       "theta_off_deg": (dims, theta)},
                      coords={"time": [0.0, 900.0], "gps": np.arange(5), "prn": ("gps", [7, 3, 12, 1, 5])})


def test_link_status_counts_and_shares():
    link = _synthetic_link()
    status = gps.link_status(link)
    assert status[0].tolist() == ["Moon blocks", "Earth (+margin) blocks", "Earth (+margin) blocks", "outside beam", "visible"]
    assert status[1].tolist() == ["C/N0 < 15 dB-Hz", "visible", "visible", "visible", "outside beam"]
    assert np.array_equal(status == "visible", link["visible"].values)
    counts = gps.link_test_counts(link)
    assert counts["all (gps, epoch) pairs"] == 10 and counts["visible"] == 4 and counts["Moon blocks"] == 1
    assert counts["WGS-84 ray test blocks (beyond eq. 21)"] == 1 and counts["C/N0 below threshold (geometry ok)"] == 1
    share = gps.visible_share_by_prn(link)
    assert share.index.tolist() == [1, 3, 5, 7, 12] and share.tolist() == [0.5, 0.5, 0.5, 0.0, 0.5]
    assert gps.main_lobe_share(link, 23.0) == pytest.approx(0.25)   # visible at 30, 20, 25, 50 deg: one below 23


def test_comparison_catalogue_and_per_satellite_tables(profile):
    table = gps.paper_comparison_table({"gps_visible_mean": 7.0, "gps_pdop_mean": 1000.0})
    np.testing.assert_allclose(table["ratio"], [7.0 / 7.74, 1000.0 / 6238.0])
    _, catalogue = gps.gps_catalogue(profile)
    days = gps.catalogue_table(catalogue, "2025-05-01T00:00:00")
    first = catalogue.iloc[0]["tle_epoch_utc"]
    assert days.iloc[0]["days_back_from_tle"] == pytest.approx((first - dt.datetime(2025, 5, 1)).total_seconds() / 86400.0)
    assert isinstance(days.iloc[0]["launch_date"], str)
    t = tdb_seconds(profile["epoch"]["start_tdb"]) + 900.0 * np.arange(6)
    states = gps.gps_states_mci(profile, t)
    ang = np.linspace(0.0, 1.0, t.size)
    r_lnss = np.stack([8000.0 * np.stack([np.cos(ang + p), np.sin(ang + p), 0.3 * np.ones_like(ang)], axis=-1)
                       for p in (0.0, 2.0, 4.0)])
    per_sat = gps.per_satellite_summary(gps.gps_link(profile, states, r_lnss, sats="all"))
    assert per_sat.index.name == "satellite" and not isinstance(per_sat.index, pd.RangeIndex)  # tables keep the index
    one = gps.gps_link(profile, states, r_lnss, sats=[2])
    assert per_sat.loc[2, "gps_visible_mean"] == pytest.approx(one["n_visible"].values.mean())


@pytest.fixture(scope="module")
def elfo_link(profile):
    from lnss_lib.constellation import standalone_elfo
    from lnss_lib.propagator import propagate_elements

    elements = standalone_elfo(profile)[:1]
    prop = propagate_elements(profile, elements)
    return elements, prop, gps.gps_states_mci(profile, prop["time"].values)


def test_pdop_split_adds_up_and_clock_column_only_adds_error(profile, elfo_link):
    _, prop, states = elfo_link
    split = gps.pdop_split(profile, states, prop)
    both = np.isfinite(split["pdop"]) & np.isfinite(split["along"])
    assert both.sum() > 10
    np.testing.assert_allclose(split["along"][both] ** 2 + split["across"][both] ** 2, split["pdop"][both] ** 2, rtol=1e-6)
    with_clock = np.isfinite(split["pdop"])
    assert np.all(split["pdop_no_clock"][with_clock] <= split["pdop"][with_clock] * (1 + 1e-9))
    table = gps.pdop_decomposition(profile, states, prop)
    assert table.loc["PDOP (eq. 5-7, clock column)", "median"] == pytest.approx(np.nanmedian(split["pdop"]))


def test_sensitivity_variants_and_table(profile, elfo_link):
    variants = gps.sensitivity_variants(profile)
    assert variants["default"] == {} and f"gain {profile['gps']['gain_column']}" not in variants
    for label, over in variants.items():
        assert len(over) <= 1 and set(over) <= set(profile["gps"]), label     # one setting at a time
    elements, prop, states = elfo_link
    sens = gps.sensitivity_table(profile, states, prop, elements, phase_shifts_days=(7.0,))
    assert list(sens.index[:len(variants)]) == list(variants)
    assert sens.index[-1] == "GPS phase: SGP4 at t +7 d"
    default = gps.gps_link_summary(gps.gps_link(profile, states, prop))
    assert sens.loc["default", "gps_pdop_mean"] == pytest.approx(default["gps_pdop_mean"])
    # A colder receiver or stronger sidelobes only add links; main lobe only removes them.
    visible = sens["gps_visible_mean"]
    assert visible["T = 100 K"] >= visible["default"] >= visible["T = 400 K"]
    assert sens.loc["sidelobes +3 dB", "gps_visible_mean"] >= sens.loc["default", "gps_visible_mean"]
    assert sens.loc["main lobe only", "gps_visible_mean"] <= sens.loc["default", "gps_visible_mean"]
    np.testing.assert_allclose(sens["pdop_ratio_to_paper"], sens["gps_pdop_mean"] / 6238.0)
    lines = gps.sensitivity_findings(sens, gps.pdop_decomposition(profile, states, prop), 0.25)
    assert f"**{default['gps_visible_mean']:.2f}**" in lines[0] and "25.0%" in lines[1]


def test_pdop_at_visible_count_interpolates_in_log():
    vis = np.array([4.0, 6.0, 9.0, 12.0])
    sens = pd.DataFrame({"gps_visible_mean": vis, "gps_pdop_mean": np.exp(10.0 - 0.5 * vis)},
                        index=["T = 400 K", "T = 300 K", "default", "gain other"])
    # log PDOP is linear in the count here, so the interpolation is exact; "gain other" is not in the sweep.
    assert gps.pdop_at_visible_count(sens, 7.74) == pytest.approx(math.exp(10.0 - 0.5 * 7.74))
    assert gps.pdop_at_visible_count(sens, 11.0) == pytest.approx(math.exp(10.0 - 0.5 * 9.0))   # clamped at the sweep's end
