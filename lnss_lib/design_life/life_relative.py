"""Relative node and slot of the life estimate: the corrections the service controller's laws
(:func:`lnss_lib.design_life.control.overshoot_target`, :func:`lnss_lib.design_life.control.drift_band_rate`) make to
the averaged drift histories of a constellation, each satellite against the circular mean of all
(:func:`node_corrections`, :func:`phase_corrections`). Read by :func:`lnss_lib.design_life.life_estimate.life_estimate`."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..constants import SECONDS_PER_DAY
from ..elements import TWO_PI
from .control import drift_band_rate, overshoot_target
from .mean_elements import wrap_pi

__all__ = ["SEARCH_WINDOW", "node_corrections", "phase_corrections"]

SEARCH_WINDOW = 64
"""Checks (history samples) searched at once for the next node or slot decision."""


@nb.njit(cache=True)
def _wrapped_sums(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compiled first half of :func:`_relative`, bit for bit that of :func:`~lnss_lib.design_life.mean_elements.wrap_pi`
    and the sums of :func:`~lnss_lib.design_life.mean_elements.circular_mean` (NaN as 0, satellites in order): the
    wrapped angles (n, m) and the sums of their sines and cosines (m,)."""
    n, m = x.shape
    diff = np.empty((n, m))
    sin_sum, cos_sum = np.zeros(m), np.zeros(m)
    for i in range(n):
        for k in range(m):
            d = np.mod(x[i, k] + np.pi, TWO_PI) - np.pi
            diff[i, k] = d
            s, c = (0.0, 0.0) if np.isnan(d) else (np.sin(d), np.cos(d))
            sin_sum[k], cos_sum[k] = (s, c) if i == 0 else (sin_sum[k] + s, cos_sum[k] + c)
    return diff, sin_sum, cos_sum


def _relative(x: np.ndarray) -> np.ndarray:
    """Angles (n_sat, m) relative to their circular mean over the satellites at each time, wrapped to [-pi, pi)
    (numpy's arctan2: the compiled one differs in the last bit)."""
    diff, sin_sum, cos_sum = _wrapped_sums(np.ascontiguousarray(x, dtype=float))
    return wrap_pi(diff - np.arctan2(sin_sum, cos_sum)[None, :])


def _decisions(m: int, window):
    """The checks 0..m-1 at which a correction fires, one decision per check: ``window(k, end)`` gives the drifts
    (n, end - k) and where they fire (bool, same shape) over checks k..end-1 under the corrections made so far (it
    is called again after each decision); yields (check, drifts there (n,), firing satellites (n,))."""
    k = 0
    while k < m:
        end = min(k + SEARCH_WINDOW, m)
        rel, fire = window(k, end)
        hit = np.flatnonzero(fire.any(axis=0))
        if not hit.size:
            k = end
            continue
        k += int(hit[0])
        yield k, rel[:, hit[0]], fire[:, hit[0]]
        k += 1


def node_corrections(
    t_days: np.ndarray,
    raan_rad: np.ndarray,
    half_rad: np.ndarray,
    target_fraction: float,
    spacing_days: float,
) -> list[list[tuple[int, float]]]:
    """Relative-node corrections of each satellite: lists of (time index, RAAN change rad).

    ``raan_rad`` (n_sat, m): RAAN drift of each satellite from its design value; the relative node (against the
    circular mean over the satellites) is held within ``half_rad`` (n_sat,) by
    :func:`lnss_lib.design_life.control.overshoot_target`, at most one correction per satellite each ``spacing_days``.
    """
    n, m = raan_rad.shape
    offset = np.zeros(n)
    last = np.full(n, -np.inf)
    out = [[] for _ in range(n)]

    def window(k, end):
        rel = _relative(raan_rad[:, k:end] + offset[:, None])
        return rel, (np.abs(rel) > half_rad[:, None]) & (
            t_days[None, k:end] - last[:, None] >= spacing_days
        )

    for k, rel, fire in _decisions(m, window):
        for i in np.flatnonzero(fire):
            change = overshoot_target(float(rel[i]), float(half_rad[i]), target_fraction)
            offset[i] += change
            last[i] = t_days[k]
            out[i].append((k, change))
    return out


def phase_corrections(
    t_days: np.ndarray,
    u_rad: np.ndarray,
    half_rad: float,
    target_fraction: float,
    coast_days: float,
    lookahead_days: float,
) -> list[list[tuple[int, float]]]:
    """Drift-band slot corrections of each satellite: lists of (time index, change of drift rate rad/s).

    ``u_rad`` (n_sat, m): the argument of latitude's drift from its slot; the slot (against the circular mean)
    is held within ``half_rad``: a satellite found outside, not already commanded back inward over
    ``lookahead_days``, gets the rate of :func:`lnss_lib.design_life.control.drift_band_rate` (no acceleration).
    """
    n, m = u_rad.shape
    day_s = SECONDS_PER_DAY
    rate = np.zeros(n)
    t_ref = np.zeros(n)
    offset = np.zeros(n)
    out = [[] for _ in range(n)]

    def window(k, end):
        own = offset[:, None] + rate[:, None] * (t_days[None, k:end] - t_ref[:, None]) * day_s
        rel = _relative(u_rad[:, k:end] + own)
        ahead = rel + rate[:, None] * lookahead_days * day_s
        return rel, (np.abs(ahead) > half_rad) & (np.sign(rate)[:, None] != -np.sign(ahead))

    for k, rel, fire in _decisions(m, window):
        for i in np.flatnonzero(fire):
            new = drift_band_rate(float(rel[i]), 0.0, half_rad, target_fraction, coast_days * day_s)
            offset[i] += rate[i] * (t_days[k] - t_ref[i]) * day_s
            t_ref[i] = t_days[k]
            out[i].append((k, new - rate[i]))
            rate[i] = new
    return out
