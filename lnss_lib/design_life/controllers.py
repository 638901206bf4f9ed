"""The closed loop's controllers: objects the loop asks, at each check, "what burns now?".

A controller implements :class:`Controller`: :meth:`~Controller.decide` reads the :class:`~.fleet.FleetState`
measured at the check and answers with :class:`~.fleet.Burn` records for the next chunk; :meth:`~Controller.report`
gives what the life's Dataset records of it. Three of them (``[design_life] controller`` picks one of
:data:`CONTROLLERS`; :func:`controller_for` builds it):

- :class:`NaturalDrift` never burns (natural drift, the same insertion trim);
- :class:`BoxController` (``"box"``) holds the fixed-element box of :mod:`lnss_lib.design_life.closed_loop`: mean
  e, AOP and i about the design's values, the relative node and the slot, by the laws of
  :mod:`lnss_lib.design_life.control`;
- :class:`ServiceController` (``"service"``) holds what the service needs (:mod:`lnss_lib.design_life.service`):
  safety raises of a perilune predicted below the floor, navigation restores, relative node and slot within the
  tolerances of :func:`lnss_lib.design_life.tolerances.relative_tolerances_deg`; e, AOP and i otherwise run free.

A set of burns is queued whole or not at all (:func:`lnss_lib.design_life.fleet.enqueue`): never with a
non-finite impulse and, safety apart, never past what is left of the Delta-v cap or through an orbit whose
perilune is below the floor. After every correction the next check trims the mean a back (:data:`A_TRIM_FRACTION`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..forces import ForceModel
from ..settings import DesignLifeSettings, DopSettings, Dynamics, StabilitySettings
from .control import SlotState, drift_band_rate, overshoot_target, predicted_exit, running_mean
from .fleet import Burn, FleetState, LifeGrid, budget_kms, enqueue
from .manoeuvres import plan_impulses
from .secular import SecularField
from .service import (
    NavigationMonitor,
    mean_vectors_j2000,
    raan_half_width_rad,
    raised_history,
    restore_target,
    safety_targets,
)
from .tolerances import relative_tolerances_deg

__all__ = [
    "A_TRIM_FRACTION",
    "CONTROLLERS",
    "Controller",
    "NaturalDrift",
    "BoxController",
    "ServiceController",
    "controller_for",
    "box_half_widths",
    "box_plan",
]

A_TRIM_FRACTION = 0.1
"""Mean-a check after every manoeuvre set: a residual that would drift the slot by more than this fraction
of its half-width over ``slot_coast_days`` is trimmed at once (a tangential touch of ~0.1 m/s per km)."""


class Controller(Protocol):
    """What the closed loop asks at each check (:func:`lnss_lib.design_life.closed_loop.simulate_life`)."""

    name: str
    """The Dataset's ``controller`` attribute."""
    half: np.ndarray
    """(n_sat, 5) half-widths (:data:`~.fleet.BOX_KEYS`, rad but e) the box ratios are reported against."""

    def decide(self, t_tdb_s: float, fleet: FleetState) -> list[Burn]:
        """The burns to queue for the next chunk, given the check just measured at ``t_tdb_s``."""
        ...

    def report(self) -> dict:
        """``n_maneuver_sets`` (n_sat,) and the Dataset attributes of the controller."""
        ...


def box_half_widths(design_life: DesignLifeSettings) -> np.ndarray:
    """Half-widths (5,) of ``[design_life.box]`` in the order of :data:`~.fleet.BOX_KEYS` (e, then rad)."""
    box = design_life.box
    return np.array(
        [
            box.ecc,
            np.radians(box.aop_deg),
            np.radians(box.inc_deg),
            np.radians(box.raan_rel_deg),
            np.radians(box.u_rel_deg),
        ]
    )


