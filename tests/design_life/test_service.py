"""The service station-keeping controller: it pays for what the service needs and nothing else."""

import dataclasses

import numpy as np
import pytest

from lnss_lib.config import ConfigError
from lnss_lib.constellation import WalkerDesign
from lnss_lib.design_life.evaluation import life_metrics
from lnss_lib.design_life.service import (
    PURPOSES,
    burn_location,
    mean_vectors_j2000,
    raan_half_width_rad,
)
from lnss_lib.settings import load_settings

from .helpers import fly, model_from_epoch, paper_degree8

LIFE_DAYS = 60.0
DRIVEN_DOWN = [[6143.0, 0.6, 70.0, 0.0, 45.0, 0.0]]
"""Lidov-Kozai drives this perilune into the surface in about 40 days (degree-8 field, study epoch)."""


@pytest.fixture(scope="module")
def profile():
    return paper_degree8()


@pytest.fixture(scope="module")
def model(profile):
    return model_from_epoch(profile, LIFE_DAYS)


@pytest.fixture(scope="module")
def driven_down(profile, model):
    runs = {
        "controlled": fly(profile, DRIVEN_DOWN, life_days=LIFE_DAYS, model=model),
        "natural": fly(profile, DRIVEN_DOWN, natural=True, life_days=LIFE_DAYS, model=model),
    }
    return runs


def test_frozen_orbit_that_keeps_the_service_flies_no_burn(profile, model):
    """Two satellites of the Table 4 ELFO plane: its natural motion keeps the perilune far above the floor, the
    slots and the navigation windows (positions sampled), so the service controller flies nothing."""
    el = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0], [6143.0, 0.6, 51.7, 0.0, 90.0, 180.0]]
    ds = fly(profile, el, life_days=LIFE_DAYS, model=model, sample_step_s=3600.0)
    assert ds.attrs["controller"] == "service"
    assert ds.attrs["navigation_violations"] == 0  # the monitor ran and found the requirement kept
    assert int(ds["n_maneuvers"].sum()) == 0 and float(ds["dv_total_kms"].sum()) == 0.0
    assert not bool(ds["impact"].any()) and bool(ds["box_held"].all())
    assert (
        float(ds["min_perilune_alt_km"].min()) > 300.0
    )  # 6143 (1 - 0.6) - 1737 = 720 km, minus the swing


def test_perilune_driven_down_gets_a_safety_burn_before_impact_and_survives(profile, driven_down):
    natural, ctl = driven_down["natural"], driven_down["controlled"]
    impact = float(natural["impact_day"][0])
    assert (
        np.isfinite(impact)
        and impact < LIFE_DAYS
        and str(natural["loss_cause"].values[0]) == "impact"
    )
    assert float(natural["loss_day"][0]) == pytest.approx(impact)
    assert not bool(ctl["impact"][0]) and str(ctl["loss_cause"].values[0]) == ""
    purposes = ctl["maneuver_purpose"].values[0]
    days = ctl["maneuver_day"].values[0]
    safety = purposes == "safety"
    assert safety.any() and np.nanmax(days[safety]) < impact
    assert set(ctl["maneuver_location"].values[0][safety]) <= {
        "perilune",
        "apolune",
    }  # e vector at the apses
    floor = float(profile.impact.min_altitude_km)
    assert (
        float(ctl["min_perilune_alt_km"][0])
        > floor + profile.design_life.service.perilune_margin_km
    )
    assert float(natural["min_perilune_alt_km"][0]) <= floor


def test_deltav_split_adds_up_to_the_total(driven_down):
    ctl = driven_down["controlled"]
    total = ctl["dv_kms_per_year"].values
    assert total[0] > 0.0
    np.testing.assert_allclose(
        ctl["dv_purpose_kms_per_year"].sum("purpose").values, total, rtol=1e-12
    )
    np.testing.assert_allclose(
        ctl["dv_location_kms_per_year"].sum("location").values, total, rtol=1e-12
    )
    metrics = life_metrics(driven_down)
    assert set(metrics["sk_dv_split"]) == set(PURPOSES)
    assert sum(metrics["sk_dv_split"].values()) == pytest.approx(
        metrics["sk_dv_kms_per_year"], rel=1e-12
    )
    assert metrics["natural_min_perilune_alt_km"] < metrics["min_perilune_alt_km"]
    assert (
        metrics["lost_satellites"] == []
        and metrics["natural_lost_satellites"][0]["cause"] == "impact"
    )


