"""Objectives, constraints, dominance and hypervolume of eq. 45 and Table 3: pure functions on arrays.

Numpy, and pymoo's HV indicator alone (pymoo's ``functions/`` and ``indicators/`` apart from its algorithms): the objectives are
the metrics named in ``campaign.objectives`` (a leading ``-`` marks a maximised metric, negated so
every objective is minimised); the constraints are Table 3's fitness bounds as inequality
constraints ``g <= 0``, normalised by their limits. A design without a metric (impact, invalid
elements, no four-satellite coverage: NaN) gets the finite penalty ``nan_objective`` for that
objective and ``nan_violation`` for that constraint, so it is dominated, never an error.
"""

from __future__ import annotations

import numpy as np

from ..keys import EXTRA_METRIC_KEYS, METRIC_KEYS, NON_NAVIGATION_METRICS, bound_text

__all__ = [
    "objective_matrix",
    "constraint_matrix",
    "constraint_violation",
    "non_dominated_mask",
    "hypervolume_points",
    "front_of",
    "hypervolume_of_front",
    "metric_columns",
    "parse_constraints",
    "satisfies",
    "deltav_constraint",
    "SERVICE_AVAILABILITY",
    "smallest_constellation",
]


def objective_matrix(metrics: dict, objectives, nan_objective: float) -> np.ndarray:
    """F (n, k) for pymoo (minimised): metric, or -metric for a ``-name`` objective; NaN -> ``nan_objective``."""
    columns = []
    for name in objectives:
        values = np.asarray(metrics[name.lstrip("-")], dtype=float)
        signed = -values if name.startswith("-") else values
        columns.append(np.where(np.isfinite(signed), signed, nan_objective))
    return np.column_stack(columns)


def constraint_matrix(metrics: dict, constraints, nan_violation: float) -> np.ndarray:
    """G (n, m), feasible where <= 0: ``value / limit - 1`` for a max bound, ``1 - value / limit`` for a min
    bound (divided by ``|limit|``, or 1 for a zero limit); a NaN metric violates by ``nan_violation``."""
    n = len(np.asarray(metrics[METRIC_KEYS[0]]))
    if not constraints:
        return np.zeros((n, 0))
    columns = []
    for metric, kind, limit in constraints:
        values = np.asarray(metrics[metric], dtype=float)
        scale = abs(limit) if limit != 0.0 else 1.0
        g = (values - limit) / scale if kind == "max" else (limit - values) / scale
        columns.append(np.where(np.isfinite(g), g, nan_violation))
    return np.column_stack(columns)


def constraint_violation(g: np.ndarray) -> np.ndarray:
    """Total violation (n,) >= 0: the sum of the positive parts of G (pymoo's CV)."""
    return np.sum(np.maximum(np.asarray(g, dtype=float), 0.0), axis=1)


def non_dominated_mask(f: np.ndarray) -> np.ndarray:
    """True for the rows of F (n, k) that no other row dominates (<= everywhere, < somewhere); minimisation.

    Identical rows do not dominate each other, so duplicates are all kept. moocore's ``is_nondominated`` with
    ``keep_weakly`` (pymoo's own filter: Kung, Luccio and Preparata's O(n log^(k-2) n) sweep, in C): the front of a
    120 x 1000 campaign's 69,000 feasible designs in nine objectives in a quarter of a second.
    """
    f = np.asarray(f, dtype=float)
    if f.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    import moocore  # pymoo's dependency, imported when a front is wanted

    return np.asarray(moocore.is_nondominated(f, keep_weakly=True), dtype=bool)


def hypervolume_points(metrics: dict, feasible: np.ndarray, reference) -> np.ndarray:
    """The feasible designs in the space of ``reference`` metrics ``((metric, value), ...)``, each divided by its
    reference value, those inside the box [0, 1) only: (m, len(reference))."""
    points = np.column_stack(
        [np.asarray(metrics[m], dtype=float)[feasible] / ref for m, ref in reference]
    )
    return points[np.all(points < 1.0, axis=1)]


def front_of(points: np.ndarray) -> np.ndarray:
    """The non-dominated rows of ``points``, sorted lexicographically (one order, however they were gathered)."""
    front = points[non_dominated_mask(points)]
    return front[np.lexsort(tuple(front[:, j] for j in range(front.shape[1] - 1, -1, -1)))]


def hypervolume_of_front(front: np.ndarray) -> float:
    """Hypervolume of normalised points (ideal at 0, reference point at 1) given as their :func:`front_of`."""
    if front.shape[0] == 0:
        return 0.0
    from pymoo.indicators.hv import HV  # the indicator alone: no algorithm machinery

    return float(HV(ref_point=np.ones(front.shape[1]))(front))


def metric_columns(records: list[dict], extras=()) -> dict:
    """Metric arrays (n,) keyed by ``METRIC_KEYS`` and the ``extras`` (of ``EXTRA_METRIC_KEYS``; NaN where a
    record has none) from cache records, plus ``ok`` (evaluated without impact)."""
    unknown = [k for k in extras if k not in EXTRA_METRIC_KEYS]
    if unknown:
        raise ValueError(
            f"unknown extra metric(s) {unknown}; allowed: {', '.join(EXTRA_METRIC_KEYS)}"
        )
    columns = {
        k: np.array([r["metrics"][k] for r in records], dtype=int if k == "n_sat" else float)
        for k in METRIC_KEYS
    }
    columns.update(
        {k: np.array([r["metrics"].get(k, np.nan) for r in records], dtype=float) for k in extras}
    )
    columns["ok"] = np.array([r["ok"] for r in records], dtype=bool)
    return columns


