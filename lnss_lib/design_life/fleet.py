"""The satellites of a closed-loop life as one object: where each is, what it has flown and what it will fly.

:class:`FleetState` holds every satellite's state vector, whether it is still flown (an impact, an escape or a
failed propagation ends it), the burns it has flown (:class:`Burn`, booked when the chunk that flies them
succeeds) and those queued for the next chunk, and what the last check measured: one-orbit mean elements in the
element frame, their errors against the design (the box quantities of :data:`BOX_KEYS`) and the lowest osculating
perilune. :meth:`FleetState.fly` integrates one chunk (:func:`lnss_lib.design_life.propagation.integrate_chunk`)
and measures the next check; a controller (:mod:`lnss_lib.design_life.controllers`) reads it and answers with
burns. :class:`LifeGrid` is the life's clock: check chunks, the one-orbit windows and the DOP sample epochs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..elements import orbital_period_s
from ..forces import ForceModel
from ..propagator import METHODS, STATUS_IMPACT, STATUS_NOT_RUN, STATUS_OK, STATUS_TEXT, check_batch
from ..settings import DesignLifeSettings, IntegratorSetting
from .manoeuvres import candidate_true_anomalies, lowest_perilune_km, mean_anomaly
from .mean_elements import osculating_elements, relative_angles, window_means, wrap_pi
from .propagation import integrate_chunk
from .service import burn_location

__all__ = ["BOX_KEYS", "Burn", "LifeGrid", "FleetState", "enqueue", "budget_kms", "flight_plan"]

BOX_KEYS = ("ecc", "aop_deg", "inc_deg", "raan_rel_deg", "u_rel_deg")
"""Box quantities (``[design_life.box]``): half-widths about the reference."""

MAX_STEPS = 5_000_000
"""Integrator steps allowed to one satellite in one chunk before its propagation is reported failed."""


class Burn(NamedTuple):
    """One impulse: the satellite, its TDB epoch (s), the RTN impulse (km/s), what it is paid for
    (:data:`lnss_lib.design_life.service.PURPOSES`) and where it is flown (:data:`~.service.LOCATIONS`)."""

    sat: int
    t_tdb_s: float
    dv_rtn_kms: np.ndarray
    purpose: str
    location: str


@dataclass(frozen=True)
class LifeGrid:
    """The clock of a life: ``n_chunks`` checks ``chunk_s`` apart (at least 2.05 orbits), each measuring the
    one-orbit window of ``window`` samples ``step_s`` apart that ends there, and the DOP sample epochs."""

    t0_tdb_s: float
    life_s: float
    periods_s: np.ndarray
    step_s: float
    window: np.ndarray
    n_chunks: int
    chunk_s: float
    sample_t: np.ndarray

    @classmethod
    def of(cls, design_life: DesignLifeSettings, elements_deg, t0_tdb_s, gm, sample_step_s):
        """The grid of ``elements_deg`` (n_sat, 6) over ``design_life.life_days``; raises ``ValueError`` for a
        life shorter than 2.05 orbits or a sample step outside (0, life]."""
        life_s = design_life.life_days * SECONDS_PER_DAY
        sample_t = _sample_grid(t0_tdb_s, life_s, sample_step_s)
        periods = orbital_period_s(elements_deg[:, 0], gm)
        step = float(periods.min()) / design_life.samples_per_orbit
        if life_s < 2.05 * float(periods.max()):
            raise ValueError(
                f"design life {design_life.life_days} days is shorter than 2.05 orbits "
                f"({2.05 * periods.max() / SECONDS_PER_DAY:.2f} days)"
            )
        check_s = max(
            design_life.check_interval_days * SECONDS_PER_DAY, 2.05 * float(periods.max())
        )
        n_chunks = max(1, int(np.floor(life_s / check_s)))
        return cls(
            t0_tdb_s,
            life_s,
            periods,
            step,
            np.rint(periods / step).astype(int),
            n_chunks,
            life_s / n_chunks,
            sample_t,
        )

    def check_end(self, k_chunk: int, t: float) -> float:
        """Epoch of the check that closes chunk ``k_chunk`` begun at ``t`` (the last closes the life)."""
        t_end = self.t0_tdb_s + self.life_s
        return t_end if k_chunk == self.n_chunks - 1 else min(t + self.chunk_s, t_end)


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


@dataclass
class FleetState:
    """Every satellite of a life from one check to the next (arrays over ``sat``; see the module docstring).

    ``y`` (n_sat, 6) Moon-centred J2000 states at the last check, ``rot`` the element frame's axes in J2000,
    ``design`` (n_sat, 6) the design's mean elements (deg; the references of the errors), ``ref_a`` each
    satellite's reference mean a for its slot. After :meth:`fly`: ``mel`` (n_sat, 6) one-orbit mean elements
    ``[a, e, i, raan, aop, u]`` (km, rad), ``err`` (n_sat, 5) their errors (:data:`BOX_KEYS`, rad), ``rp_min``
    the lowest osculating perilune radius of the window, ``t_mid`` its centre; the histories of all of them.
    """

    y: np.ndarray
    rot: np.ndarray
    gm: float
    design: np.ndarray
    grid: LifeGrid
    ref_a: np.ndarray
    active: np.ndarray = field(init=False)
    impact_t: np.ndarray = field(init=False)
    loss_t: np.ndarray = field(init=False)
    loss_cause: np.ndarray = field(init=False)
    dv_used: np.ndarray = field(init=False)
    booked: list = field(init=False)
    queue: list = field(init=False)
    r_sample: np.ndarray = field(init=False)
    mel: np.ndarray = field(init=False)
    err: np.ndarray = field(init=False)
    rp_min: np.ndarray = field(init=False)
    t_mid: np.ndarray = field(init=False)
    history: dict = field(init=False)

    def __post_init__(self):
        n_sat = self.y.shape[0]
        self.active = np.ones(n_sat, dtype=bool)
        self.impact_t = np.full(n_sat, np.nan)
        self.loss_t = np.full(n_sat, np.nan)
        self.loss_cause = np.full(n_sat, "", dtype=object)
        self.dv_used = np.zeros(n_sat)
        self.booked = [[] for _ in range(n_sat)]
        self.queue = [[] for _ in range(n_sat)]
        self.r_sample = np.full((n_sat, self.grid.sample_t.size, 3), np.nan)
        if self.grid.sample_t.size:
            self.r_sample[:, 0] = self.y[:, :3]
        self.mel = self.err = self.rp_min = self.t_mid = None  # measured by the first check
        self.history = {"t": [], "el": [], "err": [], "rp": []}

    @property
    def n_sat(self) -> int:
        return self.y.shape[0]

    def lose(self, i: int, t: float, cause: str) -> None:
        """Satellite ``i`` is no longer flown from ``t`` (``cause``: impact, escape, propagation failed)."""
        self.active[i], self.loss_t[i], self.loss_cause[i] = False, t, cause

    def osculating(self, i: int, t: float) -> np.ndarray | None:
        """Osculating elements of satellite ``i`` in the element frame (km, rad;
        :func:`~.mean_elements.osculating_elements`), or None (the satellite is lost at ``t``) for an unbound orbit."""
        osc = osculating_elements(self.y[i], self.rot, self.gm)
        if not (np.all(np.isfinite(osc)) and osc[0] > 0.0 and osc[1] < 1.0):
            self.lose(i, t, "escape (unbound orbit)")
            return None
        return osc

    def queue_burns(self, burns: list[Burn]) -> None:
        """Queue ``burns`` (a controller's decision) for the next chunk."""
        for burn in burns:
            self.queue[burn.sat].append(burn)

    def fly(
        self,
        t: float,
        t_next: float,
        model: ForceModel,
        integ: IntegratorSetting,
        r_min_km: float,
    ) -> None:
        """Integrate every active satellite from ``t`` to ``t_next`` flying its queued burns, book them, record
        the losses and the samples on the way, and measure the check at ``t_next``."""
        grid = self.grid
        n_win = int(grid.window.max())
        t_win = t_next - grid.step_s * np.arange(n_win, -1, -1)
        in_chunk = np.flatnonzero((grid.sample_t > t) & (grid.sample_t <= t_next))
        t_out, where = np.unique(
            np.concatenate([t_win, grid.sample_t[in_chunk]]), return_inverse=True
        )
        pending_t, pending_dv = flight_plan(self.queue)
        out_states, y_new, status, t_stop = integrate_chunk(
            self.y,
            self.active,
            t,
            t_out,
            pending_t,
            pending_dv,
            METHODS.index(integ.method),
            integ.rtol,
            integ.atol,
            r_min_km,
            MAX_STEPS,
            model.kernel_args,
            model.field.degree,
        )
        # a loop that lost an error (not run) or an "ok" satellite with unwritten samples is a failure of
        # the code, raised; impact, escape and integrator failures are the satellite's loss, reported
        active = self.active
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
            for burn in self.queue[i]:
                if status[i] == STATUS_OK or burn.t_tdb_s <= t_stop[i]:
                    self.booked[i].append(burn)
                    self.dv_used[i] += float(np.linalg.norm(burn.dv_rtn_kms))
            self.queue[i] = []
        self.r_sample[:, in_chunk] = out_states[:, where[t_win.size :], :3]
        for i in np.flatnonzero(bad):
            self.lose(
                i,
                t_stop[i],
                "impact"
                if status[i] == STATUS_IMPACT
                else f"propagation failed ({STATUS_TEXT[status[i]]})",
            )
        hit = bad & (status == STATUS_IMPACT)
        self.impact_t[hit] = t_stop[hit]
        self.y = np.where(self.active[:, None], y_new, self.y)
        self._measure(out_states[:, where[: t_win.size]], n_win, t_next)

    def _measure(self, seg_states: np.ndarray, n_win: int, t_next: float) -> None:
        """Mean elements, box errors and lowest perilune of each active satellite's last orbit before ``t_next``
        (:func:`~.mean_elements.window_means`; an unbound window: the satellite escaped)."""
        n_sat, window = self.n_sat, self.grid.window
        mel = np.full((n_sat, 6), np.nan)
        rp_min = np.full(n_sat, np.nan)
        for i in np.flatnonzero(self.active):  # an unbound window gives NaN elements, judged below
            mel[i], rp_min[i] = window_means(seg_states[i, n_win - window[i] :], self.rot, self.gm)
            if not (
                np.all(np.isfinite(mel[i]))
                and 0.0 < mel[i, 0]
                and mel[i, 1] < 1.0
                and np.isfinite(rp_min[i])
            ):
                self.lose(i, t_next, "escape (unbound orbit)")
                mel[i], rp_min[i] = np.nan, np.nan
        design = self.design
        self.err = np.stack(
            [
                mel[:, 1] - design[:, 1],
                wrap_pi(mel[:, 4] - np.radians(design[:, 4])),
                mel[:, 2] - np.radians(design[:, 2]),
                relative_angles(mel[:, 3], np.radians(design[:, 3]), self.active),
                relative_angles(mel[:, 5], np.radians(design[:, 4] + design[:, 5]), self.active),
            ],
            axis=1,
        )
        self.mel, self.rp_min = mel, rp_min
        self.t_mid = t_next - 0.5 * self.grid.step_s * window
        for key, value in zip(("t", "el", "err", "rp"), (self.t_mid, mel, self.err, rp_min)):
            self.history[key].append(value)


def enqueue(
    burns: list,
    sat: int,
    t: float,
    osc: np.ndarray,
    gm: float,
    sets: list,
    budget: float = np.inf,
    floor_km: float = -np.inf,
) -> bool:
    """Append the burns of ``sets`` ((purpose, plan) pairs planned at ``t`` on osculating elements ``osc`` of
    satellite ``sat``) to ``burns`` as :class:`Burn` records, all of them or none: none when an impulse is not
    finite, their total Delta-v exceeds ``budget`` (km/s), or an orbit they leave (between two burns or after
    the last, two-body flight: :func:`lnss_lib.design_life.manoeuvres.lowest_perilune_km`) has its perilune
    radius below ``floor_km`` (a two-burn e-vector change whose intermediate orbit dives into the Moon).
    Returns whether they were queued."""
    total = sum(plan.dv_total_kms for _, plan in sets)
    if not (np.isfinite(total) and total <= budget):
        return False
    flown = sorted(
        ((float(dt), dv) for _, plan in sets for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms)),
        key=lambda b: b[0],
    )
    if (
        flown
        and lowest_perilune_km(osc, gm, [b[0] for b in flown], [b[1] for b in flown]) < floor_km
    ):
        return False
    e, aop = float(osc[1]), float(osc[4])
    nus = candidate_true_anomalies(e, aop)
    n = np.sqrt(gm / osc[0] ** 3)
    dts = np.mod(mean_anomaly(nus, e) - np.mod(osc[5], 2.0 * np.pi), 2.0 * np.pi) / n
    for purpose, plan in sets:
        for dt, dv in zip(plan.dt_s, plan.dv_rtn_kms):
            nu = nus[int(np.argmin(np.abs(dts - dt)))]
            burns.append(
                Burn(sat, t + float(dt), np.array(dv, dtype=float), purpose, burn_location(nu, aop))
            )
    return True


