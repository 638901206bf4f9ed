"""The user range error budget and the weighted position error (lnss_lib/navigation_error.py, the weighted pass of
lnss_lib/dop.py): equal ranging errors give DOP x sigma, an older ephemeris weighs less and the error rises, a
satellite no station sees is never uploaded and ages by the profile's law, the requirement's availability spans
0-100 %, and the settings are checked."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lnss_lib import dop, navigation_error
from lnss_lib.constants import SECONDS_PER_HOUR
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings
from lnss_lib.surface_grid import surface_grid

R_MOON_KM = 1737.4


@pytest.fixture(scope="module")
def nav():
    return load_settings("ci").navigation_error


@pytest.fixture(scope="module")
def geometry():
    """12 circular orbits of random planes over 97 epochs (15 min) and the paper's grid: (r_mf_km, grid)."""
    rng = np.random.default_rng(7)
    nsat, t = 12, np.arange(97) * 900.0
    a, inc, raan, m0 = (
        rng.uniform(5000, 12000, nsat),
        rng.uniform(0.5, 1.6, nsat),
        rng.uniform(0, 2 * np.pi, nsat),
        rng.uniform(0, 2 * np.pi, nsat),
    )
    u = m0[:, None] + np.sqrt(4902.8 / a**3)[:, None] * t
    x, y = a[:, None] * np.cos(u), a[:, None] * np.sin(u)
    co, so, ci, si = (
        np.cos(raan)[:, None],
        np.sin(raan)[:, None],
        np.cos(inc)[:, None],
        np.sin(inc)[:, None],
    )
    r = np.stack([x * co - y * ci * so, x * so + y * ci * co, y * si], axis=-1)
    return r, surface_grid()


def _errors(r, grid, var_m2, multipath_m=0.0):
    return dop.dop_and_error_arrays(r, grid.r_mf_km, grid.up, 5.0, "enu", var_m2, multipath_m)


def test_equal_uere_gives_dop_times_sigma(geometry):
    r, grid = geometry
    sigma_m = 3.86
    n_visible, pdop, hdop, sigma_h, sigma_v = _errors(r, grid, np.full(r.shape[:2], sigma_m**2))
    fix = np.isfinite(hdop)
    assert fix.mean() > 0.5 and np.array_equal(np.isnan(sigma_h), np.isnan(hdop))
    conditioned = fix & (
        pdop < 1e3
    )  # beyond, the relative rounding of S^-1 grows with its condition number
    np.testing.assert_allclose(sigma_h[conditioned], sigma_m * hdop[conditioned], rtol=1e-10)
    np.testing.assert_allclose(
        np.hypot(sigma_h, sigma_v)[conditioned], sigma_m * pdop[conditioned], rtol=1e-10
    )
    same = dop.dop_arrays(r, grid.r_mf_km, grid.up, 5.0, "enu")  # the DOP outputs are the same bits
    for a, b in zip(same, (n_visible, pdop, hdop)):
        np.testing.assert_array_equal(a, b)


def test_an_older_ephemeris_counts_less_and_the_error_rises(geometry, nav):
    r, grid = geometry
    age = np.zeros(r.shape[:2])
    fresh = _errors(r, grid, navigation_error.uere_variance_m2(nav, age))
    age[0] = 10.0 * SECONDS_PER_HOUR
    old = _errors(r, grid, navigation_error.uere_variance_m2(nav, age))
    fix = np.isfinite(fresh[3]) & np.isfinite(old[3])
    # a larger variance of one range can only widen the weighted least-squares covariance
    assert np.all(old[3][fix] >= fresh[3][fix] * (1 - 1e-12)) and np.all(
        old[4][fix] >= fresh[4][fix] * (1 - 1e-12)
    )
    assert np.mean(old[3][fix] > fresh[3][fix] * (1 + 1e-6)) > 0.2
    # a satellite whose ephemeris is infinitely old is a satellite removed
    age[0] = 1e9 * SECONDS_PER_HOUR
    gone = _errors(r, grid, navigation_error.uere_variance_m2(nav, age))
    without = _errors(r[1:], grid, navigation_error.uere_variance_m2(nav, age[1:]))
    enough = np.isfinite(without[3]) & (without[1] < 1e3)
    np.testing.assert_allclose(gone[3][enough], without[3][enough], rtol=1e-6)


