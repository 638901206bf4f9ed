"""``python -m lnss_lib bench design-life``: one design-year of closed loop against the campaign's cheap predictors.

For the standalone ELFO (16 satellites): the wall time of the closed-loop station keeping over
``[design_life] life_days`` (full force model, every satellite), of the natural drift over the same
life, of the campaign-grade geometry-keeping estimate on the 10-day arc (the arc's propagation
printed apart: the evaluator pays it anyway) and of the stability screen, side by side.
"""

from __future__ import annotations

import time

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..constellation import standalone_elfo
from ..design_life.closed_loop import life_force_model, simulate_life
from ..design_life.estimate import sk_estimate_from_propagation
from ..design_life.screen import screen_states
from ..ephemeris import ensure_kernels, tdb_seconds
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import load_settings


def run(profile_name: str = "paper", overrides: dict | None = None) -> None:
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
    closed = simulate_life(
        settings,
        profile.dynamics,
        el,
        t0,
        stability=profile.stability,
        dop=profile.dop,
        model=model,
    )
    natural = simulate_life(
        settings,
        profile.dynamics,
        el,
        t0,
        stability=profile.stability,
        dop=profile.dop,
        natural=True,
        model=model,
    )
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
