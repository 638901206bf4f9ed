"""Keplerian conversion (lnss_lib.elements): closed orbits round-trip; orbits that are no longer closed
give a NaN mean anomaly without a floating-point warning (a notebook's records stay quiet); the one copy of
the anomaly conversions, vis-viva and the eccentricity vector against analytic cases."""

import warnings

import numpy as np
import pytest

from lnss_lib.elements import (
    eccentric_anomaly_from_true,
    eccentricity_vector,
    elements_to_state,
    mean_anomaly_from_true,
    state_to_elements,
    true_anomaly_from_eccentric,
    true_anomaly_from_mean,
    vis_viva_sma_km,
)

GM_MOON_KM3_S2 = 4902.800066


def test_closed_orbits_round_trip():
    elements = np.array([[6143.0, 0.6, 0.9, 0.3, 1.57, 2.0], [4000.0, 0.01, 1.5, 4.0, 0.2, 5.5]])
    back = state_to_elements(elements_to_state(elements, GM_MOON_KM3_S2), GM_MOON_KM3_S2)
    assert np.allclose(back, elements, rtol=0, atol=1e-8 * np.array([1e4, 1, 1, 1, 1, 1]))


def test_escaping_state_has_no_mean_anomaly_and_no_warning():
    r_km = 2000.0
    v_escape_kms = np.sqrt(2.0 * GM_MOON_KM3_S2 / r_km)
    states = np.array(
        [
            [r_km, 0.0, 0.0, 0.0, 1.2 * v_escape_kms, 0.1],  # hyperbolic: e > 1
            [r_km, 0.0, 0.0, 0.0, 0.8 * v_escape_kms, 0.1],
        ]
    )  # closed
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning fails the test
        el = state_to_elements(states, GM_MOON_KM3_S2)
    assert el[0, 1] > 1.0 and el[0, 0] < 0.0 and np.isnan(el[0, 5])
    assert el[1, 1] < 1.0 and el[1, 0] > 0.0 and 0.0 <= el[1, 5] < 2 * np.pi
    assert np.all(np.isfinite(el[:, :5]))


EPS = np.finfo(float).eps


def test_anomaly_conversions_known_value_and_round_trip():
    # e = 0.6, nu = 90 deg: tan(E / 2) = sqrt(0.4 / 1.6) tan(45 deg) = 1/2, M = E - e sin E
    e_anom = 2.0 * np.arctan(0.5)
    assert abs(eccentric_anomaly_from_true(np.pi / 2, 0.6) - e_anom) <= 4 * EPS
    assert abs(mean_anomaly_from_true(np.pi / 2, 0.6) - (e_anom - 0.6 * np.sin(e_anom))) <= 4 * EPS
    assert abs(true_anomaly_from_eccentric(e_anom, 0.6) - np.pi / 2) <= 4 * EPS
    # circular: all three anomalies agree; elliptic: nu -> M -> nu round-trips to Kepler's tolerance (1e-14)
    nu = np.linspace(-np.pi + 1e-3, np.pi - 1e-3, 721)
    assert np.max(np.abs(mean_anomaly_from_true(nu, 0.0) - nu)) <= 4 * EPS * np.pi
    for ecc in (1e-6, 0.3, 0.9):
        back = true_anomaly_from_mean(mean_anomaly_from_true(nu, ecc), ecc)
        assert np.max(np.abs(np.angle(np.exp(1j * (back - nu))))) < 1e-11


def test_vis_viva_and_eccentricity_vector_of_known_orbits():
    gm = GM_MOON_KM3_S2
    # circular orbit: v^2 = GM / r gives a = r to rounding
    r = 3000.0
    assert abs(vis_viva_sma_km(r, gm / r, gm) - r) <= 4 * EPS * r
    # at perilune (M = 0) the eccentricity vector is e times the unit position vector
    el = np.array([[6143.0, 0.6, 0.9, 0.3, 1.57, 0.0], [4000.0, 0.01, 1.5, 4.0, 0.2, 0.0]])
    s = elements_to_state(el, gm)
    r_vec, v_vec = s[:, :3], s[:, 3:]
    r_km = np.linalg.norm(r_vec, axis=-1)
    e_vec = eccentricity_vector(r_vec, v_vec, gm)
    np.testing.assert_allclose(e_vec, el[:, 1:2] * r_vec / r_km[:, None], rtol=0, atol=1e-13)
    assert np.array_equal(
        e_vec, eccentricity_vector(r_vec, v_vec, gm, np.cross(r_vec, v_vec), r_km)
    )
    np.testing.assert_allclose(
        vis_viva_sma_km(r_km, np.sum(v_vec * v_vec, axis=-1), gm), el[:, 0], rtol=1e-13
    )


def test_every_element_path_shares_the_hill_sphere_bound():
    """validate_elements (Walker designs, the explorer, explicit constellations, element states) refuses a beyond
    the Moon's Hill sphere as the flags and files do: no bound lunar orbit."""
    from lnss_lib.constants import MOON_HILL_RADIUS_KM
    from lnss_lib.elements import validate_elements
    from lnss_lib.errors import InvalidOrbitError

    validate_elements(MOON_HILL_RADIUS_KM, 0.5, 1737.4)
    with pytest.raises(InvalidOrbitError, match="beyond the Moon's Hill sphere"):
        validate_elements([6143.0, 80000.0], [0.6, 0.1], 1737.4)
