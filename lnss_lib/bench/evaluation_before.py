"""The campaign's design evaluation before the evaluation-path work, kept here only to time it beside the new.

Before, each evaluation resolved and checked the SPICE kernel paths again (:func:`evaluate_before` calls
:func:`~lnss_lib.ephemeris.load_kernels` on :func:`~lnss_lib.ephemeris.kernel_paths` as
``ensure_kernels`` did; now once per ephemeris settings), built the propagation Dataset, and computed every
Delta-V model of satellite 0 into a Dataset (:func:`~lnss_lib.evaluator.analyse_states` with
``datasets=False``, which the profiles with extra metrics still take). Now
:func:`~lnss_lib.evaluator.campaign_metrics` keeps the propagation in arrays and computes ``[deltav] model``
alone: the same metrics bit for bit. :func:`compare_evaluations` times both on the same designs, alternating.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from ..ephemeris import kernel_paths, load_kernels
from ..errors import InfeasibleDesignError
from ..evaluator import EvaluationContext, analyse_states, evaluate_constellation
from ..keys import METRIC_KEYS, TIMING_KEYS
from ..propagator import elements_deg_to_states


def evaluate_before(context: EvaluationContext, elements_deg: np.ndarray) -> dict | None:
    """The previous campaign evaluation of a constellation's elements (n, 6); None for an infeasible design."""
    load_kernels(kernel_paths(context.settings.dynamics.ephemeris))
    try:
        states = elements_deg_to_states(context.dynamics, elements_deg, context.t0_tdb_s)
        return analyse_states(context, elements_deg, states, datasets=False)["metrics"]
    except InfeasibleDesignError:
        return None


def _evaluate_now(context: EvaluationContext, elements_deg: np.ndarray) -> dict | None:
    result = evaluate_constellation(context, elements_deg)
    return result if result["evaluated"] else None


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def compare_evaluations(
    context: EvaluationContext, designs: list[np.ndarray], repeats: int = 3
) -> dict:
    """Wall time of the previous and the current campaign evaluation of each design (elements (n, 6)), one
    numba thread as in a campaign worker, the two alternating (which goes first alternates by repeat) so that
    machine load hits both alike; medians per design. Returns the per-design medians (s) of both paths and of
    each timed part, the designs evaluated and those whose metrics differ (expected: none)."""
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    paths = {"before": evaluate_before, "now": _evaluate_now}
    times = {name: [] for name in paths}
    parts = {name: {k: [] for k in TIMING_KEYS} for name in paths}
    differing, evaluated = 0, 0
    try:
        for elements in designs[:1]:  # compile or load the kernels outside the clock
            for func in paths.values():
                func(context, elements)
        for elements in designs:
            runs = {name: [] for name in paths}
            results = {}
            for repeat in range(repeats):
                order = list(paths) if repeat % 2 == 0 else list(paths)[::-1]
                for name in order:
                    start = time.perf_counter()
                    results[name] = paths[name](context, elements)
                    runs[name].append((time.perf_counter() - start, results[name]))
            if results["before"] is None or results["now"] is None:
                differing += (results["before"] is None) != (results["now"] is None)
                continue
            evaluated += 1
            differing += not all(
                _same(results["before"][k], results["now"][k]) for k in METRIC_KEYS
            )
            for name in paths:
                times[name].append(float(np.median([t for t, _ in runs[name]])))
                for key in TIMING_KEYS:
                    parts[name][key].append(
                        float(np.median([r["timing_s"][key] for _, r in runs[name]]))
                    )
    finally:
        numba.set_num_threads(threads)
    return {
        "n_designs": evaluated,
        "n_differing": differing,
        **{
            f"{name}_s": float(np.mean(values)) if values else math.nan
            for name, values in times.items()
        },
        **{
            f"{name}_{key}_s": float(np.mean(values)) if values else math.nan
            for name in paths
            for key, values in parts[name].items()
        },
    }
