"""Station-keeping Delta-V (lnss_lib.deltav): GVEs, inverses, eq. 36-41, secular budget.

Independent references: states integrated here with scipy (two-body + constant RTN thrust, and
two-body + J2), the analytic J2 acceleration and secular nodal rate, SLSQP, exact integrals.
"""

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp

from lnss_lib import deltav as dv
from lnss_lib.config import load_profile
from lnss_lib.elements import elements_to_state, orbital_period_s

GM = 4902.7999671
R_REF = 1738.0
J2 = 1.0e-3  # about five times the Moon's, so the drift stands well above finite-difference noise
YEAR_S = 365.25 * 86400.0


def random_elements(rng, m):
    """Elements [a, e, i, raan, aop, nu] of closed orbits well away from e = 0 and i = 0, pi."""
    return np.column_stack([
        rng.uniform(2500.0, 9000.0, m), rng.uniform(0.05, 0.7, m), rng.uniform(0.2, np.pi - 0.2, m),
        rng.uniform(0.0, 2 * np.pi, m), rng.uniform(0.0, 2 * np.pi, m), rng.uniform(0.0, 2 * np.pi, m),
    ])


def state_from_nu(el):
    """State from [a, e, i, raan, aop, nu] (converted through the mean anomaly)."""
    a, e, inc, raan, aop, nu = el
    ecc_anom = 2.0 * np.arctan2(np.sqrt(1 - e) * np.sin(nu / 2), np.sqrt(1 + e) * np.cos(nu / 2))
    mean_anom = ecc_anom - e * np.sin(ecc_anom)
    return elements_to_state(np.array([a, e, inc, raan, aop, mean_anom]), GM)


def j2_acceleration(r_vec):
    """Zonal J2 acceleration (km/s^2), pole along z."""
    x, y, z = r_vec
    r2 = x * x + y * y + z * z
    r = np.sqrt(r2)
    k = -1.5 * J2 * GM * R_REF**2 / r**5
    f = 5.0 * z * z / r2
    return k * np.array([x * (1 - f), y * (1 - f), z * (3 - f)])


def integrate(state0, t_eval, extra):
    """Two-body plus ``extra(state)`` acceleration, DOP853 at tight tolerances; (n, 6) states at t_eval."""
    def rhs(_, y):
        r = y[:3]
        return np.concatenate([y[3:], -GM * r / np.linalg.norm(r) ** 3 + extra(y)])

    sol = solve_ivp(rhs, (t_eval[0], t_eval[-1]), state0, method="DOP853", t_eval=t_eval, rtol=1e-12, atol=1e-12)
    assert sol.success
    return sol.y.T


@pytest.fixture(scope="module")
def j2_arc():
    """Near-circular J2-only arc: a 2500 km, e 0.001, i 60 deg, six orbits sampled every 60 s."""
    el0 = np.array([2500.0, 0.001, np.radians(60.0), 0.4, 0.3, 0.0])
    period = orbital_period_s(el0[0], GM)
    t = np.arange(0.0, 6.0 * period, 60.0)
    states = integrate(elements_to_state(el0, GM), t, lambda y: j2_acceleration(y[:3]))
    return el0, t, states


