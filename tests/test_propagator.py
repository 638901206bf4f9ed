"""Propagator: conservation laws, analytic J2 rates, scipy equivalence, the reference model, impacts."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from lnss_lib.elements import state_to_elements
from lnss_lib.ephemeris import EphemerisTable, rotation
from lnss_lib.forces import SCRATCH_SIZE, TERMS, ForceModel, acceleration, acceleration_breakdown
from lnss_lib.propagator import (
    ImpactError,
    elements_deg_to_states,
    propagate_elements,
    propagate_states,
)
from lnss_lib.reference import ReferenceModel

ELFO = [6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]


def test_two_body_conserves_energy_and_angular_momentum(two_body_profile, epoch_tdb_s):
    ds = propagate_elements(
        two_body_profile.dynamics,
        two_body_profile.epoch,
        [ELFO],
        t0_tdb_s=epoch_tdb_s,
        duration_s=5 * 86400.0,
    )
    r, v = ds.r_mci_km.values[0], ds.v_mci_kms.values[0]
    gm = ds.attrs["gm_km3_s2"]
    energy = 0.5 * np.sum(v * v, axis=1) - gm / np.linalg.norm(r, axis=1)
    h = np.cross(r, v)
    # the last sample is an integrator step: the converged setting keeps the integrals to 1e-8 over 5 days
    assert abs(energy[-1] / energy[0] - 1) < 1e-8
    assert np.linalg.norm(h[-1] - h[0]) / np.linalg.norm(h[0]) < 1e-9
    # samples between steps come from the quintic Hermite interpolant (velocity good to ~1e-7 km/s)
    assert np.abs(energy / energy[0] - 1).max() < 2e-6
    assert np.abs(h - h[0]).max() / np.linalg.norm(h[0]) < 2e-6


def test_j2_secular_rates_match_analytic(paper_profile, epoch_tdb_s):
    profile = paper_profile.with_overrides(
        {
            "forces": {"third_bodies": [], "srp": False, "albedo": False, "relativity": False},
            "integrator": {"setting": "converged"},
        }
    )
    duration = 10 * 86400.0
    table = EphemerisTable.build(profile.dynamics, epoch_tdb_s, epoch_tdb_s + duration)
    model = ForceModel.build(profile.dynamics, table, degree=2)
    cnm = np.zeros_like(model.field.cnm)
    cnm[0, 0], cnm[2, 0] = 1.0, model.field.cnm[2, 0]
    model = dataclasses.replace(
        model, field=dataclasses.replace(model.field, cnm=cnm, snm=np.zeros_like(cnm))
    )
    a, e, inc = 3000.0, 0.1, 50.0
    ds = propagate_elements(
        profile.dynamics,
        profile.epoch,
        [[a, e, inc, 30.0, 40.0, 0.0]],
        t0_tdb_s=epoch_tdb_s,
        duration_s=duration,
        step_s=300.0,
        model=model,
    )
    # elements in the lunar (MOON_PA) equator frozen at the epoch: inertial, and the field's equator
    rot = rotation("J2000", "MOON_PA", [epoch_tdb_s])[0]
    r_pa = ds.r_mci_km.values[0] @ rot.T
    v_pa = ds.v_mci_kms.values[0] @ rot.T
    el = state_to_elements(np.concatenate([r_pa, v_pa], axis=1), model.field.gm_km3_s2)
    t = ds.time.values - ds.time.values[0]
    raan_rate = np.polyfit(t, np.unwrap(el[:, 3]), 1)[0]
    aop_rate = np.polyfit(t, np.unwrap(el[:, 4]), 1)[0]
    gm, r_ref, j2 = model.field.gm_km3_s2, model.field.r_ref_km, -np.sqrt(5.0) * cnm[2, 0]
    a_mean, e_mean, i_mean = np.mean(el[:, 0]), np.mean(el[:, 1]), np.mean(el[:, 2])
    n = np.sqrt(gm / a_mean**3)
    k = n * j2 * (r_ref / (a_mean * (1 - e_mean**2))) ** 2
    assert raan_rate == pytest.approx(-1.5 * k * np.cos(i_mean), rel=0.02)
    assert aop_rate == pytest.approx(0.75 * k * (5 * np.cos(i_mean) ** 2 - 1), rel=0.03)


def test_integrator_takes_scipy_steps(paper_profile, epoch_tdb_s):
    """Same tableau and controller as solve_ivp: identical evaluation counts and end states."""
    duration = 86400.0
    table = EphemerisTable.build(paper_profile.dynamics, epoch_tdb_s, epoch_tdb_s + duration)
    model = ForceModel.build(paper_profile.dynamics, table)
    y0 = elements_deg_to_states(paper_profile.dynamics, [ELFO], epoch_tdb_s)[0]
    args, work, scratch, terms, acc = (
        model.kernel_args,
        model.field.workspace(),
        np.zeros(SCRATCH_SIZE),
        np.zeros((8, 3)),
        np.zeros(3),
    )

    def rhs(t, y):
        acceleration(t, y, args, work, scratch, terms, acc)
        return np.concatenate([y[3:], acc])

    for setting in ("paper", "converged"):
        cfg = paper_profile.integrator.settings[setting]
        sol = solve_ivp(
            rhs,
            (epoch_tdb_s, epoch_tdb_s + duration),
            y0,
            method=cfg.method,
            rtol=cfg.rtol,
            atol=cfg.atol,
        )
        ds = propagate_states(
            paper_profile.dynamics,
            y0[None],
            epoch_tdb_s,
            duration,
            900.0,
            setting=setting,
            model=model,
        )
        assert int(ds.n_rhs[0]) == sol.nfev
        assert np.linalg.norm(ds.r_mci_km.values[0, -1] - sol.y[:3, -1]) < 1e-6


def test_dense_output_matches_integration_ending_at_the_sample(paper_profile, epoch_tdb_s):
    """Interpolated samples (quintic Hermite between steps) against runs whose last step ends exactly there."""
    fine = load_overrides(paper_profile, "DOP853", 1e-12, 1e-14)
    day = propagate_elements(
        fine.dynamics, fine.epoch, [ELFO], t0_tdb_s=epoch_tdb_s, duration_s=86400.0, step_s=900.0
    )
    for k in (7, 31, 58, 90):
        exact = propagate_elements(
            fine.dynamics,
            fine.epoch,
            [ELFO],
            t0_tdb_s=epoch_tdb_s,
            duration_s=900.0 * k,
            step_s=900.0 * k,
        )
        assert (
            np.linalg.norm(day.r_mci_km.values[0, k] - exact.r_mci_km.values[0, -1]) < 1e-5
        )  # 1 cm
        assert (
            np.linalg.norm(day.v_mci_kms.values[0, k] - exact.v_mci_kms.values[0, -1]) < 1e-7
        )  # 0.1 mm/s


def load_overrides(profile, method, rtol, atol):
    return profile.with_overrides(
        {
            "integrator": {
                "setting": "tight",
                "settings": {"tight": {"method": method, "rtol": rtol, "atol": atol}},
            }
        }
    )


def test_force_model_matches_reference_implementation(paper_profile, epoch_tdb_s, rng):
    ref = ReferenceModel(paper_profile.dynamics)
    times = epoch_tdb_s + rng.uniform(0, 9 * 86400.0, 10)
    states = elements_deg_to_states(
        paper_profile.dynamics,
        [[6143.0, 0.6, 51.7, 10.0, 90.0, m] for m in np.linspace(0, 330, 10)],
        epoch_tdb_s,
    )
    terms = acceleration_breakdown(paper_profile.dynamics, times, states)
    total = sum(terms[k] for k in TERMS)
    for k in range(len(times)):
        expected = ref.acceleration(times[k], states[k, :3], states[k, 3:])
        perturbation = np.linalg.norm(total[k] - terms["central"][k])
        table_floor = 1e-15  # km/s^2: Hermite tables vs direct SPICE (at most 6e-16, validation.table_interpolation_errors)
        assert np.linalg.norm(total[k] - expected) < 1e-8 * perturbation + table_floor


def test_force_terms_have_expected_sizes(paper_profile, epoch_tdb_s):
    """Every term against its closed-form magnitude, at a sunlit state far from the Moon's shadow."""
    from lnss_lib.ephemeris import body_states_mci

    sun = body_states_mci("SUN", [epoch_tdb_s])[0, :3]
    earth = body_states_mci("EARTH", [epoch_tdb_s])[0, :3]
    r = 9000.0 * sun / np.linalg.norm(sun)  # on the day side, towards the Sun
    v = np.cross([0.0, 0.0, 1.0], r)
    v *= np.sqrt(4902.7999671 / 9000.0) / np.linalg.norm(v)
    terms = {
        k: np.linalg.norm(x[0])
        for k, x in acceleration_breakdown(
            paper_profile.dynamics, [epoch_tdb_s], np.concatenate([r, v])[None]
        ).items()
    }
    assert terms["central"] == pytest.approx(4902.7999671 / 9000.0**2, rel=1e-12)
    d_earth, d_sun = np.linalg.norm(earth), np.linalg.norm(sun)
    tidal = lambda gm, d: gm * 9000.0 / d**3  # noqa: E731, differential (tidal) scale
    assert tidal(398600.436233, d_earth) < terms["EARTH"] < 2.1 * tidal(398600.436233, d_earth)
    assert tidal(132712440040.944, d_sun) < terms["SUN"] < 2.1 * tidal(132712440040.944, d_sun)
    assert 1e-16 < terms["JUPITER"] < 1e-14
    craft = paper_profile.spacecraft
    srp_expected = (
        1361.0
        / 299792458.0
        * craft.cr
        * craft.area_m2
        / craft.mass_kg
        * 1e-3
        * (149597870.7 / np.linalg.norm(sun - r)) ** 2
    )
    assert terms["srp"] == pytest.approx(srp_expected, rel=1e-9)
    gm, c = 4902.7999671, 299792.458
    relativity = gm / (c**2 * 9000.0**3) * (4 * gm / 9000.0 - v @ v) * 9000.0  # circular: r.v = 0
    assert terms["relativity"] == pytest.approx(relativity, rel=1e-9)
    # Earth albedo: Lambertian sphere, reflected flux (2/3) A (R/q)^2 phi(phase) of the solar flux
    assert (
        1e-6 * srp_expected
        < terms["albedo"]
        < 0.3 * (2 / 3) * (6378.137 / (d_earth - 9000.0)) ** 2 * 1.1 * srp_expected
    )


