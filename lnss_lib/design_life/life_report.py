"""The Dataset of a closed-loop life: what each satellite flew, how well it kept its box, what it cost.

:func:`life_dataset` turns the :class:`~.fleet.FleetState` at the end of a life and the controller that flew it
into the Dataset :func:`lnss_lib.design_life.closed_loop.simulate_life` returns (its docstring lists the
variables); :func:`impact_day` reads one back.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..forces import ForceModel
from ..settings import DesignLifeSettings, IntegratorSetting
from .control import tidal_mean
from .fleet import BOX_KEYS, FleetState
from .service import LOCATIONS, PURPOSES

__all__ = ["life_dataset", "impact_day"]


def life_dataset(
    fleet: FleetState,
    controller,
    design_life: DesignLifeSettings,
    *,
    integ: IntegratorSetting,
    model: ForceModel,
    element_frame: str,
    r_impact_km: float,
    r_moon_km: float,
    wall_s: float,
    sampled: bool,
) -> xr.Dataset:
    """The life's Dataset: burns, box ratios and histories (:func:`_flown`), then perilune, losses and the
    Delta-V split by purpose and location (:func:`_add_life_report`) and the controller's report."""
    ds = _flown(fleet, controller, design_life, integ, model, element_frame, wall_s, sampled)
    report = controller.report()
    _add_life_report(
        ds,
        np.array(fleet.history["rp"]) - r_moon_km,
        fleet,
        r_impact_km - r_moon_km,
        report["navigation_violations"],
    )
    for key in ("relative_tolerances", "raan_rel_tolerance_deg", "u_rel_tolerance_deg"):
        ds.attrs[key] = report[key]
    ds["n_maneuver_sets"] = ("sat", report["n_maneuver_sets"])
    ds["n_maneuver_sets"].attrs["description"] = (
        "corrections (each one or two burns per purpose, plus a mean-a trim)"
    )
    return ds


def _add_life_report(
    ds: xr.Dataset,
    rp_alt_km: np.ndarray,
    fleet: FleetState,
    floor_alt_km: float,
    navigation_violations: int,
) -> None:
    """Perilune, losses and the Delta-V split by purpose and location, added to ``ds`` in place."""
    loss_t, loss_cause = fleet.loss_t, fleet.loss_cause
    t0, life_s = fleet.grid.t0_tdb_s, fleet.grid.life_s
    finite = np.isfinite(rp_alt_km)
    low = np.where(finite.any(axis=0), np.min(np.where(finite, rp_alt_km, np.inf), axis=0), np.nan)
    ds["min_perilune_alt_km"] = (
        "sat",
        np.where(ds["impact"].values, np.fmin(low, floor_alt_km), low),
    )
    ds["min_perilune_alt_km"].attrs["description"] = (
        "lowest osculating perilune altitude (km) over the one-orbit "
        "windows of the checks (at most the floor for a satellite that impacts)"
    )
    ds["loss_day"] = ("sat", (loss_t - t0) / SECONDS_PER_DAY)
    ds["loss_cause"] = ("sat", np.array([str(c) for c in loss_cause], dtype=object))
    ds["loss_cause"].attrs["description"] = (
        "impact, escape (unbound orbit) or propagation failed (why); empty when kept"
    )
    span_yr = np.where(np.isfinite(loss_t), loss_t - t0, life_s) / (
        DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY
    )
    dv = np.linalg.norm(np.nan_to_num(ds["maneuver_dv_rtn_kms"].values), axis=-1)
    for name, dim, coord in (
        ("dv_purpose_kms_per_year", "purpose", PURPOSES),
        ("dv_location_kms_per_year", "location", LOCATIONS),
    ):
        labels = ds[f"maneuver_{dim}"].values
        split = (
            np.stack([np.sum(np.where(labels == c, dv, 0.0), axis=1) for c in coord], axis=1)
            / span_yr[:, None]
        )
        ds[name] = xr.DataArray(split, dims=("sat", dim), coords={dim: list(coord)})
        ds[name].attrs["description"] = (
            f"Delta-V per year (over the flown span) by {dim}; sums to dv_kms_per_year"
        )
    ds.attrs["navigation_violations"] = navigation_violations


