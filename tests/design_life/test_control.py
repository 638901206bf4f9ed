"""The box controller (:mod:`lnss_lib.design_life.control` and the planning step of the closed loop) against
physics: vis-viva, the Gauss variational equations, the drift of the slot under a mean-a offset, and a closed
loop that has nothing to do."""

import numpy as np
import pytest

from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.design_life.control import (
    SlotState,
    drift_band_rate,
    overshoot_target,
    predicted_exit,
    running_mean,
    tidal_mean,
)
from lnss_lib.design_life.controllers import box_plan
from lnss_lib.design_life.evaluation import evaluate_design_life
from lnss_lib.design_life.fleet import BOX_KEYS
from lnss_lib.design_life.manoeuvres import CONTROL_ROWS, kepler_achieved, plan_impulses
from lnss_lib.elements import kepler_states
from lnss_lib.settings import load_settings

GM = 4902.7999671  # km^3/s^2, the paper profile's lunar GM
ELFO = np.array([6143.0, 0.6, np.radians(51.7), 0.0, np.radians(90.0), np.pi])  # at apolune (rad)
TIDE_DAYS = 13.66  # half the sidereal month


@pytest.mark.parametrize("error", [0.07, -0.07, 0.031, -1e-9])
def test_overshoot_lands_at_the_target_fraction_on_the_far_side(error):
    half, fraction = 0.03, 0.8
    change = overshoot_target(error, half, fraction)
    assert error + change == pytest.approx(-np.sign(error) * fraction * half, abs=1e-15)


@pytest.mark.parametrize(
    "u0, accel", [(0.1, 2e-13), (-0.1, 2e-13), (0.15, -5e-14), (-0.02, -3e-12)]
)
def test_drift_band_parabola_turns_at_the_far_edge(u0, accel):
    """u(t) = u0 + r t + a t^2 / 2 turns where r + a t = 0, at u0 - r^2 / (2 a): on the far edge
    (-sign(a) x fraction x half) whenever the rate this needs is at least the crossing floor."""
    half, fraction, coast_s = np.radians(10.0), 0.8, 45.0 * SECONDS_PER_DAY
    rate = drift_band_rate(u0, accel, half, fraction, coast_s)
    floor = (abs(u0) + fraction * half) / coast_s
    assert abs(rate) >= floor * (1.0 - 1e-12)
    if abs(rate) > floor * (1.0 + 1e-12):  # turned by the acceleration
        assert np.sign(rate) == -np.sign(accel)
        assert u0 - rate**2 / (2.0 * accel) == pytest.approx(
            -np.sign(accel) * fraction * half, rel=1e-12
        )


@pytest.mark.parametrize("u0", [0.1, -0.1])
def test_drift_band_without_acceleration_crosses_the_box_in_the_coast(u0):
    half, fraction, coast_s = np.radians(10.0), 0.8, 45.0 * SECONDS_PER_DAY
    rate = drift_band_rate(u0, 0.0, half, fraction, coast_s)
    assert u0 + rate * coast_s == pytest.approx(-np.sign(u0) * fraction * half, rel=1e-12)


def test_predicted_exit_only_when_leaving_outward():
    half, look = 0.1, SECONDS_PER_DAY
    assert predicted_exit(0.09, 0.02 / SECONDS_PER_DAY, 0.0, half, look)  # crosses +half, outward
    assert not predicted_exit(
        0.05, 0.02 / SECONDS_PER_DAY, 0.0, half, look
    )  # still inside at the end
    assert not predicted_exit(
        0.15, -0.02 / SECONDS_PER_DAY, 0.0, half, look
    )  # outside, already coming back
    assert predicted_exit(-0.09, -0.02 / SECONDS_PER_DAY, 0.0, half, look)  # the other side
    # outward now, but turned around by the acceleration before the look-ahead ends: no burn
    assert not predicted_exit(0.11, 0.01 / SECONDS_PER_DAY, -0.04 / SECONDS_PER_DAY**2, half, look)