def test_sise_follows_the_profile_law(nav):
    ref_s = nav.sise_growth_age_h * SECONDS_PER_HOUR
    ages = np.array([0.0, 0.5 * ref_s, ref_s])
    quadratic = navigation_error.sise_m(dataclasses.replace(nav, sise_law="quadratic"), ages)
    linear = navigation_error.sise_m(dataclasses.replace(nav, sise_law="linear"), ages)
    constant = navigation_error.sise_m(dataclasses.replace(nav, sise_law="constant"), ages)
    s0, g = nav.sise_at_upload_m, nav.sise_growth_m
    np.testing.assert_allclose(quadratic, [s0, s0 + g / 4, s0 + g], rtol=1e-15)
    np.testing.assert_allclose(linear, [s0, s0 + g / 2, s0 + g], rtol=1e-15)
    np.testing.assert_allclose(constant, [s0, s0, s0], rtol=1e-15)
    with pytest.raises(ValueError, match="ages must be"):
        navigation_error.sise_m(nav, [-1.0])


def test_a_satellite_no_station_sees_is_never_uploaded_and_ages(nav):
    """Earth on +x at the lunar distance, one station facing the Moon: a satellite on the far side is hidden by
    the Moon, one on the near side is uploaded at every epoch."""
    times = np.arange(5) * 3600.0
    earth = np.array([384400.0, 0.0, 0.0])
    station_km = np.broadcast_to(earth - np.array([6378.0, 0.0, 0.0]), (1, times.size, 3))
    up = np.broadcast_to(np.array([-1.0, 0.0, 0.0]), (1, times.size, 3))
    r = np.zeros((2, times.size, 3))
    r[0, :, 0] = 3000.0  # between the Moon and the Earth
    r[1, :, 0] = -3000.0  # behind the Moon
    contact = navigation_error.upload_contact(r, station_km, up, nav.station_mask_deg, R_MOON_KM)
    assert contact[0].all() and not contact[1].any()
    age, never = navigation_error.ephemeris_age_s(contact, times)
    assert list(never) == [False, True]
    np.testing.assert_array_equal(age[0], 0.0)
    np.testing.assert_array_equal(age[1], times - times[0])
    sise = navigation_error.sise_m(nav, age[1])
    assert np.all(np.diff(sise) > 0.0)
    contact[0, 2:] = False  # the last upload at the second epoch
    age, _ = navigation_error.ephemeris_age_s(contact, times)
    np.testing.assert_array_equal(age[0], [0.0, 0.0, 3600.0, 7200.0, 10800.0])


def test_requirement_availability_spans_0_to_100(geometry, nav):
    r, grid = geometry
    age = np.zeros(r.shape[:2])
    _, _, _, sigma_h, sigma_v = _errors(r, grid, navigation_error.uere_variance_m2(nav, age), 0.1)
    weights = grid.weight.reshape(-1)
    never = np.zeros(r.shape[0], dtype=bool)
    fix = np.isfinite(sigma_h)
    huge = dataclasses.replace(nav, requirement_horizontal_95_m=1e30)
    metrics = navigation_error.error_metrics(huge, sigma_h, sigma_v, weights, age, never)
    assert metrics["position_error_avail_pct"] == pytest.approx(100.0 * fix.mean(), rel=1e-12)
    floor = dataclasses.replace(
        nav, requirement_horizontal_95_m=0.5 * np.nanmin(sigma_h)
    )  # below any fix
    assert (
        navigation_error.error_metrics(floor, sigma_h, sigma_v, weights, age, never)[
            "position_error_avail_pct"
        ]
        == 0.0
    )
    vertical = dataclasses.replace(huge, requirement_vertical_95_m=0.5 * np.nanmin(sigma_v))
    assert (
        navigation_error.error_metrics(vertical, sigma_h, sigma_v, weights, age, never)[
            "position_error_avail_pct"
        ]
        == 0.0
    )
    expected = np.percentile(
        np.where(fix, 2.0 * sigma_h, np.inf), 95.0, method="higher"
    )  # no fix: infinite
    value = metrics["horizontal_error_95_m"]
    assert value == expected if np.isfinite(expected) else np.isnan(value)
    assert metrics["ephemeris_age_max_h"] == 0.0 and metrics["satellites_never_uploaded"] == 0


