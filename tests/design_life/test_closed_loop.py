"""Closed-loop station keeping with the fixed-element box (``controller = "box"``) and natural drift over short
design lives (degree 8 field, fast); the service controller is tested in test_service.py."""

import numpy as np
import pytest

from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.design_life.closed_loop import life_force_model
from lnss_lib.design_life.mean_elements import mean_elements, relative_angles
from lnss_lib.ephemeris import ensure_kernels, tdb_seconds
from lnss_lib.errors import ConfigError, ImpactError
from lnss_lib.propagator import elements_deg_to_states, propagate_states
from lnss_lib.settings import load_settings

from .helpers import fly

LIFE_DAYS = 60.0


@pytest.fixture(scope="module")
def life_profile():
    profile = load_settings(
        "paper", overrides={"gravity": {"degree": 8}, "design_life": {"controller": "box"}}
    )
    ensure_kernels(profile.ephemeris)
    return profile


@pytest.fixture(scope="module")
def life_model(life_profile):
    t0 = tdb_seconds(life_profile.epoch.start_tdb, "TDB")
    return life_force_model(life_profile.dynamics, t0, LIFE_DAYS)


def test_frozen_orbit_holds_its_box_for_far_less_deltav(life_profile, life_model):
    """AOP 90 deg at the ELFO's a, e and i keeps the apse line (natural AOP within a few degrees over
    120 days); AOP 0 deg at the same a, e, i has its apse line turned by the Earth's tide."""
    frozen = fly(
        life_profile, [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]], life_days=LIFE_DAYS, model=life_model
    )
    loose = fly(
        life_profile, [[6143.0, 0.6, 51.7, 0.0, 0.0, 0.0]], life_days=LIFE_DAYS, model=life_model
    )
    dv_frozen, dv_loose = float(frozen.dv_kms_per_year[0]), float(loose.dv_kms_per_year[0])
    assert bool(frozen.box_held[0]) and not bool(frozen.impact[0])
    assert dv_frozen < 0.3 * dv_loose, (dv_frozen, dv_loose)
    assert int(loose.n_maneuvers[0]) > int(frozen.n_maneuvers[0])
    # every recorded manoeuvre lies inside the life and adds up to the reported total
    t = loose.maneuver_t_tdb_s.values[0]
    t = t[np.isfinite(t)]
    assert t.size == int(loose.n_maneuvers[0]) and np.all(np.diff(t) > 0)
    assert np.all(
        (t > loose.attrs["t0_tdb_s"]) & (t < loose.attrs["t0_tdb_s"] + LIFE_DAYS * SECONDS_PER_DAY)
    )
    np.testing.assert_allclose(
        np.nansum(np.linalg.norm(loose.maneuver_dv_rtn_kms.values[0], axis=-1)),
        float(loose.dv_total_kms[0]),
        rtol=1e-12,
    )


def test_natural_drift_leaves_the_box_that_station_keeping_holds(life_profile, life_model):
    el = [[6143.0, 0.6, 51.7, 0.0, 0.0, 0.0]]
    natural = fly(life_profile, el, natural=True, life_days=LIFE_DAYS, model=life_model)
    assert int(natural.n_maneuvers[0]) == 0 and float(natural.dv_kms_per_year[0]) == 0.0
    assert float(natural.max_box_ratio.sel(box="aop_deg")[0]) > 1.5


def test_impact_is_reported_with_its_day(life_profile, life_model):
    """High a, high i: the Earth's tide pumps e until the perilune reaches the surface; the day agrees
    with one plain propagation (different step sequences: within 0.05 day)."""
    el = [[15000.0, 0.6, 80.0, 0.0, 90.0, 0.0]]
    ds = fly(life_profile, el, natural=True, life_days=LIFE_DAYS, model=life_model)
    assert bool(ds.impact[0]) and not bool(ds.box_held[0])
    t0 = ds.attrs["t0_tdb_s"]
    states = elements_deg_to_states(
        life_profile.dynamics, ds.insertion_elements_deg.values, t0
    )  # after the initial trim
    with pytest.raises(ImpactError) as caught:
        propagate_states(
            life_profile.dynamics,
            states,
            t0,
            LIFE_DAYS * SECONDS_PER_DAY,
            3600.0,
            model=life_model,
            setting="design_life",
        )
    assert caught.value.sat == 0
    assert abs(float(ds.impact_day[0]) - caught.value.days) < 0.05
    assert 5.0 < float(ds.impact_day[0]) < LIFE_DAYS
    assert np.all(
        np.isnan(ds.mean_elements.values[0][ds.check_day.values[0] > ds.impact_day.values[0] + 1])
    )


