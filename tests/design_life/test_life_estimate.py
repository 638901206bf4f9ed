"""The life-long estimate of the service controller's cost: frozen orbits cost nothing, the cost
rises with the libration amplitude, a perilune predicted to cross the floor pays safety, and the band laws."""

import dataclasses

import numpy as np
import pytest

from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.design_life import life_estimate as le
from lnss_lib.design_life import life_navigation as ln
from lnss_lib.design_life import life_relative as lr
from lnss_lib.design_life import tolerances as tol
from lnss_lib.design_life.frozen import FrozenModel, libration
from lnss_lib.design_life.screen import cached_field, screen_states
from lnss_lib.ephemeris import ensure_kernels, tdb_seconds
from lnss_lib.evaluator import context_for, evaluate_design
from lnss_lib.keys import LIFE_NAVIGATION_KEYS
from lnss_lib.propagator import elements_deg_to_states, propagate_states
from lnss_lib.settings import load_settings

LIFE = {
    "frames": {"element_frame": "moon_op"},
    "sk_estimate": {"model": "life", "arc_frame": "moon_op"},
    "gravity": {"degree": 8},
    "stability": {"span_days": 365.25},
}
ELFO = (6143.0, 0.6, 51.7)
"""The Table 4 ELFO's a, e, i: frozen in moon_op (e^2 + 5/3 cos^2 i = 1 near e 0.6, i 51.7 deg)."""


@pytest.fixture(scope="module")
def profile():
    prof = load_settings("operational", overrides=LIFE)
    ensure_kernels(prof.ephemeris)
    return prof


def _estimate(profile, elements):
    """The campaign's estimate of elements (n, 6) [a, e, i, RAAN, AOP, M] (moon_op) from their 10-day arc."""
    dyn = profile.dynamics
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    states = elements_deg_to_states(dyn, np.asarray(elements, dtype=float), t0)
    arc = propagate_states(
        dyn,
        states,
        t0,
        profile.epoch.duration_days * SECONDS_PER_DAY,
        profile.epoch.step_s,
        batch=True,
    )
    return le.campaign_estimate(
        profile.sk_estimate, profile.stability, profile.design_life, dyn, profile.dop, arc
    )


def _two_planes(a, e, inc, aop):
    return [[a, e, inc, 0.0, aop, 0.0], [a, e, inc, 180.0, aop, 0.0]]


def test_frozen_orbit_that_meets_every_requirement_costs_nothing(profile):
    """The Table 4 ELFO read in moon_op, one satellite per plane: the closed loop flies no burn there (notebook 08),
    and the estimate charges nothing for any purpose."""
    est = _estimate(profile, _two_planes(*ELFO, 90.0))
    for part in (*le.PARTS, "total"):
        assert np.all(est["per_sat"][part] == 0.0), part
    assert est["sk_dv_estimate_max_kms_per_year"] == 0.0 and np.all(est["n_safety_burns"] == 0)


def test_estimate_rises_with_the_libration_amplitude(profile):
    """Same a, e and i, the apse line moved away from the frozen AOP 90 deg: the libration swings e higher (the
    frozen model's range) and the safety cost, and the total with its navigation part, grow with it, from nothing at
    the frozen point."""
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    model = FrozenModel.from_settings(profile.stability, profile.dynamics, t0)
    aops = (90.0, 70.0, 50.0, 30.0)
    e_max = [libration(model, *ELFO, aop)["ecc_max"] for aop in aops]
    assert np.all(np.diff(e_max) > 0.0)
    estimates = [_estimate(profile, _two_planes(*ELFO, aop))["per_sat"] for aop in aops]
    safety = [float(np.mean(est["safety"])) for est in estimates]
    assert safety[0] == 0.0
    assert np.all(np.diff(safety) >= 0.0) and safety[-1] > 0.1  # km/s per year
    total = [float(np.mean(est["total"])) for est in estimates]
    assert total[0] == 0.0 and np.all(np.diff(total) >= 0.0)


def test_perilune_predicted_to_cross_the_floor_pays_safety(profile):
    """Lidov-Kozai drives this perilune into the surface within two months (the screen says so); the estimate
    places a safety burn before the crossing and books a positive safety share."""
    elements = [[6143.0, 0.6, 70.0, 0.0, 45.0, 0.0]]
    dyn = profile.dynamics
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    screen = screen_states(
        profile.stability, dyn, elements_deg_to_states(dyn, np.array(elements), t0), t0
    )
    assert not screen.attrs["stable"]
    est = _estimate(profile, elements)
    assert est["n_safety_burns"][0] >= 1
    assert est["per_sat"]["safety"][0] > 0.0
    assert est["per_sat"]["total"][0] == pytest.approx(sum(est["per_sat"][p][0] for p in le.PARTS))