def test_rtn_basis_orthonormal_and_round_trip():
    rng = np.random.default_rng(3)
    states = np.stack([state_from_nu(el) for el in random_elements(rng, 20)])
    basis = dv.rtn_basis(states)
    np.testing.assert_allclose(basis @ np.swapaxes(basis, -1, -2), np.broadcast_to(np.eye(3), basis.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(basis), 1.0, atol=1e-13)
    vec = rng.normal(size=(20, 3))
    np.testing.assert_allclose(dv.from_rtn(dv.to_rtn(vec, states), states), vec, atol=1e-13)
    np.testing.assert_allclose(dv.to_rtn(states[:, :3], states)[:, 0], np.linalg.norm(states[:, :3], axis=1))


@pytest.mark.parametrize("el", [
    [6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 1.0],
    [3000.0, 0.2, np.radians(100.0), 4.0, 2.0, 4.0],
    [8000.0, 0.4, np.radians(20.0), 1.0, 5.0, 2.5],
])
def test_forward_gves_match_integrated_constant_rtn_thrust(el):
    """Element rates of two-body states integrated with a constant RTN thrust equal eq. 25-29."""
    acc_rtn = np.array([3e-5, -2e-5, 4e-5])
    state0 = state_from_nu(np.array(el))
    h = 5.0

    def thrust(y):
        return dv.from_rtn(acc_rtn, y)

    before = integrate(state0, np.array([0.0, -h]), thrust)[-1]
    after = integrate(state0, np.array([0.0, h]), thrust)[-1]
    elements = dv.osculating_elements(np.stack([before, state0, after]), GM)
    fd = (elements[2, :5] - elements[0, :5]) / (2 * h)
    expected = dv.gve_rates(elements[1], acc_rtn, GM)
    np.testing.assert_allclose(fd, expected, rtol=2e-4, atol=1e-12 * np.abs(expected).max())


def test_lsq_inverts_forward_gves_exactly():
    rng = np.random.default_rng(7)
    el = random_elements(rng, 500)
    acc = rng.normal(size=(500, 3)) * 1e-7
    natural = dv.natural_rates_from_elements(el, dv.gve_rates(el, acc, GM))
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", dv.natural_gve_matrix(el, GM), acc), natural,
                               rtol=1e-12, atol=1e-25)
    solution, residual = dv.lsq_thrust(el, natural, GM)
    np.testing.assert_allclose(solution, acc, rtol=0, atol=1e-12 * 1e-7)
    assert np.all(residual < 1e-18)


def test_natural_rates_from_vectors_match_element_rates():
    """Central differences of (a, e vector, orbit normal) equal those of the elements where both are regular."""
    el0 = np.array([5000.0, 0.3, 0.9, 1.0, 2.0, 0.5])
    t = np.linspace(0.0, 3000.0, 31)
    acc = np.array([2e-6, -1e-6, 3e-6])
    states = integrate(state_from_nu(el0), t, lambda y: dv.from_rtn(acc, y))
    elements = dv.osculating_elements(states, GM)
    from_elements = dv.natural_rates_from_elements(elements, dv.element_rates(t, elements))
    from_vectors = dv.natural_rates_from_states(t, states, GM)
    scale = np.abs(from_elements).max(axis=0)
    np.testing.assert_allclose(from_vectors[1:-1], from_elements[1:-1], rtol=0, atol=1e-3 * scale.max())
    exact = dv.natural_rates_from_elements(elements, dv.gve_rates(elements, acc, GM))
    np.testing.assert_allclose(from_vectors[1:-1], exact[1:-1], rtol=0, atol=2e-3 * np.abs(exact).max())


def test_corrected_paper_equations_invert_forward_gves():
    """Eq. 30-35 corrected: exact inverse when eq. 30's assumption holds (T_R = 0), and each
    single-equation estimate exact given the true T_T, away from singular points."""
    rng = np.random.default_rng(11)
    el = random_elements(rng, 4000)
    theta = el[:, 4] + el[:, 5]
    regular = np.min(np.abs([np.sin(el[:, 5]), np.cos(el[:, 5]), np.sin(theta), np.cos(theta)]), axis=0) > 0.1
    el = el[regular]
    acc = rng.normal(size=(len(el), 3)) * 1e-7
    no_radial = acc * np.array([0.0, 1.0, 1.0])
    est = dv.paper_thrust(el, dv.gve_rates(el, no_radial, GM), GM)
    for key, col in (("T_R", 0), ("T_T", 1), ("T_N", 2)):
        np.testing.assert_allclose(est[key], no_radial[:, col], atol=1e-9 * 1e-7)
    est = dv.paper_thrust(el, dv.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1])
    for key, col in (("T_i", 2), ("T_raan", 2), ("T_N", 2), ("T_e", 0), ("T_aop", 0), ("T_R", 0)):
        np.testing.assert_allclose(est[key], acc[:, col], atol=1e-8 * 1e-7, err_msg=key)
    literal = dv.paper_thrust(el, dv.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1], normal="eq32", radial="eq35")
    np.testing.assert_allclose(literal["T_N"], np.abs(acc[:, 2]), atol=1e-8 * 1e-7)
    np.testing.assert_allclose(literal["T_R"], literal["T_e"] + literal["T_aop"], rtol=1e-12)
    summed = dv.paper_thrust(el, dv.gve_rates(el, acc, GM), GM, t_t_kms2=acc[:, 1], radial="eq35")
    np.testing.assert_allclose(summed["T_R"], 2 * acc[:, 0], atol=1e-8 * 1e-7)