MAX_SETS_PER_MONTH = (
    4  # an operator's cadence: at most ~4 box corrections (pairs) per satellite and month
)
MAX_BURNS_PER_SET = 4  # a correction pair plus its mean-a trim (one or two burns)


def test_two_planes_hold_every_box_at_an_operators_cadence(life_profile, life_model):
    """ELFO subset, two planes of two, 60 days: every satellite holds every box after the first check
    (geometry on the tidal mean, within box_tolerance), with at most MAX_SETS_PER_MONTH corrections a month;
    relative RAAN and slot errors are zero on average over the satellites."""
    from lnss_lib.constellation import planes_elements_deg

    el = planes_elements_deg(6143.0, 0.6, 51.7, 90.0, [0.0, 180.0], 2)
    ds = fly(life_profile, el, life_days=LIFE_DAYS, model=life_model, sample_step_s=SECONDS_PER_DAY)
    tol = float(life_profile.design_life.box_tolerance)
    assert bool(ds.box_held.all()), ds.max_box_ratio.values
    assert float(ds.max_box_ratio.max()) <= 1.0 + tol
    months = LIFE_DAYS / 30.44
    assert np.all(ds.n_maneuver_sets.values <= MAX_SETS_PER_MONTH * months), (
        ds.n_maneuver_sets.values
    )
    assert np.all(
        ds.n_maneuvers.values <= MAX_BURNS_PER_SET * np.maximum(ds.n_maneuver_sets.values, 1)
    )
    days = ds.maneuver_day.values
    spacing = float(life_profile.design_life.min_maneuver_spacing_days)
    for row in days:  # sets start at least min spacing apart: gaps > 2 days are sets
        burns = row[np.isfinite(row)]
        starts = burns[np.r_[True, np.diff(burns) > 2.0]] if burns.size else burns
        assert np.all(np.diff(starts) >= spacing - 1e-9), starts
    assert np.all(np.isfinite(ds.r_mci_km.values)) and ds.sizes["sample"] == int(LIFE_DAYS) + 1
    radius = np.linalg.norm(ds.r_mci_km.values, axis=-1)
    assert np.all(
        (radius > 1737.4) & (radius < 6143.0 * 1.7)
    )  # above the surface, below apolune + margin
    err = ds.box_error.sel(box=["raan_rel_deg", "u_rel_deg"]).values
    np.testing.assert_allclose(np.sin(err).sum(axis=0), 0.0, atol=1e-9)


def test_initial_trim_matches_the_design_mean_a(life_profile, life_model):
    """The design's a is a MEAN a: after the trim, an independent propagation (propagate_states) of the first
    orbit of each insertion state averages to the design a within 0.01 km (untrimmed, satellites at
    different mean anomalies are > 1 km apart: the slots would drift ~0.2 deg/day per km)."""
    from lnss_lib.constellation import planes_elements_deg
    from lnss_lib.design_life.mean_elements import to_element_frame
    from lnss_lib.design_life.propagation import trim_to_mean
    from lnss_lib.elements import orbital_period_s
    from lnss_lib.frames import element_frame_to_j2000

    el = planes_elements_deg(6143.0, 0.6, 51.7, 90.0, [0.0], 4)
    t0 = tdb_seconds(life_profile.epoch.start_tdb, "TDB")
    gm = float(life_profile.gravity.gm_km3_s2)
    period = float(orbital_period_s(6143.0, gm))
    rot = element_frame_to_j2000(life_profile.dynamics, t0)
    insert, resid = trim_to_mean(
        life_profile.dynamics, el, t0, life_model, life_profile.integrator.named("design_life")
    )
    assert np.all(np.abs(resid[:, 0]) < 0.01)

    def first_orbit_mean_a(elements):
        ds = propagate_states(
            life_profile.dynamics,
            elements_deg_to_states(life_profile.dynamics, elements, t0),
            t0,
            period,
            period / 128,
            batch=True,
            model=life_model,
            setting="design_life",
        )
        states = np.concatenate(
            [
                ds.r_mci_km.transpose("sat", "time", "xyz").values,
                ds.v_mci_kms.transpose("sat", "time", "xyz").values,
            ],
            axis=-1,
        )
        return mean_elements(to_element_frame(states, rot), gm)[:, 0]

    np.testing.assert_allclose(first_orbit_mean_a(insert), 6143.0, atol=0.01)
    untrimmed = first_orbit_mean_a(el)
    assert np.ptp(untrimmed) > 1.0, untrimmed


