"""``python -m lnss_lib bench stability``: the design-life screen against full-model propagations.

For each design of ``[stability] validation_designs``: the screen's verdict, first impact day and
minimum perilune altitude (all satellites), and the same from a full-force-model propagation of one
satellite per plane (M = 0: the satellites of a plane share their mean orbit) over the screen's
life, at ``validation_degree`` with the ``converged`` integrator setting, no station keeping.
"""

from __future__ import annotations

import time

import numpy as np

from ..constellation import WalkerDesign
from ..design_life.screen import propagated_perilune, screen_elements
from ..ephemeris import ensure_kernels
from ..settings import Settings, load_settings


def validation_table(
    settings: Settings, designs=None, life_days: float | None = None, reference: bool = True
) -> list[dict]:
    """One row per design: screen and (optionally) reference verdicts, impact days, minimum altitudes, walls."""
    ensure_kernels(settings.ephemeris)
    section = settings.stability
    days = section.life_days if life_days is None else float(life_days)
    rows = []
    for d in designs if designs is not None else section.validation_designs:
        design = WalkerDesign(d[0], d[1], d[2], d[3], int(d[4]), int(d[5]))
        elements = design.elements_deg()
        screen = screen_elements(
            section, settings.dynamics, settings.epoch, elements, life_days=days
        )
        row = {
            "design": list(d),
            "n_sat": design.n_sat,
            "screen_stable": screen.attrs["stable"],
            "screen_impact_day": screen.attrs["impact_day"],
            "screen_min_alt_km": screen.attrs["min_perilune_alt_km"],
            "screen_wall_s": screen.attrs["wall_s"],
        }
        if reference:
            one_per_plane = elements[:: design.sats_per_plane]
            ref = propagated_perilune(
                settings.dynamics,
                settings.epoch,
                one_per_plane,
                days,
                degree=section.validation_degree,
                step_s=section.validation_step_s,
            )
            row.update(
                ref_stable=ref["stable"],
                ref_impact_day=float(np.nanmin(ref["impact_day"]))
                if not ref["stable"]
                else float("nan"),
                ref_min_alt_km=float(np.min(ref["min_perilune_alt_km"])),
                ref_wall_s=ref["wall_s"],
                agree=ref["stable"] == screen.attrs["stable"],
            )
        rows.append(row)
    return rows


def run(profile_name: str = "paper", reference: bool = True, overrides: dict | None = None) -> None:
    profile = load_settings(profile_name, overrides=overrides)
    ensure_kernels(profile.ephemeris)
    start = time.perf_counter()
    screen_elements(
        profile.stability,
        profile.dynamics,
        profile.epoch,
        WalkerDesign(6143.0, 0.6, 90.0, 51.7, 4, 5).elements_deg(),
    )
    print(f"first screen (SPICE tide table, JIT): {time.perf_counter() - start:.2f} s")
    walls = [
        screen_elements(
            profile.stability,
            profile.dynamics,
            profile.epoch,
            WalkerDesign(6143.0, 0.6, 90.0, 51.7, 4, 5).elements_deg(),
        ).attrs["wall_s"]
        for _ in range(3)
    ]
    print(
        f"screen, 20-satellite ELFO-like design (4 planes), {profile.stability.life_days} days: "
        f"median {np.median(walls):.3f} s"
    )
    for row in validation_table(profile, reference=reference):
        print(
            "  "
            + ", ".join(
                f"{k}={v:.1f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
            ),
            flush=True,
        )