class NaturalDrift:
    """The controller that never burns: the natural drift of the inserted constellation."""

    name = "none"

    def __init__(self, design_life: DesignLifeSettings, n_sat: int):
        self.half = np.tile(box_half_widths(design_life), (n_sat, 1))
        self.n_sat = n_sat

    def decide(self, t_tdb_s: float, fleet: FleetState) -> list[Burn]:
        return []

    def report(self) -> dict:
        return {
            "n_maneuver_sets": np.zeros(self.n_sat, dtype=int),
            "relative_tolerances": "none",
            "raan_rel_tolerance_deg": np.nan,
            "u_rel_tolerance_deg": np.nan,
            "navigation_violations": -1,
        }


class BoxController:
    """The fixed-element box: each of e, AOP, i and the relative node judged on its running mean over
    ``avg_days`` and aimed past its reference when out; the slot predicted from its fitted drift and corrected
    by a drift-band change of a; a mean-a trim after every correction."""

    name = "box"
    hold_u = True  # a geometry correction holds u (one orbit after the burns)

    def __init__(
        self,
        design_life: DesignLifeSettings,
        grid: LifeGrid,
        gm: float,
        ref_a_km: np.ndarray,
        half: np.ndarray,
        floor_km: float,
    ):
        n_sat = half.shape[0]
        cfg = self.cfg = design_life
        self.grid, self.gm, self.half, self.floor_km = grid, gm, half, floor_km
        self.cap_kms = cfg.dv_cap_kms_per_year * cfg.life_days / DAYS_PER_JULIAN_YEAR
        self.avg_days = cfg.tide_period_days
        self.a_tol = (
            A_TRIM_FRACTION
            * half[:, 4]
            / (1.5 * np.sqrt(gm / ref_a_km**3) / ref_a_km * cfg.slot_coast_days * SECONDS_PER_DAY)
        )
        self.slot = [SlotState() for _ in range(n_sat)]
        self.geo_hist = [[] for _ in range(n_sat)]  # (t, e/AOP/i/relative-node errors) of the coast
        self.last_burn = np.full(n_sat, -np.inf)
        self.a_hold = np.full(n_sat, np.nan)  # mean a to trim back to at the next check
        self.n_sets = np.zeros(n_sat, dtype=int)

    def decide(self, t_tdb_s: float, fleet: FleetState) -> list[Burn]:
        self._prepare(t_tdb_s, fleet)
        burns = []
        for i in np.flatnonzero(fleet.active):
            self.slot[i].history.append((fleet.t_mid[i], fleet.err[i, 4]))
            self.geo_hist[i].append((fleet.t_mid[i], fleet.err[i, :4]))
            osc = fleet.osculating(i, t_tdb_s)
            if osc is not None:
                burns += self._satellite(i, t_tdb_s, fleet, osc)
        return burns

    def report(self) -> dict:
        return {
            "n_maneuver_sets": self.n_sets,
            "relative_tolerances": "none",
            "raan_rel_tolerance_deg": np.nan,
            "u_rel_tolerance_deg": np.nan,
            "navigation_violations": -1,
        }

    def _prepare(self, t: float, fleet: FleetState) -> None:
        """What the check decides for the whole fleet before each satellite (the box: nothing)."""

    def _safety(self, i: int, t: float, fleet: FleetState, osc, burns: list) -> bool:
        """Queue a safety raise of satellite ``i``; True when one was due (the box: never)."""
        return False

    def _restore(self, i: int, t: float, fleet: FleetState, osc, burns: list) -> None:
        """Queue a navigation restore of satellite ``i`` (the box: none)."""

    def _groups(self, out: np.ndarray) -> list[np.ndarray]:
        """The quantities out of their box planned as separate sets (the box: all in one)."""
        return [out]

    def _satellite(self, i: int, t: float, fleet: FleetState, osc) -> list[Burn]:
        """The burns of satellite ``i`` (osculating elements ``osc``) at the check ``t``."""
        burns = []
        if self._safety(i, t, fleet, osc, burns):  # safety first, and beyond the Delta-v cap
            return burns
        if fleet.dv_used[i] >= self.cap_kms:
            return burns
        mel = fleet.mel[i]
        if np.isfinite(self.a_hold[i]):
            d_a, self.a_hold[i] = self.a_hold[i] - mel[0], np.nan
            if abs(d_a) > self.a_tol[i]:
                plan = plan_impulses(
                    osc,
                    self.gm,
                    {"a_km": d_a, "ex": 0.0, "ey": 0.0, "inc_rad": 0.0, "raan_rad": 0.0},
                )
                if self._enqueue(burns, i, t, fleet, osc, [("a_trim", plan)]):
                    self.slot[i].history = []
                return burns
        self._restore(i, t, fleet, osc, burns)
        if t - self.last_burn[i] < self.cfg.min_maneuver_spacing_days * SECONDS_PER_DAY:
            return burns
        self._hold_box(i, t, fleet, osc, burns)
        return burns

    def _enqueue(self, burns: list, i: int, t: float, fleet: FleetState, osc, sets) -> bool:
        """:func:`~.fleet.enqueue` within what is left of satellite ``i``'s cap, above the floor."""
        budget = budget_kms(self.cap_kms, fleet.dv_used[i], burns)
        return enqueue(burns, i, t, osc, self.gm, sets, budget, self.floor_km)

    def _booked_set(self, i: int, t: float, a_km: float) -> None:
        """A correction of satellite ``i`` was queued at ``t``: trim the mean a to ``a_km`` next check."""
        self.a_hold[i], self.n_sets[i], self.last_burn[i] = a_km, self.n_sets[i] + 1, t

    def _hold_box(self, i: int, t: float, fleet: FleetState, osc, burns: list) -> None:
        """Queue the correction of whatever of satellite ``i``'s box its running means or slot trend leave."""
        cfg, half, slot = self.cfg, self.half[i], self.slot[i]
        u_rel, mel, ref_a = fleet.err[i, 4], fleet.mel[i], fleet.ref_a[i]
        hist = self.geo_hist[i]
        tt, gg = zip(*hist[_window_start(hist, self.avg_days) :])
        err_avg = np.append(running_mean(np.array(tt), np.array(gg), self.avg_days), u_rel)
        out = np.abs(err_avg) > half
        out[:4] &= hist[-1][0] - hist[0][0] >= 0.5 * self.avg_days * SECONDS_PER_DAY
        out[4] = False
        trend = slot.fit(cfg.slot_fit_days, cfg.slot_quad_days, cfg.tide_period_days)
        rate_a = -1.5 * np.sqrt(self.gm / ref_a**3) * (mel[0] - ref_a) / ref_a
        fit = (
            (u_rel if trend is None else trend[0], rate_a, 0.0, 0.0)
            if len(slot.history) >= 2
            else None
        )
        if fit is not None:
            lookahead_s = self.grid.chunk_s + float(self.grid.periods_s[i])
            out[4] = predicted_exit(*fit[:3], half[4], lookahead_s)
        if not out.any():
            return
        plans = [
            (part, *box_plan(osc, mel, ref_a, err_avg, part, fit, half, cfg, self.gm, self.hold_u))
            for part in self._groups(out)
        ]
        sets = [(_purpose(part), plan) for part, plan, _ in plans if plan is not None]
        if not self._enqueue(burns, i, t, fleet, osc, sets):
            return
        self._booked_set(i, t, mel[0] + sum(d_a_part for _, _, d_a_part in plans))
        if out[:4].any():
            shift = np.where(
                out[:4], -err_avg[:4] - np.sign(err_avg[:4]) * cfg.target_fraction * half[:4], 0.0
            )
            self.geo_hist[i] = [(tk, gk + shift) for tk, gk in self.geo_hist[i]]
        if (
            out[4]
            and slot.history[-1][0] - slot.history[0][0] >= cfg.slot_quad_days * SECONDS_PER_DAY
        ):
            slot.accel = fit[2]
        slot.history = []