class _Reads:
    """A settings section that records the dotted keys read from it (through its nested sections)
    into ``seen``."""

    def __init__(self, section, prefix: str, seen: set):
        self._section, self._prefix, self._seen = section, prefix, seen

    def __getattr__(self, name):
        value, key = getattr(self._section, name), f"{self._prefix}.{name}"
        if dataclasses.is_dataclass(value):
            return _Reads(value, key, self._seen)
        self._seen.add(key)
        return value


def test_the_estimate_reads_the_design_life_settings_the_evaluation_hash_holds(profile):
    """Every ``[design_life]`` setting the campaign's life estimate reads, on a design that pays
    safety, on a constellation whose drift the navigation monitor restores and with either tolerance
    source, is one of :data:`~lnss_lib.campaign.settings.LIFE_ESTIMATE_KEYS` (the settings a
    campaign's evaluation hash holds where its evaluations run the estimate), and each of those is
    read."""
    from types import SimpleNamespace

    from lnss_lib.campaign.settings import LIFE_ESTIMATE_KEYS

    seen = set()
    design_life = _Reads(profile.design_life, "design_life", seen)
    recording = SimpleNamespace(
        **{
            name: getattr(profile, name) for name in ("sk_estimate", "stability", "dynamics", "dop")
        },
        epoch=profile.epoch,
        design_life=design_life,
    )
    est = _estimate(recording, [[6143.0, 0.6, 70.0, 0.0, 45.0, 0.0]])  # the safety case above
    assert est["n_safety_burns"][0] >= 1
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    drift = ln.navigation_restores(
        profile.dop, profile.dynamics, design_life, t0, *_rebuilt_case(profile, 1.0)
    )
    assert drift["violations"]
    for source in ("fixed", "derived"):
        service = dataclasses.replace(profile.design_life.service, tolerances=source)
        tol.estimate_tolerances_deg(_Reads(service, "design_life.service", seen))
    assert seen == set(LIFE_ESTIMATE_KEYS)


def test_node_band_corrects_a_steady_differential_drift():
    """Two satellites drifting apart at a steady rate: each is corrected when its offset from the mean leaves the
    band, aimed past the reference (overshoot law), no more often than the spacing."""
    t = np.arange(0.0, 366.0)
    rate = np.radians(0.1)  # rad/day, each way
    drift = np.stack([rate * t, -rate * t])
    half = np.radians(np.array([3.0, 3.0]))
    events = lr.node_corrections(t, drift, half, 0.8, 7.0)
    for sat in events:
        days = np.array([k for k, _ in sat])
        assert days.size >= 5 and np.all(np.diff(days) >= 7)
    total = sum(abs(change) for sat in events for _, change in sat)
    assert total == pytest.approx(
        2.0 * rate * 365.0, rel=0.15
    )  # the drift taken out, to within one band
    assert lr.node_corrections(t, 0.5 * half[:, None] * np.ones((2, t.size)), half, 0.8, 7.0) == [
        [],
        [],
    ]


def test_phase_band_sets_a_drift_rate_only_outside():
    """A slot drifting out of its band gets a drift rate back across it; slots inside the band get nothing."""
    t = np.arange(0.0, 200.0)
    half = np.radians(20.0)
    assert lr.phase_corrections(t, np.zeros((3, t.size)), half, 0.8, 45.0, 1.0) == [[], [], []]
    drift = np.stack([np.radians(0.5) * t, np.zeros_like(t)])
    events = lr.phase_corrections(t, drift, half, 0.8, 45.0, 1.0)
    first_day, first_rate = events[0][0]
    assert 60 <= first_day <= 90  # the relative offset (half the drift) leaves 20 deg
    assert first_rate < 0.0  # commanded back
    assert abs(first_rate) * 45.0 * SECONDS_PER_DAY == pytest.approx(1.8 * half, rel=0.3)


def test_evaluator_reports_the_life_estimate_when_asked():
    """``[sk_estimate] model = "life"`` changes only the estimate's model: the evaluator's keys stay the same."""
    over = {
        **LIFE,
        "evaluator": {
            "extra_metrics": [
                "sk_dv_estimate_kms_per_year",
                "sk_dv_estimate_max_kms_per_year",
                "stable_screen",
            ]
        },
    }
    metrics = evaluate_design(
        context_for(load_settings("ci", overrides=over)), 6143.0, 0.6, 90.0, 51.7, 2, 1
    )
    assert metrics["sk_dv_estimate_kms_per_year"] == 0.0 and metrics["stable_screen"] == 1.0


