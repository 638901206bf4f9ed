"""Notebook 07: is a headline design robust, or lucky?

Question: a design the operational search picks keeps the south-pole service over its life when every satellite
flies and is inserted exactly on its mean elements. Does it still when (a) one satellite is lost, the worst one
(N-1), and (b) every satellite is inserted with the errors a real insertion leaves (``[robustness]``: 1-sigma errors
of the mean elements, drawn independently per satellite, flown in closed loop with the design as the controller's
reference)? Reported per design: the N-1 availability over the life (mean and worst month, PDOP and HDOP) with the
satellite whose loss costs most, and over the draws the 95th percentile of the Delta-V (mean and worst satellite),
the 5th percentile of the worst-month availability and of the lowest perilune, and the satellites lost.

Both answers come from the closed loop, never from the estimate: the loss of a satellite is read from one flight
sampled every ``[life_evaluation] sample_step_s`` by dropping each satellite's positions in turn (the others fly as
they flew: an operator does not re-phase the constellation); an insertion error is a flight of its own.

Verdict: the notebook prints it for the profile's headline designs once the operational campaign is shipped.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from ..design_life.evaluation import (
    life_availability,
    life_navigation,
    lost_satellites,
    run_design_life,
    satellite_loss,
)
from ..outputs import cached_json
from ..progress import steps
from ..settings import RobustnessSettings, Settings
from .design_life import flown_elements
from .life_navigation import AVAILABILITY_KEYS

__all__ = [
    "DISPERSION_PERCENTILES",
    "loss_table",
    "insertion_errors_deg",
    "dispersed_flight",
    "dispersion_table",
    "dispersion_summary",
]

DISPERSION_PERCENTILES = {"dv": 95.0, "availability": 5.0, "perilune": 5.0}
"""Percentiles over the draws: the Delta-V an operator must budget (95th), the service and the perilune margin it
can count on (5th)."""


def loss_table(settings: Settings, flight: xr.Dataset) -> pd.DataFrame:
    """:func:`~lnss_lib.design_life.evaluation.satellite_loss` of a closed-loop ``flight`` as a table: the full
    constellation first, then each satellite lost, worst first (the N-1 case)."""
    return pd.DataFrame(
        satellite_loss(
            settings.dop, settings.dynamics, flight, month_days=settings.life_evaluation.month_days
        )
    )


def insertion_errors_deg(
    robustness: RobustnessSettings, elements_deg: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """One draw of insertion errors (n_sat, 6) of mean elements ``[sma_km, e, inc_deg, raan_deg, aop_deg, M_deg]``,
    normal with the 1-sigma errors of ``robustness``. An error that would make e negative reflects it (|e|) and turns
    the perilune by half a turn, keeping the position: a near-circular orbit's eccentricity vector is the
    quantity drawn, not its length."""
    elements = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    sigma = np.array(
        [
            robustness.sma_km,
            robustness.ecc,
            robustness.inc_deg,
            robustness.raan_deg,
            robustness.aop_deg,
            robustness.anomaly_deg,
        ]
    )
    errors = rng.standard_normal(elements.shape) * sigma
    flipped = elements[:, 1] + errors[:, 1] < 0.0
    errors[flipped, 1] = -2.0 * elements[flipped, 1] - errors[flipped, 1]
    errors[flipped, 4] += 180.0
    errors[flipped, 5] -= 180.0
    return errors


def dispersed_flight(
    settings: Settings, design, errors_deg: np.ndarray | None, life_days: float
) -> dict:
    """The closed loop of a whole design inserted with ``errors_deg`` (None: on its elements) over ``life_days``:
    Delta-V (mean and worst satellite, km/s per year), the lowest perilune altitude (km), the satellites lost and
    the availability over the life and in the worst month."""
    elements = flown_elements(design)
    flight = run_design_life(
        settings, elements, life_days, natural=False, insertion_errors_deg=errors_deg
    )
    ctl = flight["controlled"]
    nav = life_navigation(
        settings.dop, settings.dynamics, ctl, month_days=settings.life_evaluation.month_days
    )
    return {
        "sk_dv_kms_per_year": float(ctl["dv_kms_per_year"].mean()),
        "sk_dv_max_kms_per_year": float(ctl["dv_kms_per_year"].max()),
        "min_perilune_alt_km": float(np.nanmin(ctl["min_perilune_alt_km"].values)),
        "n_lost": len(lost_satellites(ctl)),
        **{
            f"{key}_worst_month": float(nav[key].sel(run="life").min()) for key in AVAILABILITY_KEYS
        },
        **{f"{key}_life": life_availability(nav, "life", key) for key in AVAILABILITY_KEYS},
    }


def dispersion_table(
    settings: Settings, design, *, draws: int | None = None, cache_dir: Path | None = None
) -> pd.DataFrame:
    """``[robustness] draws`` (or ``draws``) closed-loop flights of ``design`` over ``[robustness] flown_days``, each
    inserted with its own :func:`insertion_errors_deg` (generator seeded by ``[robustness] seed``: draw k is the same
    whatever the number of draws); one row a draw. Each flight is cached in ``cache_dir`` by design, draw, settings,
    code and data (:func:`~lnss_lib.outputs.cached_json`)."""
    robustness = settings.robustness
    n = robustness.draws if draws is None else int(draws)
    if n < 1:
        raise ValueError(
            f"draws = {n!r}: at least one dispersed insertion is needed ([robustness] draws)"
        )
    elements = flown_elements(design)
    rows = []
    for k in steps(n, f"insertion dispersions of {design}", "draws"):
        errors = insertion_errors_deg(
            robustness, elements, np.random.default_rng([robustness.seed, k])
        )
        row = cached_json(
            cache_dir,
            "dispersed_flight",
            [list(design), k, errors.tolist(), robustness.flown_days, settings.hash],
            partial(dispersed_flight, settings, design, errors, robustness.flown_days),
        )[0]
        rows.append({"draw": k, **row})
    return pd.DataFrame(rows)


def dispersion_summary(table: pd.DataFrame) -> dict:
    """The percentiles of :data:`DISPERSION_PERCENTILES` over the draws of :func:`dispersion_table`, the draws and
    the draws that lost a satellite."""
    p = DISPERSION_PERCENTILES
    out = {"draws": int(len(table)), "draws_losing_a_satellite": int((table["n_lost"] > 0).sum())}
    for key in ("sk_dv_kms_per_year", "sk_dv_max_kms_per_year"):
        out[f"{key}_p{p['dv']:g}"] = float(np.percentile(table[key], p["dv"]))
    for key in AVAILABILITY_KEYS:
        out[f"{key}_worst_month_p{p['availability']:g}"] = float(
            np.percentile(table[f"{key}_worst_month"], p["availability"])
        )
    out[f"min_perilune_alt_km_p{p['perilune']:g}"] = float(
        np.percentile(table["min_perilune_alt_km"], p["perilune"])
    )
    return out
