"""The design grid of eq. 43-44 (paper Section 5, Table 3): scaled integers <-> physical Walker designs.

Decision variables live on the integer grid of eq. 43, ``x_j = (X_j - L_j) / dX_j``, with the bounds
``L_j``, ``U_j`` and step sizes ``dX_j`` of ``[campaign.variables]``; a scaled design is de-scaled by
eq. 44, ``X_j = min(max(L_j + dX_j x_j, L_j), U_j)``, with Np and Ns rounded to integers.
"""

from __future__ import annotations

from collections.abc import Mapping

import math
from dataclasses import dataclass

import numpy as np

from ..config import SEMI_MAJOR_AXIS, SEMI_MAJOR_AXIS_WHY, allowed_range_text, in_range
from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS

__all__ = ["DesignGrid"]


@dataclass(frozen=True)
class DesignGrid:
    """Bounds ``lower``, ``upper`` and steps ``step`` (6,) of ``DESIGN_KEYS`` (Table 3, eq. 43-44)."""

    lower: np.ndarray
    upper: np.ndarray
    step: np.ndarray

    @classmethod
    def from_settings(cls, variables: dict) -> "DesignGrid":
        """From ``{name: {lower, upper, step}}`` for every name in ``DESIGN_KEYS``; ValueError if bad."""
        missing = [k for k in DESIGN_KEYS if k not in variables]
        extra = [k for k in variables if k not in DESIGN_KEYS]
        if missing or extra:
            raise ValueError(f"campaign.variables must name exactly {', '.join(DESIGN_KEYS)}; "
                             f"missing {missing}, unknown {extra}")
        rows = []
        for name in DESIGN_KEYS:
            spec = variables[name]
            if not isinstance(spec, Mapping) or set(spec) != {"lower", "upper", "step"}:
                raise ValueError(f"campaign.variables.{name} must be {{lower, upper, step}}; got {spec!r}")
            lo, hi, step = (float(spec[k]) for k in ("lower", "upper", "step"))
            if not all(map(math.isfinite, (lo, hi, step))) or step <= 0.0 or hi <= lo:
                raise ValueError(f"campaign.variables.{name}: need finite lower < upper and step > 0; got {spec!r}")
            if name == "sma_km" and not (in_range(lo, SEMI_MAJOR_AXIS) and in_range(hi, SEMI_MAJOR_AXIS)):
                raise ValueError(f"campaign.variables.sma_km: bounds must be in {allowed_range_text(SEMI_MAJOR_AXIS)} "
                                 f"({SEMI_MAJOR_AXIS_WHY}); got {spec!r}")
            if name in INTEGER_DESIGN_KEYS and (lo != round(lo) or hi != round(hi) or lo < 1):
                raise ValueError(f"campaign.variables.{name}: integer bounds >= 1 required; got {spec!r}")
            rows.append((lo, hi, step))
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
