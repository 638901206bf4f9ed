"""The force model's right-hand side timed on an integration's points, beside the model before its speed
work, which runs from the workbook's own history rather than from a copy kept in the package.

Before, each evaluation chose its gravity degree with a loop over degrees, interpolated the MOON_PA
rotation and each body with its own Hermite weights, summed the harmonic acceleration term by term and
took the conical shadow's three angles at every call. That code is
``lnss_lib/bench/kernels_before.py`` at commit :data:`BEFORE_COMMIT`; :func:`before_on_points` extracts
that commit's tree with ``git archive`` into a temporary folder and runs it in a child interpreter on
the same points, so both sides are timed on this machine. The two agree to round-off (~1e-15
relative; the current sums are reordered), the shadow factors bit for bit. :func:`rhs_points` records
the (t, y) points an integration of one satellite evaluates and :func:`current_on_points` times the
current right-hand side and shadow factors on them; :func:`kernel_comparison` prints the two side by
side for ``bench campaign``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp

from ..campaign.grid import DesignGrid
from ..constants import SECONDS_PER_DAY
from ..constellation import WalkerDesign
from ..ephemeris import hermite_apply, hermite_basis
from ..evaluator import context_for
from ..forces import (
    R_EARTH,
    R_MOON,
    R_SUN,
    SCRATCH_SIZE,
    TERMS,
    ForceModel,
    acceleration,
    shadow_factor,
)
from ..propagator import elements_deg_to_states
from ..settings import load_settings
from .git_tree import extract_tree

__all__ = [
    "BEFORE_COMMIT",
    "KERNEL_DESIGNS",
    "rhs_points",
    "current_on_points",
    "before_on_points",
    "kernel_comparison",
]

BEFORE_COMMIT = (
    "5b283da196b61d5cdceb0c75b3361ce6bc87873c"  # the last tree with the previous kernels
)
REPEATS = 3  # timings per side; the median is reported
KERNEL_DESIGNS = 4  # designs of the short run whose right-hand sides are timed before and after

# Run in the tree of BEFORE_COMMIT (its lnss_lib first on the path): the previous right-hand side and
# shadow factors on the points of every satellite, timed, with their values.
_BEFORE_SCRIPT = """
import json, sys, time
import numpy as np
from lnss_lib.bench.kernels_before import (
    _replay_before, _replay_shadows, acceleration_before, before_field,
)
from lnss_lib.ephemeris import EphemerisTable, ensure_kernels
from lnss_lib.forces import SCRATCH_SIZE, TERMS, ForceModel
from lnss_lib.settings import load_settings

request = json.loads(sys.argv[1])
settings = load_settings(request["profile"], overrides=request["overrides"])
ensure_kernels(settings.ephemeris)
table = EphemerisTable.build(settings.dynamics, request["t0_tdb_s"], request["t_end_tdb_s"])
model = ForceModel.build(settings.dynamics, table)
args, field = model.kernel_args, before_field(model)
work, scratch, terms = model.field.workspace(), np.zeros(SCRATCH_SIZE), np.zeros((len(TERMS), 3))
points = np.load(request["points"])
result = {}
for k in range(request["n_satellites"]):
    ts, ys = points[f"t_{k}"], points[f"y_{k}"]
    acc, shadows, out = np.empty((len(ts), 3)), np.empty((len(ts), 2)), np.zeros(3)
    for i in range(len(ts)):
        acceleration_before(ts[i], ys[i], args, field, work, scratch, terms, acc[i])
    rhs_s, shadow_s = [], []
    for _ in range(request["repeats"]):
        start = time.process_time()
        _replay_before(ts, ys, args, field, work, scratch, terms, out)
        rhs_s.append(time.process_time() - start)
        start = time.process_time()
        _replay_shadows(ts, ys, args, True, shadows)
        shadow_s.append(time.process_time() - start)
    result[f"acceleration_{k}"], result[f"shadow_{k}"] = acc, shadows
    result[f"times_{k}"] = np.array([np.median(rhs_s), np.median(shadow_s)])
np.savez(request["out"], **result)
"""


def rhs_points(
    model: ForceModel,
    y0: np.ndarray,
    t0_tdb_s: float,
    duration_s: float,
    method: str,
    rtol: float,
    atol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The (t, y) points at which an integration of one satellite (``method`` RK45 or DOP853) evaluates the
    force model."""
    args, work = model.kernel_args, model.field.workspace()
    scratch, terms, acc = np.zeros(SCRATCH_SIZE), np.zeros((len(TERMS), 3)), np.zeros(3)
    ts, ys = [], []

    def rhs(t, y):
        ts.append(t)
        ys.append(y.copy())
        acceleration(t, y, args, work, scratch, terms, acc)
        return np.concatenate([y[3:], acc])

    solve_ivp(rhs, (t0_tdb_s, t0_tdb_s + duration_s), y0, method=method, rtol=rtol, atol=atol)
    return np.array(ts), np.array(ys)