def test_slot_fit_recovers_the_drift_of_a_mean_a_offset():
    """A satellite whose mean a is 0.5 km above the design's drifts back along its slot at -1.5 n da / a
    (the controller's slot model); on top, the Earth tide's half-month swing. The fit separates them."""
    a, da = 6143.0, 0.5
    rate = -1.5 * np.sqrt(GM / a**3) * da / a  # rad/s
    accel = 3e-15  # rad/s^2, a slow creep
    t = np.arange(0.0, 20.0 + 1e-9, 0.5) * SECONDS_PER_DAY
    swing = 0.004 * np.sin(2 * np.pi * (t / SECONDS_PER_DAY - 20.0) / TIDE_DAYS + 0.3)
    slot = SlotState(history=list(zip(t, 0.01 + rate * t + 0.5 * accel * t**2 + swing)))
    u_now, fit_rate, fit_accel, tide_now = slot.fit(3.0, 15.0, TIDE_DAYS)
    t_end = t[-1]
    assert fit_rate == pytest.approx(rate + accel * t_end, rel=1e-8)
    assert fit_accel == pytest.approx(accel, rel=1e-6)
    assert u_now == pytest.approx(0.01 + rate * t_end + 0.5 * accel * t_end**2, abs=1e-10)
    assert u_now + tide_now == pytest.approx(slot.history[-1][1], abs=1e-10)
    assert (
        SlotState(history=slot.history[:4]).fit(3.0, 15.0, TIDE_DAYS) is None
    )  # 1.5 days: too short


def test_tidal_mean_removes_the_half_month_swing():
    """The centred mean over one tidal period of a swing at that period is zero but for the one sample by which
    the inclusive window's edges (rounded) miss a whole period: at most amplitude / (samples per period - 1)."""
    step_days, amplitude = TIDE_DAYS / 40, 0.015
    t = np.arange(0, 200) * step_days * SECONDS_PER_DAY
    e = 0.6 + amplitude * np.sin(2 * np.pi * t / (TIDE_DAYS * SECONDS_PER_DAY))
    mean = tidal_mean(t, e, TIDE_DAYS)
    interior = slice(25, -25)
    assert np.max(np.abs(mean[interior] - 0.6)) <= amplitude / 39 * (1 + 1e-9)
    # the running (trailing) mean of a linear drift is its value half a window back
    drift = 1e-9 * t
    back = running_mean(t, drift[:, None], TIDE_DAYS)[0]
    kept = t[t >= t[-1] - TIDE_DAYS * SECONDS_PER_DAY]
    assert back == pytest.approx(1e-9 * kept.mean(), rel=1e-12)