def test_conical_shadow_closed_forms():
    from lnss_lib.forces import shadow_factor

    sun = np.array([1.5e8, 0.0, 0.0])
    r_sun, r_body = 696000.0, 1737.4
    assert (
        shadow_factor(np.array([-3000.0, 0.0, 0.0]), sun, 0.0, 0.0, 0.0, r_body, r_sun) == 0.0
    )  # umbra
    assert (
        shadow_factor(np.array([3000.0, 0.0, 0.0]), sun, 0.0, 0.0, 0.0, r_body, r_sun) == 1.0
    )  # day side
    assert (
        shadow_factor(np.array([0.0, 5000.0, 0.0]), sun, 0.0, 0.0, 0.0, r_body, r_sun) == 1.0
    )  # beside the Moon
    # annular: a small body far from the spacecraft, centred on the Sun's disc
    nu = shadow_factor(np.array([-1e6, 0.0, 0.0]), sun, 0.0, 0.0, 0.0, 100.0, r_sun)
    a, b = np.arcsin(r_sun / (1.5e8 + 1e6)), np.arcsin(100.0 / 1e6)
    assert nu == pytest.approx(1 - b**2 / a**2, rel=1e-12)
    # penumbra: the fraction falls monotonically from 1 to 0 across the shadow edge
    edge = [
        shadow_factor(np.array([-3000.0, y, 0.0]), sun, 0.0, 0.0, 0.0, r_body, r_sun)
        for y in np.linspace(1760, 1700, 13)
    ]
    assert edge[0] == 1.0 and edge[-1] == 0.0 and np.all(np.diff(edge) <= 0) and 0 < edge[6] < 1