def test_paper_divisor_floor_and_cap():
    """At sin(nu) = 0 the literal eq. 33 grows as 1 / floor; the cap bounds every estimate; the
    weighted combinations are unaffected."""
    el = np.array([[6143.0, 0.6, np.radians(51.7), 0.0, np.radians(90.0), 0.0]])
    acc = np.array([[2e-8, 1e-8, -3e-8]])
    rates = dv.gve_rates(el, acc, GM)
    rates[:, 1] += 1e-12  # an e-dot that no finite T_R at perilune can produce
    big = dv.paper_thrust(el, rates, GM, divisor_floor=1e-4, radial="eq35")
    small = dv.paper_thrust(el, rates, GM, divisor_floor=1e-6, radial="eq35")
    assert abs(small["T_e"][0]) == pytest.approx(100 * abs(big["T_e"][0]), rel=1e-6)
    capped = dv.paper_thrust(el, rates, GM, divisor_floor=1e-6, radial="eq35", cap_kms2=1e-6)
    for key in ("T_R", "T_T", "T_N", "T_i", "T_raan", "T_e", "T_aop"):
        assert np.all(np.abs(capped[key]) <= 1e-6)
    w1 = dv.paper_thrust(el, rates, GM, divisor_floor=1e-4)
    w2 = dv.paper_thrust(el, rates, GM, divisor_floor=1e-6)
    assert w1["T_N"][0] == w2["T_N"][0]
    assert w1["T_R"][0] == pytest.approx(w2["T_R"][0], rel=1e-12)


def test_tmax_closed_form_equals_slsqp():
    rng = np.random.default_rng(5)
    samples = rng.normal(size=(40, 3)) * 10.0 ** rng.uniform(-10, -6, size=(40, 1))
    samples[0] = [0.0, 3e-8, 0.0]
    samples[1] = [1e-8, -1e-8, 1e-8]
    closed = dv.tmax_closed_form(samples)
    solved, ok = dv.slsqp_tmax(samples, lam=20.0)
    assert ok.all()
    np.testing.assert_allclose(solved, closed, rtol=1e-6)
    total = dv.thrust_total(samples)
    assert np.all(closed <= total * (1 + 1e-12)) and np.all(closed >= total / 3 * (1 - 1e-12))
    assert closed[0] == pytest.approx(3e-8) and closed[1] == pytest.approx(total[1] / 3)
    assert dv.tmax_closed_form(np.zeros(3)) == 0.0


def test_trapezoid_constant_thrust_and_year_scaling():
    t = np.linspace(0.0, 10 * 86400.0, 961)
    assert dv.trapezoid_deltav(t, np.full(t.size, 2e-8)) == pytest.approx(2e-8 * 10 * 86400.0, rel=1e-13)
    assert dv.per_year_factor(t) == pytest.approx(36.525)
    assert dv.per_year_factor(t[:193]) == pytest.approx(365.25 / 2)
    assert dv.per_year_factor(t, year_days=365.0) == pytest.approx(36.5)
    with pytest.raises(ValueError, match="arc length"):
        dv.per_year_factor(np.array([5.0, 5.0]))


