"""Closed-loop station keeping over a design life, and natural drift, with the full force model.

Every satellite of a constellation (one :class:`~lnss_lib.design_life.fleet.FleetState`) is propagated by the
compiled engine (:func:`lnss_lib.propagator.integrate_one`, satellites in parallel) in chunks of
``check_interval_days`` (at least two orbits); at each check a controller
(:mod:`lnss_lib.design_life.controllers`, ``[design_life] controller``) answers with the burns of the next chunk:

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
(:func:`lnss_lib.design_life.fleet.enqueue`): never with a non-finite impulse, and, safety apart, never when its total exceeds what is
left of the Delta-v cap (a scaled-down set would hit none of the targets it was solved for) or when an orbit it
leaves, between its burns or after them (two-body flight), has its perilune below the impact radius (plus
``perilune_margin_km`` under the service controller). The one-orbit
MEAN a still moves by a few km when e or AOP change (the orbit-averaged lunar potential seen by the new orbit
differs: 2 a^2/GM Delta<R>), so after every correction the next check measures the mean a and trims it back
with a small tangential burn (:data:`lnss_lib.design_life.controllers.A_TRIM_FRACTION`). The control laws are in :mod:`lnss_lib.design_life.control`: e, AOP, i and
relative RAAN are judged on their running mean over one tidal period (the one-orbit mean e swings by
about +-0.015 at half the sidereal month on the ELFO, hence an e box of 0.03) and aimed past the
reference to the far side of the box; the slot is predicted from the mean-a drift rate
(-1.5 n (a - a_design)/a) and corrected by a drift-band change of a. Reported box ratios use the centred
tidal mean for the geometry (the one-orbit ratios beside them). A satellite can still fail its box when
its secular drift within ``min_maneuver_spacing_days`` exceeds ``box_tolerance`` of the half-width, when
its Delta-v cap is spent, or when it impacts; ``box_held`` then says False and ``max_box_ratio`` which
quantity by how much. ``natural=True`` flies the controller that never burns (natural drift, same
insertion trim).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import xarray as xr

from ..constants import SECONDS_PER_DAY
from ..ephemeris import ensure_kernels
from ..forces import ForceModel
from ..frames import element_frame_to_j2000
from ..progress import steps
from ..propagator import elements_deg_to_states
from ..settings import (
    DesignLifeSettings,
    DopSettings,
    Dynamics,
    IntegratorSetting,
    StabilitySettings,
)
from .controllers import controller_for
from .fleet import FleetState, LifeGrid
from .life_report import life_dataset
from .propagation import life_force_model, trim_to_mean


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
    elements_deg_to_states(dynamics, el, t0)  # checks the elements
    gm = dynamics.gravity.gm_km3_s2
    if model is None:
        model = life_force_model(dynamics, t0, cfg.life_days, degree)
    elif (
        model.table.t0_tdb_s > t0 or model.table.t_end_tdb_s < t0 + cfg.life_days * SECONDS_PER_DAY
    ):
        raise ValueError("the force model's ephemeris table does not span the design life")
    integ = dynamics.integrator.named(cfg.integrator_setting)
    inserted, trim_resid = _insertion(dynamics, cfg, el, t0, model, integ, insertion_errors_deg)
    grid = LifeGrid.of(cfg, el, t0, gm, sample_step_s)
    fleet = FleetState(
        elements_deg_to_states(dynamics, inserted[1], t0),
        element_frame_to_j2000(dynamics, t0),
        gm,
        el,
        grid,
        el[:, 0].copy(),
    )
    controller = controller_for(
        cfg, dynamics, grid, el, inserted[0], model, stability=stability, dop=dop, natural=natural
    )
    start = time.perf_counter()
    t, t_end = t0, t0 + grid.life_s
    label = f"{'natural drift' if natural else 'station keeping'}: {el.shape[0]} satellite(s)"
    for k_chunk in steps(grid.n_chunks, f"{label}, {cfg.life_days:g} days", "box checks"):
        t_next = grid.check_end(k_chunk, t)
        fleet.fly(t, t_next, model, integ, dynamics.r_impact_km)
        if (
            k_chunk == 0 and not cfg.initial_trim
        ):  # inserted as given: slots drift against the first mean a
            fleet.ref_a = np.where(fleet.active, fleet.mel[:, 0], fleet.ref_a)
        t = t_next
        if t < t_end - 1e-6:
            fleet.queue_burns(controller.decide(t, fleet))
    ds = life_dataset(
        fleet,
        controller,
        cfg,
        integ=integ,
        model=model,
        element_frame=dynamics.frames.element_frame,
        r_impact_km=dynamics.r_impact_km,
        r_moon_km=dynamics.constants.r_moon_mean_km,
        wall_s=time.perf_counter() - start,
        sampled=sample_step_s is not None,
    )
    ds["insertion_elements_deg"] = (("sat", "element"), inserted[1])
    ds["trim_residual"] = (("sat", "element"), trim_resid)
    ds["trim_residual"].attrs["description"] = (
        "first-orbit mean minus design at insertion (km, -, deg: i, raan, "
        "aop, u); NaN without the initial trim"
    )
    return ds


def _insertion(dynamics, design_life, el, t0, model, integ, insertion_errors_deg):
    """((trimmed elements, flown elements) (n_sat, 6) deg, trim residual): the design's mean elements
    trimmed to osculating ones (:func:`~.propagation.trim_to_mean`, or as given without
    ``initial_trim``), plus the insertion errors; raises ``ValueError`` for errors of another shape."""
    trimmed, resid = (
        trim_to_mean(
            dynamics, el, t0, model, integ, samples_per_orbit=design_life.samples_per_orbit
        )
        if design_life.initial_trim
        else (el.copy(), np.full_like(el, np.nan))
    )
    if insertion_errors_deg is None:
        return (trimmed, trimmed), resid
    errors = np.asarray(insertion_errors_deg, dtype=float)
    if errors.shape != el.shape or not np.all(np.isfinite(errors)):
        raise ValueError(
            f"insertion_errors_deg must be finite with the elements' shape {el.shape}; "
            f"got shape {errors.shape}"
        )
    return (trimmed, trimmed + errors), resid


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