def test_impact_raises_for_single_and_flags_in_batch(paper_profile, epoch_tdb_s):
    falling = np.array([[2000.0, 0.0, 0.0, -0.5, 0.2, 0.0]])
    with pytest.raises(ImpactError, match="hits the Moon"):
        propagate_states(paper_profile.dynamics, falling, epoch_tdb_s, 86400.0, 900.0)
    healthy = elements_deg_to_states(paper_profile.dynamics, [ELFO], epoch_tdb_s)
    ds = propagate_states(
        paper_profile.dynamics, np.vstack([healthy, falling]), epoch_tdb_s, 86400.0, 900.0
    )
    assert ds.impact.values.tolist() == [False, True]
    assert (
        np.isfinite(ds.impact_t_tdb_s.values[1])
        and ds.impact_t_tdb_s.values[1] - epoch_tdb_s < 3600.0
    )
    assert ds.valid.values[0].all() and not ds.valid.values[1, -1]
    assert np.isnan(ds.r_mci_km.values[1, -1]).all() and np.isfinite(ds.r_mci_km.values[0]).all()


def test_minimum_altitude_parameter(paper_profile, epoch_tdb_s):
    profile = paper_profile.with_overrides({"impact": {"min_altitude_km": 800.0}})
    with pytest.raises(ValueError, match="minimum altitude 800.0 km"):
        propagate_elements(
            profile.dynamics, profile.epoch, [ELFO], t0_tdb_s=epoch_tdb_s, duration_s=3600.0
        )


