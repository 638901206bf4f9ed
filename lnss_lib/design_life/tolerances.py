"""The service controller's relative-geometry tolerances, derived per design from its navigation sensitivity.

Question: how far may one satellite's plane tilt away from its slot's plane (relative node) or its argument of
latitude slide along its orbit (slot) before the design's navigation requirement breaks? The requirement is the one
the navigation monitor holds (:func:`lnss_lib.design_life.service.navigation_violations`): PDOP/HDOP availability at
most ``nav_avail_drop_pct`` points below the design's own, their 3-sigma means at most ``nav_dop_rise_fraction``
above it.

How: the constellation and copies of its first satellite, each with its plane tilted (RAAN moved by
:func:`lnss_lib.design_life.service.raan_half_width_rad` of the tilt: the same reading of the node tolerance as the
controller's) or its mean anomaly moved by a trial amount, both signs, are flown together with the full force model
over ``tolerance_arc_days`` (at most the life; the profile's integrator; one batch) and the south-pole DOP of each
trial constellation (the first satellite replaced by its copy) is compared with the nominal's over the same arc. Each
trial's
:func:`requirement_margin` is its largest degradation as a fraction of what the requirement allows (1 = at the
limit). The trial amounts are a geometric ladder of :data:`TRIALS` steps over the bounds
``raan_rel_bounds_deg`` / ``u_rel_bounds_deg``; the tolerance is where the margin first reaches 1, interpolated in
the logarithm of the amount between the last trial within the requirement and the first beyond it, the smaller
over the two signs; the lower bound when the smallest trial already breaks the requirement, the upper when none
does. The bounds say what the numbers may mean: below the lower the controller would chase the tidal swing of the
mean node and slot (about a degree of node and a few degrees of slot on high orbits); above the upper the slot no
longer describes a slot (a quarter of an orbit), and a node correction, which aims ``target_fraction`` of the
tolerance past the slot's plane, grows into a plane change that reshapes a high orbit's tidal evolution (a 20 deg
bound gave a 36 deg correction on a 23233 km, e 0.58 design whose perilune then reached the Moon within 2.5 days;
with 10 deg all its satellites are kept, at 0.57 km/s/yr against 0.90 with the fixed 4.7 deg).

Only the first satellite is moved: a Walker design's satellites are alike up to where the Earth and the south pole
lie, which the arc averages over. Several satellites at the edges of their tolerances at once can break the
requirement together; the navigation monitor catches that over the life. A design whose arc gives no navigation at
all (availability 0, no 3-sigma DOP: e.g. two satellites) has nothing for the geometry to protect and gets the upper
bounds. The arc's cost (one batch of n + 4 :data:`TRIALS` satellites over the arc, 1 + 4 :data:`TRIALS` DOP
evaluations) is paid once, at the start of the life: 1.6-3 s per design on this 2-core machine.

Measured (paper profile, study epoch): the Table 4 ELFO (2 x 8) gets the upper bounds, 10 deg of tilt and 90 deg
of slot (one satellite of sixteen moved by 20 deg of tilt or 90 deg of slot raises 3-sigma PDOP by under 5 %, half of
what is allowed), against the fixed 4.7 / 20 deg calibrated with every satellite moved at once
(:mod:`lnss_lib.studies.sk_box`); with 4 satellites a plane 10 / 39 deg; the 2 x 3 a 8400 km Table 6 pick of the
``paper_dv_physical`` campaign 10 / 43 deg.
"""

from __future__ import annotations

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..dop import dop_for_settings, summary_for_settings
from ..forces import ForceModel
from ..frames import rotate_to_moon_fixed
from ..propagator import elements_deg_to_states, propagate_states
from ..settings import DopSettings, Dynamics, ServiceSettings
from ..surface_grid import SurfaceGrid
from .service import raan_half_width_rad, requirement_fractions

__all__ = [
    "TRIALS",
    "requirement_margin",
    "trial_ladder",
    "tolerance_at_limit",
    "estimate_tolerances_deg",
    "derived_tolerances",
    "relative_tolerances_deg",
]

TRIALS = 6
"""Trial amounts per quantity and sign (a geometric ladder from the lower bound to the upper)."""


def requirement_margin(summary: dict, baseline: dict, service: ServiceSettings) -> float:
    """Largest degradation of ``summary`` against ``baseline`` as a fraction of what the navigation requirement allows
    (:func:`lnss_lib.design_life.service.requirement_fractions`): above 1 exactly where the navigation monitor names a
    violation."""
    return float(max(requirement_fractions(summary, baseline, service).values()))


def trial_ladder(bounds_deg) -> np.ndarray:
    """:data:`TRIALS` amounts (deg) from ``bounds_deg[0]`` to ``bounds_deg[1]``, evenly spaced in the logarithm."""
    low, high = (float(b) for b in bounds_deg)
    return np.geomspace(low, high, TRIALS)


def tolerance_at_limit(amounts_deg: np.ndarray, margins: np.ndarray) -> float:
    """Amount (deg) at which the margin (one per amount, ascending amounts) first reaches 1: log-linear between the
    last trial below and the first at or above it; the first amount when it already breaks, the last when none does."""
    above = np.flatnonzero(~(np.asarray(margins) < 1.0))
    if above.size == 0:
        return float(amounts_deg[-1])
    k = int(above[0])
    if k == 0:
        return float(amounts_deg[0])
    m0, m1 = float(margins[k - 1]), float(margins[k])
    frac = 0.0 if not np.isfinite(m1) else (1.0 - m0) / (m1 - m0)
    x0, x1 = np.log(amounts_deg[k - 1]), np.log(amounts_deg[k])
    return float(np.exp(x0 + frac * (x1 - x0)))


