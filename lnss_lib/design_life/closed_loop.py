"""Closed-loop station keeping over a design life, and natural drift, with the full force model.

Every satellite of a constellation is propagated by the compiled engine
(:func:`lnss_lib.propagator.integrate_one`, satellites in parallel) in chunks of
``check_interval_days`` (at least two orbits). Two controllers (``[design_life] controller``):

- ``"service"`` (the default; :mod:`lnss_lib.design_life.service`) holds what the service needs: the perilune
  above the floor as predicted by the averaged model (safety burns, flown even beyond the Delta-v cap),
  the navigation of each window of sampled positions against the first window's (a violation restores
  e, AOP and i of the satellites outside ``[design_life.box]``), and the relative node and slot within the
  tolerances of :func:`lnss_lib.design_life.tolerances.relative_tolerances_deg`, derived at the start of the life
  from the design's navigation sensitivity (``[design_life.service] tolerances = "derived"``) or fixed (the node as
  the tilt of the plane: a RAAN half-width of :func:`lnss_lib.design_life.service.raan_half_width_rad` of each
  satellite's design inclination, about the tilt / sin i, unbounded below i = tilt / 2; the Dataset's attributes
  ``raan_rel_tolerance_deg``, ``u_rel_tolerance_deg``); e, AOP and i are otherwise left to their natural motion;
- ``"box"`` holds the fixed-element box described below.

A satellite that impacts, escapes (unbound osculating or mean orbit) or whose propagation fails is
reported (``loss_day``, ``loss_cause``) and the others fly on. Every burn is booked with its purpose
(:data:`lnss_lib.design_life.service.PURPOSES`) and where it was flown (:data:`lnss_lib.design_life.service.LOCATIONS`);
``dv_purpose_kms_per_year`` and ``dv_location_kms_per_year`` split ``dv_kms_per_year`` accordingly.

The box: at the end of each chunk the mean elements (:mod:`lnss_lib.design_life.mean_elements`, one orbit of
samples in the element frame) are compared with

- mean e, AOP and i about the design's values (they place the apolune over the south pole);
- RAAN relative to the constellation's mean RAAN (the common precession is left free);
- the mean argument of latitude relative to its slot: nominal phasing plus the constellation's
  mean along-track offset (common drift free).

The design's elements are MEAN elements: at insertion each satellite's osculating a, e, i, RAAN, AOP
and M are trimmed (:func:`lnss_lib.design_life.propagation.trim_to_mean`, fixed point on first-orbit means, no Delta-v counted) so that
each satellite's first-orbit mean a equals its own design a: a Walker plane's common a, a catalogue
file's per-satellite a (designed phasing, e.g. Ely's) as given (a common osculating a at different mean
anomalies leaves their mean a ~5 km apart, which alone drifts the slots ~100 deg in 120 days). Slot
phasing is judged against the design's mean motion, a fixed reference that does not move with anybody's burns.

A satellite out of its box (whose last correction is at least ``min_maneuver_spacing_days`` old and whose
Delta-v cap is not spent) gets one or two impulses on the next orbit, planned from the GVEs and
Newton-refined in two-body motion (:func:`lnss_lib.design_life.manoeuvres.plan_impulses`), so an e-vector pair at
perilune/apolune leaves the osculating a unchanged. A set of burns is flown whole or not at all
(:func:`_enqueue`): never with a non-finite impulse, and, safety apart, never when its total exceeds what is
left of the Delta-v cap (a scaled-down set would hit none of the targets it was solved for) or when an orbit it
leaves, between its burns or after them (two-body flight), has its perilune below the impact radius (plus
``perilune_margin_km`` under the service controller). The one-orbit
MEAN a still moves by a few km when e or AOP change (the orbit-averaged lunar potential seen by the new orbit
differs: 2 a^2/GM Delta<R>), so after every correction the next check measures the mean a and trims it back
with a small tangential burn (:data:`A_TRIM_FRACTION`). The control laws are in :mod:`lnss_lib.design_life.control`: e, AOP, i and
relative RAAN are judged on their running mean over one tidal period (the one-orbit mean e swings by
about +-0.015 at half the sidereal month on the ELFO, hence an e box of 0.03) and aimed past the
reference to the far side of the box; the slot is predicted from the mean-a drift rate
(-1.5 n (a - a_design)/a) and corrected by a drift-band change of a. Reported box ratios use the centred
tidal mean for the geometry (the one-orbit ratios beside them). A satellite can still fail its box when
its secular drift within ``min_maneuver_spacing_days`` exceeds ``box_tolerance`` of the half-width, when
its Delta-v cap is spent, or when it impacts; ``box_held`` then says False and ``max_box_ratio`` which
quantity by how much. ``natural=True`` flies no manoeuvre (natural drift, same insertion trim).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import xarray as xr

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..elements import eccentricity_vector, orbital_period_s, state_to_elements, vis_viva_sma_km
from ..ephemeris import ensure_kernels
from ..forces import ForceModel
from ..frames import element_frame_to_j2000
from ..progress import steps
from ..propagator import (
    METHODS,
    STATUS_IMPACT,
    STATUS_NOT_RUN,
    STATUS_OK,
    STATUS_TEXT,
    check_batch,
    elements_deg_to_states,
)
from ..settings import (
    DesignLifeSettings,
    DopSettings,
    Dynamics,
    IntegratorSetting,
    StabilitySettings,
)
from .control import (
    SlotState,
    drift_band_rate,
    overshoot_target,
    predicted_exit,
    running_mean,
    tidal_mean,
)
from .manoeuvres import candidate_true_anomalies, lowest_perilune_km, mean_anomaly, plan_impulses
from .mean_elements import mean_elements, relative_angles, to_element_frame, wrap_pi
from .propagation import integrate_chunk, life_force_model, trim_to_mean
from .screen import SecularField
from .service import (
    LOCATIONS,
    PURPOSES,
    NavigationMonitor,
    burn_location,
    mean_vectors_j2000,
    raan_half_width_rad,
    raised_history,
    restore_target,
    safety_targets,
)
from .tolerances import relative_tolerances_deg

BOX_KEYS = ("ecc", "aop_deg", "inc_deg", "raan_rel_deg", "u_rel_deg")
"""Box quantities (``[design_life.box]``): half-widths about the reference."""

A_TRIM_FRACTION = 0.1
"""Mean-a check after every manoeuvre set: a residual that would drift the slot by more than this fraction
of its half-width over ``slot_coast_days`` is trimmed at once (a tangential touch of ~0.1 m/s per km)."""


def simulate_life(
    design_life: DesignLifeSettings,
    dynamics: Dynamics,
    elements_deg,
    t0_tdb_s: float,
    *,
    stability: StabilitySettings,
    dop: DopSettings,
    natural: bool = False,
    life_days: float | None = None,
    degree: int | None = None,
    model: ForceModel | None = None,
    sample_step_s: float | None = None,
    insertion_errors_deg=None,
) -> xr.Dataset:
    """Station keeping (or, with ``natural=True``, natural drift) of a constellation over its design life.

    ``design_life`` is the ``[design_life]`` section (``life_days`` replaces its life); the service
    controller also reads ``stability`` (the averaged model of its safety prediction) and ``dop`` (its
    navigation monitor). ``elements_deg`` (n_sat, 6) ``[sma_km, e, inc_deg, raan_deg, aop_deg, M_deg]`` in the
    element frame of ``dynamics.frames`` at TDB ``t0_tdb_s`` are also the references of the box.
    Returns a Dataset with dims ``sat``, ``check`` (mean-element history, one per chunk) and
    ``maneuver``: per satellite ``dv_kms_per_year`` (over the life, or over the flown span of a lost satellite), ``dv_total_kms``, ``n_maneuvers``,
    ``maneuver_t_tdb_s`` and ``maneuver_dv_rtn_kms``, ``box_held``, ``impact``, ``impact_day``,
    ``max_box_ratio`` (largest error / half-width per box quantity after the first check; e, AOP, i and
    relative RAAN on their centred tidal running mean, the slot on the one-orbit mean), ``max_box_ratio_one_orbit``
    (all on one-orbit means), ``n_maneuver_sets``, the insertion trim, and the histories ``mean_elements``,
    ``box_error`` and ``box_error_tidal_mean``. With ``sample_step_s`` the Dataset also holds
    ``r_mci_km`` (sat, sample, xyz): Moon-centred J2000 positions (km) on the grid ``sample_t_tdb_s`` =
    t0 + k ``sample_step_s`` over the life (manoeuvres flown; NaN after an impact), for navigation
    metrics over the design life. ``insertion_errors_deg`` (n_sat, 6), in the units of ``elements_deg``, is added to
    the (trimmed) insertion elements only: the satellites start off their design while the controller keeps
    ``elements_deg`` as its references (an insertion dispersion). Raises ``ValueError`` for invalid elements, life,
    sample step or insertion errors.
    """
    cfg = (
        design_life
        if life_days is None
        else dataclasses.replace(design_life, life_days=float(life_days))
    )
    if not (np.isfinite(cfg.life_days) and cfg.life_days > 0.0):
        raise ValueError(f"life_days = {cfg.life_days!r} must be a positive number of days")
    ensure_kernels(dynamics.ephemeris)
    el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    t0 = float(t0_tdb_s)
    elements_deg_to_states(dynamics, el, t0)
    gm = dynamics.gravity.gm_km3_s2
    life_s = cfg.life_days * SECONDS_PER_DAY
    if model is None:
        model = life_force_model(dynamics, t0, cfg.life_days, degree)
    elif model.table.t0_tdb_s > t0 or model.table.t_end_tdb_s < t0 + life_s:
        raise ValueError("the force model's ephemeris table does not span the design life")
    integ = dynamics.integrator.named(cfg.integrator_setting)
    el_insert, trim_resid = (
        trim_to_mean(dynamics, el, t0, model, integ, samples_per_orbit=cfg.samples_per_orbit)
        if cfg.initial_trim
        else (el.copy(), np.full_like(el, np.nan))
    )
    flown = el_insert
    if insertion_errors_deg is not None:
        errors = np.asarray(insertion_errors_deg, dtype=float)
        if errors.shape != el.shape or not np.all(np.isfinite(errors)):
            raise ValueError(
                f"insertion_errors_deg must be finite with the elements' shape {el.shape}; "
                f"got shape {errors.shape}"
            )
        flown = el_insert + errors
    states = elements_deg_to_states(dynamics, flown, t0)
    rot = element_frame_to_j2000(dynamics, t0)
    r_min = dynamics.r_impact_km
    floor_km = r_min + (
        cfg.service.perilune_margin_km if cfg.controller == "service" else 0.0
    )  # of any burn set but safety's

    n_sat = el.shape[0]
    sample_t = _sample_grid(t0, life_s, sample_step_s)
    r_sample = np.full((n_sat, sample_t.size, 3), np.nan)
    if sample_t.size:
        r_sample[:, 0] = states[:, :3]
    periods = orbital_period_s(el[:, 0], gm)
    step = float(periods.min()) / cfg.samples_per_orbit
    window = np.rint(periods / step).astype(int)
    if life_s < 2.05 * float(periods.max()):
        raise ValueError(
            f"design life {cfg.life_days} days is shorter than 2.05 orbits "
            f"({2.05 * periods.max() / SECONDS_PER_DAY:.2f} days)"
        )
    n_chunks = max(
        1,
        int(
            np.floor(
                life_s / max(cfg.check_interval_days * SECONDS_PER_DAY, 2.05 * float(periods.max()))
            )
        ),
    )
    chunk_s = life_s / n_chunks
    ref_a, ref_ecc, ref_aop, ref_inc = (
        el[:, 0].copy(),
        el[:, 1],
        np.radians(el[:, 4]),
        np.radians(el[:, 2]),
    )
    nom_raan, nom_u = np.radians(el[:, 3]), np.radians(el[:, 4] + el[:, 5])
    half = np.array(
        [
            cfg.box.ecc,
            np.radians(cfg.box.aop_deg),
            np.radians(cfg.box.inc_deg),
            np.radians(cfg.box.raan_rel_deg),
            np.radians(cfg.box.u_rel_deg),
        ]
    )
    box_half = half.copy()
    service = cfg.controller == "service"
    svc = cfg.service
    tol_deg = (
        relative_tolerances_deg(
            svc,
            dop,
            dynamics,
            el_insert,
            t0,
            model=model,
            arc_days=min(svc.tolerance_arc_days, cfg.life_days),
        )
        if service and not natural
        else None
    )
    if tol_deg is not None:
        half = np.array(
            [np.inf, np.inf, np.inf, np.radians(tol_deg["raan_rel"]), np.radians(tol_deg["u_rel"])]
        )
    half = np.tile(half, (n_sat, 1))  # per satellite: the service's node half-width depends on i
    if tol_deg is not None:
        half[:, 3] = raan_half_width_rad(np.radians(tol_deg["raan_rel"]), ref_inc)
    cap_kms = cfg.dv_cap_kms_per_year * cfg.life_days / DAYS_PER_JULIAN_YEAR
    r_moon = dynamics.constants.r_moon_mean_km
    field = (
        SecularField.from_settings(stability, dynamics, t0, cfg.life_days + 1.0)
        if service and not natural
        else None
    )
    nav = (
        NavigationMonitor(dop, dynamics, sample_t, svc)
        if service and not natural and sample_t.size
        else None
    )

    y = states.copy()
    active = np.ones(n_sat, dtype=bool)
    impact_t = np.full(n_sat, np.nan)
    loss_t = np.full(n_sat, np.nan)
    loss_cause = np.full(n_sat, "", dtype=object)
    hist_t, hist_el, hist_err, hist_rp = [], [], [], []
    booked = [[] for _ in range(n_sat)]  # (t, dv_rtn, purpose, location) flown
    queue = [[] for _ in range(n_sat)]  # the same, planned for the next chunk
    last_burn = np.full(n_sat, -np.inf)
    last_safety = -np.inf
    a_hold = np.full(n_sat, np.nan)
    n_sets = np.zeros(n_sat, dtype=int)
    a_tol = (
        A_TRIM_FRACTION
        * half[:, 4]
        / (1.5 * np.sqrt(gm / ref_a**3) / ref_a * cfg.slot_coast_days * SECONDS_PER_DAY)
    )
    dv_used = np.zeros(n_sat)
    slot = [SlotState() for _ in range(n_sat)]
    geo_hist = [[] for _ in range(n_sat)]
    safe_hist = [
        [] for _ in range(n_sat)
    ]  # (t, e and j vectors J2000, lowest osculating perilune km)
    avg_days = 2.0 * cfg.tide_period_days if service else cfg.tide_period_days
    start = time.perf_counter()
    t = t0
    for k_chunk in steps(
        n_chunks,
        f"{'natural drift' if natural else 'station keeping'}: {n_sat} satellite(s), "
        f"{cfg.life_days:g} days",
        "box checks",
    ):
        t_next = t0 + life_s if k_chunk == n_chunks - 1 else min(t + chunk_s, t0 + life_s)
        n_win = int(window.max())
        t_win = t_next - step * np.arange(n_win, -1, -1)
        in_chunk = np.flatnonzero((sample_t > t) & (sample_t <= t_next))
        t_out, where = np.unique(np.concatenate([t_win, sample_t[in_chunk]]), return_inverse=True)
        pending_t, pending_dv = _flight_plan(queue)
        out_states, y_new, status, t_stop = integrate_chunk(
            y,
            active,
            t,
            t_out,
            pending_t,
            pending_dv,
            METHODS.index(integ.method),
            integ.rtol,
            integ.atol,
            r_min,
            5_000_000,
            model.kernel_args,
            model.field.degree,
        )
        # a loop that lost an error (not run) or an "ok" satellite with unwritten samples is a failure of
        # the code, raised; impact, escape and integrator failures are the satellite's loss, reported
        check_batch(
            status,
            t_stop,
            out_states,
            t_out,
            t,
            active & ((status == STATUS_OK) | (status == STATUS_NOT_RUN)),
        )
        bad = active & (status != STATUS_OK)
        for i in np.flatnonzero(active):
            for burn in queue[i]:
                if status[i] == STATUS_OK or burn[0] <= t_stop[i]:
                    booked[i].append(burn)
                    dv_used[i] += float(np.linalg.norm(burn[1]))
            queue[i] = []
        seg_states = out_states[:, where[: t_win.size]]
        r_sample[:, in_chunk] = out_states[:, where[t_win.size :], :3]
        for i in np.flatnonzero(bad):
            loss_t[i] = t_stop[i]
            loss_cause[i] = (
                "impact"
                if status[i] == STATUS_IMPACT
                else f"propagation failed ({STATUS_TEXT[status[i]]})"
            )
        impact_t[bad & (status == STATUS_IMPACT)] = t_stop[bad & (status == STATUS_IMPACT)]
        active &= ~bad
        y = np.where(active[:, None], y_new, y)
        mel = np.full((n_sat, 6), np.nan)
        rp_min = np.full(n_sat, np.nan)
        for i in np.flatnonzero(active):
            win = to_element_frame(seg_states[i, n_win - window[i] :], rot)
            with np.errstate(
                invalid="ignore"
            ):  # an unbound window gives NaN elements, judged just below
                mel[i] = mean_elements(win, gm)
                rp_min[i] = np.min(_perilune_radius_km(win, gm))
            if not (
                np.all(np.isfinite(mel[i]))
                and 0.0 < mel[i, 0]
                and mel[i, 1] < 1.0
                and np.isfinite(rp_min[i])
            ):
                active[i], loss_t[i], loss_cause[i] = False, t_next, "escape (unbound orbit)"
                mel[i], rp_min[i] = np.nan, np.nan
        raan_rel = relative_angles(mel[:, 3], nom_raan, active)
        u_rel = relative_angles(mel[:, 5], nom_u, active)
        err = np.stack(
            [
                mel[:, 1] - ref_ecc,
                wrap_pi(mel[:, 4] - ref_aop),
                mel[:, 2] - ref_inc,
                raan_rel,
                u_rel,
            ],
            axis=1,
        )
        t_mid = t_next - 0.5 * step * window
        hist_t.append(t_mid)
        hist_el.append(mel)
        hist_err.append(err)
        hist_rp.append(rp_min)
        if (
            k_chunk == 0 and not cfg.initial_trim
        ):  # inserted as given: slots drift against the first mean a
            ref_a = np.where(active, mel[:, 0], ref_a)
        t = t_next
        if natural or t >= t0 + life_s - 1e-6:
            continue
        d_ecc = np.full(n_sat, np.nan)
        restore = np.zeros(n_sat, dtype=bool)
        if service:
            ev, jv = mean_vectors_j2000(np.where(active[:, None], mel, 0.0), rot)
            for i in np.flatnonzero(active):
                safe_hist[i] = [
                    h
                    for h in safe_hist[i]
                    if h[0] >= t_mid[i] - 2.0 * cfg.tide_period_days * SECONDS_PER_DAY
                ]
                safe_hist[i].append((t_mid[i], ev[i], jv[i], rp_min[i]))
            if t - last_safety >= svc.safety_check_days * SECONDS_PER_DAY:
                last_safety = t
                d_ecc = safety_targets(
                    field,
                    safe_hist,
                    mel,
                    active,
                    (t - t0) / SECONDS_PER_DAY,
                    cfg.life_days,
                    r_min + svc.perilune_margin_km,
                    svc,
                    cfg.tide_period_days,
                )
            if nav is not None:
                nav.update(t, r_sample)
                if nav.violated:
                    restore = active & np.any(np.abs(err[:, :3]) > box_half[:3], axis=1)
        for i in np.flatnonzero(active):
            slot[i].history.append((t_mid[i], u_rel[i]))
            geo_hist[i].append((t_mid[i], err[i, :4]))
            osc = state_to_elements(to_element_frame(y[i], rot), gm)
            if not (np.all(np.isfinite(osc)) and osc[0] > 0.0 and osc[1] < 1.0):
                active[i], loss_t[i], loss_cause[i] = False, t, "escape (unbound orbit)"
                continue
            if np.isfinite(d_ecc[i]):  # safety first, and beyond the Delta-v cap
                target = {
                    "a_km": 0.0,
                    "ex": d_ecc[i] * np.cos(mel[i, 4]),
                    "ey": d_ecc[i] * np.sin(mel[i, 4]),
                }
                if _enqueue(
                    queue[i], t, osc, gm, [("safety", plan_impulses(osc, gm, target, max_burns=2))]
                ):
                    safe_hist[i] = raised_history(
                        safe_hist[i], d_ecc[i], ev[i], mel[i, 1], mel[i, 0]
                    )
                    a_hold[i], n_sets[i], last_burn[i] = mel[i, 0], n_sets[i] + 1, t
                    slot[i].history = []
                continue
            if dv_used[i] >= cap_kms:
                continue
            if np.isfinite(a_hold[i]):
                d_a, a_hold[i] = a_hold[i] - mel[i, 0], np.nan
                if abs(d_a) > a_tol[i]:
                    plan = plan_impulses(
                        osc,
                        gm,
                        {"a_km": d_a, "ex": 0.0, "ey": 0.0, "inc_rad": 0.0, "raan_rad": 0.0},
                    )
                    if _enqueue(
                        queue[i],
                        t,
                        osc,
                        gm,
                        [("a_trim", plan)],
                        _budget_kms(cap_kms, dv_used[i], queue[i]),
                        floor_km,
                    ):
                        slot[i].history = []
                    continue
            if restore[i]:
                target = restore_target(mel[i, 1], mel[i, 4], err[i, 2], ref_ecc[i], ref_aop[i])
                if _enqueue(
                    queue[i],
                    t,
                    osc,
                    gm,
                    [("navigation", plan_impulses(osc, gm, target, max_burns=2))],
                    _budget_kms(cap_kms, dv_used[i], queue[i]),
                    floor_km,
                ):
                    geo_hist[i] = [(tk, gk - np.append(err[i, :3], 0.0)) for tk, gk in geo_hist[i]]
                    a_hold[i], n_sets[i], last_burn[i] = mel[i, 0], n_sets[i] + 1, t
            if t - last_burn[i] < cfg.min_maneuver_spacing_days * SECONDS_PER_DAY:
                continue
            tt, gg = zip(*geo_hist[i])
            err_avg = np.append(running_mean(np.array(tt), np.array(gg), avg_days), u_rel[i])
            out = np.abs(err_avg) > half[i]
            out[:4] &= tt[-1] - tt[0] >= 0.5 * avg_days * SECONDS_PER_DAY
            out[4] = False
            trend = slot[i].fit(cfg.slot_fit_days, cfg.slot_quad_days, cfg.tide_period_days)
            rate_a = -1.5 * np.sqrt(gm / ref_a[i] ** 3) * (mel[i, 0] - ref_a[i]) / ref_a[i]
            fit = (
                (u_rel[i] if trend is None else trend[0], rate_a, 0.0, 0.0)
                if len(slot[i].history) >= 2
                else None
            )
            if fit is not None:
                out[4] = predicted_exit(*fit[:3], half[i, 4], chunk_s + float(periods[i]))
            if not out.any():
                continue
            groups = [out] if not service else [np.arange(5) == k for k in (3, 4) if out[k]]
            plans = [
                (
                    part,
                    *_plan(
                        osc,
                        mel[i],
                        ref_a[i],
                        err_avg,
                        part,
                        fit,
                        half[i],
                        cfg,
                        gm,
                        hold_u=not service,
                    ),
                )
                for part in groups
            ]
            if not _enqueue(
                queue[i],
                t,
                osc,
                gm,
                [(_purpose(part), plan) for part, plan, _ in plans if plan is not None],
                _budget_kms(cap_kms, dv_used[i], queue[i]),
                floor_km,
            ):
                continue
            a_hold[i] = mel[i, 0] + sum(d_a_part for _, _, d_a_part in plans)
            n_sets[i] += 1
            last_burn[i] = t
            if out[:4].any():
                shift = np.where(
                    out[:4],
                    -err_avg[:4] - np.sign(err_avg[:4]) * cfg.target_fraction * half[i, :4],
                    0.0,
                )
                geo_hist[i] = [(tk, gk + shift) for tk, gk in geo_hist[i]]
            if (
                out[4]
                and slot[i].history[-1][0] - slot[i].history[0][0]
                >= cfg.slot_quad_days * SECONDS_PER_DAY
            ):
                slot[i].accel = fit[2]
            slot[i].history = []
    ds = _life_dataset(
        dynamics.frames.element_frame,
        cfg,
        integ,
        model,
        natural,
        el,
        t0,
        life_s,
        np.array(hist_t),
        np.array(hist_el),
        np.array(hist_err),
        half,
        booked,
        impact_t,
        loss_t,
        cap_kms,
        time.perf_counter() - start,
        sample_t,
        r_sample if sample_step_s is not None else None,
    )
    _add_life_report(
        ds, np.array(hist_rp) - r_moon, loss_t, loss_cause, r_min - r_moon, t0, life_s, natural, nav
    )
    ds.attrs["relative_tolerances"] = "none" if tol_deg is None else svc.tolerances
    ds.attrs["raan_rel_tolerance_deg"], ds.attrs["u_rel_tolerance_deg"] = (
        (np.nan, np.nan) if tol_deg is None else (tol_deg["raan_rel"], tol_deg["u_rel"])
    )
    ds["n_maneuver_sets"] = ("sat", n_sets)
    ds["n_maneuver_sets"].attrs["description"] = (
        "corrections (each one or two burns per purpose, plus a mean-a trim)"
    )
    ds["insertion_elements_deg"] = (("sat", "element"), flown)
    ds["trim_residual"] = (("sat", "element"), trim_resid)
    ds["trim_residual"].attrs["description"] = (
        "first-orbit mean minus design at insertion (km, -, deg: i, raan, "
        "aop, u); NaN without the initial trim"
    )
    return ds


def _perilune_radius_km(states: np.ndarray, gm: float) -> np.ndarray:
    """Osculating perilune radius a (1 - e) (km) of states (n, 6)."""
    r, v = states[:, :3], states[:, 3:]
    rn = np.linalg.norm(r, axis=1)
    e = np.linalg.norm(eccentricity_vector(r, v, gm, r_km=rn), axis=1)
    return vis_viva_sma_km(rn, np.sum(v * v, axis=1), gm) * (1.0 - e)


def _enqueue(
    queue: list,
    t: float,
    osc: np.ndarray,
    gm: float,
    sets: list,
    budget_kms: float = np.inf,
    floor_km: float = -np.inf,
) -> bool:
    """Append the burns of ``sets`` ((purpose, plan) pairs planned at ``t`` on osculating elements ``osc``) as
    (epoch, dv_rtn, purpose, location) records, all of them or none: none when an impulse is not finite, their
    total Delta-v exceeds ``budget_kms``, or an orbit they leave (between two burns or after the last, two-body
    flight: :func:`lnss_lib.design_life.manoeuvres.lowest_perilune_km`) has its perilune radius below ``floor_km``
    (a two-burn e-vector change whose intermediate orbit dives into the Moon). Returns whether they were queued."""
    total = sum(plan.dv_total_kms for _, plan in sets)
    if not (np.isfinite(total) and total <= budget_kms):
        return False
    burns = sorted(
        ((float(dt), dv) for _, plan in sets for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms)),
        key=lambda b: b[0],
    )
    if (
        burns
        and lowest_perilune_km(osc, gm, [b[0] for b in burns], [b[1] for b in burns]) < floor_km
    ):
        return False
    e, aop = float(osc[1]), float(osc[4])
    nus = candidate_true_anomalies(e, aop)
    n = np.sqrt(gm / osc[0] ** 3)
    dts = np.mod(mean_anomaly(nus, e) - np.mod(osc[5], 2.0 * np.pi), 2.0 * np.pi) / n
    for purpose, plan in sets:
        for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms):
            nu = nus[int(np.argmin(np.abs(dts - dt)))]
            queue.append(
                (t + float(dt), np.array(dv, dtype=float), purpose, burn_location(nu, aop))
            )
    return True


def _budget_kms(cap_kms: float, used_kms: float, queued: list) -> float:
    """Delta-v (km/s) left under the cap after ``used_kms`` flown and the burns already ``queued``."""
    return cap_kms - used_kms - sum(float(np.linalg.norm(dv)) for _, dv, _, _ in queued)


def _flight_plan(queue: list) -> tuple[np.ndarray, np.ndarray]:
    """Burn epochs (n_sat, k) (NaN = none, sorted) and RTN impulses (n_sat, k, 3) for :func:`lnss_lib.design_life.propagation.integrate_chunk`
    from the queued records; impulses planned for the same epoch are flown as one."""
    merged = []
    for records in queue:
        epochs = {}
        for tb, dv, _, _ in records:
            key = round(tb, 3)
            epochs[key] = epochs.get(key, np.zeros(3)) + dv
        merged.append(sorted(epochs.items()))
    k = max([len(m) for m in merged] + [1])
    burn_t = np.full((len(queue), k), np.nan)
    burn_dv = np.zeros((len(queue), k, 3))
    for i, items in enumerate(merged):
        for j, (tb, dv) in enumerate(items):
            burn_t[i, j], burn_dv[i, j] = tb, dv
    return burn_t, burn_dv


def _purpose(out: np.ndarray) -> str:
    """Purpose a correction of the quantities ``out`` (order :data:`BOX_KEYS`) is booked to: the first of
    navigation (e, AOP, i), relative node, phase."""
    return "navigation" if out[:3].any() else ("relative_node" if out[3] else "phase")


def _add_life_report(
    ds: xr.Dataset,
    rp_alt_km: np.ndarray,
    loss_t: np.ndarray,
    loss_cause: np.ndarray,
    floor_alt_km: float,
    t0: float,
    life_s: float,
    natural: bool,
    nav,
) -> None:
    """Perilune, losses and the Delta-V split by purpose and location, added to ``ds`` in place."""
    finite = np.isfinite(rp_alt_km)
    low = np.where(finite.any(axis=0), np.min(np.where(finite, rp_alt_km, np.inf), axis=0), np.nan)
    ds["min_perilune_alt_km"] = (
        "sat",
        np.where(ds["impact"].values, np.fmin(low, floor_alt_km), low),
    )
    ds["min_perilune_alt_km"].attrs["description"] = (
        "lowest osculating perilune altitude (km) over the one-orbit "
        "windows of the checks (at most the floor for a satellite that impacts)"
    )
    ds["loss_day"] = ("sat", (loss_t - t0) / SECONDS_PER_DAY)
    ds["loss_cause"] = ("sat", np.array([str(c) for c in loss_cause], dtype=object))
    ds["loss_cause"].attrs["description"] = (
        "impact, escape (unbound orbit) or propagation failed (why); empty when kept"
    )
    span_yr = np.where(np.isfinite(loss_t), loss_t - t0, life_s) / (
        DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY
    )
    dv = np.linalg.norm(np.nan_to_num(ds["maneuver_dv_rtn_kms"].values), axis=-1)
    for name, dim, coord in (
        ("dv_purpose_kms_per_year", "purpose", PURPOSES),
        ("dv_location_kms_per_year", "location", LOCATIONS),
    ):
        labels = ds[f"maneuver_{dim}"].values
        split = (
            np.stack([np.sum(np.where(labels == c, dv, 0.0), axis=1) for c in coord], axis=1)
            / span_yr[:, None]
        )
        ds[name] = xr.DataArray(split, dims=("sat", dim), coords={dim: list(coord)})
        ds[name].attrs["description"] = (
            f"Delta-V per year (over the flown span) by {dim}; sums to dv_kms_per_year"
        )
    ds.attrs["navigation_violations"] = -1 if nav is None else nav.n_violations


def _sample_grid(t0: float, life_s: float, sample_step_s: float | None) -> np.ndarray:
    """Epochs t0 + k step (k = 0, 1, ...) up to the end of the life; empty without a step."""
    if sample_step_s is None:
        return np.empty(0)
    step = float(sample_step_s)
    if not (np.isfinite(step) and 0.0 < step <= life_s):
        raise ValueError(
            f"sample_step_s = {sample_step_s!r} must be a positive number of seconds at most the "
            f"design life ({life_s:.0f} s)"
        )
    return np.minimum(t0 + step * np.arange(int(np.floor(life_s / step + 1e-9)) + 1), t0 + life_s)


def _plan(osc, mel, a_ref, err, out, fit, half, cfg, gm, hold_u=True):
    """Impulses for one satellite (None when there is nothing to fly).

    Each geometry quantity out of its box (``out``, order :data:`BOX_KEYS`) is aimed past its reference
    (:func:`lnss_lib.design_life.control.overshoot_target`; e and AOP together as the e vector in nodal axes);
    the others are held (zero change). A slot correction sets the mean a so that the drift rate relative
    to the design's mean motion (``a_ref``) becomes :func:`lnss_lib.design_life.control.drift_band_rate`; otherwise
    a and u are held (u one orbit after the burns; u is left free with ``hold_u=False``, as the service
    controller's relative-node corrections do: its slot has its own drift-band control). The e-vector
    correction is thus a perilune/apolune pair with no net change of a (Newton-refined in
    :func:`lnss_lib.design_life.manoeuvres.plan_impulses`).
    """
    n = np.sqrt(gm / a_ref**3)
    ecc, aop = mel[1], mel[4]
    d_ecc = overshoot_target(err[0], half[0], cfg.target_fraction) if out[0] else 0.0
    d_aop = overshoot_target(err[1], half[1], cfg.target_fraction) if out[1] else 0.0
    ecc_new, aop_new = ecc + d_ecc, aop + d_aop
    target = {
        "ex": ecc_new * np.cos(aop_new) - ecc * np.cos(aop),
        "ey": ecc_new * np.sin(aop_new) - ecc * np.sin(aop),
        "inc_rad": overshoot_target(err[2], half[2], cfg.target_fraction) if out[2] else 0.0,
        "raan_rad": overshoot_target(err[3], half[3], cfg.target_fraction) if out[3] else 0.0,
        "a_km": 0.0,
        "u_rad": 0.0,
    }
    if out[4]:
        u0, rate, accel, _ = fit
        new_rate = drift_band_rate(
            u0, accel, half[4], cfg.target_fraction, cfg.slot_coast_days * SECONDS_PER_DAY
        )
        target["a_km"] = (new_rate - rate) / (-1.5 * n / a_ref)
    if out[4] or not hold_u:
        del target["u_rad"]
    plan = plan_impulses(osc, gm, target, max_burns=2)
    return (plan if plan.dv_rtn_kms.size else None), target["a_km"]


def _life_dataset(
    element_frame,
    cfg,
    integ,
    model,
    natural,
    el,
    t0,
    life_s,
    hist_t,
    hist_el,
    hist_err,
    half,
    booked,
    impact_t,
    loss_t,
    cap_kms,
    wall_s,
    sample_t,
    r_sample,
) -> xr.Dataset:
    n_sat = el.shape[0]
    n_max = max([len(b) for b in booked] + [1])
    man_t = np.full((n_sat, n_max), np.nan)
    man_dv = np.full((n_sat, n_max, 3), np.nan)
    man_purpose = np.full((n_sat, n_max), "", dtype=object)
    man_location = np.full((n_sat, n_max), "", dtype=object)
    for i in range(n_sat):
        for k, (tb, dv, purpose, location) in enumerate(booked[i]):
            man_t[i, k], man_dv[i, k], man_purpose[i, k], man_location[i, k] = (
                tb,
                dv,
                purpose,
                location,
            )
    dv_total = np.nansum(np.linalg.norm(man_dv, axis=-1), axis=1)
    impact, lost = np.isfinite(impact_t), np.isfinite(loss_t)
    span_s = np.where(lost, loss_t - t0, life_s)
    err = hist_err.transpose(1, 0, 2)
    smooth = err.copy()
    for i in range(n_sat):
        smooth[i, :, :4] = tidal_mean(hist_t[:, i], err[i, :, :4], cfg.tide_period_days)
    max_ratio, max_ratio_orbit = (_max_ratio(np.abs(x) / half[:, None, :]) for x in (smooth, err))
    dv_per_year = dv_total / (
        span_s / (DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY)
    )  # a lost satellite: over its flown span
    held = (
        (~lost)
        & np.all(max_ratio <= 1.0 + cfg.box_tolerance, axis=1)
        & (dv_total <= cap_kms * (1 + 1e-9))
    )
    mel = hist_el.transpose(1, 0, 2).copy()
    mel[..., 1:] = np.where(np.arange(6)[1:] >= 2, np.degrees(mel[..., 1:]), mel[..., 1:])
    ds = xr.Dataset(
        {
            "dv_kms_per_year": ("sat", dv_per_year),
            "dv_total_kms": ("sat", dv_total),
            "n_maneuvers": ("sat", np.array([len(b) for b in booked])),
            "maneuver_purpose": (("sat", "maneuver"), man_purpose),
            "maneuver_location": (("sat", "maneuver"), man_location),
            "maneuver_t_tdb_s": (("sat", "maneuver"), man_t),
            "maneuver_day": (("sat", "maneuver"), (man_t - t0) / SECONDS_PER_DAY),
            "maneuver_dv_rtn_kms": (("sat", "maneuver", "rtn"), man_dv),
            "box_held": ("sat", held),
            "impact": ("sat", impact),
            "impact_t_tdb_s": ("sat", impact_t),
            "impact_day": ("sat", (impact_t - t0) / SECONDS_PER_DAY),
            "max_box_ratio": (("sat", "box"), max_ratio),
            "max_box_ratio_one_orbit": (("sat", "box"), max_ratio_orbit),
            "box_error_tidal_mean": (("sat", "check", "box"), smooth),
            "mean_elements": (("sat", "check", "mean_element"), mel),
            "box_error": (("sat", "check", "box"), hist_err.transpose(1, 0, 2)),
            "check_t_tdb_s": (("sat", "check"), hist_t.T),
            "check_day": (("sat", "check"), (hist_t.T - t0) / SECONDS_PER_DAY),
            "elements_deg": (("sat", "element"), el),
        },
        coords={
            "sat": np.arange(n_sat),
            "maneuver": np.arange(n_max),
            "rtn": ["R", "T", "N"],
            "box": list(BOX_KEYS),
            "mean_element": ["a_km", "e", "inc_deg", "raan_deg", "aop_deg", "u_deg"],
            "element": ["a_km", "e", "inc_deg", "raan_deg", "aop_deg", "M_deg"],
        },
        attrs={
            "mode": "natural drift" if natural else "closed-loop station keeping",
            "controller": "none" if natural else cfg.controller,
            "life_days": cfg.life_days,
            "t0_tdb_s": t0,
            "integrator_setting": integ.name,
            "integrator": f"{integ.method} rtol {integ.rtol:g} atol {integ.atol:g}",
            "force_model": model.describe(),
            "element_frame": element_frame,
            "box_half_widths": ", ".join(f"{k} {getattr(cfg.box, k):g}" for k in BOX_KEYS),
            "box_error_units": "ecc (-), aop/inc/raan_rel/u_rel (rad)",
            "dv_cap_kms_per_year": cfg.dv_cap_kms_per_year,
            "wall_s": wall_s,
        },
    )
    if r_sample is not None:
        ds["r_mci_km"] = (("sat", "sample", "xyz"), r_sample)
        ds = ds.assign_coords(
            sample_t_tdb_s=("sample", sample_t),
            sample_day=("sample", (sample_t - t0) / SECONDS_PER_DAY),
            xyz=["x", "y", "z"],
        )
        ds["r_mci_km"].attrs["description"] = (
            "Moon-centred J2000 positions (km) on the sample grid, NaN after an impact"
        )
    ds["dv_kms_per_year"].attrs["units"] = "km/s per year"
    ds["mean_elements"].attrs["description"] = (
        "mean elements over one orbit ending at each check; u = aop + M"
    )
    return ds


def _max_ratio(ratio: np.ndarray) -> np.ndarray:
    """Largest ratio (sat, box) over the checks after the first (all checks when there is one)."""
    r = np.where(np.isfinite(ratio), ratio, -np.inf)
    r = r[:, 1:] if r.shape[1] > 1 else r
    return np.where(np.isfinite(r.max(axis=1)), r.max(axis=1), np.nan)


def impact_day(ds: xr.Dataset) -> float:
    """First impact day of a :func:`simulate_life` result over all satellites (NaN when none)."""
    days = ds["impact_day"].values
    return float(np.nanmin(days)) if np.any(np.isfinite(days)) else float("nan")


def integrator_convergence(
    dynamics: Dynamics,
    elements_deg,
    t0_tdb_s: float,
    *,
    life_days: float = 365.0,
    settings=("paper", "converged", "design_life"),
    reference: dict | None = None,
    degree: int | None = None,
    step_days: float = 1.0,
) -> xr.Dataset:
    """Position difference (km) of each integrator setting against a tighter reference over the life.

    Natural drift of ``elements_deg`` (n_sat, 6) (element frame, TDB ``t0_tdb_s``) with each named
    setting of ``dynamics.integrator.settings`` and with ``reference`` (default DOP853 at rtol 1e-12 /
    atol 1e-14); returns ``pos_diff_km`` (setting, sat, day) sampled every ``step_days``, with
    NaN after an impact, and ``n_rhs`` (setting, sat).
    """
    from ..propagator import propagate_states

    ref = reference or {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14}
    integrator = dataclasses.replace(
        dynamics.integrator,
        settings={
            **dynamics.integrator.settings,
            "_reference": IntegratorSetting(ref["method"], float(ref["rtol"]), float(ref["atol"])),
        },
    )
    dyn = dataclasses.replace(dynamics, integrator=integrator)
    ensure_kernels(dyn.ephemeris)
    t0 = float(t0_tdb_s)
    el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    states = elements_deg_to_states(dyn, el, t0)
    model = life_force_model(dyn, t0, life_days, degree)
    runs = {}
    for name in (*settings, "_reference"):
        runs[name] = propagate_states(
            dyn,
            states,
            t0,
            life_days * SECONDS_PER_DAY,
            step_days * SECONDS_PER_DAY,
            batch=True,
            model=model,
            setting=name,
        )
    r_ref = runs["_reference"].r_mci_km.values
    diff = np.stack([np.linalg.norm(runs[s].r_mci_km.values - r_ref, axis=-1) for s in settings])
    day = (runs["_reference"].time.values - t0) / SECONDS_PER_DAY
    return xr.Dataset(
        {
            "pos_diff_km": (("setting", "sat", "day"), diff),
            "n_rhs": (("setting", "sat"), np.stack([runs[s].n_rhs.values for s in settings])),
            "n_rhs_reference": ("sat", runs["_reference"].n_rhs.values),
        },
        coords={"setting": list(settings), "sat": np.arange(el.shape[0]), "day": day},
        attrs={"reference": f"{ref['method']} rtol {ref['rtol']:g} atol {ref['atol']:g}"},
    )