def test_evaluator_reports_the_navigation_over_the_life_when_asked():
    """The Table 4 ELFO as two planes of four keeps its service for the life: availabilities over the life and in the
    worst month within [0, 100], the worst month no better than the mean, both close to the 10-day arc's (the orbit
    is frozen: only the Moon's turn changes the geometry from month to month); an orbit that hits the Moon has none."""
    over = {**LIFE, "evaluator": {"extra_metrics": list(LIFE_NAVIGATION_KEYS)}}
    context = context_for(load_settings("ci", overrides=over))
    metrics = evaluate_design(context, 6143.0, 0.6, 90.0, 51.7, 2, 4)
    for name in ("pdop", "hdop"):
        life, worst = (
            metrics[f"{name}_avail_pct_life_estimate"],
            metrics[f"{name}_avail_pct_worst_month_estimate"],
        )
        assert 0.0 <= worst <= life <= 100.0
        assert life == pytest.approx(
            metrics[f"{name}_avail_pct"],
            abs=context.settings.design_life.service.nav_avail_drop_pct,
        )
    hit = evaluate_design(context, 2000.0, 0.5, 90.0, 51.7, 2, 2)
    assert all(np.isnan(hit[key]) for key in LIFE_NAVIGATION_KEYS)


def test_the_campaign_estimate_holds_the_upper_tilt_when_tolerances_are_derived(profile):
    """The derivation's arc costs ten evaluations, so the campaign's estimate takes the tilt the derivation gives the
    designs of a front (the upper bound) and the fixed slot; with fixed tolerances the fixed values."""
    svc = profile.design_life.service
    derived = dataclasses.replace(svc, tolerances="derived")
    assert tol.estimate_tolerances_deg(derived) == {
        "raan_rel": svc.raan_rel_bounds_deg[1],
        "u_rel": svc.u_rel_deg,
    }
    fixed = dataclasses.replace(svc, tolerances="fixed")
    assert tol.estimate_tolerances_deg(fixed) == {
        "raan_rel": svc.raan_rel_deg,
        "u_rel": svc.u_rel_deg,
    }


def test_a_wider_node_tolerance_costs_no_more_and_none_beyond_the_drift(profile):
    """Four planes of a circular 20300 km orbit at i 30 deg drift apart in node (the closed loop pays for it): the
    relative-node share falls as the tilt tolerance widens, and a band wider than the whole drift over the life
    costs nothing."""
    dyn = profile.dynamics
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    elements = np.array([[20300.0, 0.0, 30.0, 90.0 * k, 276.0, 0.0] for k in range(4)])
    states = elements_deg_to_states(dyn, elements, t0)
    arc = propagate_states(
        dyn,
        states,
        t0,
        profile.epoch.duration_days * SECONDS_PER_DAY,
        profile.epoch.step_s,
        batch=True,
    )
    screen = screen_states(profile.stability, dyn, states, t0)
    field = cached_field(profile.stability, dyn, t0)[0]
    node = [
        float(
            np.mean(
                le.life_estimate(
                    profile.sk_estimate,
                    profile.design_life,
                    dyn,
                    profile.dop,
                    arc,
                    screen,
                    field,
                    {"raan_rel": tilt, "u_rel": 20.0},
                )["per_sat"]["relative_node"]
            )
        )
        for tilt in (1.0, 4.7, 10.0, 90.0)
    ]
    assert node[0] > 0.0 and np.all(np.diff(node) <= 0.0)
    assert node[-1] == 0.0


def _rebuilt_case(profile, drift: float, days: int = 200):
    """Two planes of four satellites (9800 km, e 0.39, i 58 deg, AOP 58 deg: the cheapest designs of the quick
    operational front) whose e, i and AOP run along ``drift`` times the averaged model's first three months for those
    designs (e +0.004, i -0.16 deg and AOP +0.18 deg a day: 0.39 to 0.75, 58 to 43 deg, 56 to 73 deg), held after day
    100: the navigation estimate's inputs."""
    t_days = np.arange(float(days))
    ramp = drift * np.minimum(np.tile(t_days, (8, 1)), 100.0)
    ecc = 0.39 + 0.004 * ramp
    inc, aop = np.radians(58.0 - 0.16 * ramp), np.radians(58.0 + 0.18 * ramp)
    raan = np.radians(np.repeat([0.0, 180.0], 4))[:, None] * np.ones(t_days.size)
    u0 = np.radians(np.concatenate([np.arange(4) * 90.0, np.arange(4) * 90.0 + 45.0]))
    return t_days, np.full(8, 9800.0), u0, raan, ecc, inc, aop