def parse_constraints(text: str) -> list[tuple[str, str, float]]:
    """``"pdop_mean_3sigma <= 10,pdop_avail_pct >= 70"`` -> [(metric, "max"|"min", limit), ...]."""
    constraints = []
    for item in filter(None, (part.strip() for part in text.split(","))):
        for operator, kind in (("<=", "max"), (">=", "min")):
            if operator in item:
                metric, limit = (s.strip() for s in item.split(operator))
                constraints.append((metric, kind, float(limit)))
                break
        else:
            raise ValueError(
                f"cannot read constraint {item!r}; expected 'metric <= limit' or 'metric >= limit'"
            )
    return constraints


def satisfies(ds, constraints) -> np.ndarray:
    """Boolean (design,) mask of the designs of a dataset (``ds[metric]``: (design,)) meeting every
    (metric, kind, limit) constraint (NaN fails)."""
    ok = np.ones(ds.sizes["design"], dtype=bool)
    for metric, kind, limit in constraints:
        values = ds[metric].values.astype(float)
        with np.errstate(invalid="ignore"):
            ok &= (values <= limit) if kind == "max" else (values >= limit)
    return ok


NAVIGATION_ONLY = "navigation bounds only (no Delta-V or stability bound)"
ALL_BOUNDS = "all Table 3 bounds (feasible)"


def bound_masks(evaluations, constraints) -> dict[str, np.ndarray]:
    """Boolean (design,) masks, keyed by what they mean: evaluated without impact (PDOP availability defined),
    each (metric, kind, limit) of ``constraints`` separately (:func:`~lnss_lib.keys.bound_text`; NaN fails),
    all bounds except those on Delta-V and stability (:data:`NAVIGATION_ONLY`), and the campaign's own
    ``feasible`` flag (:data:`ALL_BOUNDS`)."""
    masks = {
        "evaluated without impact": ~np.isnan(evaluations["pdop_avail_pct"].values.astype(float))
    }
    navigation = np.ones(evaluations.sizes["design"], dtype=bool)
    for metric, kind, limit in constraints:
        if kind not in ("min", "max"):
            raise ValueError(f"constraint kind {kind!r} for {metric!r} unknown; allowed: min, max")
        met = satisfies(evaluations, [(metric, kind, limit)])
        masks[bound_text(metric, kind, limit)] = met
        if metric not in NON_NAVIGATION_METRICS:
            navigation &= met
    masks[NAVIGATION_ONLY] = navigation
    masks[ALL_BOUNDS] = evaluations["feasible"].values.astype(bool)
    return masks


def deltav_constraint(evaluations) -> tuple[str, float]:
    """(metric, limit) of a campaign's Delta-V bound, read from its results' ``attrs["constraints"]`` (Table 3's; a ``max`` on a metric with ``dv_`` in its
    name, e.g. ``dv_total_kms_per_year`` or ``sk_dv_estimate_max_kms_per_year``); the paper's Delta-V
    total and no limit (inf) when the campaign has none."""
    bounds = [
        (m, v)
        for m, k, v in parse_constraints(evaluations.attrs["constraints"])
        if k == "max" and "dv_" in m
    ]
    if len(bounds) > 1:
        raise ValueError(f"the campaign has several Delta-V bounds {bounds}; expected at most one")
    return bounds[0] if bounds else ("dv_total_kms_per_year", np.inf)


SERVICE_AVAILABILITY = ("pdop_avail_pct", "hdop_avail_pct")
"""The availabilities a constellation keeps the service by (Table 6's rule): PDOP and HDOP, each in %."""


def smallest_constellation(
    designs,
    admissible,
    dv_metric: str,
    *,
    availability_min_pct: float,
    availability: tuple[str, ...] = SERVICE_AVAILABILITY,
) -> int | None:
    """The smallest constellation that keeps the service: the one rule of every "smallest" the workbook states (the
    answer and the findings, Table 6's first row and its Figure 16, notebook 07's comparison with the paper, the
    headline flown in closed loop).

    Among the ``admissible`` designs (boolean (design,) mask, e.g. those meeting every bound) whose ``availability``
    columns all reach ``availability_min_pct`` (the paper's "over 90 % coverage"; NaN fails), the fewest satellites;
    ties: the lowest ``dv_metric`` (the Delta-V the campaign bounds; NaN last). ``designs``: a Dataset or DataFrame
    of (design,) columns with ``n_sat``. Returns the design's position, or None when none qualifies. Among a
    campaign's feasible designs the front holds it: a design dominating it would qualify with no more satellites
    and no more Delta-V.
    """
    mask = np.array(admissible, dtype=bool)
    with np.errstate(invalid="ignore"):
        for key in availability:
            mask &= np.asarray(designs[key], dtype=float) >= availability_min_pct
    index = np.flatnonzero(mask)
    if not index.size:
        return None
    dv = np.asarray(designs[dv_metric], dtype=float)[index]
    n_sat = np.asarray(designs["n_sat"], dtype=float)[index]
    return int(index[np.lexsort((np.where(np.isnan(dv), np.inf, dv), n_sat))[0]])
