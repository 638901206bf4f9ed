"""Keplerian conversion (lnss_lib.elements): closed orbits round-trip; orbits that are no longer closed
give a NaN mean anomaly without a floating-point warning (issue 24: quiet notebook records)."""

import warnings

import numpy as np

from lnss_lib.elements import elements_to_state, state_to_elements

GM_MOON_KM3_S2 = 4902.800066


def test_closed_orbits_round_trip():
    elements = np.array([[6143.0, 0.6, 0.9, 0.3, 1.57, 2.0], [4000.0, 0.01, 1.5, 4.0, 0.2, 5.5]])
    back = state_to_elements(elements_to_state(elements, GM_MOON_KM3_S2), GM_MOON_KM3_S2)
    assert np.allclose(back, elements, rtol=0, atol=1e-8 * np.array([1e4, 1, 1, 1, 1, 1]))


def test_escaping_state_has_no_mean_anomaly_and_no_warning():
    r_km = 2000.0
    v_escape_kms = np.sqrt(2.0 * GM_MOON_KM3_S2 / r_km)
    states = np.array([[r_km, 0.0, 0.0, 0.0, 1.2 * v_escape_kms, 0.1],      # hyperbolic: e > 1
                       [r_km, 0.0, 0.0, 0.0, 0.8 * v_escape_kms, 0.1]])     # closed
    with warnings.catch_warnings():
        warnings.simplefilter("error")                                     # a RuntimeWarning fails the test
        el = state_to_elements(states, GM_MOON_KM3_S2)
    assert el[0, 1] > 1.0 and el[0, 0] < 0.0 and np.isnan(el[0, 5])
    assert el[1, 1] < 1.0 and el[1, 0] > 0.0 and 0.0 <= el[1, 5] < 2 * np.pi
    assert np.all(np.isfinite(el[:, :5]))
