"""``python -m lnss_lib bench design-life``: one design-year of closed loop against the campaign's cheap predictors.

First the closed loop's cost per satellite-year on one core (the compiled kernels on one thread), the path of
:data:`BEFORE_COMMIT` (the package ``lnss_lib/design_life`` of that commit, read from git into
``~/.cache/lnss_lib/tree``) and today's side by side in one run, alternating, on one satellite of the standalone ELFO
flown ``[design_life] life_days`` with the profile's controller and DOP samples every
``[life_evaluation] sample_step_s`` (as the validations fly it): the loop itself (``wall_s``) and the whole call
(insertion trim, derived tolerances, averaged field), whether both paths gave the same Delta-V, burns and positions
to the last bit, and the largest relative differences. Without git or that commit only today's path is timed.

Then, for the standalone ELFO (16 satellites): the wall time of the closed-loop station keeping over
``[design_life] life_days`` (full force model, every satellite), of the natural drift over the same
life, of the campaign-grade geometry-keeping estimate on the 10-day arc (the arc's propagation
printed apart: the evaluator pays it anyway) and of the stability screen, side by side.
"""

from __future__ import annotations

import importlib.util
import sys
import tarfile
import time

import numba
import numpy as np

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..constellation import standalone_elfo
from ..design_life.closed_loop import life_force_model, simulate_life
from ..design_life.estimate import sk_estimate_from_propagation
from ..design_life.screen import screen_states
from ..ephemeris import ensure_kernels, tdb_seconds
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import load_settings
from .git_tree import cached_tree

BEFORE_COMMIT = "f1900c1d4fff8da8da3dcf664b5ce50e6636f769"
"""The closed loop before its check measured the mean elements, the osculating elements and the navigation DOP
with compiled kernels and the force model's tabulated Moon-fixed rotation (numpy, SPICE per sample and the Dataset
DOP path)."""

WHAT = "the closed loop before its compiled check measurements"

BEFORE_PACKAGE = "lnss_lib.design_life_before"
"""Module name the package of :data:`BEFORE_COMMIT` is imported under (its ``..`` imports reach today's lnss_lib)."""


def closed_loop_before(commit: str = BEFORE_COMMIT):
    """``simulate_life`` of ``lnss_lib/design_life`` at ``commit`` (its tree from git,
    :func:`~lnss_lib.bench.git_tree.cached_tree`), or None (with the reason printed) when git or the commit is not
    there or that package no longer imports against today's modules."""
    try:
        package = cached_tree(commit, WHAT) / "lnss_lib" / "design_life"
        if BEFORE_PACKAGE not in sys.modules:
            spec = importlib.util.spec_from_file_location(
                BEFORE_PACKAGE, package / "__init__.py", submodule_search_locations=[str(package)]
            )
            module = importlib.util.module_from_spec(spec)
            sys.modules[BEFORE_PACKAGE] = module
            spec.loader.exec_module(module)
        return importlib.import_module(f"{BEFORE_PACKAGE}.closed_loop").simulate_life
    except (OSError, RuntimeError, ImportError, tarfile.TarError) as error:
        sys.modules.pop(BEFORE_PACKAGE, None)
        print(
            f"  the path of {commit[:10]} is not available here ({type(error).__name__}: {error})"
        )
        return None


def _fly(profile, el, t0, model, simulate=simulate_life, **kwargs):
    """``simulate`` (a ``simulate_life``) of elements ``el`` with the profile's sections."""
    return simulate(
        profile.design_life,
        profile.dynamics,
        el,
        t0,
        stability=profile.stability,
        dop=profile.dop,
        model=model,
        **kwargs,
    )


def satellite_year(profile_name: str = "paper", overrides: dict | None = None, repeats: int = 2):
    """Print seconds per satellite-year of the closed loop, the path of :data:`BEFORE_COMMIT` and today's, on one
    core (the compiled kernels on one thread, as in a validation worker; the threads are restored after)."""
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        _satellite_year(profile_name, overrides, repeats)
    finally:
        numba.set_num_threads(threads)