@pytest.mark.parametrize("controller", ["service", "box"])
def test_a_design_the_trim_cannot_hold_completes(profile, model, controller):
    """Near-circular orbits whose first-orbit mean e is larger than the design's: the insertion trim once stepped
    to e < 0 and stopped the evaluation ("eccentricity must be in [0, 1)"); now every satellite is flown."""
    el = WalkerDesign(11925.0, 0.005, 152.0, 23.6, 3, 1).elements_deg()
    ds = fly(
        profile,
        el,
        model=model,
        design_life=dataclasses.replace(profile.design_life, life_days=20.0, controller=controller),
    )
    assert ds.sizes["sat"] == 3 and np.all(np.isfinite(ds["dv_kms_per_year"].values))
    assert np.all(ds["insertion_elements_deg"].values[:, 1] >= 0.0)


def test_controller_setting_is_checked():
    with pytest.raises(ConfigError, match="allowed: 'service', 'box'"):
        load_settings("paper", overrides={"design_life": {"controller": "elements"}})


def test_burn_location_names_apses_and_nodes():
    aop = np.radians(30.0)
    assert burn_location(0.0, aop) == "perilune" and burn_location(np.pi, aop) == "apolune"
    assert burn_location(-aop, aop) == "node" and burn_location(np.pi / 2 - aop, aop) == "antinode"
    assert burn_location(1.0, aop) == "other"


def _normal(inc_rad, raan_rad):
    return np.array(
        [np.sin(inc_rad) * np.sin(raan_rad), -np.sin(inc_rad) * np.cos(raan_rad), np.cos(inc_rad)]
    )


def _plane_angle(n1, n2):
    return np.arctan2(np.linalg.norm(np.cross(n1, n2)), np.dot(n1, n2))


@pytest.mark.parametrize("tol_deg", [0.5, 3.0, 6.0])
def test_raan_half_width_tilts_the_plane_by_the_tolerance(tol_deg):
    """The RAAN half-width moves the orbit normal by exactly the tolerance (angle between the two normals,
    computed from the vectors), tends to tol / sin i for small angles, equals the tolerance on a polar orbit, and
    is pi (no bound) below i = tol / 2, where even opposite nodes tilt the plane by 2 i <= tol."""
    tol = np.radians(tol_deg)
    for inc_deg in (3.5, 10.0, 30.0, 60.0, 90.0, 120.0, 176.0):
        inc = np.radians(inc_deg)
        half = float(raan_half_width_rad(tol, inc))
        assert half < np.pi
        assert _plane_angle(_normal(inc, 0.3), _normal(inc, 0.3 + half)) == pytest.approx(
            tol, rel=1e-9
        )
        assert half * abs(np.sin(inc)) / tol == pytest.approx(
            1.0, abs=0.3 * (half / 2.0) ** 2 + 1e-12
        )
    assert float(raan_half_width_rad(tol, np.pi / 2)) == pytest.approx(tol, rel=1e-12)
    for inc in (0.0, 0.2 * tol, 0.499 * tol, np.pi - 0.4 * tol):
        assert float(raan_half_width_rad(tol, inc)) == np.pi
        assert _plane_angle(_normal(inc, 0.0), _normal(inc, np.pi)) <= tol


@pytest.mark.parametrize("inc_deg, tol_deg, held", [(1.0, 2.0, False), (90.0, 0.03, True)])
def test_relative_node_is_held_as_the_tilt_of_the_plane(profile, inc_deg, tol_deg, held):
    """The i = 1 deg validation design (a 5000, e 0.05, AOP 180, one satellite in each of two planes): within 16
    days its mean relative RAAN runs past a 2 deg tolerance (the RAAN rule burned there), but at i = 1 deg no node
    tilts the plane by 2 deg, so the node is left free; the same design polar, with a tolerance that its few
    hundredths of a degree of relative RAAN exceed, is held."""
    el = WalkerDesign(5000.0, 0.05, 180.0, inc_deg, 2, 1).elements_deg()
    prof = load_settings(
        "paper",
        overrides={
            "gravity": {"degree": 8},
            "design_life": {"service": {"tolerances": "fixed", "raan_rel_deg": tol_deg}},
        },
    )
    ds = fly(prof, el, life_days=16.0)
    raan_err = np.abs(ds["box_error_tidal_mean"].sel(box="raan_rel_deg").values)
    assert np.nanmax(raan_err[:, ds["check_day"].values[0] > 13.7]) > np.radians(tol_deg)
    assert ("relative_node" in ds["maneuver_purpose"].values) == held


def test_mean_vectors_match_the_state_vectors():
    """e and j of elements built from the classical definitions (identity frame) against r x v of the state."""
    from lnss_lib.elements import elements_to_state

    gm = 4902.8
    el = np.array([6143.0, 0.6, np.radians(51.7), np.radians(40.0), np.radians(90.0), 0.3])
    state = elements_to_state(el, gm)
    r, v = state[:3], state[3:]
    h = np.cross(r, v)
    e_ref = np.cross(v, h) / gm - r / np.linalg.norm(r)
    j_ref = h / np.sqrt(gm * el[0])
    e_vec, j_vec = mean_vectors_j2000(el[None, :], np.eye(3))
    np.testing.assert_allclose(e_vec[0], e_ref, atol=1e-12)
    np.testing.assert_allclose(j_vec[0], j_ref, atol=1e-12)