def derived_tolerances(
    service: ServiceSettings,
    dop: DopSettings,
    dynamics: Dynamics,
    elements_deg,
    t0_tdb_s: float,
    *,
    model: ForceModel | None = None,
    arc_days: float | None = None,
) -> dict:
    """The relative node (plane tilt) and slot tolerances (deg) of a constellation (elements (n, 6) deg in the element
    frame at TDB ``t0_tdb_s``) at the limit of its navigation requirement, and the evidence.

    Returns ``{"raan_rel_deg", "u_rel_deg", "trials": {quantity: (amounts (TRIALS,), margins (2, TRIALS): + and -
    sign)}, "baseline": the nominal DOP summary, "arc_days"}``. ``model``: a force model whose table spans the arc;
    ``arc_days`` replaces ``tolerance_arc_days``."""
    el = np.atleast_2d(np.asarray(elements_deg, dtype=float))
    n_sat = el.shape[0]
    ladders = {
        "raan_rel_deg": trial_ladder(service.raan_rel_bounds_deg),
        "u_rel_deg": trial_ladder(service.u_rel_bounds_deg),
    }
    copies = []
    for key, amounts in ladders.items():
        for sign in (1.0, -1.0):
            for amount in amounts:
                row = el[0].copy()
                if key == "raan_rel_deg":
                    row[3] += sign * np.degrees(
                        raan_half_width_rad(np.radians(amount), np.radians(row[2]))
                    )
                else:
                    row[5] += sign * amount
                copies.append(row)
    t0 = float(t0_tdb_s)
    arc_days = float(service.tolerance_arc_days if arc_days is None else arc_days)
    states = elements_deg_to_states(dynamics, np.vstack([el, copies]), t0)
    arc = propagate_states(
        dynamics,
        states,
        t0,
        arc_days * SECONDS_PER_DAY,
        service.tolerance_step_s,
        batch=True,
        model=model,
    )
    t = arc["time"].values
    r_mf = rotate_to_moon_fixed(dynamics, arc["r_mci_km"].transpose("sat", "time", "xyz").values, t)
    grid = SurfaceGrid.from_settings(dop, dynamics.constants.r_moon_mean_km)

    def summary(r):
        return summary_for_settings(dop, dop_for_settings(dop, r, t, grid))

    baseline = summary(r_mf[:n_sat])
    out = {"baseline": baseline, "arc_days": arc_days, "trials": {}}
    k = n_sat
    for key, amounts in ladders.items():
        margins = np.empty((2, TRIALS))
        for s in range(2):
            for j in range(TRIALS):
                r = r_mf[:n_sat].copy()
                r[0] = r_mf[k]
                margins[s, j] = requirement_margin(summary(r), baseline, service)
                k += 1
        out["trials"][key] = (amounts, margins)
        out[key] = min(tolerance_at_limit(amounts, margins[s]) for s in range(2))
    return out


def estimate_tolerances_deg(service: ServiceSettings) -> dict[str, float]:
    """``{"raan_rel": tilt, "u_rel": slot}`` (deg) the campaign's life estimate holds
    (:mod:`lnss_lib.design_life.life_estimate`), without the derivation's arc (1.6-3 s a design, ten times an
    evaluation): the fixed values with ``tolerances = "fixed"``; with ``"derived"`` the upper bound of the tilt and the
    fixed slot. Measured (operational profile, every satellite): the derivation gives the upper tilt bound on 12 of 12
    random designs of the ``paper_dv_physical`` front (3-20 satellites); only designs with barely any position fix
    (four or five satellites, one a plane) get less, down to the lower bound. The derived slot spreads from 6 to
    90 deg on those designs; the fixed 20 deg prices phase keeping on the cautious side of most, and it costs a few
    m/s a year at most (:mod:`lnss_lib.studies.estimate_validation`)."""
    if service.tolerances == "fixed":
        return {"raan_rel": float(service.raan_rel_deg), "u_rel": float(service.u_rel_deg)}
    return {"raan_rel": float(service.raan_rel_bounds_deg[1]), "u_rel": float(service.u_rel_deg)}


def relative_tolerances_deg(
    service: ServiceSettings,
    dop: DopSettings,
    dynamics: Dynamics,
    elements_deg,
    t0_tdb_s: float,
    *,
    model: ForceModel | None = None,
    arc_days: float | None = None,
) -> dict[str, float]:
    """``{"raan_rel": tilt, "u_rel": slot}`` (deg) the service controller holds: ``[design_life.service]
    raan_rel_deg`` / ``u_rel_deg`` with ``tolerances = "fixed"``, :func:`derived_tolerances` with ``"derived"``."""
    if service.tolerances == "fixed":
        return {"raan_rel": float(service.raan_rel_deg), "u_rel": float(service.u_rel_deg)}
    derived = derived_tolerances(
        service, dop, dynamics, elements_deg, t0_tdb_s, model=model, arc_days=arc_days
    )
    return {"raan_rel": derived["raan_rel_deg"], "u_rel": derived["u_rel_deg"]}
