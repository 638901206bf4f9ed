"""Impulsive GVEs against finite differences, burn planning against two-body and full-model propagation."""

import numpy as np
import pytest

from lnss_lib.design_life.manoeuvres import (
    CONTROL_ROWS,
    apply_impulse,
    candidate_true_anomalies,
    control_elements,
    control_gve_matrix,
    impulsive_gve_matrix,
    plan_impulses,
)
from lnss_lib.design_life.mean_elements import mean_elements, to_element_frame
from lnss_lib.elements import elements_to_state, kepler_states, state_to_elements

GM = 4902.7999671
STEP_KMS = 1e-7  # central-difference impulse (0.1 mm/s): truncation error far below the tolerance


def _fd(elements, fn):
    state = elements_to_state(elements, GM)
    cols = []
    for j in range(3):
        dv = np.zeros(3)
        dv[j] = STEP_KMS
        plus, minus = (
            fn(state_to_elements(apply_impulse(state, dv), GM)),
            fn(state_to_elements(apply_impulse(state, -dv), GM)),
        )
        d = plus - minus
        d[3:] = (d[3:] + np.pi) % (2 * np.pi) - np.pi
        cols.append(d / (2 * STEP_KMS))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize(
    "elements",
    [
        [6143.0, 0.6, np.radians(51.7), 0.3, np.radians(90.0), 1.0],
        [9000.0, 0.25, np.radians(20.0), 2.0, np.radians(300.0), 4.0],
        [4500.0, 0.05, np.radians(85.0), 5.0, np.radians(10.0), 2.5],
    ],
)
def test_impulsive_gve_matrix_matches_finite_differences(elements):
    el = np.array(elements)
    per_a = np.array([1.0 / el[0], 1, 1, 1, 1, 1])[
        :, None
    ]  # the a row in units of a (round-off of a ~ 1e-12 a)
    np.testing.assert_allclose(
        per_a * impulsive_gve_matrix(el, GM), per_a * _fd(el, lambda x: x), rtol=1e-5, atol=1e-6
    )


@pytest.mark.parametrize("ecc", [0.6, 1e-3, 1e-6])
def test_control_gve_matrix_is_regular_and_matches_finite_differences(ecc):
    el = np.array([5000.0, ecc, np.radians(60.0), 1.0, np.radians(45.0), 0.7])
    b = control_gve_matrix(el, GM)
    assert np.all(np.isfinite(b)) and np.abs(b[1:3]).max() < 10.0
    per_a = np.array([1.0 / el[0], 1, 1, 1, 1, 1])[:, None]
    np.testing.assert_allclose(per_a * b, per_a * _fd(el, control_elements), rtol=1e-5, atol=1e-5)


def test_candidate_points_include_apsides_and_nodes():
    nus = candidate_true_anomalies(0.6, np.radians(90.0))
    # AOP 90 deg: the antinode at u = 90 deg is the perilune, u = 270 deg the apolune: 4 distinct points
    assert nus.size == 4
    np.testing.assert_allclose(np.sort(nus), np.radians([0.0, 90.0, 180.0, 270.0]), atol=1e-12)


def test_plan_reaches_its_target_in_two_body_motion():
    """Fly the planned burns in Keplerian motion; the control set at the target epoch moves as requested."""
    el = np.array([6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 2.0])
    target = {
        "ex": -4e-4,
        "ey": 8e-4,
        "inc_rad": np.radians(0.05),
        "raan_rad": np.radians(-0.03),
        "a_km": 0.0,
    }
    plan = plan_impulses(el, GM, target)
    horizon = 2 * np.pi * np.sqrt(el[0] ** 3 / GM)
    assert (
        1 <= len(plan.dt_s) <= 2 and np.all(np.diff(plan.dt_s) > 0) and np.all(plan.dt_s < horizon)
    )
    state, t = elements_to_state(el, GM), 0.0
    for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms):
        state = apply_impulse(kepler_states(state_to_elements(state, GM), [dt - t], GM)[0, 0], dv)
        t = dt
    final = control_elements(
        state_to_elements(kepler_states(state_to_elements(state, GM), [horizon - t], GM)[0, 0], GM)
    )
    nominal = control_elements(state_to_elements(kepler_states(el, [horizon], GM)[0, 0], GM))
    for k, want in target.items():
        row = CONTROL_ROWS.index(k)
        got = final[row] - nominal[row]
        got = (got + np.pi) % (2 * np.pi) - np.pi if k.endswith("_rad") else got
        # linearisation error only, second order in the impulse: 2% of the change; in a, (a^2 / GM) dv^2
        tol = el[0] ** 2 / GM * plan.dv_total_kms**2 if k == "a_km" else 0.02 * abs(want) + 1e-7
        assert abs(got - want) <= tol, (k, got, want)


