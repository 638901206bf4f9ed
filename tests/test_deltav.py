"""Station-keeping Delta-V (lnss_lib.deltav): GVEs, inverses, eq. 36-41, secular budget.

Independent references: states integrated here with scipy (two-body + constant RTN thrust, and
two-body + J2), the analytic J2 acceleration and secular nodal rate, SLSQP, exact integrals.
"""

import numpy as np
import pytest
import xarray as xr
from orbit_cases import GM, J2, R_REF, YEAR_S, integrate, j2_acceleration, make_j2_arc

from lnss_lib import deltav as dv
from lnss_lib import frames, gve
from lnss_lib.elements import elements_to_state, orbital_period_s
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings

DELTAV = load_settings("paper").deltav


@pytest.fixture(scope="module")
def j2_arc():
    """Near-circular J2-only arc: a 2500 km, e 0.001, i 60 deg, six orbits sampled every 60 s."""
    return make_j2_arc()


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
    assert dv.trapezoid_deltav(t, np.full(t.size, 2e-8)) == pytest.approx(
        2e-8 * 10 * 86400.0, rel=1e-13
    )
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
    res = dv.deltav_arrays(t, elements_to_state(series, GM), GM, DELTAV)
    for model in dv.MODELS:
        assert res["dv_total"][model] < 1e-9
        assert res["dv_opt"][model] < 1e-9


