"""Campaign-grade estimate of the geometry-keeping station-keeping cost.

From the short arc the evaluator already propagates (every satellite), the secular drift of exactly
the quantities a geometry box holds, converted to Delta-V per year with linearised impulsive costs.

What is held, in a frame that turns about the lunar pole ``k`` (z of the element frame) with the
constellation's common RAAN rate ``W`` (least-squares fit over all satellites, so the common node
precession costs nothing):

* the eccentricity vector (mean e and AOP: they put the apolune over the south pole);
* the orbit normal (inclination and the RAAN relative to the constellation's mean RAAN);
* the argument of latitude relative to the slot (differential along-track drift).

Mean quantities are one-period running means (:func:`lnss_lib.deltav.orbit_mean`) of a, the
eccentricity vector, the orbit normal (:func:`lnss_lib.deltav.orbit_vectors`) and the mean
argument of latitude u = AOP + M; a least-squares line through them gives the drift rates. Costs
(the GVE small-change limits used by :func:`lnss_lib.deltav.secular_deltav_rates`; h, p, n, v of
the mean orbit):

* ``ecc_vector``: the in-plane part of the turning-frame drift of the e vector, ``h |de_in/dt| / (2 p)``
  (opposite tangential impulses at perilune and apolune for e, at nu = +-90 deg for the apse line);
* ``plane``: the turning-frame rotation rate ``w`` of the orbit normal (inclination and differential
  RAAN together), ``h w (1 - e |cos(axis, perilune)|) / p``: one normal impulse at the far end of
  the rotation axis;
* ``sma``: the differential semi-major-axis drift ``(n a / 2) sqrt(1 - e^2) |da/dt - mean| / a``
  (it would accelerate the along-track drift);
* ``along_track``: the differential drift ``du/dt - mean`` is stopped by biasing a once by
  ``da = -(2/3) a (du/dt) / n``, costing ``(a / 3) sqrt(1 - e^2) |du/dt - mean|``; counted
  ``along_track_rebias_per_year`` times a year (the drift rate changes as the planes' geometry
  to the Earth changes, which a 10-day arc cannot measure).

What it captures: the secular (orbit-averaged) drift of every satellite over the arc, the
geometry-keeping part only. What it misses: periodic terms cost nothing (a box wider than their
amplitude is assumed); long-period terms (the Earth's half-month tide, Lidov-Kozai growth over
months) enter only as their 10-day trend, so a design that is stable over 10 days but not over a
year is underestimated (the stability screen, :mod:`lnss_lib.design_life.screen`, flags those); box sizes,
manoeuvre spacing and execution errors are not modelled; the along-track term is a one-time bias
amortised per year.
"""

from __future__ import annotations

import time

import numpy as np
import xarray as xr

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..deltav import orbit_mean, orbit_vectors
from ..elements import eccentric_anomaly_from_true
from ..frames import element_frame_to_j2000
from ..settings import Dynamics, SkEstimateSettings

__all__ = ["PARTS", "mean_drift", "sk_estimate_arrays", "sk_estimate_from_propagation"]

PARTS = ("ecc_vector", "plane", "sma", "along_track")


def _mean_argument_of_latitude(r: np.ndarray, e_vec: np.ndarray, h_hat: np.ndarray) -> np.ndarray:
    """u = AOP + M (rad) from positions, eccentricity vectors and orbit normals (..., 3) (node on z = 0)."""
    node = np.stack([-h_hat[..., 1], h_hat[..., 0], np.zeros_like(h_hat[..., 0])], axis=-1)
    m_hat = np.cross(h_hat, node)
    theta = np.arctan2(np.sum(r * m_hat, axis=-1), np.sum(r * node, axis=-1))  # AOP + true anomaly
    e = np.sqrt(np.sum(e_vec * e_vec, axis=-1))
    cos_nu_e = np.sum(r * e_vec, axis=-1)
    sin_nu_e = np.sum(np.cross(e_vec, r) * h_hat, axis=-1)
    nu = np.arctan2(sin_nu_e, cos_nu_e)  # exact angles times |r| e
    ecc_anomaly = eccentric_anomaly_from_true(nu, e)
    return (
        theta - nu + ecc_anomaly - e * np.sin(ecc_anomaly)
    )  # (theta - nu + E) - e sin E: kept in this order