def test_box_that_drives_satellites_out_of_lunar_orbit_reports_them_and_completes(paper_profile):
    """a 15940 km, e 0.734, i 62.1 deg, AOP 180 deg, three planes of one satellite, one year with the box (the
    box controller, whose burns unbind two of the orbits): the planner was handed hyperbolic elements
    and the evaluation stopped ("elements must be 6 finite values"); now every loss is reported with its day
    and cause and the others fly on."""
    el = WalkerDesign(15940.0, 0.734, 180.0, 62.1, 3, 1).elements_deg()
    ds = fly(
        paper_profile,
        el,
        design_life=dataclasses.replace(
            paper_profile.design_life, life_days=365.0, controller="box"
        ),
    )
    causes = [str(c) for c in ds["loss_cause"].values]
    assert "escape (unbound orbit)" in causes
    lost = np.isfinite(ds["loss_day"].values)
    assert np.all((ds["loss_day"].values[lost] > 0.0) & (ds["loss_day"].values[lost] < 365.0))
    assert [c != "" for c in causes] == lost.tolist()
    assert np.all(np.isfinite(ds["dv_kms_per_year"].values))


def test_a_satellite_whose_propagation_fails_is_reported_and_the_others_fly_on(
    profile, model, monkeypatch
):
    """The engine gives up on satellite 1 in the third chunk (as it did on a Table 6 design: 'propagation failed
    for satellite(s) [9]' stopped the evaluation): it is reported lost with the engine's reason, satellite 0 flies
    the whole life."""
    from lnss_lib.design_life import fleet
    from lnss_lib.propagator import STATUS_MAX_STEPS, STATUS_TEXT

    engine, calls = fleet.integrate_chunk, []

    def failing(y0s, active, t0, t_out, *rest):
        states, y_end, status, t_stop = engine(y0s, active, t0, t_out, *rest)
        if y0s.shape[0] == 2:  # the life loop (the insertion trim flies one at a time)
            calls.append(t0)
            if len(calls) == 3:
                states[1], y_end[1], status[1], t_stop[1] = (
                    np.nan,
                    np.nan,
                    STATUS_MAX_STEPS,
                    t_out[0],
                )
        return states, y_end, status, t_stop

    monkeypatch.setattr(fleet, "integrate_chunk", failing)
    el = [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0], [6143.0, 0.6, 51.7, 0.0, 90.0, 180.0]]
    ds = fly(profile, el, life_days=10.0, model=model)
    assert (
        str(ds["loss_cause"].values[1]) == f"propagation failed ({STATUS_TEXT[STATUS_MAX_STEPS]})"
    )
    assert 0.0 < float(ds["loss_day"][1]) < 10.0 and not bool(ds["impact"][1])
    assert str(ds["loss_cause"].values[0]) == "" and np.isfinite(
        ds["mean_elements"].values[0, -1, 0]
    )


def test_a_safety_raise_keeps_the_recorded_dip_below_the_averaged_perilune():
    """After a raise, the floor's margin (the dip of the osculating perilune below the averaged one) is what it was:
    the recorded minima move with the e vectors. Left behind, the raise itself read as a dip and a week later
    called for a second burn (a 6500 km e 0.5 design paid 0.45 km/s/yr instead of 0.14)."""
    from lnss_lib.design_life.service import raised_history

    a_km, rng = 6500.0, np.random.default_rng(7)
    history = []
    for k in range(8):
        e_vec = np.array([0.5 + 0.01 * rng.standard_normal(), 0.01 * rng.standard_normal(), 0.0])
        rp_min = a_km * (1.0 - np.linalg.norm(e_vec)) - 30.0 - 5.0 * rng.random()
        history.append((float(k), e_vec, np.array([0.0, 0.0, 1.0]), rp_min))

    def dip(hist):
        e_mean = np.mean([h[1] for h in hist], axis=0)
        return a_km * (1.0 - np.linalg.norm(e_mean)) - min(h[3] for h in hist)

    e_now = np.mean([h[1] for h in history], axis=0)
    raised = raised_history(history, -0.05, e_now, float(np.linalg.norm(e_now)), a_km)
    assert dip(raised) == pytest.approx(dip(history), rel=1e-9)
    assert dip(history) > 30.0
    e_after = np.mean([h[1] for h in raised], axis=0)
    assert np.linalg.norm(e_after) == pytest.approx(np.linalg.norm(e_now) - 0.05, rel=1e-9)