def _satellite_year(profile_name: str, overrides: dict | None, repeats: int):
    profile = load_settings(profile_name, overrides=overrides)
    ensure_kernels(profile.ephemeris)
    settings = profile.design_life
    el = standalone_elfo(profile.standalone_elfo, profile.dynamics)[:1]
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    years = settings.life_days / DAYS_PER_JULIAN_YEAR
    model = life_force_model(profile.dynamics, t0, settings.life_days)
    paths = {"today": simulate_life}
    before = closed_loop_before()
    if before is not None:
        paths = {f"before ({BEFORE_COMMIT[:10]})": before, **paths}
    print(
        f"closed loop, one standalone-ELFO satellite, {settings.life_days:g} days, controller "
        f"{settings.controller}, samples every {profile.life_evaluation.sample_step_s:g} s"
    )

    def fly(path, days):
        step = profile.life_evaluation.sample_step_s
        return _fly(profile, el, t0, model, paths[path], life_days=days, sample_step_s=step)

    for path in paths:  # compiled kernels and caches warm
        fly(path, 3.0)
    loop, whole, runs = ({path: [] for path in paths} for _ in range(3))
    for _ in range(repeats):
        for path in paths:
            start = time.perf_counter()
            ds = fly(path, settings.life_days)
            whole[path].append((time.perf_counter() - start) / years)
            loop[path].append(ds.attrs["wall_s"] / years)
            runs[path] = ds
    for path in paths:
        ds = runs[path]
        print(
            f"  {path:<20} loop {min(loop[path]):7.2f} s/sat-yr, whole call {min(whole[path]):7.2f} "
            f"s/sat-yr  ({float(ds.dv_kms_per_year[0]):.6f} km/s/yr, {int(ds.n_maneuvers[0])} burns)"
        )
    if len(paths) == 2:
        old, new = runs.values()
        keys = ("dv_kms_per_year", "maneuver_t_tdb_s", "maneuver_dv_rtn_kms", "r_mci_km")
        same = all(np.array_equal(old[k].values, new[k].values, equal_nan=True) for k in keys)
        first, last = (min(loop[p]) for p in paths)
        print(f"  loop {first / last:.1f}x faster; same burns and positions to the bit: {same}")
        print(
            "  largest relative difference: "
            + ", ".join(
                f"{k} {_relative_difference(old[k].values, new[k].values):.1e}"
                for k in (*keys, "box_error", "min_perilune_alt_km")
            )
        )


def _relative_difference(old: np.ndarray, new: np.ndarray) -> float:
    """Largest |new - old| / max |old| over the finite entries (0 for identical arrays; inf where the NaNs differ,
    e.g. another number of burns or a loss on another day)."""
    if old.shape != new.shape or not np.array_equal(np.isnan(old), np.isnan(new)):
        return np.inf
    finite = np.isfinite(old)
    if not finite.any():
        return 0.0
    return float(
        np.max(np.abs(new[finite] - old[finite])) / max(np.max(np.abs(old[finite])), 1e-300)
    )


def run(profile_name: str = "paper", overrides: dict | None = None) -> None:
    satellite_year(profile_name, overrides)
    profile = load_settings(profile_name, overrides=overrides)
    ensure_kernels(profile.ephemeris)
    settings = profile.design_life
    el = standalone_elfo(profile.standalone_elfo, profile.dynamics)
    t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
    states = elements_deg_to_states(profile.dynamics, el, t0)
    print(
        f"standalone ELFO, {el.shape[0]} satellites, profile {profile_name}, design life {settings.life_days:g} days"
    )

    start = time.perf_counter()
    arc = propagate_states(
        profile.dynamics,
        states,
        t0,
        profile.epoch.duration_days * SECONDS_PER_DAY,
        profile.epoch.step_s,
        batch=True,
    )
    arc_s = time.perf_counter() - start
    estimate = [
        sk_estimate_from_propagation(profile.sk_estimate, profile.dynamics, arc) for _ in range(3)
    ]
    est_s = float(np.median([e["wall_s"] for e in estimate]))
    start = time.perf_counter()
    screen_states(profile.stability, profile.dynamics, states, t0, life_days=settings.life_days)
    first_screen_s = time.perf_counter() - start
    screens = [
        screen_states(profile.stability, profile.dynamics, states, t0, life_days=settings.life_days)
        for _ in range(3)
    ]
    screen_s = float(np.median([s.attrs["wall_s"] for s in screens]))

    start = time.perf_counter()
    model = life_force_model(profile.dynamics, t0, settings.life_days)
    model_s = time.perf_counter() - start
    closed = _fly(profile, el, t0, model)
    natural = _fly(profile, el, t0, model, natural=True)
    rows = [
        (
            "closed-loop station keeping, one design life",
            closed.attrs["wall_s"],
            f"{float(closed.dv_kms_per_year.mean()):.3f} km/s/yr mean, {int(closed.n_maneuvers.sum())} manoeuvres, "
            f"box held: {bool(closed.box_held.all())}",
        ),
        (
            "natural drift, one design life",
            natural.attrs["wall_s"],
            f"impacts: {int(natural.impact.sum())} of {el.shape[0]}",
        ),
        ("force model for the life (ephemeris table)", model_s, ""),
        (f"{profile.epoch.duration_days:g}-day arc propagation (the evaluator's)", arc_s, ""),
        (
            "campaign-grade estimate on that arc",
            est_s,
            f"{estimate[0]['sk_dv_estimate_kms_per_year']:.3f} km/s/yr mean, "
            f"{estimate[0]['sk_dv_estimate_max_kms_per_year']:.3f} max",
        ),
        ("stability screen, first call (tide table)", first_screen_s, ""),
        (
            "stability screen",
            screen_s,
            f"stable: {screens[0].attrs['stable']}, min perilune altitude "
            f"{screens[0].attrs['min_perilune_alt_km']:.0f} km",
        ),
    ]
    width = max(len(r[0]) for r in rows)
    for label, seconds, note in rows:
        print(f"  {label:<{width}}  {seconds:9.3f} s  {note}")
    print(f"closed loop / (estimate + screen): {closed.attrs['wall_s'] / (est_s + screen_s):.0f}x")