@pytest.mark.parametrize("da_km", [10.0, -25.0])
def test_tangential_perilune_burn_changes_a_by_the_vis_viva_amount(da_km):
    """Only a at perilune: the GVE row of a there is 2 a^2 v / GM along T alone, so the minimum-norm impulse is
    tangential, and two-body flight (the planner's Newton steps) makes it the vis-viva difference."""
    plan = plan_impulses(ELFO, GM, {"a_km": da_km}, true_anomalies=[0.0], max_burns=1)
    a, e = ELFO[0], ELFO[1]
    r_p = a * (1 - e)
    v_before, v_after = np.sqrt(GM * (2 / r_p - 1 / a)), np.sqrt(GM * (2 / r_p - 1 / (a + da_km)))
    dv = plan.dv_rtn_kms[0]
    assert plan.dv_rtn_kms.shape == (1, 3)
    assert abs(dv[0]) < 1e-9 * abs(dv[1]) and abs(dv[2]) < 1e-9 * abs(dv[1])
    # tolerance: what is left of the requested change, through the GVE row (da/dv_T = 2 a^2 v / GM)
    tolerance = abs(plan.residual[0]) * GM / (2 * a**2 * v_before) + 1e-12
    assert dv[1] == pytest.approx(v_after - v_before, abs=tolerance)
    assert abs(plan.residual[0]) < 1e-6 * abs(da_km)
    # the burn is flown at perilune: half an orbit after the apolune epoch
    assert plan.dt_s[0] == pytest.approx(np.pi * np.sqrt(a**3 / GM), rel=1e-12)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_box_plan_brings_an_aop_out_of_its_band_back_inside(sign):
    """The closed loop's planning step for an AOP past its half-width: after the planned burns (two-body
    flight over one orbit) the AOP sits at target_fraction of the half-width on the other side, e, i and RAAN
    stay inside their boxes, each to the planner's residual of its row (a and u, which two burns cannot also
    hold, are left to the next check's trim); the Delta-V is at least the GVE bound on the e-vector turn."""
    cfg = load_settings("paper").design_life
    half = np.array([cfg.box.ecc, *np.radians([getattr(cfg.box, k) for k in BOX_KEYS[1:]])])
    err = np.zeros(5)
    err[1] = sign * 1.2 * half[1]
    out = np.abs(err) > half
    mel = np.array([ELFO[0], ELFO[1], ELFO[2], ELFO[3], ELFO[4], ELFO[4] + ELFO[5]])
    plan, a_change = box_plan(ELFO, mel, ELFO[0], err, out, None, half, cfg, GM)
    assert a_change == 0.0 and plan is not None
    got = kepler_achieved(
        ELFO, GM, plan.dt_s, plan.dv_rtn_kms, 2 * np.pi * np.sqrt(ELFO[0] ** 3 / GM)
    )
    change = dict(zip(CONTROL_ROWS, got))
    residual = dict(
        zip(("ex", "ey", "inc_rad", "raan_rad", "a_km", "u_rad"), plan.residual)
    )  # box_plan's target order
    e, aop = ELFO[1], ELFO[4]
    ex, ey = e * np.cos(aop) + change["ex"], e * np.sin(aop) + change["ey"]
    new_err = err[1] + (np.arctan2(ey, ex) - aop)
    e_tol = np.hypot(residual["ex"], residual["ey"])
    assert new_err == pytest.approx(-sign * cfg.target_fraction * half[1], abs=e_tol / e + 1e-12)
    assert abs(new_err) < half[1]
    assert abs(np.hypot(ex, ey) - e) <= e_tol + 1e-12 < half[0]
    assert abs(change["inc_rad"]) <= abs(residual["inc_rad"]) + 1e-12 < half[2]
    assert abs(change["raan_rad"]) <= abs(residual["raan_rad"]) + 1e-12 < half[3]
    # first-order GVE of the e vector: |de| <= 2 r v |dv| / GM at the burn point, so the turn needs at least this
    turn = 2 * e * abs(np.sin(0.5 * (err[1] - new_err)))
    states = kepler_states(ELFO, np.linspace(0, 2 * np.pi * np.sqrt(ELFO[0] ** 3 / GM), 721), GM)[0]
    rv_max = np.max(np.linalg.norm(states[:, :3], axis=1) * np.linalg.norm(states[:, 3:], axis=1))
    assert plan.dv_total_kms >= turn * GM / (2 * rv_max)


def test_a_design_inside_a_wide_box_flies_no_burn_and_matches_its_natural_drift():
    """End to end: with the box controller and a box far wider than any drift of a frozen ELFO over a short
    life, nothing is out, so nothing is flown: zero burns, zero Delta-V, the box held, and the controlled run
    is the natural one (same lowest perilune, same monthly availability)."""
    wide = {"ecc": 0.3, "aop_deg": 60.0, "inc_deg": 30.0, "raan_rel_deg": 60.0, "u_rel_deg": 170.0}
    profile = load_settings("ci", overrides={"design_life": {"controller": "box", "box": wide}})
    elements = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0], [6143.0, 0.6, 51.7, 180.0, 90.0, 180.0]]
    out = evaluate_design_life(profile, elements, 6.0)
    assert (
        out["n_maneuvers"] == 0
        and out["sk_dv_kms_per_year"] == 0.0
        and out["sk_dv_max_kms_per_year"] == 0.0
    )
    assert (
        out["box_held"] is True and out["impact_day"] is None and out["natural_impact_day"] is None
    )
    assert out["min_perilune_alt_km"] == out["natural_min_perilune_alt_km"]
    assert out["pdop_avail_pct_monthly"]["controlled"] == out["pdop_avail_pct_monthly"]["natural"]
