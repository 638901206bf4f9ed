"""The design grid of eq. 43-44 (paper Section 5, Table 3): scaled integers <-> physical Walker designs.

Decision variables live on the integer grid of eq. 43, ``x_j = (X_j - L_j) / dX_j``, with the bounds
``L_j``, ``U_j`` and step sizes ``dX_j`` of ``[campaign.variables]``; a scaled design is de-scaled by
eq. 44, ``X_j = min(max(L_j + dX_j x_j, L_j), U_j)``, with Np and Ns rounded to integers.

A search restricted to one constellation size N (``[campaign] n_sat``) asks which orbit and which split of N
satellites into planes serves best; the plane count then indexes the splits ``Np x Ns = N`` allowed by the bounds
(``x_Np = 0..len(splits) - 1``) and ``x_Ns`` is held at 0, so every design the search can propose has N
satellites.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS
from ..sections import walker_splits
from ..settings import VariableBounds

__all__ = ["DesignGrid"]


@dataclass(frozen=True)
class DesignGrid:
    """Bounds ``lower``, ``upper`` and steps ``step`` (6,) of ``DESIGN_KEYS`` (Table 3, eq. 43-44)."""

    lower: np.ndarray
    upper: np.ndarray
    step: np.ndarray
    n_sat: int = 0  # 0: any size; N > 0: only the splits Np x Ns = N (module docstring)

    @classmethod
    def from_variables(cls, variables: Mapping[str, VariableBounds], n_sat: int = 0) -> DesignGrid:
        """From ``settings.campaign.variables`` (``{name: VariableBounds}`` for every name in ``DESIGN_KEYS``,
        checked at load by :mod:`lnss_lib.config`) and ``settings.campaign.n_sat``."""
        rows = [
            (
                float(variables[name].lower),
                float(variables[name].upper),
                float(variables[name].step),
            )
            for name in DESIGN_KEYS
        ]
        lower, upper, step = (np.array(col) for col in zip(*rows))
        return cls(lower, upper, step, int(n_sat))

    @property
    def splits(self) -> tuple[tuple[int, int], ...]:
        """``(Np, Ns)`` on the plane and satellite grids with ``Np x Ns = n_sat`` (empty when the size is free)."""
        if not self.n_sat:
            return ()
        j = [DESIGN_KEYS.index(name) for name in INTEGER_DESIGN_KEYS]
        planes, sats = (
            range(int(self.lower[i]), int(self.upper[i]) + 1, int(self.step[i])) for i in j
        )
        return walker_splits(self.n_sat, planes, sats)

    @property
    def n_levels(self) -> np.ndarray:
        """Largest scaled value of each variable (int, 6): ``ceil((U - L) / dX)``; the scaled domain is 0..n (for a
        restricted size, the last split's index and 0)."""
        levels = np.ceil((self.upper - self.lower) / self.step - 1e-9).astype(int)
        if self.n_sat:
            levels[[DESIGN_KEYS.index(name) for name in INTEGER_DESIGN_KEYS]] = (
                len(self.splits) - 1,
                0,
            )
        return levels

    def scale(self, designs) -> np.ndarray:
        """Eq. 43: scaled values ``(X - L) / dX`` (float, not rounded) of physical designs (n, 6); for a restricted
        size the split's index and 0 (NaN for a design of another size)."""
        designs = np.atleast_2d(np.asarray(designs, dtype=float))
        scaled = (designs - self.lower) / self.step
        if self.n_sat:
            counts = [DESIGN_KEYS.index(name) for name in INTEGER_DESIGN_KEYS]
            index = {split: i for i, split in enumerate(self.splits)}
            scaled[:, counts[0]] = [
                index.get((int(p), int(n)), np.nan) for p, n in designs[:, counts]
            ]
            scaled[:, counts[1]] = 0.0
        return scaled

    def descale(self, scaled) -> np.ndarray:
        """Eq. 44: physical designs (n, 6) of scaled ones, clipped to [L, U]; Np and Ns rounded.

        Real variables are rounded to 12 decimals so that grid values print cleanly (0.3, not
        0.30000000000000004).
        """
        x = np.atleast_2d(np.asarray(scaled, dtype=float))
        if x.shape[-1] != len(DESIGN_KEYS) or not np.all(np.isfinite(x)):
            raise ValueError(
                f"scaled designs must be finite with {len(DESIGN_KEYS)} columns; got shape {x.shape}"
            )
        values = np.round(
            np.minimum(np.maximum(self.lower + self.step * x, self.lower), self.upper), 12
        )
        counts = [DESIGN_KEYS.index(name) for name in INTEGER_DESIGN_KEYS]
        if self.n_sat:
            index = np.clip(np.rint(x[:, counts[0]]), 0, len(self.splits) - 1).astype(int)
            values[:, counts] = np.asarray(self.splits, dtype=float)[index]
        values[:, counts] = np.rint(values[:, counts])
        return values

    def designs(self, scaled) -> list[dict]:
        """Keyword dicts for :func:`~lnss_lib.evaluator.evaluate_design` (ints for Np and Ns)."""
        return [
            {
                k: (int(v) if k in INTEGER_DESIGN_KEYS else float(v))
                for k, v in zip(DESIGN_KEYS, row)
            }
            for row in self.descale(scaled)
        ]