class ServiceController(BoxController):
    """What the service needs: safety raises (flown beyond the Delta-v cap), navigation restores of e, AOP
    and i when the monitor finds the requirement broken, relative node and slot within the service's
    tolerances, each planned as its own set (a node correction leaves u free)."""

    name = "service"
    hold_u = False  # a node correction leaves u free: the slot has its own drift-band control

    def __init__(
        self,
        design_life: DesignLifeSettings,
        grid: LifeGrid,
        gm: float,
        design_deg: np.ndarray,
        tol_deg: dict,
        floor_km: float,
        field: SecularField,
        nav: NavigationMonitor | None,
    ):
        box = box_half_widths(design_life)
        half = np.array(
            [np.inf, np.inf, np.inf, np.radians(tol_deg["raan_rel"]), np.radians(tol_deg["u_rel"])]
        )
        half = np.tile(half, (design_deg.shape[0], 1))  # the node's half-width depends on i
        half[:, 3] = raan_half_width_rad(
            np.radians(tol_deg["raan_rel"]), np.radians(design_deg[:, 2])
        )
        super().__init__(design_life, grid, gm, design_deg[:, 0].copy(), half, floor_km)
        self.box_half, self.tol_deg, self.field, self.nav = box, tol_deg, field, nav
        self.svc = design_life.service
        self.avg_days = 2.0 * design_life.tide_period_days
        self.safe_hist = [[] for _ in design_deg]  # (t, e and j vectors, lowest perilune km)
        self.last_safety = -np.inf

    def report(self) -> dict:
        return {
            "n_maneuver_sets": self.n_sets,
            "relative_tolerances": self.svc.tolerances,
            "raan_rel_tolerance_deg": self.tol_deg["raan_rel"],
            "u_rel_tolerance_deg": self.tol_deg["u_rel"],
            "navigation_violations": -1 if self.nav is None else self.nav.n_violations,
        }

    def _prepare(self, t: float, fleet: FleetState) -> None:
        """Safety predictions every ``safety_check_days``, the navigation monitor's verdict."""
        cfg, svc, active, mel = self.cfg, self.svc, fleet.active, fleet.mel
        self.ev, jv = mean_vectors_j2000(np.where(active[:, None], mel, 0.0), fleet.rot)
        for i in np.flatnonzero(active):
            self.safe_hist[i] = [
                h
                for h in self.safe_hist[i]
                if h[0] >= fleet.t_mid[i] - 2.0 * cfg.tide_period_days * SECONDS_PER_DAY
            ]
            self.safe_hist[i].append((fleet.t_mid[i], self.ev[i], jv[i], fleet.rp_min[i]))
        self.d_ecc = np.full(fleet.n_sat, np.nan)
        if t - self.last_safety >= svc.safety_check_days * SECONDS_PER_DAY:
            self.last_safety = t
            self.d_ecc = safety_targets(
                self.field,
                self.safe_hist,
                mel,
                active,
                (t - self.grid.t0_tdb_s) / SECONDS_PER_DAY,
                cfg.life_days,
                self.floor_km,
                svc,
                cfg.tide_period_days,
            )
        self.restore = np.zeros(fleet.n_sat, dtype=bool)
        if self.nav is not None:
            self.nav.update(t, fleet.r_sample)
            if self.nav.violated:
                self.restore = active & np.any(np.abs(fleet.err[:, :3]) > self.box_half[:3], axis=1)

    def _safety(self, i: int, t: float, fleet: FleetState, osc, burns: list) -> bool:
        d_ecc = self.d_ecc[i]
        if not np.isfinite(d_ecc):
            return False
        mel = fleet.mel[i]
        target = {"a_km": 0.0, "ex": d_ecc * np.cos(mel[4]), "ey": d_ecc * np.sin(mel[4])}
        plan = plan_impulses(osc, self.gm, target, max_burns=2)
        if enqueue(burns, i, t, osc, self.gm, [("safety", plan)]):
            self.safe_hist[i] = raised_history(self.safe_hist[i], d_ecc, self.ev[i], mel[1], mel[0])
            self._booked_set(i, t, mel[0])
            self.slot[i].history = []
        return True

    def _restore(self, i: int, t: float, fleet: FleetState, osc, burns: list) -> None:
        if not self.restore[i]:
            return
        mel, err, design = fleet.mel[i], fleet.err[i], fleet.design[i]
        target = restore_target(mel[1], mel[4], err[2], design[1], np.radians(design[4]))
        plan = plan_impulses(osc, self.gm, target, max_burns=2)
        if self._enqueue(burns, i, t, fleet, osc, [("navigation", plan)]):
            shift = np.append(err[:3], 0.0)
            self.geo_hist[i] = [(tk, gk - shift) for tk, gk in self.geo_hist[i]]
            self._booked_set(i, t, mel[0])

    def _groups(self, out: np.ndarray) -> list[np.ndarray]:
        return [np.arange(5) == k for k in (3, 4) if out[k]]