def test_bad_inputs_rejected(paper_profile, epoch_tdb_s):
    with pytest.raises(ValueError, match="eccentricity"):
        propagate_elements(
            paper_profile.dynamics,
            paper_profile.epoch,
            [[6143.0, 1.0, 51.7, 0, 90, 0]],
            duration_s=3600.0,
        )
    with pytest.raises(ValueError, match="shape"):
        propagate_states(paper_profile.dynamics, np.zeros((2, 5)), epoch_tdb_s, 3600.0, 900.0)
    circular = [[3000.0, 0.0, 0.0, 0.0, np.sqrt(paper_profile.gravity.gm_km3_s2 / 3000.0), 0.0]]
    with pytest.raises(ValueError, match="duration"):
        propagate_states(paper_profile.dynamics, circular, epoch_tdb_s, -1.0, 900.0)
    with pytest.raises(
        ValueError, match="escape speed"
    ):  # a state is a lunar orbit's (elements.check_states_km)
        propagate_states(paper_profile.dynamics, np.ones((1, 6)) * 3000, epoch_tdb_s, 3600.0, 900.0)
    with pytest.raises(ValueError, match="integrator setting"):
        propagate_elements(
            paper_profile.dynamics, paper_profile.epoch, [ELFO], setting="sloppy", duration_s=3600.0
        )


def test_dataset_layout(paper_profile, epoch_tdb_s):
    ds = propagate_elements(
        paper_profile.dynamics,
        paper_profile.epoch,
        [ELFO, [6143.0, 0.6, 51.7, 180.0, 90.0, 0.0]],
        duration_s=86400.0,
    )
    assert ds.r_mci_km.dims == ("sat", "time", "xyz")
    assert ds.sizes["time"] == 97 and ds.time.values[1] - ds.time.values[0] == 900.0
    assert ds.time.values[0] == epoch_tdb_s
    for key in ("frame", "time_scale", "force_model", "integrator", "rtol", "atol"):
        assert key in ds.attrs
    assert "30x30" in ds.attrs["force_model"] and ds.attrs["integrator"] == "RK45"
    assert np.linalg.norm(ds.r_mci_km.values[0, 0]) == pytest.approx(6143.0 * 0.4, rel=1e-12)


# ---- batch kernels report what they did not do ------------------------------------------------


def _batch_model(profile, t0, hours=1.0):
    return ForceModel.build(
        profile.dynamics, EphemerisTable.build(profile.dynamics, t0, t0 + hours * 3600.0), degree=2
    )


