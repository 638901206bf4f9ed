"""The tide's monthly terms, restored to first order about the doubly-averaged model of
:mod:`lnss_lib.design_life.secular` (the stability screen's verdict, ``[stability] monthly_terms``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import SECONDS_PER_DAY
from .secular import TideSamples

__all__ = ["MonthlyTide", "monthly_offsets"]


@dataclass(frozen=True)
class MonthlyTide:
    """The tide's oscillation about its running month-mean, integrated once: ``z`` (m, 3, 3) (1/s) on ``t_days``.

    ``dZ/dt = T(t) - <T>(t)`` and ``Z`` has zero running mean: ``Z = W - <W>`` with ``W = int T dt``
    (the running mean of ``dW/dt`` is ``d<W>/dt``). The Milankovitch rates are linear in the tide
    tensor, so to first order in the oscillation (first-order averaging: the near-identity transform
    between doubly- and singly-averaged vectors) the orbit-averaged vectors are the doubly-averaged
    ones plus the tide-only rates of :func:`secular_rates` evaluated with ``Z`` in place of ``T``
    (:func:`monthly_offsets`). This restores the half-monthly swing of e (amplitude ~ (15/16)
    (n_month / n) e sqrt(1 - e^2) at the worst geometry: 0.012 at a = 7800 km, e = 0.74; 0.05 at
    a = 20900 km, e = 0.8), the Earth's orbital eccentricity's monthly term and the Sun's.
    """

    t_days: np.ndarray
    z: np.ndarray

    @classmethod
    def from_samples(cls, samples: TideSamples) -> MonthlyTide:
        dt_s = np.diff(samples.t_days) * SECONDS_PER_DAY
        w = np.concatenate(
            [
                np.zeros((1, 3, 3)),
                np.cumsum(
                    0.5 * dt_s[:, None, None] * (samples.inst[1:] + samples.inst[:-1]), axis=0
                ),
            ]
        )
        core = w[samples.half : samples.t_days.size - samples.half]
        return cls(samples.out_days, core - samples.running_mean(w))

    def at(self, t_days) -> np.ndarray:
        """Z (n, 3, 3) at days ``t_days`` (n,) (linear between nodes, held outside)."""
        t = np.atleast_1d(np.asarray(t_days, dtype=float))
        flat = self.z.reshape(self.t_days.size, 9)
        return np.stack([np.interp(t, self.t_days, flat[:, k]) for k in range(9)], axis=-1).reshape(
            t.size, 3, 3
        )


def monthly_offsets(e_vec, j_vec, sma_km, z, gm_km3_s2: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order monthly terms (de, dj) (..., 3) (dimensionless) of vectors (..., 3) with ``sma_km`` (...)
    under ``z`` (..., 3, 3) (:class:`MonthlyTide`): the tide part of :func:`secular_rates` with Z for T."""
    e_vec, j_vec = np.asarray(e_vec, float), np.asarray(j_vec, float)
    a = np.asarray(sma_km, dtype=float)[..., None]
    s = np.trace(z, axis1=-2, axis2=-1)[..., None]
    grad_e = -0.25 * a**2 * (-12.0 * s * e_vec + 30.0 * np.einsum("...ij,...j->...i", z, e_vec))
    grad_j = 1.5 * a**2 * np.einsum("...ij,...j->...i", z, j_vec)
    inv_l = 1.0 / np.sqrt(gm_km3_s2 * a)
    return (
        -inv_l * (np.cross(j_vec, grad_e) + np.cross(e_vec, grad_j)),
        -inv_l * (np.cross(j_vec, grad_j) + np.cross(e_vec, grad_e)),
    )
