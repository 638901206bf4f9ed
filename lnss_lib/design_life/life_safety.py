"""Safety raises of the life estimate: where the averaged perilune of one orbit crosses the floor, the service
controller's raise (:func:`lnss_lib.design_life.service.safety_ecc`'s law), priced at fixed a and followed through the
averaged model (:func:`safety_dv_kms`); :func:`perilune_dip_km` is the arc's dip of the osculating perilune below its
mean that the floor adds. Read by :func:`lnss_lib.design_life.life_estimate.life_estimate`."""

from __future__ import annotations

import numpy as np

from ..elements import eccentricity_vector, vis_viva_sma_km
from .secular import SecularField, integrate_secular
from .service import SAFETY_RAISE_KM

__all__ = ["FOLLOWED_SAFETY_BURNS", "perilune_dip_km", "first_below", "safety_dv_kms"]

FOLLOWED_SAFETY_BURNS = 1
"""Safety raises of one orbit followed through the averaged model; an orbit that crosses the floor again (no raise
held it for the rest of the life) pays the rest of its life at their rate: their Delta-V over the time they bought."""

SEARCH_RTOL, SEARCH_ATOL = 1e-4, 1e-6
"""Tolerances of the averaged integration of the candidate raises (the screen's are tighter): a few hundred metres of
perilune; the same ranking and costs on the validation designs as 1e-6, at half the cost over five years."""


def perilune_dip_km(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Mean minus lowest osculating perilune radius (km) over an arc of states (n_sat, n_time, 6)."""
    r, v = states[..., :3], states[..., 3:]
    rn = np.linalg.norm(r, axis=-1)
    e = np.linalg.norm(eccentricity_vector(r, v, gm_km3_s2, r_km=rn), axis=-1)
    rp = vis_viva_sma_km(rn, np.sum(v * v, axis=-1), gm_km3_s2) * (1.0 - e)
    return np.mean(rp, axis=1) - np.min(rp, axis=1)


def _ecc_cost_kms(sma_km: float, ecc: float, d_ecc: float, gm_km3_s2: float) -> float:
    """Delta-V (km/s) of a change ``d_ecc`` of e at fixed a: h |de| / (2 p)."""
    p = sma_km * (1.0 - ecc * ecc)
    return float(np.sqrt(gm_km3_s2 * p) * abs(d_ecc) / (2.0 * p))


def first_below(t_days: np.ndarray, perilune_km: np.ndarray, floor_km: float) -> np.ndarray:
    """First day (n,) each perilune radius history (n, m) is at or below the floor (NaN counts); NaN if never."""
    below = ~(perilune_km > floor_km)
    return np.where(below.any(axis=1), t_days[np.argmax(below, axis=1)], np.nan)


def _raise(
    field: SecularField,
    t_burn: float,
    sma_km: float,
    e_vec: np.ndarray,
    j_vec: np.ndarray,
    floor_km: float,
    t_rest: np.ndarray,
) -> tuple[float, np.ndarray, np.ndarray, float]:
    """The controller's safety raise (:func:`lnss_lib.design_life.service.safety_ecc`'s law: the smallest raise of
    :data:`lnss_lib.design_life.service.SAFETY_RAISE_KM` whose averaged perilune stays above ``floor_km`` for the rest
    of the life, else the one that delays the crossing most), from one integration of the candidates that stops
    each at its crossing: the new e, the raised orbit's e and j histories on ``t_rest`` (days from the burn; NaN
    after its crossing) and that crossing (days from the burn, NaN when none)."""
    ecc = float(np.linalg.norm(e_vec))
    e_new = np.unique(np.maximum(ecc - np.asarray(SAFETY_RAISE_KM) / sma_km, 0.0))[::-1]
    direction = e_vec / ecc if ecc > 0.0 else np.zeros(3)
    h_hat = j_vec / np.linalg.norm(j_vec)
    shifted = field.shifted(t_burn)
    res = integrate_secular(
        np.full(e_new.size, sma_km),
        e_new[:, None] * direction,
        np.sqrt(1.0 - e_new**2)[:, None] * h_hat,
        shifted,
        float(t_rest[-1]),
        floor_km=floor_km,
        rtol=SEARCH_RTOL,
        atol=SEARCH_ATOL,
        output_step_days=float(t_rest[1] - t_rest[0]) if t_rest.size > 1 else 1.0,
    )
    cross = res["impact_day"]
    safe = np.flatnonzero(np.isnan(cross))
    k = int(safe[0]) if safe.size else int(np.argmax(cross))
    return float(e_new[k]), res["e"][k], res["j"][k], float(cross[k])


def safety_dv_kms(
    field: SecularField,
    t_days: np.ndarray,
    sma_km: float,
    e_hist: np.ndarray,
    j_hist: np.ndarray,
    floor_km: float,
    lead_days: float,
    check_days: float,
) -> tuple[float, int, np.ndarray, np.ndarray]:
    """Safety burns of one orbit over the life ``t_days`` (m,) (a uniform grid from 0): Delta-V (km/s), number of
    burns, and the controlled e and j histories (m, 3).

    ``e_hist``, ``j_hist`` (m, 3): the orbit's averaged e and j vectors (J2000; NaN after its impact, which comes
    after its crossing of the higher floor ``floor_km``, the perilune radius to hold). A burn is placed
    ``lead_days`` before each predicted crossing (at least ``check_days`` after the previous one) and sized by the
    controller's law (:func:`_raise`); after
    :data:`FOLLOWED_SAFETY_BURNS` burns the rest of the life is charged at their rate (the histories from there
    on are NaN: the relative drifts go on at their mean rates).
    """
    gm = field.gm_km3_s2
    e_ctl, j_ctl = e_hist.copy(), j_hist.copy()
    t_cross = float(
        first_below(t_days, sma_km * (1.0 - np.linalg.norm(e_ctl, axis=-1))[None], floor_km)[0]
    )
    dv, n_burns, t_first, t_last = 0.0, 0, np.nan, -np.inf
    while np.isfinite(t_cross):
        k = int(np.searchsorted(t_days, max(t_cross - lead_days, t_last + check_days, 0.0) - 1e-9))
        if k >= t_days.size - 1:
            break
        if n_burns == FOLLOWED_SAFETY_BURNS:
            e_ctl[k:], j_ctl[k:] = np.nan, np.nan
            return dv * (t_days[-1] - t_first) / (t_days[k] - t_first), n_burns, e_ctl, j_ctl
        ecc = float(np.linalg.norm(e_ctl[k]))
        ecc_new, e_ctl[k:], j_ctl[k:], t_next = _raise(
            field, float(t_days[k]), sma_km, e_ctl[k], j_ctl[k], floor_km, t_days[k:] - t_days[k]
        )
        dv += _ecc_cost_kms(sma_km, ecc, ecc_new - ecc, gm)
        n_burns += 1
        t_first = float(t_days[k]) if n_burns == 1 else t_first
        t_last, t_cross = float(t_days[k]), float(t_days[k]) + t_next
    return dv, n_burns, e_ctl, j_ctl