def test_plan_phasing_drifts_the_slot():
    """A requested a change shows up as the along-track drift -1.5 n da/a after the burns."""
    el = np.array([6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 2.0])
    plan = plan_impulses(el, GM, {"a_km": 2.0, "ex": 0.0, "ey": 0.0})
    np.testing.assert_allclose(plan.achieved, [2.0, 0.0, 0.0], atol=1e-9)
    assert 0.0 < plan.dv_total_kms < 2e-3


def test_plan_rejects_unknown_rows():
    with pytest.raises(ValueError, match="rows"):
        plan_impulses(np.array([6143.0, 0.6, 0.9, 0.0, 1.5, 0.0]), GM, {"ecc": 0.01})


def test_planned_manoeuvre_moves_the_mean_elements(ci_profile, epoch_tdb_s):
    """Full force model (degree 8): mean elements one orbit after the burns, with and without them,
    differ by the planned change within 5% (e vector, i, RAAN) and 1 km in a."""
    from lnss_lib.design_life.propagation import integrate_chunk, life_force_model
    from lnss_lib.frames import element_frame_to_j2000
    from lnss_lib.propagator import METHODS, elements_deg_to_states

    el_deg = np.array([[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]])
    state = elements_deg_to_states(ci_profile.dynamics, el_deg, epoch_tdb_s)
    rot = element_frame_to_j2000(ci_profile.dynamics, epoch_tdb_s)
    osc = state_to_elements(to_element_frame(state[0], rot), GM)
    target = {
        "ex": 2e-3,
        "ey": -3e-3,
        "inc_rad": np.radians(0.2),
        "raan_rad": np.radians(0.2),
        "a_km": 0.0,
    }
    plan = plan_impulses(osc, GM, target)
    period = 2 * np.pi * np.sqrt(6143.0**3 / GM)
    model = life_force_model(ci_profile.dynamics, epoch_tdb_s, 3.0)
    t_out = epoch_tdb_s + period * (1.0 + np.linspace(0.0, 1.0, 129))
    burn_t = np.full((2, 2), np.nan)
    burn_dv = np.zeros((2, 2, 3))
    burn_t[1, : len(plan.dt_s)] = epoch_tdb_s + plan.dt_s
    burn_dv[1, : len(plan.dt_s)] = plan.dv_rtn_kms
    out, _, status, _ = integrate_chunk(
        np.repeat(state, 2, axis=0),
        np.ones(2, dtype=bool),
        epoch_tdb_s,
        t_out,
        burn_t,
        burn_dv,
        METHODS.index("DOP853"),
        1e-10,
        1e-12,
        1737.4,
        10**6,
        model.kernel_args,
        model.field.degree,
    )
    assert np.all(status == 0)
    mean = mean_elements(to_element_frame(out, rot), GM)
    ctrl = control_elements(np.column_stack([mean[:, :5], np.zeros(2)]))
    delta = ctrl[1] - ctrl[0]
    for k, want in target.items():
        got = delta[CONTROL_ROWS.index(k)]
        got = (got + np.pi) % (2 * np.pi) - np.pi if k.endswith("_rad") else got
        assert abs(got - want) <= (1.0 if k == "a_km" else 0.05 * abs(want)), (k, got, want)


def test_newton_refinement_keeps_a_through_a_large_e_vector_pair():
    """A 0.036 change of the e vector (about 40 m/s on the ELFO) with a held: flown in two-body motion, the
    linear plan moves a by several km (second order in the impulse); the Newton-refined plan by < 0.05 km."""
    el = np.array([6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 2.0])
    target = {"ex": 0.0, "ey": -0.036, "inc_rad": 0.0, "raan_rad": 0.0, "a_km": 0.0, "u_rad": 0.0}
    horizon = 2 * np.pi * np.sqrt(el[0] ** 3 / GM)

    def fly(plan):
        state, t = elements_to_state(el, GM), 0.0
        for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms):
            state = apply_impulse(
                kepler_states(state_to_elements(state, GM), [dt - t], GM)[0, 0], dv
            )
            t = dt
        return control_elements(
            state_to_elements(
                kepler_states(state_to_elements(state, GM), [horizon - t], GM)[0, 0], GM
            )
        )

    linear, refined = plan_impulses(el, GM, target, newton_steps=0), plan_impulses(el, GM, target)
    assert 0.02 < refined.dv_total_kms < 0.06
    assert abs(fly(linear)[0] - el[0]) > 5.0
    got = fly(refined)
    assert abs(got[0] - el[0]) < 0.05
    assert (
        abs(got[2] - (el[1] * np.sin(el[4]) - 0.036)) < 1e-4
        and abs(got[1] - el[1] * np.cos(el[4])) < 1e-4
    )