def mean_drift(
    t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float, min_periods: float = 2.0
) -> dict:
    """Mean orbit and secular rates of every satellite from states (n_sat, n_time, 6) in the element frame.

    Returns (n_sat, ...) arrays: ``a_km``, ``e_vec``, ``h_hat`` (3), their rates ``a_dot``,
    ``e_vec_dot``, ``h_hat_dot`` (per s) and ``u_dot`` (rad/s, mean argument of latitude).
    ``ValueError`` if the arc is shorter than ``min_periods`` orbits of a satellite.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    s = np.asarray(states, dtype=float)
    if s.ndim != 3 or s.shape[1] != t.size or s.shape[2] != 6:
        raise ValueError(f"states must have shape (n_sat, {t.size}, 6); got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError(
            "states hold non-finite values (impact or failed propagation): no estimate"
        )
    vectors = orbit_vectors(s, gm_km3_s2)
    u = np.unwrap(
        _mean_argument_of_latitude(s[..., :3], vectors[..., 1:4], vectors[..., 4:7]), axis=-1
    )
    values = np.concatenate([vectors, u[..., None]], axis=-1)
    means, slopes = [], []
    for k in range(s.shape[0]):
        period = 2.0 * np.pi * np.sqrt(np.mean(vectors[k, :, 0]) ** 3 / gm_km3_s2)
        if t[-1] - t[0] < min_periods * period:
            raise ValueError(
                f"satellite {k}: the estimate needs an arc of at least {min_periods:g} orbits "
                f"({min_periods * period:.0f} s); got {t[-1] - t[0]:.0f} s"
            )
        t_mid, m = orbit_mean(t, values[k], period)
        x = t_mid - t_mid.mean()
        slopes.append(x @ (m - m.mean(axis=0)) / np.sum(x * x))
        means.append(m.mean(axis=0))
    mean, slope = np.array(means), np.array(slopes)
    h_hat = mean[:, 4:7] / np.linalg.norm(mean[:, 4:7], axis=1)[:, None]
    e_vec = mean[:, 1:4] - np.sum(mean[:, 1:4] * h_hat, axis=1)[:, None] * h_hat
    return {
        "a_km": mean[:, 0],
        "e_vec": e_vec,
        "h_hat": h_hat,
        "a_dot": slope[:, 0],
        "e_vec_dot": slope[:, 1:4],
        "h_hat_dot": slope[:, 4:7],
        "u_dot": slope[:, 7],
    }


def sk_estimate_arrays(
    drift: dict,
    gm_km3_s2: float,
    year_days: float = DAYS_PER_JULIAN_YEAR,
    along_track_rebias_per_year: float = 1.0,
) -> dict:
    """Geometry-keeping Delta-V (km/s per year) by part and ``total`` (n_sat,) from :func:`mean_drift`.

    Also returns ``common_raan_dot`` (rad/s), the free precession rate that was removed.
    """
    a, e_vec, h_hat = drift["a_km"], drift["e_vec"], drift["h_hat"]
    pole = np.array([0.0, 0.0, 1.0])
    k_x_h = np.cross(pole, h_hat)
    common = float(np.sum(k_x_h * drift["h_hat_dot"]) / max(np.sum(k_x_h * k_x_h), 1e-300))
    e_dot = drift["e_vec_dot"] - common * np.cross(pole, e_vec)
    h_dot = drift["h_hat_dot"] - common * k_x_h
    e = np.linalg.norm(e_vec, axis=1)
    p = a * (1.0 - e * e)
    h = np.sqrt(gm_km3_s2 * p)
    n = np.sqrt(gm_km3_s2 / a**3)
    e_in = e_dot - np.sum(e_dot * h_hat, axis=1)[:, None] * h_hat
    h_perp = h_dot - np.sum(h_dot * h_hat, axis=1)[:, None] * h_hat
    w = np.linalg.norm(h_perp, axis=1)
    axis = np.cross(h_hat, h_perp) / np.where(w > 0.0, w, 1.0)[:, None]
    axis_cos = np.abs(np.sum(axis * e_vec, axis=1)) / np.where(e > 0.0, e, 1.0)
    year_s = float(year_days) * SECONDS_PER_DAY
    root = np.sqrt(1.0 - e * e)
    parts = {
        "ecc_vector": h * np.linalg.norm(e_in, axis=1) / (2.0 * p) * year_s,
        "plane": h * w * (1.0 - e * axis_cos) / p * year_s,
        "sma": 0.5 * n * a * root * np.abs(drift["a_dot"] - np.mean(drift["a_dot"])) / a * year_s,
        "along_track": a
        / 3.0
        * root
        * np.abs(drift["u_dot"] - np.mean(drift["u_dot"]))
        * along_track_rebias_per_year,
    }
    parts["total"] = sum(parts[k] for k in PARTS)
    parts["common_raan_dot"] = common
    return parts


def sk_estimate_from_propagation(
    sk_estimate: SkEstimateSettings, dynamics: Dynamics, ds: xr.Dataset
) -> dict:
    """The estimate for a propagator Dataset (every satellite; e.g. the evaluator's 10-day arc).

    Returns ``sk_dv_estimate_kms_per_year`` (mean over satellites), ``sk_dv_estimate_max_kms_per_year``,
    ``per_sat`` (dict part -> (n_sat,) km/s per year), ``common_raan_dot_deg_per_day`` and ``wall_s``.
    """
    start = time.perf_counter()
    t = ds["time"].values.astype(float)
    states = np.concatenate([ds["r_mci_km"].values, ds["v_mci_kms"].values], axis=-1)
    rot = element_frame_to_j2000(dynamics, float(t[0]), sk_estimate.arc_frame)
    states = np.concatenate([states[..., :3] @ rot, states[..., 3:] @ rot], axis=-1)
    gm = dynamics.gravity.gm_km3_s2
    parts = sk_estimate_arrays(
        mean_drift(t, states, gm, sk_estimate.min_periods),
        gm,
        sk_estimate.year_days,
        sk_estimate.along_track_rebias_per_year,
    )
    total = parts["total"]
    return {
        "sk_dv_estimate_kms_per_year": float(np.mean(total)),
        "sk_dv_estimate_max_kms_per_year": float(np.max(total)),
        "per_sat": {k: parts[k] for k in (*PARTS, "total")},
        "common_raan_dot_deg_per_day": float(
            np.degrees(parts["common_raan_dot"]) * SECONDS_PER_DAY
        ),
        "wall_s": time.perf_counter() - start,
    }
