"""Gauss variational equations and their inverses (lnss_lib.gve).

Independent references: states integrated here with scipy (two-body + constant RTN thrust), the
forward equations against those integrations, and exact inversion of the forward equations.
"""

import numpy as np
import pytest
from orbit_cases import GM, integrate, random_elements, state_from_nu

from lnss_lib import frames, gve


@pytest.mark.parametrize(
    "el",
    [
        [6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 1.0],
        [3000.0, 0.2, np.radians(100.0), 4.0, 2.0, 4.0],
        [8000.0, 0.4, np.radians(20.0), 1.0, 5.0, 2.5],
    ],
)
def test_forward_gves_match_integrated_constant_rtn_thrust(el):
    """Element rates of two-body states integrated with a constant RTN thrust equal eq. 25-29."""
    acc_rtn = np.array([3e-5, -2e-5, 4e-5])
    state0 = state_from_nu(np.array(el))
    h = 5.0

    def thrust(y):
        return frames.from_rtn(acc_rtn, y)

    before = integrate(state0, np.array([0.0, -h]), thrust)[-1]
    after = integrate(state0, np.array([0.0, h]), thrust)[-1]
    elements = gve.osculating_elements(np.stack([before, state0, after]), GM)
    fd = (elements[2, :5] - elements[0, :5]) / (2 * h)
    expected = gve.gve_rates(elements[1], acc_rtn, GM)
    np.testing.assert_allclose(fd, expected, rtol=2e-4, atol=1e-12 * np.abs(expected).max())


def test_lsq_inverts_forward_gves_exactly():
    rng = np.random.default_rng(7)
    el = random_elements(rng, 500)
    acc = rng.normal(size=(500, 3)) * 1e-7
    natural = gve.natural_rates_from_elements(el, gve.gve_rates(el, acc, GM))
    np.testing.assert_allclose(
        np.einsum("...ij,...j->...i", gve.natural_gve_matrix(el, GM), acc),
        natural,
        rtol=1e-12,
        atol=1e-25,
    )
    solution, residual = gve.lsq_thrust(el, natural, GM)
    np.testing.assert_allclose(solution, acc, rtol=0, atol=1e-12 * 1e-7)
    assert np.all(residual < 1e-18)


def test_natural_rates_from_vectors_match_element_rates():
    """Central differences of (a, e vector, orbit normal) equal those of the elements where both are regular."""
    el0 = np.array([5000.0, 0.3, 0.9, 1.0, 2.0, 0.5])
    t = np.linspace(0.0, 3000.0, 31)
    acc = np.array([2e-6, -1e-6, 3e-6])
    states = integrate(state_from_nu(el0), t, lambda y: frames.from_rtn(acc, y))
    elements = gve.osculating_elements(states, GM)
    from_elements = gve.natural_rates_from_elements(elements, gve.element_rates(t, elements))
    from_vectors = gve.natural_rates_from_states(t, states, GM)
    scale = np.abs(from_elements).max(axis=0)
    np.testing.assert_allclose(
        from_vectors[1:-1], from_elements[1:-1], rtol=0, atol=1e-3 * scale.max()
    )
    exact = gve.natural_rates_from_elements(elements, gve.gve_rates(elements, acc, GM))
    np.testing.assert_allclose(
        from_vectors[1:-1], exact[1:-1], rtol=0, atol=2e-3 * np.abs(exact).max()
    )


def test_corrected_paper_equations_invert_forward_gves():
    """Eq. 30-35 corrected: exact inverse when eq. 30's assumption holds (T_R = 0), and each
    single-equation estimate exact given the true T_T, away from singular points."""
    rng = np.random.default_rng(11)
    el = random_elements(rng, 4000)
    theta = el[:, 4] + el[:, 5]
    regular = (
        np.min(np.abs([np.sin(el[:, 5]), np.cos(el[:, 5]), np.sin(theta), np.cos(theta)]), axis=0)
        > 0.1
    )
    el = el[regular]
    acc = rng.normal(size=(len(el), 3)) * 1e-7
    no_radial = acc * np.array([0.0, 1.0, 1.0])
    est = gve.paper_thrust(el, gve.gve_rates(el, no_radial, GM), GM)
    for key, col in (("T_R", 0), ("T_T", 1), ("T_N", 2)):
        np.testing.assert_allclose(est[key], no_radial[:, col], atol=1e-9 * 1e-7)
    est = gve.paper_thrust(el, gve.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1])
    for key, col in (("T_i", 2), ("T_raan", 2), ("T_N", 2), ("T_e", 0), ("T_aop", 0), ("T_R", 0)):
        np.testing.assert_allclose(est[key], acc[:, col], atol=1e-8 * 1e-7, err_msg=key)
    literal = gve.paper_thrust(
        el, gve.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1], normal="eq32", radial="eq35"
    )
    np.testing.assert_allclose(literal["T_N"], np.abs(acc[:, 2]), atol=1e-8 * 1e-7)
    np.testing.assert_allclose(literal["T_R"], literal["T_e"] + literal["T_aop"], rtol=1e-12)
    summed = gve.paper_thrust(el, gve.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1], radial="eq35")
    np.testing.assert_allclose(summed["T_R"], 2 * acc[:, 0], atol=1e-8 * 1e-7)


def test_paper_divisor_floor_and_cap():
    """At sin(nu) = 0 the literal eq. 33 grows as 1 / floor; the cap bounds every estimate; the
    weighted combinations are unaffected."""
    el = np.array([[6143.0, 0.6, np.radians(51.7), 0.0, np.radians(90.0), 0.0]])
    acc = np.array([[2e-8, 1e-8, -3e-8]])
    rates = gve.gve_rates(el, acc, GM)
    rates[:, 1] += 1e-12  # an e-dot that no finite T_R at perilune can produce
    big = gve.paper_thrust(el, rates, GM, divisor_floor=1e-4, radial="eq35")
    small = gve.paper_thrust(el, rates, GM, divisor_floor=1e-6, radial="eq35")
    assert abs(small["T_e"][0]) == pytest.approx(100 * abs(big["T_e"][0]), rel=1e-6)
    capped = gve.paper_thrust(el, rates, GM, divisor_floor=1e-6, radial="eq35", cap_kms2=1e-6)
    for key in ("T_R", "T_T", "T_N", "T_i", "T_raan", "T_e", "T_aop"):
        assert np.all(np.abs(capped[key]) <= 1e-6)
    w1 = gve.paper_thrust(el, rates, GM, divisor_floor=1e-4)
    w2 = gve.paper_thrust(el, rates, GM, divisor_floor=1e-6)
    assert w1["T_N"][0] == w2["T_N"][0]
    assert w1["T_R"][0] == pytest.approx(w2["T_R"][0], rel=1e-12)


def test_e_times_aop_row_is_regular_and_equals_e_times_the_aop_row():
    """The one GVE matrix: the regular last row is e times the aop row, and finite at e = 0."""
    el = np.array(
        [
            [6143.0, 0.6, np.radians(51.7), 0.3, np.radians(90.0), 1.0],
            [9000.0, 1e-4, np.radians(20.0), 2.0, np.radians(300.0), 4.0],
        ]
    )
    b, reg = gve.gve_matrix(el, GM), gve.gve_matrix(el, GM, e_times_aop=True)
    assert np.array_equal(b[:, :4], reg[:, :4])
    np.testing.assert_allclose(reg[:, 4], el[:, 1:2] * b[:, 4], rtol=1e-14, atol=0)
    circular = el.copy()
    circular[:, 1] = 0.0
    assert np.all(np.isfinite(gve.gve_matrix(circular, GM, e_times_aop=True)))