def test_the_safety_prediction_over_the_lead_finds_the_crossings_of_the_whole_life(profile):
    """The controller acts on a predicted crossing within ``safety_lead_days`` only, so it integrates the averaged
    model over the lead plus one ``safety_check_days`` (the next check looks again). On orbits the tides drive down
    before and after the lead, the crossings within the lead are those of the rest-of-life prediction to the bit,
    and none beyond the lead reads as within it."""
    from lnss_lib.design_life.secular import SecularField
    from lnss_lib.design_life.service import predicted_crossing_day
    from lnss_lib.ephemeris import tdb_seconds
    from lnss_lib.frames import element_frame_to_j2000

    svc, life = profile.design_life.service, 365.0
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    field = SecularField.from_settings(profile.stability, profile.dynamics, t0, life + 1.0)
    ecc, aop = (x.ravel() for x in np.meshgrid([0.6, 0.65, 0.7], np.radians([30.0, 45.0, 60.0])))
    mel = np.column_stack(
        [np.full(ecc.size, 6143.0), ecc, np.full(ecc.size, np.radians(70.0)), 0 * ecc, aop, 0 * ecc]
    )
    e_vec, j_vec = mean_vectors_j2000(mel, element_frame_to_j2000(profile.dynamics, t0))
    floor_km = profile.dynamics.r_impact_km + svc.perilune_margin_km
    lead, horizon = svc.safety_lead_days, svc.safety_lead_days + svc.safety_check_days
    whole = predicted_crossing_day(field, 0.0, mel[:, 0], e_vec, j_vec, floor_km, life)
    short = predicted_crossing_day(field, 0.0, mel[:, 0], e_vec, j_vec, floor_km, horizon)
    within = whole <= lead
    assert within.any() and (whole > lead).any(), whole
    np.testing.assert_array_equal(short[within], whole[within])
    assert not np.any(short[~within] <= lead), (short, whole)


def test_navigation_monitor_gives_the_verdicts_of_spice_and_the_dataset_path(profile):
    """The monitor (tabulated Moon-fixed rotation, compiled DOP statistics) against the path it replaced (SPICE per
    sample, the Dataset DOP and its summary) on three windows: the baseline, the same geometry, and the apolunes
    moved off the pole (a violation). The rotation differs by < 6e-12 (tests/test_frames.py) and the sums by
    rounding: the DOP means agree to 1e-9 relative, the availabilities within one sample of the window, and every
    verdict is the same."""
    from lnss_lib.design_life.service import NavigationMonitor, navigation_violations
    from lnss_lib.dop import dop_for_settings, summary_for_settings
    from lnss_lib.elements import kepler_states
    from lnss_lib.ephemeris import EphemerisTable, tdb_seconds
    from lnss_lib.frames import rotate_to_moon_fixed

    prof = profile
    dyn, svc = prof.dynamics, prof.design_life.service
    t0 = tdb_seconds(prof.epoch.start_tdb, "TDB")
    window_s = svc.nav_window_days * 86400.0
    sample_t = t0 + 900.0 * np.arange(int(3 * window_s / 900.0) + 1)
    design = np.array(
        [[6143.0, 0.6, np.radians(57.7), k * np.pi / 3, np.radians(90.0), k] for k in range(6)]
    )
    moved = design.copy()
    moved[:, 4] = np.radians(10.0)
    late = sample_t > t0 + 2.0 * window_s
    r = np.concatenate(
        [
            kepler_states(el, sample_t[part] - t0, dyn.gravity.gm_km3_s2)[..., :3]
            for el, part in ((design, ~late), (moved, late))
        ],
        axis=1,
    )
    table = EphemerisTable.build(dyn, sample_t[0], sample_t[-1])
    monitor = NavigationMonitor(prof.dop, dyn, sample_t, svc, table)
    assert monitor.offset is not None
    grid, baseline, verdicts, start = monitor.grid, None, [], sample_t[0]
    for k in (1, 2, 3):
        t = t0 + k * window_s
        monitor.update(t, r)
        idx = np.flatnonzero((sample_t > start) & (sample_t <= t))
        start = t
        tt = sample_t[idx]
        old = summary_for_settings(
            prof.dop, dop_for_settings(prof.dop, rotate_to_moon_fixed(dyn, r[:, idx], tt), tt, grid)
        )
        if baseline is None:
            baseline = old
            one_sample_pct = 100.0 / idx.size
            for key in ("pdop_avail_pct", "hdop_avail_pct"):
                assert abs(monitor.baseline[key] - old[key]) <= one_sample_pct
            for key in ("pdop_mean_3sigma", "hdop_mean_3sigma"):
                np.testing.assert_allclose(monitor.baseline[key], old[key], rtol=1e-9)
            continue
        verdicts.append(monitor.violated)
        assert monitor.violated == bool(navigation_violations(old, baseline, svc))
    assert verdicts == [False, True]