def test_mean_elements_of_a_keplerian_orbit_are_its_elements():
    from lnss_lib.elements import kepler_states

    gm = 4902.8
    el = np.array([6143.0, 0.6, np.radians(51.7), 0.4, np.radians(90.0), 0.0])
    period = 2 * np.pi * np.sqrt(el[0] ** 3 / gm)
    states = kepler_states(el, np.linspace(0.0, period, 257), gm)[0]
    mean = mean_elements(states, gm)
    np.testing.assert_allclose(mean[:5], el[:5], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        mean[5], np.mod(el[4] + np.pi, 2 * np.pi), atol=1e-9
    )  # u at the window centre


def test_relative_angles_remove_the_common_motion():
    nominal = np.radians([0.0, 90.0, 180.0, 270.0])
    angles = nominal + 1.0 + np.radians([1.0, -1.0, 0.5, -0.5])
    np.testing.assert_allclose(
        relative_angles(angles, nominal), np.radians([1.0, -1.0, 0.5, -0.5]), atol=1e-12
    )


def test_settings_are_checked(life_profile):
    with pytest.raises(ValueError, match="life_days"):
        fly(life_profile, [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]], life_days=-1.0)
    with pytest.raises(ConfigError, match="design_life.box.ecc"):
        life_profile.with_overrides({"design_life": {"box": {"ecc": -0.01}}})
    with pytest.raises(ConfigError, match="design_life.samples_per_orbit"):
        life_profile.with_overrides({"design_life": {"samples_per_orbit": 8}})
    with pytest.raises(ConfigError, match="design_life.target_fraction"):
        life_profile.with_overrides({"design_life": {"target_fraction": 1.0}})
    with pytest.raises(ValueError, match="shorter than"):
        fly(life_profile, [[20000.0, 0.1, 50.0, 0.0, 90.0, 0.0]], life_days=3.0)