@pytest.mark.parametrize(
    "override, words",
    [
        ({"navigation_error": {"sise_law": "cubic"}}, "allowed: 'constant', 'linear', 'quadratic'"),
        ({"navigation_error": {"station_lon_deg": [0.0]}}, "one longitude per latitude"),
        (
            {"navigation_error": {"sise_at_upload_m": 0.0, "receiver_noise_m": 0.0}},
            "positive range error floor",
        ),
        ({"navigation_error": {"station_mask_deg": 90.0}}, "out of range"),
        (
            {"navigation_error": {"station_lat_deg": [], "station_lon_deg": []}},
            "at least one entry",
        ),
    ],
)
def test_bad_settings_are_refused(override, words):
    with pytest.raises(ConfigError, match=words):
        load_settings("ci", overrides=override)


def test_the_evaluator_adds_the_metres_without_changing_eq45():
    """The campaign's path and the notebooks' give the same metre metrics; asking for them leaves every eq. 45
    metric the same bits."""
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.evaluator import analyse_constellation, context_for, evaluate_constellation
    from lnss_lib.keys import METRIC_KEYS, NAVIGATION_ERROR_KEYS

    context = context_for(
        load_settings("ci", overrides={"evaluator": {"extra_metrics": list(NAVIGATION_ERROR_KEYS)}})
    )
    elements = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 8).elements_deg()
    fast = evaluate_constellation(context, elements)
    full = analyse_constellation(context, elements)["metrics"]
    plain = evaluate_constellation(context_for(load_settings("ci")), elements)
    for key in NAVIGATION_ERROR_KEYS:
        assert fast[key] == pytest.approx(full[key], rel=1e-9), key
    assert all(fast[key] == plain[key] for key in METRIC_KEYS)
    assert not set(NAVIGATION_ERROR_KEYS) & set(plain)
    assert 0.0 < fast["horizontal_error_95_m"] < fast["vertical_error_95_m"]


def test_maps_and_time_series_are_the_percentiles_of_the_samples(geometry, nav):
    r, grid = geometry
    _, _, _, sigma_h, sigma_v = _errors(
        r, grid, navigation_error.uere_variance_m2(nav, np.zeros(r.shape[:2])), 0.1
    )
    errors = navigation_error.PositionErrors(
        sigma_h,
        sigma_v,
        np.zeros(r.shape[:2]),
        np.ones(r.shape[:2], bool),
        np.zeros(r.shape[0], bool),
        {},
    )
    ds = navigation_error.error_percentiles(errors, grid, np.arange(r.shape[1]) * 900.0)
    h95 = np.where(np.isnan(sigma_h), np.inf, 2.0 * sigma_h)
    point = 7
    expected = np.percentile(h95[:, point], 95.0, method="higher")
    got = ds.horizontal_95_map_m.values.reshape(-1)[point]
    assert got == expected if np.isfinite(expected) else np.isnan(got)
    assert (
        ds.horizontal_95_series_m.sizes["time"] == r.shape[1]
        and ds.vertical_95_map_m.shape == grid.shape
    )
    fixed = np.isfinite(ds.horizontal_95_series_m.values)  # epochs whose 95th percentile has a fix
    assert fixed.any() and np.all(
        ds.horizontal_95_series_m.values[fixed] >= 2.0 * np.nanmin(sigma_h[fixed], axis=1)
    )
