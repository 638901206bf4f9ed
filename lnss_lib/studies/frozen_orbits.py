"""Notebook 08, frozen orbits: which published designs are frozen, in which frame, and do the anchors hold?

Question: where does the frozen family of the doubly-averaged model (:mod:`lnss_lib.design_life.frozen`, the
Earth-Moon orbital plane ``moon_op``) lie against a, where do the Table 4 ELFO, Ely's (2005) orbits and the
campaign's Table 6 picks sit on it when their elements are read in ``moon_op`` or in the lunar equator, does
Ely's phased constellation keep its perilune above 100 km for ten years with no manoeuvre, and which of
the Table 4 ELFO's two planes drifts when read in the lunar equator?

Verdict (the notebook prints it from the numbers; words here from the paper profile at the study epoch):
read in ``moon_op``, the Table 4 ELFO (i 51.7 deg at e 0.6, Kozai's family) is frozen: about 1 deg below
the J2-shifted frozen inclination, it librates with an e swing of about 0.02. Ely's orbit (i 56.2 deg,
e 0.60-0.68) and Lunar Pathfinder's librate about AOP 90 deg with e swings near 0.08: stable, not frozen
in the strict sense. Read in the lunar equator, neither Table 4 plane is frozen: the planes sit up to
6.7 deg either side of the Earth's plane and their AOP is read several degrees off 90, so they swing by
0.12 and more (0.22 for the plane 7 deg below the family); which plane is the far one is set by where the
Earth plane's node lies against RAAN 0, which with the workbook's Moon-fixed RAAN origin turns every
draconic month (with an origin fixed in space, every 18.6 years). Ely's phased constellation, flown ten
years from its epoch with the full model and no manoeuvre, keeps its perilune above 100 km (lowest about
101 km, in year 8), as Ely reports; the averaged model's mean perilune stays near 200 km.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..catalogue import constellation_states_mci, file_epoch_profile, load_constellation
from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..design_life.evaluation import life_metrics, run_design_life
from ..design_life.frozen import (
    FrozenModel,
    allowances,
    frozen_eccentricity,
    frozen_inclination_deg,
    libration,
    mean_plane_axes,
    mean_plane_elements,
)
from ..design_life.screen import screen_states
from ..design_life.secular import SecularField, orbit_vectors_ej
from ..ephemeris import ensure_kernels, tdb_seconds
from ..frames import element_frame_to_j2000
from ..propagator import propagate_states
from ..settings import Dynamics, Settings, StabilitySettings

__all__ = [
    "FAMILY_ECC",
    "FAMILY_INC_DEG",
    "frozen_family",
    "inertial_lunar_equator",
    "planes_in_moon_op",
    "orbit_rows",
    "published_orbits",
    "frozen_words",
    "epoch_swap",
    "ely_natural",
    "closed_loop_anchors",
]

FAMILY_ECC = (0.4, 0.5, 0.6, 0.7)
FAMILY_INC_DEG = (51.7, 54.0, 56.2, 60.0)
TABLE_4 = (
    6143.0,
    0.6,
    51.7,
    90.0,
)  # sma_km, e, i, AOP of the standalone ELFO; planes at RAAN 0 and 180
FROZEN_SWING = 0.03  # e swing below which an orbit is called frozen (the box's old half-width)


def frozen_family(model: FrozenModel, sma_km) -> pd.DataFrame:
    """Frozen i (deg) for each e of :data:`FAMILY_ECC` and frozen e for each i of :data:`FAMILY_INC_DEG`, against sma_km.

    Long table: ``sma_km``, ``curve`` ("i at e = .." or "e at i = .."), ``inc_deg``, ``ecc``.
    """
    rows = []
    for a in np.asarray(sma_km, dtype=float):
        for e in FAMILY_ECC:
            rows.append(
                {
                    "sma_km": a,
                    "curve": f"i at e = {e:g}",
                    "ecc": e,
                    "inc_deg": frozen_inclination_deg(model, a, e),
                }
            )
        for inc in FAMILY_INC_DEG:
            rows.append(
                {
                    "sma_km": a,
                    "curve": f"e at i = {inc:g} deg",
                    "inc_deg": inc,
                    "ecc": frozen_eccentricity(model, a, inc),
                }
            )
    return pd.DataFrame(rows)


def inertial_lunar_equator(dynamics: Dynamics, t_tdb_s: float) -> np.ndarray:
    """Rotation to J2000 of the lunar equator at t with x along the J2000 x-axis projected on it (RAAN origin fixed in space)."""
    pole = element_frame_to_j2000(dynamics, t_tdb_s, "lunar_equator_of_epoch")[:, 2]
    x = np.array([1.0, 0.0, 0.0]) - pole[0] * pole
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(pole, x), pole])


def _model_at(
    stability: StabilitySettings, dynamics: Dynamics, t_tdb_s: float, days: float = 30.0
) -> tuple[SecularField, FrozenModel]:
    field = SecularField.from_settings(stability, dynamics, float(t_tdb_s), days)
    return field, FrozenModel.from_field(field)


def planes_in_moon_op(
    stability: StabilitySettings,
    dynamics: Dynamics,
    t_tdb_s: float,
    rot_el_to_j2000: np.ndarray,
    elements_deg,
) -> pd.DataFrame:
    """Orbits (n, 6) given in a frame (``x_j2000 = rot x``) read in the mean ``moon_op`` at t, with their libration."""
    field, model = _model_at(stability, dynamics, t_tdb_s)
    return orbit_rows(
        model,
        mean_plane_elements(field, elements_deg, rot_el_to_j2000),
        dynamics.constants.r_moon_mean_km,
    )


def orbit_rows(model: FrozenModel, read: dict, r_moon_km: float) -> pd.DataFrame:
    """Per orbit of ``read`` (:func:`lnss_lib.design_life.frozen.mean_plane_elements`): elements in ``moon_op``, the frozen i at
    its (a, e), its libration (ranges of e, i, AOP), the mean perilune's lowest altitude over the cycle and the
    short-period dip the real perilune may add (:func:`lnss_lib.design_life.frozen.allowances`, monthly + orbital, km)."""
    rows = []
    for a, e, inc, aop in zip(read["sma_km"], read["ecc"], read["inc_deg"], read["aop_deg"]):
        lib = libration(model, a, e, inc, aop)
        allow = allowances(model, a, e, inc, aop)
        frozen_inc = frozen_inclination_deg(model, a, e) if 0.0 < e < 1.0 else np.nan
        rows.append(
            {
                "sma_km": a,
                "ecc_op": e,
                "inc_op_deg": inc,
                "aop_op_deg": aop,
                "frozen_inc_deg": frozen_inc,
                "inc_off_frozen_deg": (inc if inc <= 90.0 else 180.0 - inc) - frozen_inc,
                "ecc_min": lib["ecc_min"],
                "ecc_max": lib["ecc_max"],
                "ecc_swing": lib["ecc_max"] - lib["ecc_min"],
                "aop_min_deg": lib["aop_min_deg"],
                "aop_max_deg": lib["aop_max_deg"],
                "librating": lib["librating"],
                "min_mean_perilune_alt_km": a * (1.0 - lib["ecc_max"]) - r_moon_km,
                "short_period_km": a * (allow["ecc_monthly"] + allow["ecc_orbital"]),
            }
        )
    return pd.DataFrame(rows)


def _walker_planes(design) -> np.ndarray:
    """One orbit per plane of a design ``(sma_km, ecc, aop_deg, inc_deg, n_planes, ...)`` (RAAN 360 p / n_planes)."""
    a, e, aop, inc, n_planes = (float(x) for x in design[:5])
    return np.array(
        [[a, e, inc, 360.0 * p / int(n_planes), aop, 0.0] for p in range(int(n_planes))]
    )


def published_orbits(
    settings: Settings, designs: list[tuple[str, np.ndarray]] = ()
) -> pd.DataFrame:
    """Every plane of the Table 4 ELFO and of ``designs`` (label, elements (n, 6) of its satellites: one orbit per
    distinct RAAN is kept) read in ``moon_op`` and in the lunar equator of the study epoch, and Ely's and Lunar
    Pathfinder's orbits (catalogue, ``moon_op``) at their file epoch and the study epoch, placed on the frozen
    family: :func:`orbit_rows` with ``orbit``, ``read_in``, ``epoch`` and ``verdict`` columns."""
    ensure_kernels(settings.ephemeris)
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB")
    field, model = _model_at(settings.stability, settings.dynamics, t0)
    frames = {
        "moon_op": mean_plane_axes(field, [0.0])[0],
        "lunar equator": element_frame_to_j2000(settings.dynamics, t0, "lunar_equator_of_epoch"),
    }
    entries = [
        ("Table 4 ELFO", _walker_planes((TABLE_4[0], TABLE_4[1], TABLE_4[3], TABLE_4[2], 2)))
    ]
    for label, elements in designs:
        el = np.atleast_2d(np.asarray(elements, dtype=float))
        entries.append((label, el[np.unique(np.round(el[:, 3], 6), return_index=True)[1]]))
    tables = []
    for label, planes in entries:
        for read_in, rot in frames.items():
            t = orbit_rows(
                model, mean_plane_elements(field, planes, rot), settings.constants.r_moon_mean_km
            )
            tables.append(
                t.assign(
                    orbit=[f"{label} plane {k + 1}" for k in range(len(t))],
                    read_in=read_in,
                    epoch="study",
                )
            )
    for key in ("ely2005_elfo_3sat_phased", "lupnt_pathfinder"):
        c = load_constellation(key, settings.dynamics)
        first = c.elements_deg[:1]
        for epoch in ("file", "study"):
            cs = constellation_states_mci(settings.dynamics, settings.epoch.start_tdb, c, epoch)
            f, m = _model_at(settings.stability, settings.dynamics, cs.t_epoch_tdb_s)
            t = orbit_rows(
                m, mean_plane_elements(f, first, cs.rot_to_j2000), settings.constants.r_moon_mean_km
            )
            tables.append(
                t.assign(orbit=c.name.split(":")[0], read_in=c.element_frame, epoch=cs.epoch_used)
            )
    out = pd.concat(tables, ignore_index=True)
    out["verdict"] = frozen_words(out)
    return out[
        ["orbit", "read_in", "epoch"]
        + [k for k in out.columns if k not in ("orbit", "read_in", "epoch")]
    ]


def frozen_words(table: pd.DataFrame) -> list[str]:
    """``frozen`` (librating, e swing below :data:`FROZEN_SWING`), ``librating``, ``circulating`` or ``reaches the
    surface`` (mean perilune below the surface within the cycle), per row of :func:`orbit_rows`."""
    words = []
    for r in table.itertuples():
        if r.min_mean_perilune_alt_km <= 0.0:
            words.append("reaches the surface")
        elif not r.librating:
            words.append("circulating")
        else:
            words.append("frozen" if r.ecc_swing < FROZEN_SWING else "librating")
    return words


def epoch_swap(
    settings: Settings, shifts_days, *, origin: str = "lunar_equator_of_epoch"
) -> pd.DataFrame:
    """The Table 4 ELFO's two planes (RAAN 0 and 180 deg in the lunar equator) read in ``moon_op`` at the study
    epoch moved by each shift: inclination to the Earth's plane and libration swing per plane. ``origin``:
    ``lunar_equator_of_epoch`` (RAAN from the prime meridian at that epoch, the workbook's reading) or
    ``inertial`` (from the J2000 x-axis projected on the lunar equator of the study epoch)."""
    if origin not in ("lunar_equator_of_epoch", "inertial"):
        raise ValueError(f"origin must be 'lunar_equator_of_epoch' or 'inertial'; got {origin!r}")
    ensure_kernels(settings.ephemeris)
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB")
    planes = _walker_planes((TABLE_4[0], TABLE_4[1], TABLE_4[3], TABLE_4[2], 2))
    rows = []
    for shift in np.atleast_1d(np.asarray(shifts_days, dtype=float)):
        t = t0 + shift * SECONDS_PER_DAY
        rot = (
            inertial_lunar_equator(settings.dynamics, t0)
            if origin == "inertial"
            else element_frame_to_j2000(settings.dynamics, t, "lunar_equator_of_epoch")
        )
        table = planes_in_moon_op(settings.stability, settings.dynamics, t, rot, planes)
        for k, r in enumerate(table.itertuples()):
            rows.append(
                {
                    "shift_days": float(shift),
                    "origin": origin,
                    "plane": k + 1,
                    "inc_op_deg": r.inc_op_deg,
                    "inc_off_frozen_deg": r.inc_off_frozen_deg,
                    "ecc_swing": r.ecc_swing,
                }
            )
    return pd.DataFrame(rows)


def ely_natural(
    settings: Settings, life_days: float, *, degree: int | None = None, step_s: float = 3600.0
) -> dict:
    """Ely's phased constellation flown from its file's epoch for ``life_days`` with no manoeuvre.

    The full force model of the profile (``design_life`` integrator) gives the osculating perilune; the
    stability screen (doubly-averaged) the mean one, and :func:`lnss_lib.design_life.frozen.allowances` the monthly and
    orbital terms it leaves out. Returns ``t_days``, ``perilune_alt_km`` (sat, time) and
    ``mean_perilune_alt_km`` (sat, time of the screen), their minima (``min_perilune_alt_km``,
    ``min_day``, ``min_mean_perilune_alt_km``), ``envelope_km`` (the allowance in altitude) and ``impact``.
    """
    c = load_constellation("ely2005_elfo_3sat_phased", settings.dynamics)
    fprof = file_epoch_profile(settings, c)
    cs = constellation_states_mci(settings.dynamics, settings.epoch.start_tdb, c, "file")
    ds = propagate_states(
        fprof.dynamics,
        cs.states_mci,
        cs.t_epoch_tdb_s,
        life_days * SECONDS_PER_DAY,
        step_s,
        setting="design_life",
        degree=degree,
        batch=True,
    )
    gm = settings.gravity.gm_km3_s2
    r_moon = settings.constants.r_moon_mean_km
    sv = np.concatenate([ds["r_mci_km"].values, ds["v_mci_kms"].values], axis=-1)
    alt = np.full(sv.shape[:2], np.nan)
    for k in range(sv.shape[0]):
        ok = np.all(np.isfinite(sv[k]), axis=-1)
        a, e_vec, _ = orbit_vectors_ej(sv[k][ok], gm)
        alt[k, ok] = a * (1.0 - np.linalg.norm(e_vec, axis=1)) - r_moon
    screen = screen_states(
        fprof.stability, fprof.dynamics, cs.states_mci, cs.t_epoch_tdb_s, life_days=life_days
    )
    field, model = _model_at(settings.stability, settings.dynamics, cs.t_epoch_tdb_s)
    read = mean_plane_elements(field, c.elements_deg[:1], cs.rot_to_j2000)
    allow = allowances(
        model,
        float(read["sma_km"][0]),
        float(read["ecc"][0]),
        float(read["inc_deg"][0]),
        float(read["aop_deg"][0]),
    )
    t_days = (ds["time"].values - cs.t_epoch_tdb_s) / SECONDS_PER_DAY
    k_min = np.unravel_index(np.nanargmin(alt), alt.shape)
    return {
        "t_days": t_days,
        "perilune_alt_km": alt,
        "mean_t_days": screen["time"].values,
        "mean_perilune_alt_km": screen["perilune_alt_km"].values,
        "min_perilune_alt_km": float(np.nanmin(alt)),
        "min_day": float(t_days[k_min[1]]),
        "min_sat": c.satellite_names[k_min[0]],
        "min_mean_perilune_alt_km": float(np.nanmin(screen["perilune_alt_km"].values)),
        "envelope_km": float(read["sma_km"][0]) * (allow["ecc_monthly"] + allow["ecc_orbital"]),
        "impact": bool(ds["impact"].values.any()),
        "epoch": cs.epoch_used,
        "years": life_days / DAYS_PER_JULIAN_YEAR,
    }


def closed_loop_anchors(
    settings: Settings, ely_life_days: float, table4_life_days: float
) -> pd.DataFrame:
    """The anchors flown with the profile's controller (``[design_life] controller``), no DOP sampling:
    Ely's phased constellation from its file's epoch (elements in ``moon_op``, the file's per-satellite a kept)
    for ``ely_life_days``, and one satellite per plane of the Table 4 ELFO with its elements read in ``moon_op``
    and in the lunar equator for ``table4_life_days``. One row each: Delta-V per satellite and year (mean, max,
    split by purpose, m/s), manoeuvres, lowest perilune controlled and natural, satellites lost. Ely's natural
    drift is not flown again here (:func:`ely_natural` flies it): its natural columns are NaN."""
    c = load_constellation("ely2005_elfo_3sat_phased", settings.dynamics)
    ely_profile = file_epoch_profile(settings, c).with_overrides(
        {"frames": {"element_frame": "moon_op"}}
    )
    cases = [("Ely (2005) phased, file epoch", ely_profile, c.elements_deg, ely_life_days, False)]
    planes = _walker_planes((TABLE_4[0], TABLE_4[1], TABLE_4[3], TABLE_4[2], 2))
    for frame in ("moon_op", "lunar_equator_of_epoch"):
        cases.append(
            (
                f"Table 4 ELFO, one satellite per plane, read in {frame}",
                settings.with_overrides({"frames": {"element_frame": frame}}),
                planes,
                table4_life_days,
                True,
            )
        )
    rows = []
    for label, prof, elements, life, natural in cases:
        m = life_metrics(run_design_life(prof, elements, life, natural=natural, sample=False))
        rows.append(
            {
                "anchor": label,
                "element_frame": m["element_frame"],
                "controller": m["controller"],
                "life_days": m["life_days"],
                "dv_m_s_per_year": 1000.0 * m["sk_dv_kms_per_year"],
                "dv_max_m_s_per_year": 1000.0 * m["sk_dv_max_kms_per_year"],
                "n_maneuvers": m["n_maneuvers"],
                **{f"dv_{k}_m_s_per_year": 1000.0 * v for k, v in m["sk_dv_split"].items()},
                "min_perilune_alt_km": m["min_perilune_alt_km"],
                "natural_min_perilune_alt_km": m["natural_min_perilune_alt_km"]
                if natural
                else np.nan,
                "lost": len(m["lost_satellites"]),
                "natural_lost": len(m["natural_lost_satellites"]) if natural else np.nan,
            }
        )
    return pd.DataFrame(rows)
