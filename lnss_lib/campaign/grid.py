"""The design grid of eq. 43-44 (paper Section 5, Table 3): scaled integers <-> physical Walker designs.

Decision variables live on the integer grid of eq. 43, ``x_j = (X_j - L_j) / dX_j``, with the bounds
``L_j``, ``U_j`` and step sizes ``dX_j`` of ``[campaign.variables]``; a scaled design is de-scaled by
eq. 44, ``X_j = min(max(L_j + dX_j x_j, L_j), U_j)``, with Np and Ns rounded to integers.
"""

from __future__ import annotations

from collections.abc import Mapping

from dataclasses import dataclass

import numpy as np

from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS
from ..settings import VariableBounds

__all__ = ["DesignGrid"]


@dataclass(frozen=True)
class DesignGrid:
    """Bounds ``lower``, ``upper`` and steps ``step`` (6,) of ``DESIGN_KEYS`` (Table 3, eq. 43-44)."""

    lower: np.ndarray
    upper: np.ndarray
    step: np.ndarray

    @classmethod
    def from_variables(cls, variables: Mapping[str, VariableBounds]) -> "DesignGrid":
        """From ``settings.campaign.variables`` (``{name: VariableBounds}`` for every name in ``DESIGN_KEYS``,
        checked at load by :mod:`lnss_lib.config`)."""
        rows = [(float(variables[name].lower), float(variables[name].upper), float(variables[name].step))
                for name in DESIGN_KEYS]
        lower, upper, step = (np.array(col) for col in zip(*rows))
        return cls(lower, upper, step)

    @property
    def n_levels(self) -> np.ndarray:
        """Largest scaled value of each variable (int, 6): ``ceil((U - L) / dX)``; the scaled domain is 0..n."""
        return np.ceil((self.upper - self.lower) / self.step - 1e-9).astype(int)

    def scale(self, designs) -> np.ndarray:
        """Eq. 43: scaled values ``(X - L) / dX`` (float, not rounded) of physical designs (n, 6)."""
        return (np.atleast_2d(np.asarray(designs, dtype=float)) - self.lower) / self.step

    def descale(self, scaled) -> np.ndarray:
        """Eq. 44: physical designs (n, 6) of scaled ones, clipped to [L, U]; Np and Ns rounded.

        Real variables are rounded to 12 decimals so that grid values print cleanly (0.3, not
        0.30000000000000004).
        """
        x = np.atleast_2d(np.asarray(scaled, dtype=float))
        if x.shape[-1] != len(DESIGN_KEYS) or not np.all(np.isfinite(x)):
            raise ValueError(f"scaled designs must be finite with {len(DESIGN_KEYS)} columns; got shape {x.shape}")
        values = np.round(np.minimum(np.maximum(self.lower + self.step * x, self.lower), self.upper), 12)
        for name in INTEGER_DESIGN_KEYS:
            j = DESIGN_KEYS.index(name)
            values[:, j] = np.rint(values[:, j])
        return values

    def designs(self, scaled) -> list[dict]:
        """Keyword dicts for :func:`~lnss_lib.evaluator.evaluate_design` (ints for Np and Ns)."""
        return [{k: (int(v) if k in INTEGER_DESIGN_KEYS else float(v)) for k, v in zip(DESIGN_KEYS, row)}
                for row in self.descale(scaled)]
