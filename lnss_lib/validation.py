"""Validation against a real ephemeris: CAPSTONE (NRHO) state vectors from JPL Horizons.

The Horizons file (Moon-centred, ICRF = SPICE J2000, TDB, km, km/s) is split into clean arcs at
the orbit-solution joins (``validation.capstone.arc_break_tdb``); each arc is propagated from its
first Horizons state and compared with the rest. :func:`estimate_srp` fits the one SRP parameter
Cr*A/m by Gauss-Newton least squares on an arc's position residuals.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from .config import data_path
from .constants import SECONDS_PER_DAY
from .ephemeris import EphemerisTable, ensure_kernels, tdb_seconds
from .forces import ForceModel
from .propagator import propagate_states
from .settings import CapstoneSettings, Dynamics, EphemerisSettings, ForceSettings

_RECORD = re.compile(
    r"^\s*(?P<jd>\d+\.\d+)\s*=\s*A\.D\.\s*(?P<cal>\S+\s+\S+)\s+TDB\s*$\s*"
    r"X\s*=\s*(?P<x>\S+)\s+Y\s*=\s*(?P<y>\S+)\s+Z\s*=\s*(?P<z>\S+)\s*$\s*"
    r"VX\s*=\s*(?P<vx>\S+)\s+VY\s*=\s*(?P<vy>\S+)\s+VZ\s*=\s*(?P<vz>\S+)\s*$",
    re.MULTILINE,
)
__all__ = [
    "read_horizons_vectors",
    "capstone_arcs",
    "one_step_residuals",
    "propagate_arc",
    "estimate_srp",
    "variant_differences",
    "without_term",
]

JD_J2000 = 2451545.0


def read_horizons_vectors(path: Path) -> xr.Dataset:
    """Read a Horizons VECTORS table (TDB, km, km/s) into a Dataset (dim ``time`` in TDB s past J2000).

    Raises ``ValueError`` if the file has no $$SOE/$$EOE block, or is not Moon-centred, ICRF, TDB.
    """
    text = Path(path).read_text()
    if "$$SOE" not in text or "$$EOE" not in text:
        raise ValueError(f"{path}: no $$SOE ... $$EOE block; expected a Horizons VECTORS table")
    for required in ("Center body name: Moon", "Reference frame : ICRF", "Output units    : KM-S"):
        if required not in text:
            raise ValueError(
                f"{path}: header lacks {required!r}; the validation needs Moon-centred ICRF km, km/s"
            )
    body = text.split("$$SOE", 1)[1].split("$$EOE", 1)[0]
    rows = [m.groupdict() for m in _RECORD.finditer(body)]
    if not rows:
        raise ValueError(f"{path}: no state records recognised between $$SOE and $$EOE")
    jd = np.array([float(r["jd"]) for r in rows])
    t_tdb_s = np.round((jd - JD_J2000) * SECONDS_PER_DAY, 3)
    r = np.array([[float(row[k]) for k in ("x", "y", "z")] for row in rows])
    v = np.array([[float(row[k]) for k in ("vx", "vy", "vz")] for row in rows])
    return xr.Dataset(
        {"r_mci_km": (("time", "xyz"), r), "v_mci_kms": (("time", "xyz"), v)},
        coords={"time": t_tdb_s, "xyz": ["x", "y", "z"]},
        attrs={"source": str(path), "frame": "Moon-centred ICRF (J2000)", "time_scale": "TDB"},
    )


def capstone_arcs(capstone: CapstoneSettings, ephemeris: EphemerisSettings) -> list[xr.Dataset]:
    """The Horizons CAPSTONE ephemeris split at ``capstone.arc_break_tdb`` into clean arcs."""
    ensure_kernels(ephemeris)
    ref = read_horizons_vectors(data_path(capstone.file))
    t_break = tdb_seconds(capstone.arc_break_tdb, "TDB")
    first = ref.sel(time=ref.time <= t_break)
    second = ref.sel(time=ref.time > t_break)
    return [first, second]


def one_step_residuals(
    dynamics: Dynamics,
    capstone: CapstoneSettings,
    ref: xr.Dataset,
    *,
    srp_cr_area_mass_m2_kg: float | None = None,
) -> xr.Dataset:
    """Propagate every Horizons state to the next epoch and return |prediction - Horizons| (km).

    Over one 10-minute sample the force model is good to metres, so a jump of the residual marks a
    manoeuvre or a join between orbit solutions: only arcs between such epochs are comparable.
    Defaults: ``capstone``'s Cr*A/m and integrator setting.
    """
    cr_am = (
        capstone.srp_cr_area_mass_m2_kg
        if srp_cr_area_mass_m2_kg is None
        else srp_cr_area_mass_m2_kg
    )
    times = ref.time.values
    table = EphemerisTable.build(dynamics, float(times[0]), float(times[-1]))
    model = ForceModel.build(dynamics, table, srp_cr_area_mass_m2_kg=cr_am)
    states = np.concatenate([ref.r_mci_km.values, ref.v_mci_kms.values], axis=1)
    residual = np.empty(len(times) - 1)
    for k in range(len(times) - 1):
        dt = float(times[k + 1] - times[k])
        ds = propagate_states(
            dynamics,
            states[k][None, :],
            float(times[k]),
            dt,
            dt,
            setting=capstone.integrator_setting,
            model=model,
        )
        residual[k] = np.linalg.norm(ds.r_mci_km.values[0, -1] - states[k + 1, :3])
    return xr.Dataset(
        {"one_step_error_km": ("time", residual)},
        coords={"time": times[1:]},
        attrs={"meaning": "error of a one-sample propagation ending at each epoch"},
    )


def propagate_arc(
    dynamics: Dynamics,
    capstone: CapstoneSettings,
    arc: xr.Dataset,
    *,
    srp_cr_area_mass_m2_kg: float | None = None,
    setting: str | None = None,
    degree: int | None = None,
) -> xr.Dataset:
    """Propagate from an arc's first Horizons state over the arc, sampled at the Horizons epochs.

    Defaults: ``capstone``'s Cr*A/m and integrator setting. Returns the arc with ``r_prop_km`` and
    ``pos_error_km`` (|propagated - Horizons|) added.
    """
    times = arc.time.values
    step = float(np.median(np.diff(times)))
    y0 = np.concatenate([arc.r_mci_km.values[0], arc.v_mci_kms.values[0]])
    if srp_cr_area_mass_m2_kg is None:
        srp_cr_area_mass_m2_kg = capstone.srp_cr_area_mass_m2_kg
    ds = propagate_states(
        dynamics,
        y0[None, :],
        float(times[0]),
        float(times[-1] - times[0]),
        step,
        setting=setting or capstone.integrator_setting,
        degree=degree,
        srp_cr_area_mass_m2_kg=srp_cr_area_mass_m2_kg,
    )
    r_prop = ds.r_mci_km.isel(sat=0).sel(time=times, method="nearest").values
    out = arc.copy()
    out["r_prop_km"] = (("time", "xyz"), r_prop)
    out["pos_error_km"] = ("time", np.linalg.norm(r_prop - arc.r_mci_km.values, axis=1))
    out.attrs.update(
        srp_cr_area_mass_m2_kg=float(srp_cr_area_mass_m2_kg),
        force_model=ds.attrs["force_model"],
        integrator=ds.attrs["integrator"],
        rtol=ds.attrs["rtol"],
        atol=ds.attrs["atol"],
    )
    return out


def estimate_srp(
    dynamics: Dynamics,
    capstone: CapstoneSettings,
    arc: xr.Dataset,
    *,
    initial_m2_kg: float | None = None,
    iterations: int = 6,
    setting: str | None = None,
) -> dict:
    """Least-squares estimate of Cr*A/m (m^2/kg) from an arc's position residuals (Gauss-Newton).

    The partial derivative of the positions is taken by central differences; the initial state is
    held at the Horizons value. Returns the estimate, its formal 1-sigma (from the residual RMS),
    the RMS and end errors, and the iteration history.
    """
    p = capstone.srp_cr_area_mass_m2_kg if initial_m2_kg is None else initial_m2_kg
    history = []
    for _ in range(iterations):
        delta = max(1e-4, 0.02 * abs(p))
        base = propagate_arc(dynamics, capstone, arc, srp_cr_area_mass_m2_kg=p, setting=setting)
        plus = propagate_arc(
            dynamics, capstone, arc, srp_cr_area_mass_m2_kg=p + delta, setting=setting
        )
        minus = propagate_arc(
            dynamics, capstone, arc, srp_cr_area_mass_m2_kg=max(p - delta, 0.0), setting=setting
        )
        width = delta + min(delta, p)
        partial = ((plus.r_prop_km - minus.r_prop_km) / width).values.ravel()
        residual = (arc.r_mci_km - base.r_prop_km).values.ravel()
        step = float(partial @ residual / (partial @ partial))
        history.append(
            {
                "cr_area_mass_m2_kg": p,
                "rms_km": float(np.sqrt(np.mean(base.pos_error_km.values**2))),
            }
        )
        p = max(p + step, 0.0)
        if abs(step) < 1e-6 * max(p, 1e-6):
            break
    final = propagate_arc(dynamics, capstone, arc, srp_cr_area_mass_m2_kg=p, setting=setting)
    residual = (arc.r_mci_km - final.r_prop_km).values.ravel()
    dof = max(residual.size - 1, 1)
    sigma = float(np.sqrt(residual @ residual / dof / (partial @ partial)))
    return {
        "cr_area_mass_m2_kg": float(p),
        "sigma_m2_kg": sigma,
        "rms_km": float(np.sqrt(np.mean(final.pos_error_km.values**2))),
        "end_error_km": float(final.pos_error_km.values[-1]),
        "history": history,
        "arc": final,
    }


def variant_differences(
    dynamics: Dynamics,
    state_mci: np.ndarray,
    t0_tdb_s: float,
    duration_s: float,
    step_s: float,
    variants: Mapping[str, Dynamics],
) -> xr.Dataset:
    """Position difference (km) of each variant model against ``dynamics``, from one state.

    ``variants`` maps a label to other dynamics settings (for example
    ``settings.with_overrides(without_term(settings.forces, "SUN")).dynamics``); each model, the
    baseline included, propagates with its own ``integrator.setting``. Returns ``difference_km`` (variant, time).
    """
    base = propagate_states(dynamics, state_mci[None, :], t0_tdb_s, duration_s, step_s)
    diffs = []
    for other_dynamics in variants.values():
        other = propagate_states(other_dynamics, state_mci[None, :], t0_tdb_s, duration_s, step_s)
        diffs.append(np.linalg.norm(other.r_mci_km.values[0] - base.r_mci_km.values[0], axis=1))
    return xr.Dataset(
        {"difference_km": (("variant", "time"), np.array(diffs))},
        coords={"variant": list(variants), "time": base.time.values},
        attrs={"baseline": base.attrs["force_model"], "integrator": base.attrs["integrator"]},
    )


def without_term(forces: ForceSettings, term: str) -> dict:
    """Settings overrides that switch one force term off: a third body, ``harmonics``, ``srp``, ``relativity``, ``albedo``."""
    if term in ("SUN", "EARTH", "JUPITER"):
        return {"forces": {"third_bodies": [b for b in forces.third_bodies if b != term]}}
    if term == "harmonics":
        return {"gravity": {"degree": 0}}
    if term in ("srp", "relativity", "albedo"):
        return {"forces": {term: False}}
    raise ValueError(
        f"unknown force term {term!r}; allowed: SUN, EARTH, JUPITER, harmonics, srp, relativity, albedo"
    )