def test_sampled_positions_agree_with_a_plain_propagation(life_profile, life_model):
    """Natural drift sampled every 6 h over 10 days against plain propagations. The chunked run restarts the
    step sequence at every check, so its integration error is not the plain run's error plus a small restart
    term but another realisation of the error of a run at that tolerance, and on the ELFO that error varies
    by an order of magnitude with the step sequence (a rounding difference between CPUs is enough to change
    it). The bound is the envelope of that error: the largest error, against the reference below,
    of plain runs with rtol and atol scaled by 2^(k/4), k = -4..4 (nine step sequences, the looser ones
    carrying up to 2^(7/8) times the error), doubled for a realisation beyond the nine. The envelope must be
    small enough to matter (twice it below the distance covered at apolune in 5 s, so a sample misplaced in
    time, or a state of another satellite or chunk, fails) and the reference ten times better than it: DOP853
    rtol 1e-13 / atol 1e-14 against rtol 1e-14 (a 1e-12 reference is itself one realisation of its error, which a
    round-off change of the force model moved from 0.014 to 0.11 of the envelope)."""
    from lnss_lib.constellation import planes_elements_deg
    from lnss_lib.elements import elements_to_state

    sma_km, ecc = 6143.0, 0.6
    el = planes_elements_deg(sma_km, ecc, 51.7, 90.0, [0.0, 180.0], 1)
    step_s, life = 6 * 3600.0, 10.0
    ds = fly(life_profile, el, natural=True, life_days=life, model=life_model, sample_step_s=step_s)
    t0 = ds.attrs["t0_tdb_s"]
    assert ds.r_mci_km.dims == ("sat", "sample", "xyz") and ds.sizes["sample"] == int(life * 4) + 1
    np.testing.assert_allclose(
        ds.sample_t_tdb_s.values, t0 + step_s * np.arange(ds.sizes["sample"]), rtol=0, atol=1e-6
    )
    base = life_profile.integrator.settings["design_life"]
    ensemble = {
        f"_x{k}": {
            "method": base.method,
            "rtol": base.rtol * 2 ** (k / 4),
            "atol": base.atol * 2 ** (k / 4),
        }
        for k in range(-4, 5)
    }
    references = {
        "_tight": {"method": "DOP853", "rtol": 1e-13, "atol": 1e-14},
        "_tighter": {"method": "DOP853", "rtol": 1e-14, "atol": 1e-14},
    }
    prof = life_profile.with_overrides({"integrator": {"settings": {**ensemble, **references}}})
    states = elements_deg_to_states(
        life_profile.dynamics, ds.insertion_elements_deg.values, t0
    )  # after the initial trim
    r = {
        name: propagate_states(
            prof.dynamics,
            states,
            t0,
            life * SECONDS_PER_DAY,
            step_s,
            batch=True,
            model=life_model,
            setting=name,
        )
        .r_mci_km.transpose("sat", "time", "xyz")
        .values
        for name in (*ensemble, *references)
    }
    tight = r["_tight"]
    assert r["_x0"].shape == ds.r_mci_km.shape
    envelope_km = max(np.linalg.norm(r[name] - tight, axis=-1).max() for name in ensemble)
    err_sampled = np.linalg.norm(ds.r_mci_km.values - tight, axis=-1)
    assert np.all(np.isfinite(err_sampled)) and err_sampled.max() <= 2.0 * envelope_km, (
        err_sampled.max(),
        envelope_km,
    )
    gm = life_profile.gravity.gm_km3_s2
    v_apolune_kms = np.linalg.norm(
        elements_to_state(np.array([sma_km, ecc, 0.0, 0.0, 0.0, np.pi]), gm)[3:]
    )
    assert 2.0 * envelope_km < 5.0 * v_apolune_kms, (envelope_km, v_apolune_kms)
    assert np.linalg.norm(tight - r["_tighter"], axis=-1).max() < 0.1 * envelope_km
    with pytest.raises(ValueError, match="sample_step_s"):
        fly(life_profile, el, natural=True, life_days=life, model=life_model, sample_step_s=-1.0)


def test_sampled_positions_are_nan_after_an_impact(life_profile, life_model):
    el = [[15000.0, 0.6, 80.0, 0.0, 90.0, 0.0]]
    ds = fly(
        life_profile,
        el,
        natural=True,
        life_days=LIFE_DAYS,
        model=life_model,
        sample_step_s=SECONDS_PER_DAY,
    )
    day = ds.sample_day.values
    r = ds.r_mci_km.values[0]
    assert np.all(np.isfinite(r[day < float(ds.impact_day[0])])) and np.all(
        np.isnan(r[day > float(ds.impact_day[0])])
    )


def test_a_burn_set_is_queued_whole_within_the_budget_and_finite_or_not_at_all():
    """The enqueue rule of the Delta-v cap: a set (e-vector pair plus a plane change) is queued whole when its total
    fits the budget, not at all when it does not (none of its burns), and never with a non-finite impulse, even with
    no budget limit (safety)."""
    from lnss_lib.design_life.fleet import enqueue
    from lnss_lib.design_life.manoeuvres import ImpulsePlan, plan_impulses

    gm = 4902.8
    osc = np.array([6143.0, 0.6, np.radians(51.7), 0.2, np.radians(90.0), 0.4])
    sets = [
        ("navigation", plan_impulses(osc, gm, {"a_km": 0.0, "ex": 0.0, "ey": -0.01}, max_burns=2)),
        ("relative_node", plan_impulses(osc, gm, {"raan_rad": np.radians(0.5)}, max_burns=1)),
    ]
    total = sum(plan.dv_total_kms for _, plan in sets)
    assert total > 0.0
    queue = []
    assert not enqueue(queue, 0, 0.0, osc, gm, sets, budget=0.999 * total) and queue == []
    assert enqueue(queue, 0, 0.0, osc, gm, sets, budget=1.001 * total)
    assert sum(np.linalg.norm(burn.dv_rtn_kms) for burn in queue) == pytest.approx(total, rel=1e-12)
    assert {burn.purpose for burn in queue} == {"navigation", "relative_node"}
    n_queued = len(queue)
    broken = ImpulsePlan(np.array([10.0]), np.array([[np.nan, 0.0, 0.0]]), np.zeros(1), np.zeros(1))
    assert not enqueue(queue, 0, 0.0, osc, gm, [("safety", broken)]) and len(queue) == n_queued


