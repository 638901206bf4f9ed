"""Station-keeping control laws: drift-band (parabolic) slot control and overshoot targeting of the box.

Slot (argument of latitude relative to its slot, ``u_rel``). Within one plane the orbit-averaged
tide and lunar field do not depend on the mean anomaly, so the relative drift rate of a satellite is
set by its mean semi-major axis, du_rel/dt = -1.5 n da/a, plus a slow acceleration (the mean a and the
secular rates of AOP + M creep as e and i evolve). The controller therefore

* estimates the drift rate and acceleration by a least-squares fit to the u_rel history of the
  current coast (line, then parabola once the coast is long enough to separate them), rather than
  reacting to the instantaneous error;
* removes the Earth tide's swing at half the sidereal month (a harmonic fitted with the trend);
* fires only when the fitted trajectory is predicted to leave the box within the look-ahead (the
  next check and the orbit to the burn) while still moving outward: a satellite outside its box but
  already drifting back is left alone;
* targets the far edge (GEO east-west drift-band practice, Soop 1994 ch. 6): the new drift rate
  makes the parabola turn at ``target_fraction`` of the half-width on the other side, so the next
  exit is a whole coast away; where the acceleration is too weak for that, the rate is set to cross
  the box in ``slot_coast_days`` at most (then the coast is bounded by the estimator's error, not
  by a turn-around).

Geometry (e, AOP, i, relative RAAN): the one-orbit mean elements still swing with the Earth tide at
half the sidereal month (e by about the e box itself on the ELFO), so the box is judged on their
running average over one tidal period (:func:`running_mean`); a quantity found outside its box is aimed at the opposite side
of its box (``target_fraction`` of the half-width past the reference, against the direction it left
by), so a secular drift (Lidov-Kozai e and AOP, the inclination swing of the precessing plane) gets
a full box width of coast per correction instead of half.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import SECONDS_PER_DAY


@dataclass
class SlotState:
    """Per-satellite slot estimator: (t_tdb_s, u_rel rad) of the current coast and the acceleration
    fitted over the previous coast (rad/s^2)."""

    history: list = field(default_factory=list)
    accel: float = 0.0

    def fit(self, min_span_days: float, quad_span_days: float, tide_period_days: float):
        """(u now, rate, acceleration, tidal part now) of the secular trend of the coast history, or None
        when it spans less than ``min_span_days``. Once the coast spans one tidal period a harmonic of that
        period is fitted with the trend (it is the periodic swing, not drift); a parabola once it spans
        ``quad_span_days`` (else the acceleration of the previous coast is used)."""
        if len(self.history) < 3:
            return None
        tt, uu = np.array(self.history).T
        span = tt[-1] - tt[0]
        if span < min_span_days * SECONDS_PER_DAY:
            return None
        x = (tt - tt[-1]) / SECONDS_PER_DAY
        uu = np.unwrap(uu)
        cols = [np.ones_like(x), x]
        quad = span >= quad_span_days * SECONDS_PER_DAY and len(tt) >= 7
        if quad:
            cols.append(0.5 * x * x)
        harmonic = span >= tide_period_days * SECONDS_PER_DAY and len(tt) >= len(cols) + 3
        if harmonic:
            w = 2.0 * np.pi / tide_period_days
            cols += [np.sin(w * x), np.cos(w * x)]
        coef = np.linalg.lstsq(np.column_stack(cols), uu, rcond=None)[0]
        accel = coef[2] / SECONDS_PER_DAY**2 if quad else self.accel
        tide_now = float(coef[-1]) if harmonic else 0.0
        return float(coef[0]), float(coef[1] / SECONDS_PER_DAY), float(accel), tide_now


def predicted_exit(u0: float, rate: float, accel: float, half: float, lookahead_s: float) -> bool:
    """True when the trend u0 + rate t + accel t^2 / 2 is outside +-half at the end of the look-ahead and
    still moving outward."""
    u_end = u0 + rate * lookahead_s + 0.5 * accel * lookahead_s**2
    v_end = rate + accel * lookahead_s
    return abs(u_end) > half and np.sign(v_end) == np.sign(u_end)


def drift_band_rate(
    u0: float, accel: float, half: float, target_fraction: float, coast_s: float
) -> float:
    """Drift rate (rad/s) to fly from u0: the parabola turns at ``target_fraction`` x ``half`` on the side
    the acceleration pushes away from; at least the rate that crosses to that edge in ``coast_s``."""
    edge = target_fraction * half
    floor = (abs(u0) + edge) / coast_s
    if accel != 0.0:
        turn = -np.sign(accel) * edge
        rate = -np.sign(accel) * np.sqrt(2.0 * abs(accel) * max(abs(u0 - turn), 0.0))
        if abs(rate) >= floor:
            return float(rate)
    direction = -np.sign(u0) if u0 != 0.0 else 1.0
    return float(direction * floor)


def overshoot_target(error: float, half: float, target_fraction: float) -> float:
    """Change that moves a quantity with ``error`` (outside its box) to ``target_fraction`` x ``half`` on
    the other side of its reference."""
    return float(-error - np.sign(error) * target_fraction * half)


def running_mean(t_s: np.ndarray, values: np.ndarray, window_days: float) -> np.ndarray:
    """Mean of ``values`` (n, k) over the samples within ``window_days`` of the last time of ``t_s`` (n,)."""
    t = np.asarray(t_s, dtype=float)
    keep = t >= t[-1] - window_days * SECONDS_PER_DAY
    return np.asarray(values, dtype=float)[keep].mean(axis=0)


def tidal_mean(t_s: np.ndarray, values: np.ndarray, window_days: float) -> np.ndarray:
    """Centred running mean (n, ...) of ``values`` (n, ...) sampled at ``t_s`` (n,): each sample is replaced by
    the mean of the finite samples within half a window on either side (NaN where none is finite)."""
    t = np.asarray(t_s, dtype=float)
    v = np.asarray(values, dtype=float)
    near = (np.abs(t[:, None] - t[None, :]) <= 0.5 * window_days * SECONDS_PER_DAY).astype(float)
    ok = np.isfinite(v)
    w = np.einsum("kj,j...->k...", near, ok.astype(float))
    total = np.einsum("kj,j...->k...", near, np.where(ok, v, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(w > 0, total / np.where(w > 0, w, 1.0), np.nan)