def test_orbit_mean_removes_a_periodic_term():
    """The one-period running mean of c + s t + A sin(2 pi t / P) is c + s t_mid (up to the
    trapezoid error of the sine, O((step/P)^2))."""
    period = 1000.0
    t = np.arange(0.0, 5000.0 + 1e-9, 10.0)
    values = np.column_stack([3.0 + 2e-3 * t + 0.5 * np.sin(2 * np.pi * t / period + 0.3), t])
    t_mid, means = dv.orbit_mean(t, values, period)
    assert t_mid[0] == pytest.approx(500.0) and t_mid[-1] == pytest.approx(4500.0)
    np.testing.assert_allclose(means[:, 0], 3.0 + 2e-3 * t_mid, atol=1e-6)
    np.testing.assert_allclose(means[:, 1], t_mid, rtol=1e-12)
    with pytest.raises(ValueError, match="two one-period windows"):
        dv.orbit_mean(t[:101], values[:101], period)


def test_keplerian_arc_costs_nothing():
    el = np.array([6143.0, 0.6, np.radians(51.7), 0.3, np.radians(90.0), 0.0])
    t = np.arange(0.0, 10 * 86400.0 + 1, 900.0)
    series = np.tile(el, (t.size, 1))
    series[:, 5] = np.sqrt(GM / el[0] ** 3) * t
    res = dv.deltav_arrays(t, elements_to_state(series, GM), GM)
    for model in dv.MODELS:
        assert res["dv_total"][model] < 1e-9
        assert res["dv_opt"][model] < 1e-9