CONTROLLERS = {"box": BoxController, "service": ServiceController}
"""The controllers ``[design_life] controller`` names (its declared choices)."""


def controller_for(
    design_life: DesignLifeSettings,
    dynamics: Dynamics,
    grid: LifeGrid,
    design_deg: np.ndarray,
    inserted_deg: np.ndarray,
    model: ForceModel,
    *,
    stability: StabilitySettings,
    dop: DopSettings,
    natural: bool = False,
) -> Controller:
    """The controller of ``design_life`` (natural drift with ``natural``) for a fleet of design mean
    elements ``design_deg`` (n_sat, 6) inserted at ``inserted_deg`` (the service derives its tolerances from
    them)."""
    ref_a_km = design_deg[:, 0].copy()
    if natural:
        return NaturalDrift(design_life, ref_a_km.size)
    r_min, gm, t0 = dynamics.r_impact_km, dynamics.gravity.gm_km3_s2, grid.t0_tdb_s
    if design_life.controller == "box":
        half = np.tile(box_half_widths(design_life), (ref_a_km.size, 1))
        return BoxController(design_life, grid, gm, ref_a_km, half, r_min)
    svc = design_life.service
    arc_days = min(svc.tolerance_arc_days, design_life.life_days)
    tol_deg = relative_tolerances_deg(
        svc, dop, dynamics, inserted_deg, t0, model=model, arc_days=arc_days
    )
    field = SecularField.from_settings(stability, dynamics, t0, design_life.life_days + 1.0)
    nav = (
        NavigationMonitor(dop, dynamics, grid.sample_t, svc, model.table)
        if grid.sample_t.size
        else None
    )
    floor_km = r_min + svc.perilune_margin_km
    return ServiceController(design_life, grid, gm, design_deg, tol_deg, floor_km, field, nav)


