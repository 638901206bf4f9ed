"""The campaign's design evaluation before the evaluation-path work, run from its commit, timed
beside today's.

Before, each evaluation resolved and checked the SPICE kernel paths again, built the propagation
Dataset and computed every Delta-V model of satellite 0 into a Dataset; now the campaign keeps the
propagation in arrays and computes ``[deltav] model`` alone, the same metrics bit for bit. That
previous path is ``lnss_lib/bench/evaluation_before.py`` at commit :data:`BEFORE_COMMIT`:
:class:`PreviousEvaluation` runs it from that commit's tree (read from git,
:func:`~lnss_lib.bench.git_tree.cached_tree`) in a child interpreter that evaluates one design at a
time on request, so that :func:`compare_evaluations` can alternate it with today's path design by
design. Without git or that commit only today's path is timed.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

from ..evaluator import EvaluationContext, evaluate_constellation
from ..keys import METRIC_KEYS, TIMING_KEYS
from .git_tree import cached_tree

__all__ = ["BEFORE_COMMIT", "PreviousEvaluation", "compare_evaluations"]

BEFORE_COMMIT = "5b283da196b61d5cdceb0c75b3361ce6bc87873c"
"""The last tree that ships ``lnss_lib/bench/evaluation_before.py``, the evaluation before the
evaluation-path work."""

WHAT = "the campaign evaluation before the evaluation-path work"
ANSWER = "lnss-before "  # marks the child's answers among anything else it prints

# Run in the tree of BEFORE_COMMIT (its lnss_lib first on the path): one numba thread as in a
# campaign worker, the profile's context built once, then one design's elements (n, 6) per line of
# stdin, answered with its wall time and metrics (None for an infeasible design).
_BEFORE_SCRIPT = """
import json, sys, time
import numba
import numpy as np
from lnss_lib.bench.evaluation_before import evaluate_before
from lnss_lib.evaluator import context_for
from lnss_lib.settings import load_settings

request = json.loads(sys.argv[1])
numba.set_num_threads(1)
context = context_for(load_settings(request["profile"], overrides=request["overrides"]))
print(request["answer"] + json.dumps({"ready": True}), flush=True)
for line in sys.stdin:
    elements = np.array(json.loads(line), dtype=float)
    start = time.perf_counter()
    metrics = evaluate_before(context, elements)
    answer = {"wall_s": time.perf_counter() - start, "metrics": metrics}
    print(request["answer"] + json.dumps(answer, default=float), flush=True)
"""


class PreviousEvaluation:
    """The evaluation of :data:`BEFORE_COMMIT` for profile ``profile_name`` with ``overrides`` (that
    commit's own copy of the profile), in a child interpreter: calling it with a design's elements
    (n, 6) gives the child's wall time (s) and the metrics (None for an infeasible design).
    RuntimeError, naming what is missing, when git or the commit is not there or the child stops.
    Use it as a context manager (the child ends on exit)."""

    def __init__(self, profile_name: str, overrides: dict | None = None):
        tree = cached_tree(BEFORE_COMMIT, WHAT)
        request = {"profile": profile_name, "overrides": overrides, "answer": ANSWER}
        self._stderr = tempfile.TemporaryFile(mode="w+")
        self._child = subprocess.Popen(
            [sys.executable, "-c", _BEFORE_SCRIPT, json.dumps(request)],
            cwd=tree,
            env={**os.environ, "PYTHONPATH": str(tree)},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            text=True,
        )
        self._answer()

    def _answer(self) -> dict:
        for line in self._child.stdout:
            if line.startswith(ANSWER):
                return json.loads(line[len(ANSWER) :])
        self._child.wait()
        self._stderr.seek(0)
        raise RuntimeError(
            f"{WHAT} (commit {BEFORE_COMMIT[:12]}) stopped with exit code "
            f"{self._child.returncode}: {self._stderr.read()[-400:]}"
        )

    def __call__(self, elements_deg: np.ndarray) -> tuple[float, dict | None]:
        self._child.stdin.write(json.dumps(np.asarray(elements_deg, dtype=float).tolist()) + "\n")
        self._child.stdin.flush()
        answer = self._answer()
        return answer["wall_s"], answer["metrics"]

    def close(self) -> None:
        if self._child.poll() is None:
            self._child.stdin.close()
            try:
                self._child.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self._child.kill()
                self._child.wait()
        self._stderr.close()

    def __enter__(self) -> PreviousEvaluation:
        return self

    def __exit__(self, *_) -> None:
        self.close()


def evaluate_now(context: EvaluationContext, elements_deg: np.ndarray) -> tuple[float, dict | None]:
    """Today's campaign evaluation of a design's elements (n, 6): its wall time (s) and metrics
    (None for an infeasible design)."""
    start = time.perf_counter()
    result = evaluate_constellation(context, elements_deg)
    return time.perf_counter() - start, result if result["evaluated"] else None


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def compare_evaluations(
    context: EvaluationContext, designs: list[np.ndarray], before=None, repeats: int = 3
) -> dict:
    """Wall time of the previous campaign evaluation ``before`` (a callable like
    :class:`PreviousEvaluation`; None: today's alone) and of today's on each design (elements (n,
    6)), one numba thread as in a campaign worker, the two alternating (which goes first alternates
    by repeat) so that machine load hits both alike; medians per design. Returns the mean per-design
    medians (s) of each path and of each timed part (``before_s``, ``now_s``, ``now_dop_s``, ...;
    NaN for a path not run), the designs evaluated and those whose metrics differ (expected:
    none)."""
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    paths = {"now": lambda elements: evaluate_now(context, elements)}
    if before is not None:
        paths = {"before": before, **paths}
    times = {name: [] for name in ("before", "now")}
    parts = {name: {k: [] for k in TIMING_KEYS} for name in times}
    differing, evaluated = 0, 0
    try:
        for elements in designs[:1]:  # compile or load the kernels outside the clock
            for func in paths.values():
                func(elements)
        for elements in designs:
            runs = {name: [] for name in paths}
            for repeat in range(repeats):
                order = list(paths) if repeat % 2 == 0 else list(paths)[::-1]
                for name in order:
                    runs[name].append(paths[name](elements))
            results = {name: runs[name][-1][1] for name in paths}
            if any(result is None for result in results.values()):
                differing += len({result is None for result in results.values()}) > 1
                continue
            evaluated += 1
            if before is not None:
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
            for name in times
            for key, values in parts[name].items()
        },
    }
