"""Notebook 08 (design life): how large may the station-keeping box be before navigation suffers?

Question: the closed loop (:mod:`lnss_lib.design_life.closed_loop`) holds each satellite's mean e, AOP, i,
relative RAAN and slot within half-widths ``[design_life.box]``. How much do PDOP/HDOP availability and
their 3-sigma means degrade when one satellite sits at a box edge (slot off by 5, 10, 20 deg; e off by
0.03; AOP, i, RAAN off by their half-widths), and when every satellite sits at a random point of the
box at once?

Verdict: printed by :func:`box_sensitivity` on the profile it is given; the box defaults of
params/paper.toml are chosen where the availability loss stays small (see its comments).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..evaluator import EvaluationContext, evaluate_constellation

__all__ = ["box_sensitivity", "perturbed_elements"]

_COLUMN = {"ecc": 1, "inc_deg": 2, "raan_rel_deg": 3, "aop_deg": 4, "u_rel_deg": 5}
METRICS = (
    "pdop_avail_pct",
    "hdop_avail_pct",
    "pdop_mean_3sigma",
    "hdop_mean_3sigma",
    "mean_visible_sats",
)


def perturbed_elements(
    elements_deg, offsets: dict, sat: int | None = 0, seed: int = 0
) -> np.ndarray:
    """Elements (n, 6) deg with ``offsets`` (box key -> offset, :data:`lnss_lib.design_life.fleet.BOX_KEYS`) added.

    ``sat`` an index: that satellite only (the slot offset goes on M: the mean argument of latitude
    moves with it); ``sat=None``: every satellite, each offset times a uniform draw in [-1, 1] (``seed``).
    """
    el = np.array(np.atleast_2d(elements_deg), dtype=float)
    unknown = set(offsets) - set(_COLUMN)
    if unknown:
        raise ValueError(f"unknown box key(s) {sorted(unknown)}; allowed: {sorted(_COLUMN)}")
    rng = np.random.default_rng(seed)
    rows = np.arange(el.shape[0]) if sat is None else np.array([int(sat)])
    for key, value in offsets.items():
        scale = rng.uniform(-1.0, 1.0, rows.size) if sat is None else np.ones(1)
        el[rows, _COLUMN[key]] += float(value) * scale
    return el


def box_sensitivity(context: EvaluationContext, elements_deg, cases: dict) -> pd.DataFrame:
    """Navigation metrics of the nominal constellation and of each perturbed case.

    ``cases`` maps a label to ``(offsets, sat)`` for :func:`perturbed_elements`. Rows: ``nominal`` and
    each label; columns :data:`METRICS` and their change against the nominal (``d_`` prefix).
    """
    rows = {"nominal": evaluate_constellation(context, elements_deg)}
    for label, (offsets, sat) in cases.items():
        rows[label] = evaluate_constellation(
            context, perturbed_elements(elements_deg, offsets, sat)
        )
    bad = [k for k, r in rows.items() if not r["evaluated"]]
    if bad:
        raise ValueError(
            f"case(s) {bad} could not be evaluated: {[rows[k]['reason'] for k in bad]}"
        )
    table = pd.DataFrame({k: {m: r[m] for m in METRICS} for k, r in rows.items()}).T
    for m in METRICS:
        table[f"d_{m}"] = table[m] - table.loc["nominal", m]
    return table