def test_navigation_restores_only_a_drift_that_degrades_the_dop(profile):
    """Elements that hold still are never judged (no satellite leaves the box) and cost nothing; the Lidov-Kozai drift
    of the front's cheapest designs breaks the DOP requirement, and every satellite is restored at least once, at a
    cost of the restore's order (the e change alone, h de / (2 p) with de at least the box, bounds one restore
    below)."""
    dyn, t0 = profile.dynamics, tdb_seconds(profile.epoch.start_tdb, "TDB")
    still = ln.navigation_restores(
        profile.dop, dyn, profile.design_life, t0, *_rebuilt_case(profile, 0.0)
    )
    assert still["n_judged"] == 0 and np.all(still["dv_kms"] == 0.0) and not still["violations"]
    drift = ln.navigation_restores(
        profile.dop, dyn, profile.design_life, t0, *_rebuilt_case(profile, 1.0)
    )
    assert drift["violations"] and np.all(drift["n_restores"] >= 1)
    box = profile.design_life.box.ecc
    gm = dyn.gravity.gm_km3_s2
    p = 9800.0 * (1.0 - 0.39**2)
    assert np.all(drift["dv_kms"] >= drift["n_restores"] * np.sqrt(gm * p) * box / (2.0 * p))
    assert np.all(drift["dv_kms"] < 2.0)  # km/s: a few restores of e changes below 0.4


def test_navigation_judges_by_the_monitors_rule(profile):
    """Up to its first restore, the estimate flags exactly the windows that the monitor's rule flags on the monitor's
    own DOP path (:func:`lnss_lib.dop.dop_for_settings`, :func:`lnss_lib.dop.summary_for_settings`,
    :func:`lnss_lib.design_life.service.navigation_violations`) for the rebuilt constellation at each window's own
    lattice epochs, and reports those windows' availabilities."""
    from lnss_lib.design_life.service import navigation_violations
    from lnss_lib.dop import dop_for_settings, summary_for_settings
    from lnss_lib.frames import element_frame_to_j2000, rotate_to_moon_fixed
    from lnss_lib.surface_grid import SurfaceGrid

    dyn, t0 = profile.dynamics, tdb_seconds(profile.epoch.start_tdb, "TDB")
    svc = profile.design_life.service
    t_days, sma, u0, raan, ecc, inc, aop = _rebuilt_case(profile, 1.0)
    est = ln.navigation_restores(
        profile.dop, dyn, profile.design_life, t0, t_days, sma, u0, raan, ecc, inc, aop
    )
    first = min(est["violations"])
    edges = ln.navigation_windows(t_days, svc.nav_window_days)
    grid = SurfaceGrid.from_settings(profile.dop, dyn.constants.r_moon_mean_km)
    period_s = 2.0 * np.pi * np.sqrt(9800.0**3 / dyn.gravity.gm_km3_s2)

    def monitor_summary(j):
        span_s = (t_days[edges[j + 1]] - t_days[edges[j]]) * SECONDS_PER_DAY
        t = ln.lattice_epochs_s(span_s, period_s, ln.NAV_SAMPLES_PER_WINDOW)
        k = edges[j] + np.rint(t / SECONDS_PER_DAY).astype(int)
        times = t0 + t_days[edges[j]] * SECONDS_PER_DAY + t
        r = ln.rebuilt_positions_j2000(
            sma,
            u0,
            ecc[:, k],
            inc[:, k],
            raan[:, k],
            aop[:, k],
            times - t0,
            element_frame_to_j2000(dyn, t0),
            dyn.gravity.gm_km3_s2,
        )
        return summary_for_settings(
            profile.dop,
            dop_for_settings(profile.dop, rotate_to_moon_fixed(dyn, r, times), times, grid),
        )

    baseline = monitor_summary(0)
    summaries = {j: monitor_summary(j) for j in range(1, first + 1)}
    flagged = {j: navigation_violations(summaries[j], baseline, svc) for j in summaries}
    assert {j: v for j, v in flagged.items() if v} == {first: est["violations"][first]}
    for j, summary in summaries.items():
        assert est["pdop_avail_pct_windows"][j] == pytest.approx(
            summary["pdop_avail_pct"], abs=1e-9
        )