def _window_start(history: list, window_days: float) -> int:
    """Index of the first (t, ...) entry of a time-ordered ``history`` that :func:`~.control.running_mean` keeps
    (t >= last t - ``window_days``): the mean of that tail is the mean over the whole coast's samples in the window,
    at a cost that does not grow with the coast."""
    cut = history[-1][0] - window_days * SECONDS_PER_DAY
    k = len(history)
    while k > 0 and history[k - 1][0] >= cut:
        k -= 1
    return k


def _purpose(out: np.ndarray) -> str:
    """Purpose a correction of the quantities ``out`` (order :data:`~.fleet.BOX_KEYS`) is booked to: the
    first of navigation (e, AOP, i), relative node, phase."""
    return "navigation" if out[:3].any() else ("relative_node" if out[3] else "phase")


def box_plan(osc, mel, a_ref, err, out, fit, half, cfg, gm, hold_u=True):
    """Impulses for one satellite (None when there is nothing to fly) and the change of mean a they aim at.

    Each geometry quantity out of its box (``out``, order :data:`~.fleet.BOX_KEYS`) is aimed past its
    reference (:func:`lnss_lib.design_life.control.overshoot_target`; e and AOP together as the e vector in
    nodal axes); the others are held (zero change). A slot correction sets the mean a so that the drift rate
    relative to the design's mean motion (``a_ref``) becomes :func:`lnss_lib.design_life.control.drift_band_rate`;
    otherwise a and u are held (u one orbit after the burns; u is left free with ``hold_u=False``, as the
    service controller's relative-node corrections do: its slot has its own drift-band control). The e-vector
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