def test_per_year_budget_follows_the_arc(j2_arc):
    """A steady process gives the same per-year budget from a short and a long arc."""
    _, t, states = j2_arc
    n = t.size
    half = dv.deltav_arrays(t[: n // 2], states[: n // 2], GM, DELTAV)
    full = dv.deltav_arrays(t, states, GM, DELTAV)
    assert full["per_year_factor"] == pytest.approx(
        half["per_year_factor"] * (t[n // 2 - 1] - t[0]) / (t[-1] - t[0])
    )
    for model in dv.MODELS:
        assert half["dv_total"][model] == pytest.approx(full["dv_total"][model], rel=0.03), model


def test_lsq_recovers_the_j2_acceleration(j2_arc):
    _, t, states = j2_arc
    res = dv.deltav_arrays(t, states, GM, DELTAV)
    truth = frames.to_rtn(np.stack([j2_acceleration(s[:3]) for s in states]), states)
    inner = slice(2, -2)
    err = np.linalg.norm(res["T_rtn_lsq"][inner] - truth[inner], axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.01 * np.sqrt(np.mean(np.sum(truth[inner] ** 2, axis=1)))
    dv_truth = dv.trapezoid_deltav(t, np.linalg.norm(truth, axis=1)) * res["per_year_factor"]
    assert res["dv_total"]["lsq"] == pytest.approx(dv_truth, rel=0.01)


def test_secular_model_gives_textbook_plane_change_for_j2(j2_arc):
    """J2 only: mean a, e, i do not drift; the node regresses at -1.5 n J2 (R/p)^2 cos i and the
    budget is the textbook plane change v sin(i) |dRAAN/dt| per unit time (Vallado, small angle)."""
    _, t, states = j2_arc
    res = dv.deltav_arrays(t, states, GM, DELTAV)
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
    states = integrate(
        elements_to_state(el0, GM), t, lambda y: frames.from_rtn(np.array([0.0, thrust, 0.0]), y)
    )
    res = dv.deltav_arrays(t, states, GM, DELTAV)
    np.testing.assert_allclose(
        res["T_rtn_lsq"], np.broadcast_to([0.0, thrust, 0.0], (t.size, 3)), atol=1e-3 * thrust
    )
    assert res["dv_total"]["lsq"] == pytest.approx(thrust * YEAR_S, rel=1e-3)
    assert res["secular_parts"]["sma"] == pytest.approx(thrust, rel=1e-3)
    assert res["dv_total"]["secular"] == pytest.approx(thrust * YEAR_S, rel=1e-2)


def _dataset(t, states):
    return xr.Dataset(
        {
            "r_mci_km": (("sat", "time", "xyz"), states[None, :, :3]),
            "v_mci_kms": (("sat", "time", "xyz"), states[None, :, 3:]),
        },
        coords={"sat": [0], "time": t, "xyz": ["x", "y", "z"]},
    )


def test_deltav_from_propagation_dataset(j2_arc):
    _, t, states = j2_arc
    profile = load_settings("ci")
    ds = _dataset(t, states)
    out = dv.deltav_from_propagation(
        profile.deltav, profile.dynamics, ds, sat=0, model="secular", gve_frame="j2000"
    )
    assert out.attrs["deltav_model"] == "secular"
    chosen = float(out["dv_total_kms_per_year"].sel(model_all="secular"))
    assert out.attrs["dv_total_kms_per_year"] == pytest.approx(chosen)
    assert set(out["model_all"].values) == set(dv.MODELS)
    assert out["T_total_kms2"].dims == ("model", "time")
    np.testing.assert_allclose(
        out["T_total_kms2"].sel(model="lsq"),
        np.linalg.norm(out["T_rtn_kms2"].sel(model="lsq"), axis=-1),
    )
    per_sat = dv.deltav_per_satellite(profile.deltav, profile.dynamics, ds, gve_frame="j2000")
    np.testing.assert_allclose(
        per_sat["dv_total_kms_per_year"].sel(sat=0), out["dv_total_kms_per_year"]
    )


def test_bad_inputs_are_rejected(j2_arc):
    _, t, states = j2_arc
    with pytest.raises(ValueError, match="orbital periods"):
        dv.secular_drift(t[:50], states[:50], GM)
    short = dv.deltav_arrays(t[:50], states[:50], GM, DELTAV)
    assert np.isnan(short["dv_total"]["secular"]) and np.isfinite(short["dv_total"]["lsq"])
    with pytest.raises(ValueError, match="increasing"):
        gve.element_rates(t[::-1], gve.osculating_elements(states, GM))
    ci = load_settings("ci")
    with pytest.raises(ValueError, match="satellite 3"):
        dv.deltav_from_propagation(ci.deltav, ci.dynamics, _dataset(t, states), sat=3)


@pytest.mark.parametrize(
    "bad, key",
    [
        ({"model": "osculating"}, "deltav.model"),
        ({"gve_frame": "ecliptic"}, "deltav.gve_frame"),
        ({"paper_divisor_floor": -1.0}, "deltav.paper_divisor_floor"),
        ({"paper_divisor_floor": 1.0}, "deltav.paper_divisor_floor"),
        ({"secular_min_periods": 1.0}, "deltav.secular_min_periods"),
        ({"lsq_weights": "x"}, "deltav.lsq_weights"),
        ({"lsq_rates": "splines"}, "deltav.lsq_rates"),
    ],
)
def test_bad_deltav_settings_are_config_errors_at_load_and_in_overrides(bad, key):
    """[deltav] is checked once, at load (config.py); a study's overrides are checked the same way."""
    with pytest.raises(ConfigError) as error:
        load_settings("paper", overrides={"deltav": bad})
    assert error.value.key == key
    with pytest.raises(ConfigError) as error:
        dv.with_overrides(DELTAV, **bad)
    assert error.value.key == key


def test_deltav_overrides_keep_the_section_when_nothing_changes():
    assert dv.with_overrides(DELTAV) is DELTAV and dv.with_overrides(DELTAV, model=None) is DELTAV
    floor0 = dv.with_overrides(DELTAV, paper_divisor_floor=0, model="paper")
    assert floor0.paper_divisor_floor == 0.0 and isinstance(floor0.paper_divisor_floor, float)
    assert floor0.model == "paper" and floor0.year_days == DELTAV.year_days


def test_lsq_recovers_the_force_model_perturbation():
    """On a propagated ELFO arc (ci force model) the lsq budget equals the integral of the force
    model's own non-Keplerian acceleration (notebook 04 shows the step dependence)."""
    from lnss_lib.ephemeris import ensure_kernels
    from lnss_lib.propagator import propagate_elements

    profile = load_settings("ci")
    ensure_kernels(profile.ephemeris)
    ds = propagate_elements(
        profile.dynamics,
        profile.epoch,
        [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]],
        duration_s=86400.0,
        step_s=300.0,
        setting="converged",
    )
    t = ds["time"].values
    states = np.concatenate([ds["r_mci_km"].values[0], ds["v_mci_kms"].values[0]], axis=-1)
    truth = dv.perturbing_acceleration_rtn(profile.dynamics, t, states)
    res = dv.deltav_arrays(t, states, profile.gravity.gm_km3_s2, profile.deltav)
    err = np.linalg.norm(res["T_rtn_lsq"] - truth, axis=1) / np.linalg.norm(truth, axis=1)
    assert np.median(err) < 0.01
    dv_truth = dv.trapezoid_deltav(t, np.linalg.norm(truth, axis=1)) * res["per_year_factor"]
    assert res["dv_total"]["lsq"] == pytest.approx(dv_truth, rel=0.02)
    out = dv.deltav_from_propagation(
        profile.deltav, profile.dynamics, ds, gve_frame="lunar_equator_of_epoch"
    )
    assert out.attrs["dv_total_kms_per_year"] == pytest.approx(res["dv_total"]["lsq"], rel=1e-6)


# ------------------------------------------------------------------------ analysis (notebook 04)


@pytest.mark.parametrize("model", dv.MODELS)
def test_one_model_alone_is_bit_for_bit_every_models_value(j2_arc, model):
    """deltav_arrays(models=(m,)) computes m alone (the other models' keys absent) with every-model values
    exactly; chosen_budget equals deltav_from_propagation's attributes exactly (the campaign's path)."""
    _, t, states = j2_arc
    every = dv.deltav_arrays(t, states, GM, DELTAV)
    alone = dv.deltav_arrays(t, states, GM, DELTAV, models=(model,))
    assert set(alone["dv_total"]) == {model} == set(alone["dv_opt"])
    assert (
        alone["dv_total"][model] == every["dv_total"][model]
        and alone["dv_opt"][model] == every["dv_opt"][model]
    )
    assert ("secular" in alone) == (model == "secular") and ("paper_estimates" in alone) == (
        model == "paper"
    )
    ci = load_settings("ci")
    cfg = dv.with_overrides(ci.deltav, model=model, gve_frame="j2000")
    ds = _dataset(t, states)
    full = dv.deltav_from_propagation(cfg, ci.dynamics, ds, sat=0)
    budget = dv.chosen_budget(cfg, ci.dynamics, t, states)
    assert budget == {k: full.attrs[k] for k in ("dv_total_kms_per_year", "dv_opt_kms_per_year")}
    with pytest.raises(ValueError, match="'kepler'.*allowed: paper, lsq, secular"):
        dv.deltav_arrays(t, states, GM, DELTAV, models=("kepler",))
    holed = states.copy()
    holed[7, 0] = np.nan
    with pytest.raises(ValueError, match="satellite 2 has non-finite states"):
        dv.chosen_budget(cfg, ci.dynamics, t, holed, sat=2)