def _flown(
    fleet: FleetState,
    controller,
    cfg: DesignLifeSettings,
    integ: IntegratorSetting,
    model: ForceModel,
    element_frame: str,
    wall_s: float,
    sampled: bool,
) -> xr.Dataset:
    """Burns, box ratios and mean-element histories of the life (the Dataset's core)."""
    el, booked, impact_t, loss_t = fleet.design, fleet.booked, fleet.impact_t, fleet.loss_t
    t0, life_s, half = fleet.grid.t0_tdb_s, fleet.grid.life_s, controller.half
    hist_t, hist_el, hist_err = (np.array(fleet.history[k]) for k in ("t", "el", "err"))
    cap_kms = cfg.dv_cap_kms_per_year * cfg.life_days / DAYS_PER_JULIAN_YEAR
    natural = controller.name == "none"
    n_sat = el.shape[0]
    n_max = max([len(b) for b in booked] + [1])
    man_t = np.full((n_sat, n_max), np.nan)
    man_dv = np.full((n_sat, n_max, 3), np.nan)
    man_purpose = np.full((n_sat, n_max), "", dtype=object)
    man_location = np.full((n_sat, n_max), "", dtype=object)
    for i in range(n_sat):
        for k, (_, tb, dv, purpose, location) in enumerate(booked[i]):
            man_t[i, k], man_dv[i, k], man_purpose[i, k], man_location[i, k] = (
                tb,
                dv,
                purpose,
                location,
            )
    dv_total = np.nansum(np.linalg.norm(man_dv, axis=-1), axis=1)
    impact, lost = np.isfinite(impact_t), np.isfinite(loss_t)
    span_s = np.where(lost, loss_t - t0, life_s)
    err = hist_err.transpose(1, 0, 2)
    smooth = err.copy()
    for i in range(n_sat):
        smooth[i, :, :4] = tidal_mean(hist_t[:, i], err[i, :, :4], cfg.tide_period_days)
    max_ratio, max_ratio_orbit = (_max_ratio(np.abs(x) / half[:, None, :]) for x in (smooth, err))
    dv_per_year = dv_total / (
        span_s / (DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY)
    )  # a lost satellite: over its flown span
    held = (
        (~lost)
        & np.all(max_ratio <= 1.0 + cfg.box_tolerance, axis=1)
        & (dv_total <= cap_kms * (1 + 1e-9))
    )
    mel = hist_el.transpose(1, 0, 2).copy()
    mel[..., 1:] = np.where(np.arange(6)[1:] >= 2, np.degrees(mel[..., 1:]), mel[..., 1:])
    ds = xr.Dataset(
        {
            "dv_kms_per_year": ("sat", dv_per_year),
            "dv_total_kms": ("sat", dv_total),
            "n_maneuvers": ("sat", np.array([len(b) for b in booked])),
            "maneuver_purpose": (("sat", "maneuver"), man_purpose),
            "maneuver_location": (("sat", "maneuver"), man_location),
            "maneuver_t_tdb_s": (("sat", "maneuver"), man_t),
            "maneuver_day": (("sat", "maneuver"), (man_t - t0) / SECONDS_PER_DAY),
            "maneuver_dv_rtn_kms": (("sat", "maneuver", "rtn"), man_dv),
            "box_held": ("sat", held),
            "impact": ("sat", impact),
            "impact_t_tdb_s": ("sat", impact_t),
            "impact_day": ("sat", (impact_t - t0) / SECONDS_PER_DAY),
            "max_box_ratio": (("sat", "box"), max_ratio),
            "max_box_ratio_one_orbit": (("sat", "box"), max_ratio_orbit),
            "box_error_tidal_mean": (("sat", "check", "box"), smooth),
            "mean_elements": (("sat", "check", "mean_element"), mel),
            "box_error": (("sat", "check", "box"), hist_err.transpose(1, 0, 2)),
            "check_t_tdb_s": (("sat", "check"), hist_t.T),
            "check_day": (("sat", "check"), (hist_t.T - t0) / SECONDS_PER_DAY),
            "elements_deg": (("sat", "element"), el),
        },
        coords={
            "sat": np.arange(n_sat),
            "maneuver": np.arange(n_max),
            "rtn": ["R", "T", "N"],
            "box": list(BOX_KEYS),
            "mean_element": ["a_km", "e", "inc_deg", "raan_deg", "aop_deg", "u_deg"],
            "element": ["a_km", "e", "inc_deg", "raan_deg", "aop_deg", "M_deg"],
        },
        attrs={
            "mode": "natural drift" if natural else "closed-loop station keeping",
            "controller": controller.name,
            "life_days": cfg.life_days,
            "t0_tdb_s": t0,
            "integrator_setting": integ.name,
            "integrator": f"{integ.method} rtol {integ.rtol:g} atol {integ.atol:g}",
            "force_model": model.describe(),
            "element_frame": element_frame,
            "box_half_widths": ", ".join(f"{k} {getattr(cfg.box, k):g}" for k in BOX_KEYS),
            "box_error_units": "ecc (-), aop/inc/raan_rel/u_rel (rad)",
            "dv_cap_kms_per_year": cfg.dv_cap_kms_per_year,
            "wall_s": wall_s,
        },
    )
    if sampled:
        sample_t = fleet.grid.sample_t
        ds["r_mci_km"] = (("sat", "sample", "xyz"), fleet.r_sample)
        ds = ds.assign_coords(
            sample_t_tdb_s=("sample", sample_t),
            sample_day=("sample", (sample_t - t0) / SECONDS_PER_DAY),
            xyz=["x", "y", "z"],
        )
        ds["r_mci_km"].attrs["description"] = (
            "Moon-centred J2000 positions (km) on the sample grid, NaN after an impact"
        )
    ds["dv_kms_per_year"].attrs["units"] = "km/s per year"
    ds["mean_elements"].attrs["description"] = (
        "mean elements over one orbit ending at each check; u = aop + M"
    )
    return ds


def _max_ratio(ratio: np.ndarray) -> np.ndarray:
    """Largest ratio (sat, box) over the checks after the first (all checks when there is one)."""
    r = np.where(np.isfinite(ratio), ratio, -np.inf)
    r = r[:, 1:] if r.shape[1] > 1 else r
    return np.where(np.isfinite(r.max(axis=1)), r.max(axis=1), np.nan)


def impact_day(ds: xr.Dataset) -> float:
    """First impact day of a :func:`lnss_lib.design_life.closed_loop.simulate_life` result over all satellites (NaN when none)."""
    days = ds["impact_day"].values
    return float(np.nanmin(days)) if np.any(np.isfinite(days)) else float("nan")