@nb.njit(cache=True)
def _replay(ts, ys, args, work, scratch, terms, out):
    total = 0.0
    for i in range(ts.shape[0]):
        acceleration(ts[i], ys[i], args, work, scratch, terms, out)
        total += out[0]
    return total


@nb.njit(cache=True)
def _shadows(ts, ys, args, out):
    """The Moon's and the Earth's shadow factors at every point into ``out`` (n, 2), with the bodies'
    interpolation."""
    scalars, _, _, t0dt, bodies, rot_pa = args[:6]
    r_sun, r_earth = np.empty(3), np.empty(3)
    for i in range(ts.shape[0]):
        basis = hermite_basis(rot_pa.shape[0], t0dt[0], t0dt[1], ts[i])
        hermite_apply(bodies[:, 0, :3], bodies[:, 0, 3:], basis, r_sun)
        hermite_apply(bodies[:, 1, :3], bodies[:, 1, 3:], basis, r_earth)
        ex, ey, ez = r_earth[0], r_earth[1], r_earth[2]
        out[i, 0] = shadow_factor(ys[i], r_sun, 0.0, 0.0, 0.0, scalars[R_MOON], scalars[R_SUN])
        out[i, 1] = shadow_factor(ys[i], r_sun, ex, ey, ez, scalars[R_EARTH], scalars[R_SUN])


def current_on_points(model: ForceModel, ts: np.ndarray, ys: np.ndarray) -> dict:
    """CPU seconds of the current right-hand side and of the shadow factors alone over every point (median of
    :data:`REPEATS`), with the accelerations (n, 3) and shadow factors (n, 2) they give."""
    args = model.kernel_args
    work, scratch, terms = (
        model.field.workspace(),
        np.zeros(SCRATCH_SIZE),
        np.zeros((len(TERMS), 3)),
    )
    acc, shadows, out = np.empty((len(ts), 3)), np.empty((len(ts), 2)), np.zeros(3)
    for i in range(len(ts)):
        acceleration(ts[i], ys[i], args, work, scratch, terms, acc[i])
    rhs_s, shadow_s = [], []
    for _ in range(REPEATS):
        start = time.process_time()
        _replay(ts, ys, args, work, scratch, terms, out)
        rhs_s.append(time.process_time() - start)
        start = time.process_time()
        _shadows(ts, ys, args, shadows)
        shadow_s.append(time.process_time() - start)
    return {
        "rhs_s": float(np.median(rhs_s)),
        "shadow_s": float(np.median(shadow_s)),
        "acceleration": acc,
        "shadow": shadows,
    }


def before_on_points(
    profile_name: str,
    overrides: dict | None,
    span_tdb_s: tuple[float, float],
    points: list[tuple[np.ndarray, np.ndarray]],
) -> list[dict]:
    """The previous right-hand side (commit :data:`BEFORE_COMMIT`, its model built from its own copy of
    profile ``profile_name`` with ``overrides`` on an ephemeris table over ``span_tdb_s``, as the current
    one's) on each satellite's ``(ts, ys)``: for each, ``rhs_s`` and ``shadow_s`` (CPU seconds, median of
    :data:`REPEATS`), ``acceleration`` (n, 3) and ``shadow`` (n, 2)."""
    with tempfile.TemporaryDirectory(prefix="lnss-before-") as scratch:
        tree, points_file, out = (
            Path(scratch) / "tree",
            Path(scratch) / "points.npz",
            Path(scratch) / "out.npz",
        )
        tree.mkdir()
        extract_tree(BEFORE_COMMIT, tree, "the force model before its speed work")
        np.savez(
            points_file, **{f"{k}_{i}": a for i, p in enumerate(points) for k, a in zip("ty", p)}
        )
        request = {
            "profile": profile_name,
            "overrides": overrides,
            "t0_tdb_s": float(span_tdb_s[0]),
            "t_end_tdb_s": float(span_tdb_s[1]),
            "points": str(points_file),
            "out": str(out),
            "n_satellites": len(points),
            "repeats": REPEATS,
        }
        env = {**os.environ, "PYTHONPATH": str(tree)}
        done = subprocess.run(
            [sys.executable, "-c", _BEFORE_SCRIPT, json.dumps(request)],
            cwd=tree,
            env=env,
            capture_output=True,
            text=True,
        )
        if done.returncode != 0:
            raise RuntimeError(
                f"the force model of commit {BEFORE_COMMIT[:12]} did not run: {done.stderr[-400:]}"
            )
        with np.load(out) as result:
            return [
                {
                    "rhs_s": float(result[f"times_{k}"][0]),
                    "shadow_s": float(result[f"times_{k}"][1]),
                    "acceleration": result[f"acceleration_{k}"],
                    "shadow": result[f"shadow_{k}"],
                }
                for k in range(len(points))
            ]