def test_per_year_budget_follows_the_arc(j2_arc):
    """A steady process gives the same per-year budget from a short and a long arc."""
    _, t, states = j2_arc
    n = t.size
    half = dv.deltav_arrays(t[: n // 2], states[: n // 2], GM)
    full = dv.deltav_arrays(t, states, GM)
    assert full["per_year_factor"] == pytest.approx(half["per_year_factor"] * (t[n // 2 - 1] - t[0]) / (t[-1] - t[0]))
    for model in dv.MODELS:
        assert half["dv_total"][model] == pytest.approx(full["dv_total"][model], rel=0.03), model


def test_lsq_recovers_the_j2_acceleration(j2_arc):
    _, t, states = j2_arc
    res = dv.deltav_arrays(t, states, GM)
    truth = dv.to_rtn(np.stack([j2_acceleration(s[:3]) for s in states]), states)
    inner = slice(2, -2)
    err = np.linalg.norm(res["T_rtn_lsq"][inner] - truth[inner], axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.01 * np.sqrt(np.mean(np.sum(truth[inner] ** 2, axis=1)))
    dv_truth = dv.trapezoid_deltav(t, np.linalg.norm(truth, axis=1)) * res["per_year_factor"]
    assert res["dv_total"]["lsq"] == pytest.approx(dv_truth, rel=0.01)


def test_secular_model_gives_textbook_plane_change_for_j2(j2_arc):
    """J2 only: mean a, e, i do not drift; the node regresses at -1.5 n J2 (R/p)^2 cos i and the
    budget is the textbook plane change v sin(i) |dRAAN/dt| per unit time (Vallado, small angle)."""
    _, t, states = j2_arc
    res = dv.deltav_arrays(t, states, GM)
    sec = res["secular"]
    a, e, inc = sec["a_km"], sec["e"], sec["inc_rad"]
    n = np.sqrt(GM / a**3)
    raan_rate = -1.5 * n * J2 * (R_REF / (a * (1 - e * e))) ** 2 * np.cos(inc)
    assert sec["raan_dot"] == pytest.approx(raan_rate, rel=5e-3)
    assert abs(sec["natural_rates"][3]) < 1e-3 * abs(sec["natural_rates"][4])
    textbook = np.sqrt(GM / a) * np.sin(inc) * abs(raan_rate) * YEAR_S
    parts = {k: v * YEAR_S for k, v in res["secular_parts"].items()}
    assert parts["plane"] == pytest.approx(textbook, rel=5e-3)
    assert parts["sma"] + parts["ecc_vector"] < 0.01 * parts["plane"]
    assert res["dv_total"]["secular"] == pytest.approx(parts["total"])
    assert res["dv_total"]["secular"] < res["dv_total"]["lsq"]


def test_constant_tangential_thrust_costs_the_thrust():
    """A constant tangential thrust T on a circular orbit (e = 0 at the start, so the osculating
    apse line is ill-defined): the secular a-drift costs T per unit time (Edelbaum), and the lsq
    inverse returns T at every epoch."""
    thrust = 2e-8
    el0 = np.array([3000.0, 0.0, np.radians(40.0), 0.0, 0.0, 0.0])
    t = np.arange(0.0, 4.0 * orbital_period_s(el0[0], GM), 120.0)
    states = integrate(elements_to_state(el0, GM), t, lambda y: dv.from_rtn(np.array([0.0, thrust, 0.0]), y))
    res = dv.deltav_arrays(t, states, GM)
    np.testing.assert_allclose(res["T_rtn_lsq"], np.broadcast_to([0.0, thrust, 0.0], (t.size, 3)), atol=1e-3 * thrust)
    assert res["dv_total"]["lsq"] == pytest.approx(thrust * YEAR_S, rel=1e-3)
    assert res["secular_parts"]["sma"] == pytest.approx(thrust, rel=1e-3)
    assert res["dv_total"]["secular"] == pytest.approx(thrust * YEAR_S, rel=1e-2)


def _dataset(t, states):
    return xr.Dataset(
        {"r_mci_km": (("sat", "time", "xyz"), states[None, :, :3]),
         "v_mci_kms": (("sat", "time", "xyz"), states[None, :, 3:])},
        coords={"sat": [0], "time": t, "xyz": ["x", "y", "z"]},
    )


def test_deltav_from_propagation_dataset(j2_arc):
    _, t, states = j2_arc
    profile = load_profile("ci")
    ds = _dataset(t, states)
    out = dv.deltav_from_propagation(profile, ds, sat=0, model="secular", element_frame="j2000")
    assert out.attrs["deltav_model"] == "secular"
    chosen = float(out["dv_total_kms_per_year"].sel(model_all="secular"))
    assert out.attrs["dv_total_kms_per_year"] == pytest.approx(chosen)
    assert set(out["model_all"].values) == set(dv.MODELS)
    assert out["T_total_kms2"].dims == ("model", "time")
    np.testing.assert_allclose(out["T_total_kms2"].sel(model="lsq"),
                               np.linalg.norm(out["T_rtn_kms2"].sel(model="lsq"), axis=-1))
    per_sat = dv.deltav_per_satellite(profile, ds, element_frame="j2000")
    np.testing.assert_allclose(per_sat["dv_total_kms_per_year"].sel(sat=0), out["dv_total_kms_per_year"])


def test_bad_inputs_are_rejected(j2_arc):
    _, t, states = j2_arc
    with pytest.raises(ValueError, match="model"):
        dv.deltav_settings(None, model="osculating")
    with pytest.raises(ValueError, match="element_frame"):
        dv.deltav_settings(None, element_frame="ecliptic")
    with pytest.raises(ValueError, match="paper_divisor_floor"):
        dv.deltav_settings(None, paper_divisor_floor=-1.0)
    with pytest.raises(ValueError, match="unknown"):
        dv.deltav_settings(None, lsq_weights="x")
    with pytest.raises(ValueError, match="orbital periods"):
        dv.secular_drift(t[:50], states[:50], GM)
    short = dv.deltav_arrays(t[:50], states[:50], GM)
    assert np.isnan(short["dv_total"]["secular"]) and np.isfinite(short["dv_total"]["lsq"])
    with pytest.raises(ValueError, match="lsq_rates"):
        dv.deltav_settings(None, lsq_rates="splines")
    with pytest.raises(ValueError, match="increasing"):
        dv.element_rates(t[::-1], dv.osculating_elements(states, GM))
    with pytest.raises(ValueError, match="satellite 3"):
        dv.deltav_from_propagation(load_profile("ci"), _dataset(t, states), sat=3)


def test_lsq_recovers_the_force_model_perturbation():
    """On a propagated ELFO arc (ci force model) the lsq budget equals the integral of the force
    model's own non-Keplerian acceleration (notebook 04 shows the step dependence)."""
    from lnss_lib.ephemeris import ensure_kernels
    from lnss_lib.propagator import propagate_elements

    profile = load_profile("ci")
    ensure_kernels(profile)
    ds = propagate_elements(profile, [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]], duration_s=86400.0, step_s=300.0,
                            setting="converged")
    t = ds["time"].values
    states = np.concatenate([ds["r_mci_km"].values[0], ds["v_mci_kms"].values[0]], axis=-1)
    truth = dv.perturbing_acceleration_rtn(profile, t, states)
    res = dv.deltav_arrays(t, states, profile["gravity"]["gm_km3_s2"])
    err = np.linalg.norm(res["T_rtn_lsq"] - truth, axis=1) / np.linalg.norm(truth, axis=1)
    assert np.median(err) < 0.01
    dv_truth = dv.trapezoid_deltav(t, np.linalg.norm(truth, axis=1)) * res["per_year_factor"]
    assert res["dv_total"]["lsq"] == pytest.approx(dv_truth, rel=0.02)
    out = dv.deltav_from_propagation(profile, ds, element_frame="lunar_equator_of_epoch")
    assert out.attrs["dv_total_kms_per_year"] == pytest.approx(res["dv_total"]["lsq"], rel=1e-6)


# ------------------------------------------------------------------------ analysis (notebook 04)

def test_dataset_states_and_tables_from_a_result(j2_arc):
    el0, t, states = j2_arc
    ds = _dataset(t, states)
    np.testing.assert_array_equal(dv.dataset_states(ds), states)
    res = dv.deltav_from_propagation(load_profile("ci"), ds, sat=0, element_frame="j2000")
    table = dv.model_comparison_table(res)
    assert table.index.tolist() == [*dv.MODELS, "paper (Table 4)"]
    assert table.loc["paper (Table 4)", "opt / total"] == pytest.approx(0.37 / 0.50)
    np.testing.assert_allclose(table["opt / total"], table["dv_opt_kms_per_year"] / table["dv_total_kms_per_year"])
    # Secular J2 nodal regression -1.5 n J2 (R / p)^2 cos(i) (Vallado eq. 9-41), in deg/day.
    rates = dv.secular_rates_table({"j2000": res})["j2000"]
    a, e, inc = el0[0], el0[1], el0[2]
    raan_dot = -1.5 * np.sqrt(GM / a**3) * J2 * (R_REF / (a * (1 - e * e))) ** 2 * np.cos(inc)
    assert rates["dRAAN/dt (deg/day)"] == pytest.approx(np.degrees(raan_dot) * 86400.0, rel=0.03)
    assert rates["mean i (deg)"] == pytest.approx(np.degrees(inc), abs=0.05)


def test_singularity_sweep_floor_and_cap(j2_arc):
    _, t, states = j2_arc
    sweep = dv.singularity_sweep(t, states, GM, floors=(1e-1, 1e-3, 0.0), caps_kms2=(1e-5, 1e-7, 2e-8))
    assert len(sweep) == 4 * 3 + 3 * 2
    corrected = sweep.xs("corrected (weighted eq. 32, 35)", level="variant")
    uncapped = corrected.xs("none", level="cap (km/s^2)")["dv total"]
    assert np.ptp(uncapped.values) <= 1e-12 * uncapped.max()      # the weighted forms divide by nothing the floor touches
    capped = corrected.xs(0.0, level="divisor floor")
    totals = [capped.loc[f"{c:g}", "dv total"] for c in (1e-5, 1e-7, 2e-8)]
    assert totals[0] == pytest.approx(uncapped.iloc[0])              # a cap far above J2 changes nothing
    assert totals[0] >= totals[1] >= totals[2]
    assert totals[2] <= np.sqrt(3.0) * 2e-8 * YEAR_S                  # every component clipped to the cap
    assert np.all(sweep["dv opt"] <= sweep["dv total"] * (1 + 1e-12))


def test_secular_windows_of_a_j2_arc(j2_arc):
    _, t, states = j2_arc
    window_s = (t[-1] - t[0]) / 2.0
    windows = dv.secular_window_sweep(t, states, GM, window_s)
    starts = windows.index.get_level_values("window start (days)")
    n_win = int(round(window_s / 60.0))
    np.testing.assert_allclose(starts[:-1], np.arange(len(starts) - 1) * (n_win // 4) * 60.0 / 86400.0)
    assert windows.index[-1] == (0.0, pytest.approx((t[-1] - t[0]) / 86400.0))
    # J2 regresses the node at a constant rate: every window sees the same secular plane cost.
    plane = windows["secular plane"].values
    np.testing.assert_allclose(plane[:-1], plane[-1], rtol=0.02)
    spread = dv.window_spread(windows, window_s / 86400.0)
    assert spread["lsq"] == (windows["lsq total"].iloc[:-1].min(), windows["lsq total"].iloc[:-1].max())
    with pytest.raises(ValueError, match="window"):
        dv.secular_window_sweep(t, states, GM, 2.0 * (t[-1] - t[0]))


def test_slsqp_check_and_constellation_tables():
    rng = np.random.default_rng(7)
    thrust = rng.normal(size=(30, 3)) * 1e-7
    thrust[0] = [2e-7, 0.0, 0.0]                                    # one component: T_max = T_total
    thrust[1] = [1e-7, -1e-7, 1e-7]                                 # three equal: T_max = T_total / 3
    table = dv.slsqp_check_table(thrust, n_sample=30)
    row = table.loc["lsq thrust"]
    assert row["epochs"] == 30 and row["SLSQP converged"] == 30
    assert row["max |SLSQP - closed| / closed"] < 1e-6
    assert row["min T_max / T_total"] == pytest.approx(1.0 / 3.0) and row["max T_max / T_total"] == pytest.approx(1.0)
    per_sat = xr.Dataset({"dv_total_kms_per_year": (("sat", "model_all"), [[1.0, 2.0, 3.0], [3.0, 4.0, 5.0]]),
                          "dv_opt_kms_per_year": (("sat", "model_all"), [[0.5, 1.0, 3.0], [1.5, 2.0, 5.0]])},
                         coords={"sat": [0, 1], "model_all": list(dv.MODELS)})
    const = dv.constellation_table(per_sat)
    assert const.loc["lsq"].tolist() == [3.0, 2.0, 4.0, 1.5]
    assert const.loc["paper (Table 4)", "mean total"] == 0.50 and np.isnan(const.loc["paper (Table 4)", "min total"])


def test_recovery_sampling_and_frame_tables_on_the_elfo():
    """The lsq inverse returns the force model's perturbation on a propagated ELFO arc (ci force model);
    the sweeps agree with direct calls, the budget converges with the step, lsq is frame independent."""
    from lnss_lib.ephemeris import ensure_kernels
    from lnss_lib.propagator import propagate_elements

    profile = load_profile("ci")
    ensure_kernels(profile)
    first = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]]
    table, data = dv.lsq_recovery_study(profile, first, [300.0], integrators=("converged",))
    row = table.loc[("converged", 300.0)]
    assert row["median |dT|/|T|"] < 0.01 and row["lsq / truth"] == pytest.approx(1.0, abs=0.02)
    assert row["lsq / truth"] == pytest.approx(row["dv lsq"] / row["dv truth (km/s/yr)"])
    t, truth, out = data[("converged", 300.0)]
    assert truth.shape == (t.size, 3) and out["T_rtn_lsq"].shape == truth.shape
    sampling = dv.sampling_sweep(profile, first, (300.0, 900.0), integrators=("converged",))
    assert sampling.loc[("converged", 300.0), "lsq total"] == pytest.approx(row["dv lsq"], rel=1e-12)
    assert sampling.loc[("converged", 900.0), "lsq total"] == pytest.approx(row["dv truth (km/s/yr)"], rel=0.1)
    ds = propagate_elements(profile, first)
    frames = dv.element_frame_table(profile, ds)
    assert frames.index.tolist() == list(dv.ELEMENT_FRAMES)
    assert frames.loc["j2000", "lsq total"] == pytest.approx(frames.loc["lunar_equator_of_epoch", "lsq total"], rel=1e-6)
    near = dv.singular_proximity(dv.deltav_from_propagation(profile, ds))
    assert 0.0 <= near["min_abs_sin_nu"] < 0.05     # the ELFO starts at perilune: nu = 0 is sampled