def test_batch_loop_that_fails_reports_it(paper_profile, epoch_tdb_s):
    """rtol = atol = 1e-300 overflow the error norms: the step size became NaN and the kernel raised inside the
    parallel loop, where numba lost the exception (zeros written as states, status "ok") or returned a result
    with the exception set. Now the step size is checked (status "non-finite") and the outputs stay NaN."""
    from lnss_lib.errors import PropagationError
    from lnss_lib.propagator import STATUS_NON_FINITE, check_batch, integrate_many, output_times

    times = output_times(epoch_tdb_s, 3600.0, 600.0)
    model = _batch_model(paper_profile, epoch_tdb_s)
    y0 = elements_deg_to_states(paper_profile.dynamics, [ELFO, ELFO], epoch_tdb_s)
    args = (model.kernel_args, model.field.degree)
    out, status, t_stop, _ = integrate_many(
        y0, epoch_tdb_s, times, 0, 1e-300, 1e-300, 1737.4, 100_000, *args
    )
    assert np.all(status == STATUS_NON_FINITE) and np.all(np.isnan(out[:, 1:]))
    with pytest.raises(
        PropagationError, match=r"satellite\(s\) \[0, 1\].*non-finite state"
    ) as caught:
        check_batch(status, t_stop, out, times, epoch_tdb_s)
    assert caught.value.sats == [0, 1]
    out, status, t_stop, _ = integrate_many(
        y0, epoch_tdb_s, times, 0, 1e-6, 1e-9, 1737.4, 100_000, *args
    )
    assert not check_batch(status, t_stop, out, times, epoch_tdb_s).any() and np.all(
        np.isfinite(out)
    )


def test_station_keeping_chunk_kernel_reports_a_lost_satellite(paper_profile, epoch_tdb_s):
    from lnss_lib.design_life.propagation import integrate_chunk
    from lnss_lib.errors import PropagationError
    from lnss_lib.propagator import (
        STATUS_NON_FINITE,
        STATUS_NOT_RUN,
        STATUS_OK,
        check_batch,
        output_times,
    )

    times = output_times(epoch_tdb_s, 3600.0, 600.0)
    model = _batch_model(paper_profile, epoch_tdb_s)
    y0 = elements_deg_to_states(paper_profile.dynamics, [ELFO, ELFO, ELFO], epoch_tdb_s)
    active = np.array([True, False, True])
    no_burns = (np.full((3, 1), np.nan), np.zeros((3, 1, 3)))
    for rtol, expected in ((1e-300, STATUS_NON_FINITE), (1e-6, STATUS_OK)):
        out, y_end, status, t_stop = integrate_chunk(
            y0,
            active,
            epoch_tdb_s,
            times,
            *no_burns,
            0,
            rtol,
            rtol,
            1737.4,
            100_000,
            model.kernel_args,
            model.field.degree,
        )
        assert (
            np.all(status[active] == expected)
            and status[1] == STATUS_NOT_RUN
            and np.all(np.isnan(y_end[1]))
        )
    assert not check_batch(status, t_stop, out, times, epoch_tdb_s, active).any()
    with pytest.raises(PropagationError, match=r"\[1\]"):
        check_batch(
            status, t_stop, out, times, epoch_tdb_s
        )  # the inactive one counts when asked for


def test_check_batch_reads_status_and_samples():
    from lnss_lib.errors import PropagationError
    from lnss_lib.propagator import STATUS_IMPACT, STATUS_MAX_STEPS, STATUS_OK, check_batch

    times = np.arange(5.0)
    states = np.ones((3, 5, 6))
    states[1, 3:] = np.nan  # satellite 1 hits the Moon at t = 3
    status, t_stop = np.array([STATUS_OK, STATUS_IMPACT, STATUS_OK]), np.array([4.0, 3.0, 4.0])
    assert check_batch(status, t_stop, states, times, 0.0).tolist() == [False, True, False]
    holed = states.copy()
    holed[2, 2, 0] = np.nan  # "ok" with a hole: the loop did not write it
    with pytest.raises(PropagationError, match="2: non-finite samples"):
        check_batch(status, t_stop, holed, times, 0.0)
    with pytest.raises(PropagationError, match="0: maximum number of steps"):
        check_batch(
            np.array([STATUS_MAX_STEPS, STATUS_IMPACT, STATUS_OK]), t_stop, states, times, 0.0
        )


def test_compiled_grid_kernels_that_write_nothing_are_caught(monkeypatch):
    from lnss_lib import dop
    from lnss_lib.surface_grid import surface_grid

    monkeypatch.setattr(dop, "_grid_kernel", lambda *args: None)
    grid = surface_grid()
    with pytest.raises(RuntimeError, match="DOP grid kernel left 144 of 144"):
        dop.dop_arrays(np.full((4, 1, 3), 5000.0), grid.r_mf_km, grid.up)