def budget_kms(cap_kms: float, used_kms: float, queued: list[Burn]) -> float:
    """Delta-v (km/s) left under the cap after ``used_kms`` flown and the burns already ``queued``."""
    return cap_kms - used_kms - sum(float(np.linalg.norm(b.dv_rtn_kms)) for b in queued)


def flight_plan(queue: list[list[Burn]]) -> tuple[np.ndarray, np.ndarray]:
    """Burn epochs (n_sat, k) (NaN = none, sorted) and RTN impulses (n_sat, k, 3) for
    :func:`lnss_lib.design_life.propagation.integrate_chunk` from each satellite's queued burns; impulses
    planned for the same epoch are flown as one."""
    merged = []
    for burns in queue:
        epochs = {}
        for burn in burns:
            key = round(burn.t_tdb_s, 3)
            epochs[key] = epochs.get(key, np.zeros(3)) + burn.dv_rtn_kms
        merged.append(sorted(epochs.items()))
    k = max([len(m) for m in merged] + [1])
    burn_t = np.full((len(queue), k), np.nan)
    burn_dv = np.zeros((len(queue), k, 3))
    for i, items in enumerate(merged):
        for j, (tb, dv) in enumerate(items):
            burn_t[i, j], burn_dv[i, j] = tb, dv
    return burn_t, burn_dv
