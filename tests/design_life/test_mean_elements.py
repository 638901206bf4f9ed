"""The closed loop's compiled window means and osculating elements (mean_elements.window_means,
osculating_elements) against the numpy mean elements and lnss_lib.elements.state_to_elements.

Both average the same per-sample quantities over one orbit of 65 samples; they differ only in the order of the
sums (numpy's einsum and BLAS rotation against one sequential loop). A sum of n terms of size S is off by at most
about n eps S, so a, e and the normal (each a mean of O(1) terms) agree to ~1e-14 relative; the angles inherit the
conditioning of their definition: the node divides by sin i, the perilune argument by e sin i, u by sin i. The
bound below, 1e-12 on those scaled differences, is ~70 times n eps: a wrong term (a missing weight, a sign) is
off by far more.
"""

import numpy as np
import pytest

from lnss_lib.design_life.mean_elements import (
    mean_elements,
    osculating_elements,
    to_element_frame,
    window_means,
    wrap_pi,
)
from lnss_lib.elements import kepler_states, state_to_elements

GM = 4902.800066
ROUNDING_BOUND = 1e-12
"""Scaled difference allowed between the two paths (see the module docstring)."""


def _scaled_differences(new, ref, sin_i, ecc, last_scale):
    """Differences of [a, e, i, raan, aop, last angle] scaled by their conditioning: a relative, the node by
    ``sin_i``, the perilune argument by ``ecc`` x ``sin_i``, the last angle (u or M) by ``last_scale``."""
    return [
        (new[0] - ref[0]) / ref[0],
        new[1] - ref[1],
        new[2] - ref[2],
        wrap_pi(new[3] - ref[3]) * sin_i,
        wrap_pi(new[4] - ref[4]) * ecc * sin_i,
        wrap_pi(new[5] - ref[5]) * last_scale,
    ]


def _window(rng, elements):
    """One orbit of 65 Keplerian states plus metre-level noise, in a random J2000 orientation; the rotation."""
    period = 2.0 * np.pi * np.sqrt(elements[0] ** 3 / GM)
    states = kepler_states(np.asarray(elements)[None], np.linspace(0.0, period, 65), GM)[0]
    states += rng.normal(size=states.shape) * np.r_[1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7]
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return np.concatenate([states[:, :3] @ rot.T, states[:, 3:] @ rot.T], axis=1), rot


@pytest.mark.parametrize("seed", range(40))
def test_window_means_equal_the_numpy_mean_elements_to_rounding(seed):
    rng = np.random.default_rng(seed)
    elements = [
        rng.uniform(2000.0, 30000.0),
        rng.choice([rng.uniform(0.0, 0.9), 1e-6]),
        rng.choice([rng.uniform(0.01, np.pi - 0.01), 1e-6]),
        *rng.uniform(0.0, 2.0 * np.pi, 3),
    ]
    states_mci, rot = _window(rng, elements)
    window = to_element_frame(states_mci, rot)
    ref = mean_elements(window, GM)
    osc = state_to_elements(window, GM)
    rp_ref = np.min(osc[:, 0] * (1.0 - osc[:, 1]))
    mel, rp_min = window_means(states_mci, rot, GM)
    scaled = [
        *_scaled_differences(mel, ref, np.sin(ref[2]), ref[1], np.sin(ref[2])),
        (rp_min - rp_ref) / rp_ref,
    ]
    assert np.max(np.abs(scaled)) < ROUNDING_BOUND, scaled


def test_a_window_with_a_non_finite_state_has_no_means():
    rng = np.random.default_rng(0)
    states_mci, rot = _window(rng, [6000.0, 0.3, 1.0, 0.2, 0.3, 0.4])
    states_mci[10, 4] = np.nan
    mel, rp_min = window_means(states_mci, rot, GM)
    assert np.all(np.isnan(mel)) and np.isnan(rp_min)
    assert np.all(np.isnan(mean_elements(to_element_frame(states_mci, rot), GM)))


def test_an_unbound_window_gives_no_mean_argument_of_latitude():
    rng = np.random.default_rng(1)
    states_mci, rot = _window(rng, [6000.0, 0.3, 1.0, 0.2, 0.3, 0.4])
    states_mci[20, 3:] *= 3.0  # one sample above escape speed
    mel, _ = window_means(states_mci, rot, GM)
    ref = mean_elements(to_element_frame(states_mci, rot), GM)
    assert np.isnan(mel[5]) and np.isnan(ref[5])


@pytest.mark.parametrize("seed", range(40))
def test_osculating_elements_equal_state_to_elements_to_rounding(seed):
    """Each state's elements from one evaluation of the same formulas: a, e and i to ~eps, the angles scaled by
    their conditioning (node / sin i, perilune argument / (e sin i), M / e), within the module's bound; the
    equatorial and circular conventions (RAAN 0, AOP 0) and the open orbit's NaN M as numpy gives them."""
    rng = np.random.default_rng(100 + seed)
    elements = [
        rng.uniform(2000.0, 30000.0),
        rng.choice([rng.uniform(0.0, 0.9), 0.0, 1.5]),
        rng.choice([rng.uniform(0.01, np.pi - 0.01), 0.0]),
        *rng.uniform(0.0, 2.0 * np.pi, 3),
    ]
    if elements[1] > 1.0:  # an open orbit: r and v of the ellipse with the speed raised past escape
        state = kepler_states(np.r_[elements[0], 0.3, elements[2:]][None], [0.0], GM)[0, 0]
        state[3:] *= 2.0
    else:
        state = kepler_states(np.asarray(elements)[None], [0.0], GM)[0, 0]
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    state_mci = np.concatenate([rot @ state[:3], rot @ state[3:]])
    ref = state_to_elements(to_element_frame(state_mci, rot), GM)
    osc = osculating_elements(state_mci, rot, GM)
    assert np.array_equal(np.isnan(osc), np.isnan(ref))
    sin_i = (
        max(np.sin(ref[2]), 1e-300) if ref[2] > 1e-6 else 1.0
    )  # equatorial: RAAN 0 by convention
    ecc = ref[1] if ref[1] > 1e-6 else 1.0  # circular: AOP 0 by convention
    scaled = np.nan_to_num(_scaled_differences(osc, ref, sin_i, ecc, ecc))
    assert np.max(np.abs(scaled)) < ROUNDING_BOUND, scaled
