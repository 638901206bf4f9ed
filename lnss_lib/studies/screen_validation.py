"""Notebook 08: does the stability screen agree with full-model natural propagation?

Question: over the design life, does :func:`lnss_lib.design_life.screen.screen_states` say "a satellite
reaches the surface" exactly when the full force model, flown with no manoeuvre, says so, on random
Table 3 designs?

Method: ``n`` designs drawn uniformly (seeded) from the grid of ``[campaign.variables]``, elements read
in the profile's element frame. One satellite per plane (mean anomaly 0: the satellites of a Walker
plane share their mean orbit, and the screen integrates each plane once) is propagated with the full
force model at ``[stability] validation_degree`` (the ``converged`` integrator setting, output every
``validation_step_s``) and screened from the same initial states. A design is unstable when any of
its satellites reaches the surface within the life; :func:`agreement` counts designs whose two verdicts
match, and every miss is listed per satellite: design, satellite (plane), truth impact day, screen
impact day and minimum perilune.

Verdict (``operational`` profile: elements in ``moon_op``, five years = 1826.25 days, degree 8; three runs of
40 designs, seeds 20, 21 and 22, 2026-11-25): the screen agrees with the full model on 40 of 40 designs
in each (120 of 120; 53 reach the surface within the five years, the first on day 3.4). The tide's
monthly terms decide it: the doubly-averaged perilune alone (``[stability] monthly_terms = false``)
agrees on 36, 34 and 37 of 40 (107 of 120, 89 %), calling stable designs the full model takes into the
surface from day 3.5 on (a 5800-23100 km, e 0.2-0.8): it misses the half-monthly swing of e (amplitude
~ (15/16) (n_month / n) e sqrt(1 - e^2)), which :class:`lnss_lib.design_life.screen.MonthlyTide`
restores to first order. With the monthly terms alone, seed 21 gave 37 of 40: three designs at
a 20300-22400 km, e 0.54-0.63, i 2-30 deg reach the surface on days 441-768 while the averaged perilune
stays above 850 km, beyond the orbit average's validity (period above a tenth of a month); the
validity limit (``validity_period_fraction`` 0.1, ``validity_ecc`` 0.5) was set from seeds 20 and 21
(every design there with e >= 0.54 hits, every stable one has e <= 0.49), and seed 22, drawn after,
agrees 40 of 40 with it (one design in that region, which hits on day 9.5). Cost on the shared 2-core
machine: 4.7-11.3 s of full model per satellite and five years; 0.1 s a screen (compiled RK4). Notebook
08 prints the table at its profile's size.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from ..constellation import WalkerDesign
from ..design_life.screen import propagated_perilune, screen_elements
from ..keys import DESIGN_KEYS
from ..settings import Settings

__all__ = ["random_designs", "validate_design", "validation_table", "agreement", "MISS_COLUMNS"]

MISS_COLUMNS = (
    *DESIGN_KEYS,
    "plane",
    "truth_impact_day",
    "screen_impact_day",
    "screen_min_perilune_alt_km",
    "truth_min_perilune_alt_km",
)


def random_designs(settings: Settings, n: int, seed: int = 20) -> list[tuple]:
    """``n`` Walker rows (sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane) drawn uniformly from the grid
    of ``[campaign.variables]`` (Table 3's bounds and steps), reproducibly from ``seed``. Draws whose initial
    perilune is at or below ``[impact] min_altitude_km`` are drawn again (both verdicts would be trivially "impact")."""
    rng = np.random.default_rng(seed)
    variables = settings.campaign.variables
    floor_km = settings.constants.r_moon_mean_km + settings.impact.min_altitude_km
    rows: list[tuple] = []
    while len(rows) < n:
        row = []
        for key in DESIGN_KEYS:
            v = variables[key]
            count = int(round((v.upper - v.lower) / v.step)) + 1
            value = v.lower + v.step * int(rng.integers(count))
            row.append(
                int(round(value))
                if key in ("n_planes", "sats_per_plane")
                else round(float(value), 6)
            )
        if row[0] * (1.0 - row[1]) > floor_km:
            rows.append(tuple(row))
    return rows


def validate_design(settings: Settings, design, life_days: float) -> list[dict]:
    """One row per plane of ``design`` (Walker row): the screen and the full model (one satellite per plane, M = 0)."""
    walker = WalkerDesign(*design[:4], int(design[4]), int(design[5]))
    elements = walker.elements_deg()[:: walker.sats_per_plane]
    section = settings.stability
    screen = screen_elements(
        section, settings.dynamics, settings.epoch, elements, life_days=life_days
    )
    start = time.perf_counter()
    truth = propagated_perilune(
        settings.dynamics,
        settings.epoch,
        elements,
        life_days,
        degree=section.validation_degree,
        step_s=section.validation_step_s,
    )
    truth_wall = time.perf_counter() - start
    return [
        {
            **dict(zip(DESIGN_KEYS, design)),
            "plane": k,
            "screen_impact_day": float(screen.impact_day.values[k]),
            "screen_min_perilune_alt_km": float(screen.min_perilune_alt_km.values[k]),
            "truth_impact_day": float(truth["impact_day"][k]),
            "truth_min_perilune_alt_km": float(truth["min_perilune_alt_km"][k]),
            "screen_wall_s": float(screen.attrs["wall_s"]),
            "truth_wall_s": truth_wall / elements.shape[0],
        }
        for k in range(elements.shape[0])
    ]


def validation_table(
    settings: Settings, designs, life_days: float | None = None, *, progress=None
) -> pd.DataFrame:
    """:func:`validate_design` for every design (rows: one per plane); ``progress(i, n, rows)`` after each design."""
    days = settings.stability.life_days if life_days is None else float(life_days)
    rows: list[dict] = []
    for i, design in enumerate(designs):
        rows.extend(validate_design(settings, design, days))
        if progress is not None:
            progress(i + 1, len(designs), rows)
    table = pd.DataFrame(rows)
    table.attrs.update(life_days=days, element_frame=settings.frames.element_frame)
    return table


def agreement(table: pd.DataFrame) -> dict:
    """Design-level agreement of a :func:`validation_table` (per-plane rows; NaN impact day = none).

    A design is unstable by a source when any of its planes has an impact day. Returns ``n_designs``,
    ``n_agree``, ``agreement_pct``, ``missed_impacts`` and ``false_alarms`` (designs), ``plane_agreement_pct``
    and ``misses``: every plane whose two verdicts differ (:data:`MISS_COLUMNS`, plus ``call``).
    """
    t = table.copy()
    t["screen_unstable"] = t["screen_impact_day"].notna()
    t["truth_unstable"] = t["truth_impact_day"].notna()
    by_design = t.groupby(list(DESIGN_KEYS), sort=False)[
        ["screen_unstable", "truth_unstable"]
    ].any()
    agree = by_design["screen_unstable"] == by_design["truth_unstable"]
    wrong = t[t["screen_unstable"] != t["truth_unstable"]].copy()
    wrong["call"] = np.where(wrong["truth_unstable"], "missed impact", "false alarm")
    n = int(by_design.shape[0])
    plane_agree = t["screen_unstable"] == t["truth_unstable"]
    return {
        "n_designs": n,
        "n_agree": int(agree.sum()),
        "agreement_pct": 100.0 * float(agree.mean()) if n else float("nan"),
        "missed_impacts": int((by_design["truth_unstable"] & ~by_design["screen_unstable"]).sum()),
        "false_alarms": int((~by_design["truth_unstable"] & by_design["screen_unstable"]).sum()),
        "plane_agreement_pct": 100.0 * float(plane_agree.mean()) if len(t) else float("nan"),
        "misses": wrong[[*MISS_COLUMNS, "call"]].reset_index(drop=True),
    }