def test_lattice_epochs_spread_both_the_window_and_the_orbit():
    """The lattice's epochs lie in the window, spread over it within an orbit of even spacing, and their orbital
    phases fill every one of n equal bins of the orbit at most twice (evenly spaced epochs on a whole number of orbits
    would put every sample at one phase)."""
    period_s, n = 86400.0 / 2.0, 64
    t = ln.lattice_epochs_s(30.0 * 86400.0, period_s, n)
    assert np.all((t >= 0.0) & (t <= 30.0 * 86400.0))
    assert np.all(np.abs(t - (np.arange(n) + 0.5) / n * 30.0 * 86400.0) <= period_s / 2.0 + 1e-6)
    counts = np.bincount(np.floor((t % period_s) / period_s * n).astype(int), minlength=n)
    assert counts.max() <= 2 and np.count_nonzero(counts) >= 0.6 * n


def test_life_availability_is_the_windows_mean_and_their_worst(profile):
    """The life's availability is the mean of its windows weighted by their lengths, which cover the life; the worst
    month is the lowest window; elements that hold still never fall more than the monitor allows (only the Moon's
    turn and the epochs differ between windows)."""
    dyn, t0 = profile.dynamics, tdb_seconds(profile.epoch.start_tdb, "TDB")
    still = ln.navigation_restores(
        profile.dop, dyn, profile.design_life, t0, *_rebuilt_case(profile, 0.0)
    )
    assert (
        np.sum(still["window_days"]) == pytest.approx(199.0, abs=1e-9)
        and still["window_days"].size == 7
    )
    for key in ln.AVAILABILITY_KEYS:
        windows = still[f"{key}_windows"]
        assert still[f"{key}_worst_month_estimate"] == np.min(windows)
        assert still[f"{key}_life_estimate"] == pytest.approx(
            np.average(windows, weights=still["window_days"])
        )
        assert np.all(windows[0] - windows < profile.design_life.service.nav_avail_drop_pct)


def test_life_availability_falls_when_the_apolune_drifts_off_the_pole(profile):
    """Two planes of four ELFO-like orbits whose apolune sits over the south pole (AOP 90 deg) serve it; let the AOP
    run to the equator (0 deg) and the worst month falls far below the first, as does the life's mean, although the
    monitor restores the drift each time it breaks the requirement (e and i held: only the apolune moves)."""
    dyn, t0 = profile.dynamics, tdb_seconds(profile.epoch.start_tdb, "TDB")
    t_days = np.arange(200.0)
    ones = np.ones((8, t_days.size))
    raan = np.radians(np.repeat([0.0, 180.0], 4))
    u0 = np.radians(np.concatenate([np.arange(4) * 90.0, np.arange(4) * 90.0 + 45.0]))
    case = (
        t_days,
        np.full(8, 6143.0),
        u0,
        raan[:, None] * ones,
        0.6 * ones,
        np.radians(51.7) * ones,
    )
    held = ln.navigation_restores(
        profile.dop, dyn, profile.design_life, t0, *case, np.radians(90.0) * ones
    )
    aop = np.radians(np.maximum(90.0 - 1.5 * t_days, 0.0)) * ones
    drift = ln.navigation_restores(profile.dop, dyn, profile.design_life, t0, *case, aop)
    first = held["pdop_avail_pct_windows"][0]
    assert first > 50.0
    assert (
        drift["pdop_avail_pct_worst_month_estimate"]
        < first - profile.design_life.service.nav_avail_drop_pct
    )
    assert drift["pdop_avail_pct_life_estimate"] < held["pdop_avail_pct_life_estimate"]
    assert drift["violations"]


def test_compiled_relative_angles_are_the_numpy_formula_bit_for_bit():
    from lnss_lib.design_life.mean_elements import circular_mean, wrap_pi

    rng = np.random.default_rng(3)
    x = rng.uniform(-40.0, 40.0, (7, 300))  # several turns either way
    x[2, 10:40] = np.nan  # a satellite lost part of the way
    x[:, 5] = np.nan  # every satellite lost: mean 0 as numpy's nansum
    diff = wrap_pi(x)
    expected = wrap_pi(diff - circular_mean(diff, axis=0)[None, :])
    np.testing.assert_array_equal(lr._relative(x), expected)


def test_distinct_rows_are_bit_for_bit():
    base = np.linspace(0.0, 1.0, 5)
    rows = np.stack(
        [base, base, np.nextafter(base, 2.0), base, np.full(5, np.nan), np.full(5, np.nan)]
    )
    first, back = le._distinct_rows(rows[:, :2], rows[:, 2:])
    np.testing.assert_array_equal(rows[first][back], rows)
    assert len(first) == 3 and back[0] == back[1] == back[3] != back[2] and back[4] == back[5]