def kernel_comparison(
    profile_name: str, records: list[dict], overrides: dict | None = None
) -> dict:
    """Print and return the force model's CPU time before and after, per right-hand side and per design, on the
    points each satellite of the first :data:`KERNEL_DESIGNS` valid designs of ``records`` is integrated at (the
    model before runs from its commit, :func:`before_on_points`)."""
    settings = load_settings(profile_name, overrides=overrides)
    context = context_for(settings)
    grid = DesignGrid.from_variables(settings.campaign.variables)
    integ = settings.dynamics.integrator.settings[settings.dynamics.integrator.setting]
    duration = settings.epoch.duration_days * SECONDS_PER_DAY
    print(
        f"force model before (commit {BEFORE_COMMIT[:12]}) -> after, {integ.method} at rtol {integ.rtol:g}, "
        "CPU time, same points:"
    )
    designs, points = [], []
    for record in [r for r in records if r["ok"]][:KERNEL_DESIGNS]:
        design = grid.descale(record["key"])[0]
        walker = WalkerDesign(*(float(x) for x in design[:4]), int(design[4]), int(design[5]))
        states = elements_deg_to_states(settings.dynamics, walker.elements_deg(), context.t0_tdb_s)
        designs.append((walker, len(points), len(points) + len(states)))
        points += [
            rhs_points(
                context.model, y0, context.t0_tdb_s, duration, integ.method, integ.rtol, integ.atol
            )
            for y0 in states
        ]
    span = (context.t0_tdb_s, float(context.times[-1]))  # the evaluation's ephemeris table
    before = before_on_points(profile_name, overrides, span, points)
    now = [current_on_points(context.model, ts, ys) for ts, ys in points]
    totals = {
        "new_s": sum(r["rhs_s"] for r in now),
        "before_s": sum(r["rhs_s"] for r in before),
        "n_rhs": sum(len(ts) for ts, _ in points),
        "shadow_new_s": sum(r["shadow_s"] for r in now),
        "shadow_before_s": sum(r["shadow_s"] for r in before),
        "shadow_same": all(np.array_equal(a["shadow"], b["shadow"]) for a, b in zip(now, before)),
    }
    max_rel_diff = max(
        (
            float(
                np.max(
                    np.linalg.norm(a["acceleration"] - b["acceleration"], axis=1)
                    / np.linalg.norm(b["acceleration"], axis=1)
                )
            )
            for a, b in zip(now, before)
        ),
        default=0.0,
    )
    for walker, first, last in designs:
        mine = {
            key: sum(r["rhs_s"] for r in side[first:last])
            for key, side in (("new_s", now), ("before_s", before))
        }
        n_rhs = sum(len(ts) for ts, _ in points[first:last])
        print(
            f"  a {walker.sma_km:.0f} km, e {walker.ecc:.2f}, i {walker.inc_deg:.1f} deg, {walker.n_planes} x "
            f"{walker.sats_per_plane}: {n_rhs} right-hand sides, {mine['before_s']:.3f} s -> {mine['new_s']:.3f} s "
            f"per design ({100 * (1 - mine['new_s'] / mine['before_s']):.1f}% less)"
        )
    n = max(totals["n_rhs"], 1)
    print(
        f"  per right-hand side: {1e6 * totals['before_s'] / n:.3f} us -> {1e6 * totals['new_s'] / n:.3f} us; largest relative "
        f"difference of the accelerations {max_rel_diff:.1e} (round-off of the reordered harmonic sums)"
    )
    print(
        f"  of which the conical shadow of the Moon and the Earth (with the bodies' interpolation), alone: "
        f"{1e9 * totals['shadow_before_s'] / n:.1f} ns -> {1e9 * totals['shadow_new_s'] / n:.1f} ns per right-hand side "
        f"({100 * (totals['shadow_before_s'] - totals['shadow_new_s']) / totals['new_s']:.1f}% of the new right-hand "
        f"side); same values bit for bit: {totals['shadow_same']}"
    )
    return {**totals, "max_rel_diff": max_rel_diff}
