"""``python -m lnss_lib bench gnss``: the GNSS link of one design, GPS alone against all four systems, side by side.

Today's GPS-only kernel (:func:`~lnss_lib.gps.gps_link_metrics`, the campaign's path) and the four-system one
(:func:`~lnss_lib.gnss.gnss_link_arrays` and the summary of each system and of their combination) on the first
satellite of the standalone ELFO and of Walker designs drawn from the Table 3 grid, over the profile's arc. One
numba thread, as in a campaign worker; the two alternate design by design so machine load hits both alike.
"""

from __future__ import annotations

import dataclasses
import time

import numba
import numpy as np

from ..campaign import CampaignPlan
from ..constellation import standalone_elfo
from ..evaluator import EvaluationContext
from ..gnss import gnss_link_arrays, gnss_link_summary, gnss_states_mci, system_transmitters
from ..gps import gps_link_metrics
from ..propagator import propagate_elements
from ..settings import load_settings
from .evaluate import _designs

SYSTEMS = ("gps", "galileo", "beidou", "glonass")


def run(
    profile_name: str = "paper", n_designs: int = 6, repeats: int = 3, overrides: dict | None = None
) -> dict:
    """Print the GPS-only and four-system link times per design (min of ``repeats``) and their ratio."""
    numba.set_num_threads(1)
    profile = load_settings(profile_name, overrides=overrides)
    context = EvaluationContext.build(profile)
    gnss = dataclasses.replace(profile.gnss, systems=SYSTEMS)
    start = time.perf_counter()
    states = gnss_states_mci(gnss, profile.gps, profile.epoch.start_tdb, context.times)
    tx = system_transmitters(gnss, profile.gps, states)
    print(
        f"states of {states.sizes['sat']} GNSS satellites at {states.sizes['time']} epochs and their transmitters: "
        f"{time.perf_counter() - start:.2f} s"
    )
    combinations = {"all": SYSTEMS}

    def gps_only(r):
        return gps_link_metrics(profile.gps, profile.constants, context.gps_states, r)

    def four(r):
        counts, scatter = gnss_link_arrays(profile.gps, profile.constants, states, tx, r[0])
        return gnss_link_summary(
            counts,
            scatter,
            SYSTEMS,
            combinations,
            profile.gps.pdop_filter,
            profile.gps.clock_column,
        )

    elements = [standalone_elfo(profile.standalone_elfo, profile.dynamics)[:1]]
    elements += [d.elements_deg()[:1] for d in _designs(CampaignPlan.of(profile), n_designs)[1:]]
    positions = []
    for row in elements:
        prop = propagate_elements(profile.dynamics, profile.epoch, row)
        if not bool(prop["impact"].values.any()):
            positions.append((row[0], np.ascontiguousarray(prop["r_mci_km"].values)))
    start = time.perf_counter()
    gps_only(positions[0][1])
    four(positions[0][1])
    print(f"first calls (JIT compile or cache load): {time.perf_counter() - start:.2f} s")
    print(
        f"{profile.epoch.duration_days:g} days every {profile.epoch.step_s:g} s, first satellite, 1 thread; "
        f"min of {repeats} alternating runs, ms (GPS alone -> all four):"
    )
    ratios = []
    for row, r in positions:
        best = {"gps": np.inf, "four": np.inf}
        for _ in range(repeats):
            for name, func in (("gps", gps_only), ("four", four)):
                t0 = time.perf_counter()
                func(r)
                best[name] = min(best[name], time.perf_counter() - t0)
        ratios.append(best["four"] / best["gps"])
        print(
            f"  a {row[0]:7.0f} e {row[1]:4.2f} i {row[2]:5.1f}: {1e3 * best['gps']:.2f} -> {1e3 * best['four']:.2f} "
            f"({ratios[-1]:.2f}x)"
        )
    n_gps = int(np.sum(tx.system_index == 0))
    print(
        f"  mean ratio over {len(ratios)} designs: {np.mean(ratios):.2f}x (GPS {n_gps} satellites, all four "
        f"{states.sizes['sat']})"
    )
    return {"mean_ratio": float(np.mean(ratios)), "designs": len(ratios)}