def test_box_never_flies_past_the_deltav_cap():
    """a 24000 km, e 0.2, i 90 deg, AOP 75 deg in moon_op, two planes, 80 days under the box (cap 0.219 km/s): the
    sets planned as the tide drives e up used to be checked only against what was already flown, so the last one
    went past the cap (0.2229 / 0.2203 km/s; over a year, with the full field, burns of 5.5 and 4.2 km/s unbound
    a satellite). Every satellite stays within the cap and every burn is finite."""
    profile = load_settings(
        "paper",
        overrides={
            "gravity": {"degree": 8},
            "design_life": {"controller": "box"},
            "frames": {"element_frame": "moon_op"},
        },
    )
    from lnss_lib.constellation import WalkerDesign

    ds = fly(profile, WalkerDesign(24000.0, 0.2, 75.0, 90.0, 2, 1).elements_deg(), life_days=80.0)
    cap_kms = ds.attrs["dv_cap_kms_per_year"] * 80.0 / 365.25
    assert ds["n_maneuvers"].values.min() > 0
    assert np.all(ds["dv_total_kms"].values <= cap_kms * (1.0 + 1e-12))
    flown = np.isfinite(ds["maneuver_t_tdb_s"].values)
    assert np.all(np.isfinite(ds["maneuver_dv_rtn_kms"].values[flown]))


def test_a_burn_set_whose_orbits_dive_below_the_floor_is_not_queued():
    """The navigation restore that lost Table 6 design #1's satellites on day 64 (a 11600, e 0.8, 3 x 3, one year): a
    two-burn e-vector change whose first burn leaves an orbit with its perilune under the surface before the second
    raises it again. Here the same shape on the ELFO: at apolune a retrograde burn that drops the perilune radius to
    1500 km, half an orbit later at perilune the prograde burn that restores the apolune; queued without a floor,
    refused with the surface as the floor, and the two-body perilunes checked against vis-viva."""
    from lnss_lib.design_life.fleet import enqueue
    from lnss_lib.design_life.manoeuvres import ImpulsePlan, lowest_perilune_km

    gm, a, e = 4902.8, 6143.0, 0.6
    osc = np.array([a, e, np.radians(51.7), 0.2, np.radians(90.0), np.pi])  # at apolune
    r_a, r_p_low = a * (1.0 + e), 1500.0
    v_a, v_a_new = (
        np.sqrt(gm * (2.0 / r_a - 1.0 / a)),
        np.sqrt(gm * (2.0 / r_a - 2.0 / (r_a + r_p_low))),
    )
    v_p_new, v_p_back = (
        np.sqrt(gm * (2.0 / r_p_low - 2.0 / (r_a + r_p_low))),
        np.sqrt(gm * (2.0 / r_p_low - 2.0 / (r_a + r_p_low + 3000.0))),
    )
    half_period = np.pi * np.sqrt(((r_a + r_p_low) / 2.0) ** 3 / gm)
    dive = ImpulsePlan(
        np.array([0.0, half_period]),
        np.array([[0.0, v_a_new - v_a, 0.0], [0.0, v_p_back - v_p_new, 0.0]]),
        np.zeros(1),
        np.zeros(1),
    )
    assert lowest_perilune_km(osc, gm, dive.dt_s, dive.dv_rtn_kms) == pytest.approx(
        r_p_low, rel=1e-9
    )
    assert lowest_perilune_km(osc, gm, dive.dt_s[:0], dive.dv_rtn_kms[:0]) == np.inf
    assert lowest_perilune_km(osc, gm, [0.0], [[0.0, 2.0, 0.0]]) == -np.inf  # escape
    queue = []
    assert (
        not enqueue(queue, 0, 0.0, osc, gm, [("navigation", dive)], floor_km=1737.4) and queue == []
    )
    assert (
        enqueue(queue, 0, 0.0, osc, gm, [("navigation", dive)], floor_km=1400.0) and len(queue) == 2
    )
