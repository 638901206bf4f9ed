"""Station-keeping Delta-V from a propagated arc (paper Section 3.1, eq. 25-41; Section 4).

Pipeline (pure numpy kernels, time along axis -2 of state arrays, any leading batch dims):
osculating elements at every epoch -> unwrapped angles -> drift rates by central finite
differences (:func:`element_rates`) -> thrust in RTN by an inverse of the Gauss variational
equations (GVEs, eq. 25-29) -> T_total (eq. 36) -> Delta-V by the trapezoidal rule (eq. 37) ->
per satellite per year (x 365.25 d / arc length, Section 4).

Conventions: ``T`` is the RTN acceleration that *produces* the observed drift (R along r, N along
h = r x v, T = N x R); the station-keeping thrust is -T, of the same magnitude. Accelerations in
km/s^2, elements ``[sma_km, e, i, raan, aop, nu]`` in km and rad (nu: true anomaly).

Three models (``MODELS``), all reported:

``paper``
    eq. 30-35 with the evident misprints corrected (see :func:`paper_thrust`): eq. 26's ``r e``
    inside the T_T bracket (already right in eq. 33); eq. 34 divides by cos(nu); eq. 32 and
    eq. 35 combine the two normal and the two radial estimates of one acceleration as a
    least-squares (weighted) mean instead of ``|T_i|`` and a double-counting sum. Eq. 30's
    assumption (no radial part in the SMA drift) is the paper's modelling choice and is kept.
    The literal variants and the divisor floor / component cap stay selectable.
``lsq``
    least-squares inverse of all five GVEs (5 x 3 per epoch, rows in natural units,
    :func:`lsq_thrust`), with the rates taken by central differences of a, the eccentricity
    vector and the orbit normal (regular at e -> 0 and i -> 0); with exact rates it returns the
    perturbing acceleration itself.
``secular``
    the cost of cancelling only the secular drift of the orbit-averaged (mean) orbit, with
    optimally placed linearised impulsive corrections derived from the GVEs
    (:func:`secular_drift`, :func:`secular_deltav_rates`); periodic terms cost nothing.

The optimised thrust of eq. 38-41 has a closed form (:func:`tmax_closed_form`); SLSQP
(:func:`slsqp_tmax`) is kept as a cross-check.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr
from scipy.optimize import minimize

from .config import validate_profile
from .constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from .frames import ELEMENT_FRAMES, element_frame_to_j2000, to_rtn
from .gve import (
    NATURAL_RATE_NAMES,
    PAPER_NORMAL,
    PAPER_RADIAL,
    RATE_NAMES,
    check_epochs,
    element_rates,
    lsq_thrust,
    natural_rates_from_elements,
    orbit_vectors,
    osculating_elements,
    paper_thrust,
    project_natural,
)
from .sections import DELTAV_MODELS, LSQ_RATES

if TYPE_CHECKING:
    from .settings import DeltaVSettings, Dynamics

__all__ = [
    "MODELS",
    "OSCULATING_MODELS",
    "LSQ_RATES",
    "SECULAR_PARTS",
    "with_overrides",
    "thrust_total",
    "tmax_closed_form",
    "slsqp_tmax",
    "trapezoid_deltav",
    "per_year_factor",
    "orbit_mean",
    "secular_drift",
    "secular_deltav_rates",
    "deltav_arrays",
    "perturbing_acceleration_rtn",
    "deltav_from_propagation",
    "chosen_budget",
    "deltav_per_satellite",
    "dataset_states",
    # re-exported from gve and frames (the kernels deltav_arrays is built on)
    "osculating_elements",
    "element_rates",
    "lsq_thrust",
    "paper_thrust",
    "orbit_vectors",
    "natural_rates_from_elements",
    "to_rtn",
    "ELEMENT_FRAMES",
    "RATE_NAMES",
    "NATURAL_RATE_NAMES",
    "PAPER_NORMAL",
    "PAPER_RADIAL",
]

MODELS = DELTAV_MODELS
OSCULATING_MODELS = ("paper", "lsq")
SECULAR_PARTS = ("sma", "ecc_vector", "plane")


# ----------------------------------------------------------------------------------------------
# settings
# ----------------------------------------------------------------------------------------------


def with_overrides(deltav: DeltaVSettings, **overrides) -> DeltaVSettings:
    """``deltav`` (the ``[deltav]`` section) with ``overrides`` (None values ignored; e.g. a study's
    ``gve_frame="lunar_equator_of_epoch"``), checked as the profile is (:func:`lnss_lib.config.validate_profile`:
    keys, types, ranges, allowed values); the section itself when nothing changes."""
    changed = {k: v for k, v in overrides.items() if v is not None}
    if not changed:
        return deltav
    validate_profile({"deltav": changed}, partial=True, source="overrides")
    return dataclasses.replace(
        deltav,
        **{k: float(v) if isinstance(getattr(deltav, k), float) else v for k, v in changed.items()},
    )


# ----------------------------------------------------------------------------------------------
# magnitude, optimisation and integration (eq. 36-41)
# ----------------------------------------------------------------------------------------------


def thrust_total(t_rtn_kms2: np.ndarray) -> np.ndarray:
    """T_total = sqrt(T_R^2 + T_T^2 + T_N^2) (eq. 36), over the last axis."""
    return np.linalg.norm(np.asarray(t_rtn_kms2, dtype=float), axis=-1)


def tmax_closed_form(t_rtn_kms2: np.ndarray) -> np.ndarray:
    """Optimised thrust of eq. 38-41: T_max = sqrt(sum_k T_k^4) / sum_k |T_k| (0 where T = 0).

    Derivation: squaring and adding the three equalities of eq. 40 (cos^2 b cos^2 a +
    cos^2 b sin^2 a + sin^2 b = 1) gives T_max^2 = sum_k w_k^2 T_k^2 with w_k = |T_k| / sum_j |T_j|
    (eq. 39), hence the closed form; the angles follow as alpha = atan2(w_T|T_T|, w_R|T_R|),
    beta = asin(w_N|T_N| / T_max). Three equations fix all three unknowns, so the objective of
    eq. 41 and its penalty lambda play no role. T_total / 3 <= T_max <= T_total (three equal
    components give the lower bound, a single non-zero component the upper one). Note that the
    optimised vector (w_k |T_k|) is not parallel to (|T_k|) unless all non-zero |T_k| are equal, so it
    does not produce the drift that (T_R, T_T, T_N) cancels: eq. 38-41 are reproduced, not endorsed.
    """
    t = np.abs(np.asarray(t_rtn_kms2, dtype=float))
    total_abs = np.sum(t, axis=-1)
    quartic = np.sqrt(np.sum(t**4, axis=-1))
    return np.where(total_abs > 0.0, quartic / np.where(total_abs > 0.0, total_abs, 1.0), 0.0)


def slsqp_tmax(t_rtn_kms2: np.ndarray, lam: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 41 solved by SLSQP per sample (rows of an (m, 3) array); returns (T_max km/s^2, success).

    Scaled so that T_total = 1 (SLSQP stops on infeasible points in km/s^2 units, NOTES.md):
    variables (T_max / T_total, alpha, beta), objective T + lam (T - 1)^2, equalities eq. 40,
    bounds 0 <= T <= 1, alpha in [-pi, pi], beta in [-pi/2, pi/2]; initial guess T = 1 and the
    angles of (|T_R|, |T_T|, |T_N|). ``success`` means eq. 40 holds to 1e-7 (relative); SLSQP's
    own flag can report a line-search stop at rounding level once the equalities are met.
    """
    samples = np.atleast_2d(np.asarray(t_rtn_kms2, dtype=float))
    if samples.shape[-1] != 3:
        raise ValueError(
            f"thrust samples must have shape (m, 3) [T_R, T_T, T_N]; got {samples.shape}"
        )
    out = np.zeros(samples.shape[0])
    ok = np.ones(samples.shape[0], dtype=bool)
    for k, row in enumerate(samples):
        total = float(np.linalg.norm(row))
        if total == 0.0:
            continue
        c = np.abs(row) / total
        w = c / c.sum()
        target = w * c

        def equalities(x, target=target):
            tm, alpha, beta = x
            return np.array(
                [
                    target[0] - tm * np.cos(beta) * np.cos(alpha),
                    target[1] - tm * np.cos(beta) * np.sin(alpha),
                    target[2] - tm * np.sin(beta),
                ]
            )

        x0 = np.array([1.0, np.arctan2(c[1], c[0]), np.arcsin(np.clip(c[2], -1.0, 1.0))])
        res = minimize(
            lambda x: x[0] + lam * (x[0] - 1.0) ** 2,
            x0,
            method="SLSQP",
            constraints=[{"type": "eq", "fun": equalities}],
            bounds=[(0.0, 1.0), (-np.pi, np.pi), (-np.pi / 2, np.pi / 2)],
            options={"ftol": 1e-12, "maxiter": 200},
        )
        out[k] = res.x[0] * total
        ok[k] = np.max(np.abs(equalities(res.x))) < 1e-7
    return out, ok


def trapezoid_deltav(t_tdb_s: np.ndarray, t_total_kms2: np.ndarray) -> np.ndarray:
    """Delta-V (km/s) = integral of T_total dt by the trapezoidal rule over time (last axis) (eq. 37)."""
    return np.trapezoid(
        np.asarray(t_total_kms2, dtype=float), np.asarray(t_tdb_s, dtype=float), axis=-1
    )


def per_year_factor(t_tdb_s: np.ndarray, year_days: float = DAYS_PER_JULIAN_YEAR) -> float:
    """Scale from an arc's Delta-V to a year's: year_days days / (t_end - t_start) (Section 4)."""
    t = np.asarray(t_tdb_s, dtype=float)
    span = float(t[-1] - t[0])
    if not span > 0.0:
        raise ValueError(f"arc length must be positive to scale to a year; got {span} s")
    return year_days * SECONDS_PER_DAY / span


# ----------------------------------------------------------------------------------------------
# secular (mean-element) model
# ----------------------------------------------------------------------------------------------


def orbit_mean(
    t_tdb_s: np.ndarray, values: np.ndarray, period_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Running mean over one period: window mid-times (m,) and means (..., m, k) of values (..., n, k).

    Windows [t_j, t_j + P] start at every sample with t_j + P <= t_end; the mean is the exact
    integral of the piecewise-linear interpolant divided by P.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    v = np.asarray(values, dtype=float)
    starts = t[t + period_s <= t[-1] + 1e-9 * period_s]
    if starts.size < 2:
        raise ValueError(
            f"arc of {t[-1] - t[0]:.0f} s holds fewer than two one-period windows (P = {period_s:.0f} s)"
        )
    dt = np.diff(t)
    increments = 0.5 * (v[..., 1:, :] + v[..., :-1, :]) * dt[:, None]
    cumulative = np.concatenate(
        [np.zeros_like(v[..., :1, :]), np.cumsum(increments, axis=-2)], axis=-2
    )
    ends = starts + period_s
    k = np.clip(np.searchsorted(t, ends, side="right") - 1, 0, t.size - 2)
    u = (ends - t[k]) / dt[k]
    v_end = v[..., k, :] + (v[..., k + 1, :] - v[..., k, :]) * u[:, None]
    cum_end = cumulative[..., k, :] + 0.5 * (v[..., k, :] + v_end) * (ends - t[k])[:, None]
    k0 = np.searchsorted(t, starts)
    means = (cum_end - cumulative[..., k0, :]) / period_s
    return starts + 0.5 * period_s, means


def secular_drift(
    t_tdb_s: np.ndarray,
    states: np.ndarray,
    gm_km3_s2: float,
    min_periods: float = 2.0,
    short_arc: str = "raise",
) -> dict:
    """Mean (orbit-averaged) orbit and its secular drift over an arc of states (n, 6) or (..., n, 6).

    a, the eccentricity vector and the orbit normal (:func:`orbit_vectors`) are averaged over one
    Keplerian period of the arc-mean a (:func:`orbit_mean`); a straight line fitted by least
    squares to the running means gives their secular rates, projected into natural rates
    (:func:`natural_rates_from_elements`). Assumes the arc spans at least ``min_periods`` periods;
    terms with periods longer than the arc (e.g. the Earth's half-month tide) are absorbed in the
    trend, and osculating-to-mean offsets are not modelled (plain averaging, no mean-element theory).

    Returns a dict: ``a_km``, ``e``, ``inc_rad``, ``natural_rates`` (..., 5), ``raan_dot``,
    ``aop_dot`` (rad/s, for reporting; ill-defined as i -> 0 or e -> 0), ``axis_cos`` (|cos| of the
    angle between perilune and the line about which the plane turns) and ``period_s``. An arc
    shorter than ``min_periods`` periods raises ``ValueError`` (``short_arc="raise"``) or gives NaN
    results (``short_arc="nan"``, for batch use).
    """
    if short_arc not in ("raise", "nan"):
        raise ValueError(f"short_arc = {short_arc!r}; allowed: 'raise', 'nan'")
    t = np.asarray(t_tdb_s, dtype=float)
    return _secular_from_vectors(
        t, orbit_vectors(states, gm_km3_s2), gm_km3_s2, min_periods, short_arc
    )


def _secular_from_vectors(
    t: np.ndarray, vectors: np.ndarray, gm_km3_s2: float, min_periods: float, short_arc: str
) -> dict:
    if vectors.ndim > 2:
        flat = [
            _secular_from_vectors(t, one, gm_km3_s2, min_periods, short_arc)
            for one in vectors.reshape(-1, *vectors.shape[-2:])
        ]
        return {
            k: np.stack([f[k] for f in flat]).reshape(*vectors.shape[:-2], *np.shape(flat[0][k]))
            for k in flat[0]
        }
    check_epochs(t, vectors)
    a_mean_km = np.mean(vectors[:, 0])
    if not a_mean_km > 0.0:
        raise ValueError(
            f"the secular Delta-V model needs a bound orbit: the arc-mean semi-major axis is "
            f"{a_mean_km:.6g} km, so the orbital period is undefined (the orbit escapes or hits the Moon)"
        )
    period = 2.0 * np.pi * np.sqrt(a_mean_km**3 / gm_km3_s2)
    if t[-1] - t[0] < min_periods * period:
        if short_arc == "nan":
            return {
                "a_km": np.nan,
                "e": np.nan,
                "inc_rad": np.nan,
                "natural_rates": np.full(5, np.nan),
                "raan_dot": np.nan,
                "aop_dot": np.nan,
                "axis_cos": np.nan,
                "period_s": float(period),
            }
        raise ValueError(
            f"the secular model needs an arc of at least {min_periods:g} orbital periods "
            f"({min_periods * period:.0f} s); got {t[-1] - t[0]:.0f} s"
        )
    t_mid, means = orbit_mean(t, vectors, period)
    x = t_mid - t_mid.mean()
    slope = x @ (means - means.mean(axis=0)) / np.sum(x * x)
    mean = means.mean(axis=0)
    natural, axis_cos = project_natural(mean, slope)
    h_hat = mean[4:7] / np.linalg.norm(mean[4:7])
    e_vec = mean[1:4] - np.dot(mean[1:4], h_hat) * h_hat
    e = float(np.linalg.norm(e_vec))
    inc = float(np.arccos(np.clip(h_hat[2], -1.0, 1.0)))
    raan_dot = natural[4] / np.sin(inc) if np.sin(inc) > 0.0 else np.nan
    aop_dot = natural[2] / e - np.cos(inc) * raan_dot if e > 0.0 else np.nan
    return {
        "a_km": float(mean[0]),
        "e": e,
        "inc_rad": inc,
        "natural_rates": natural,
        "raan_dot": raan_dot,
        "aop_dot": aop_dot,
        "axis_cos": float(axis_cos),
        "period_s": float(period),
    }


def secular_deltav_rates(sma_km, e, natural_rates: np.ndarray, axis_cos, gm_km3_s2: float) -> dict:
    """Delta-V rates (km/s per s) that cancel secular drifts, by part; dict of (...,) arrays.

    Linearised, optimally placed impulses derived from the GVEs (the small-change limits of
    Vallado, Fundamentals of Astrodynamics and Applications, Sec. 6.3-6.4, and of the classic
    station-keeping costs in Chobotov, Orbital Mechanics), with q = natural rates:

    * ``sma``: two equal tangential impulses at perilune and apolune (e unchanged):
      mu |a-dot| / (a^2 (v_p + v_a)) = (n a / 2) sqrt(1 - e^2) |a-dot| / a.
    * ``ecc_vector``: the in-plane eccentricity-vector drift, h |(e-dot, e (aop-dot + cos(i) raan-dot))| / (2 p).
      A pure change of e (opposite tangential impulses at perilune and apolune, a unchanged) and a pure
      apse rotation (opposite tangential impulses at nu = +-90 deg, a and e unchanged) both cost
      h / (2 p) per unit; for a circle any direction costs v |de| / 2. Taking the vector norm for a mixed
      drift is exact for circles and an approximation for eccentric orbits. The cos(i) raan-dot part
      removes the apse shift that the plane correction itself causes (GVE: a normal impulse moves aop
      by -cos(i) d raan).
    * ``plane``: one normal impulse on the line about which the drifted plane turns, at its farther end:
      h |(i-dot, sin(i) raan-dot)| (1 - e |cos(theta* - aop)|) / p; for a circle v sqrt(di^2 + sin^2(i) d raan^2),
      the textbook combined change of inclination and node.

    ``total`` is the sum of the parts (in-plane and out-of-plane corrections share nothing).
    """
    q = np.asarray(natural_rates, dtype=float)
    a = np.asarray(sma_km, dtype=float)
    e = np.asarray(e, dtype=float)
    p = a * (1.0 - e * e)
    h = np.sqrt(gm_km3_s2 * p)
    n = np.sqrt(gm_km3_s2 / a**3)
    parts = {
        "sma": 0.5 * n * a * np.sqrt(1.0 - e * e) * np.abs(q[..., 0]),
        "ecc_vector": h * np.hypot(q[..., 1], q[..., 2]) / (2.0 * p),
        "plane": h
        * np.hypot(q[..., 3], q[..., 4])
        * (1.0 - e * np.asarray(axis_cos, dtype=float))
        / p,
    }
    parts["total"] = sum(parts[k] for k in SECULAR_PARTS)
    return parts


# ----------------------------------------------------------------------------------------------
# the whole kernel on arrays
# ----------------------------------------------------------------------------------------------


def deltav_arrays(
    t_tdb_s: np.ndarray,
    states: np.ndarray,
    gm_km3_s2: float,
    deltav: DeltaVSettings,
    models: tuple[str, ...] = MODELS,
) -> dict:
    """Each of ``models``' Delta-V (default every model) from one arc of states (..., n, 6) in the GVE element
    frame, with the ``[deltav]`` settings ``deltav`` (its ``model`` does not enter).

    Returns a dict of arrays: ``elements`` (..., n, 6) and their finite-difference ``rates``
    (..., n, 5); ``natural_rates`` (..., n, 5) used by ``lsq``; for ``paper`` and ``lsq``:
    ``T_rtn_<model>`` (..., n, 3), ``T_total_<model>``, ``T_opt_<model>`` (..., n);
    ``lsq_residual`` (..., n); ``paper_estimates`` (the single-equation estimates); ``secular``
    (:func:`secular_drift`) and ``secular_parts`` (km/s per s); ``dv_total`` and ``dv_opt`` (dicts
    model -> (...,) km/s per year); ``per_year_factor``. The secular model has no instantaneous
    thrust; its optimised budget equals its total (already a minimum-cost impulsive budget, so
    eq. 38-41 do not apply); it is NaN for an arc shorter than ``secular_min_periods`` orbits. A model not in
    ``models`` is not computed and its keys are absent (ValueError naming a model outside :data:`MODELS`).
    """
    cfg = deltav
    unknown = [m for m in models if m not in MODELS]
    if unknown:
        raise ValueError(
            f"Delta-V model(s) {unknown} are not allowed; allowed: {', '.join(MODELS)}"
        )
    t = np.asarray(t_tdb_s, dtype=float)
    elements = osculating_elements(states, gm_km3_s2)
    rates = element_rates(t, elements)
    vectors = orbit_vectors(states, gm_km3_s2)
    check_epochs(t, vectors)
    if cfg.lsq_rates == "vectors":
        natural = project_natural(vectors, np.gradient(vectors, t, axis=-2, edge_order=2))[0]
    else:
        natural = natural_rates_from_elements(elements, rates)
    factor = per_year_factor(t, cfg.year_days)
    out = {
        "elements": elements,
        "rates": rates,
        "natural_rates": natural,
        "per_year_factor": factor,
        "dv_total": {},
        "dv_opt": {},
    }
    thrusts = {}
    if "paper" in models:
        paper = paper_thrust(
            elements,
            rates,
            gm_km3_s2,
            normal=cfg.paper_normal,
            radial=cfg.paper_radial,
            divisor_floor=cfg.paper_divisor_floor,
            cap_kms2=cfg.paper_cap_kms2,
        )
        out["paper_estimates"] = paper
        thrusts["paper"] = np.stack([paper["T_R"], paper["T_T"], paper["T_N"]], axis=-1)
    if "lsq" in models:
        thrusts["lsq"], out["lsq_residual"] = lsq_thrust(elements, natural, gm_km3_s2)
    for name, t_rtn in thrusts.items():
        total = thrust_total(t_rtn)
        opt = tmax_closed_form(t_rtn)
        out[f"T_rtn_{name}"] = t_rtn
        out[f"T_total_{name}"] = total
        out[f"T_opt_{name}"] = opt
        out["dv_total"][name] = trapezoid_deltav(t, total) * factor
        out["dv_opt"][name] = trapezoid_deltav(t, opt) * factor
    if "secular" not in models:
        return out
    sec = _secular_from_vectors(t, vectors, gm_km3_s2, cfg.secular_min_periods, "nan")
    parts = secular_deltav_rates(
        sec["a_km"], sec["e"], sec["natural_rates"], sec["axis_cos"], gm_km3_s2
    )
    year_s = cfg.year_days * SECONDS_PER_DAY
    out["secular"] = sec
    out["secular_parts"] = parts
    out["dv_total"]["secular"] = parts["total"] * year_s
    out["dv_opt"]["secular"] = parts["total"] * year_s
    return out


# ----------------------------------------------------------------------------------------------
# orchestration on propagator datasets
# ----------------------------------------------------------------------------------------------


def _states_from_dataset(ds: xr.Dataset) -> np.ndarray:
    return np.concatenate([ds["r_mci_km"].values, ds["v_mci_kms"].values], axis=-1)


def _rotate_states(states: np.ndarray, rot_to_j2000: np.ndarray) -> np.ndarray:
    return np.concatenate([states[..., :3] @ rot_to_j2000, states[..., 3:] @ rot_to_j2000], axis=-1)


def perturbing_acceleration_rtn(
    dynamics: Dynamics, t_tdb_s: np.ndarray, states_mci: np.ndarray, *, degree: int | None = None
) -> np.ndarray:
    """The force model's non-Keplerian acceleration (n, 3) in RTN (km/s^2): all terms but ``central``."""
    from .forces import acceleration_breakdown

    terms = acceleration_breakdown(dynamics, t_tdb_s, states_mci, degree=degree)
    perturbing = sum(value for key, value in terms.items() if key != "central")
    return to_rtn(perturbing, states_mci)


def deltav_from_propagation(
    deltav: DeltaVSettings,
    dynamics: Dynamics,
    ds: xr.Dataset,
    sat: int = 0,
    model: str | None = None,
    **overrides,
) -> xr.Dataset:
    """Delta-V of satellite ``sat`` of a propagator Dataset, every model; time series and summary.

    Data variables: the osculating elements and their rates (time), ``T_rtn_kms2`` (model, time,
    rtn), ``T_total_kms2`` and ``T_opt_kms2`` (model, time) for the osculating models,
    ``natural_rate`` (time, natural) and ``lsq_residual_per_s`` (time), the secular mean orbit, its
    natural rates and cost parts (part), and the summary
    ``dv_total_kms_per_year`` and ``dv_opt_kms_per_year`` (model_all: paper, lsq, secular).
    Attributes name the chosen model (``model`` or ``deltav.model``) and its two budgets. ``overrides``
    replace ``[deltav]`` settings (:func:`with_overrides`, e.g. ``gve_frame="lunar_equator_of_epoch"``).
    ``dynamics`` gives GM (``gravity.gm_km3_s2``) and the element frame's rotation to J2000.
    """
    cfg = with_overrides(deltav, model=model, **overrides)
    if sat not in ds["sat"].values:
        raise ValueError(
            f"satellite {sat!r} is not in the dataset; available: {ds['sat'].values.tolist()}"
        )
    one = ds.sel(sat=sat)
    t = one["time"].values.astype(float)
    res = _satellite_arrays(cfg, dynamics, t, _states_from_dataset(one), sat, MODELS)
    el, rates = res["elements"], res["rates"]
    osc = list(OSCULATING_MODELS)
    out = xr.Dataset(
        {
            "a_km": ("time", el[:, 0]),
            "ecc": ("time", el[:, 1]),
            "inc_rad": ("time", el[:, 2]),
            "raan_rad": ("time", el[:, 3]),
            "aop_rad": ("time", el[:, 4]),
            "nu_rad": ("time", el[:, 5]),
            "rate": (("time", "element"), rates),
            "T_rtn_kms2": (("model", "time", "rtn"), np.stack([res[f"T_rtn_{m}"] for m in osc])),
            "T_total_kms2": (("model", "time"), np.stack([res[f"T_total_{m}"] for m in osc])),
            "T_opt_kms2": (("model", "time"), np.stack([res[f"T_opt_{m}"] for m in osc])),
            "natural_rate": (("time", "natural"), res["natural_rates"]),
            "lsq_residual_per_s": ("time", res["lsq_residual"]),
            "secular_natural_rate": ("natural", res["secular"]["natural_rates"]),
            "secular_mean_a_km": res["secular"]["a_km"],
            "secular_mean_ecc": res["secular"]["e"],
            "secular_mean_inc_rad": res["secular"]["inc_rad"],
            "secular_raan_dot_rad_s": res["secular"]["raan_dot"],
            "secular_aop_dot_rad_s": res["secular"]["aop_dot"],
            "secular_dv_kms_per_year": (
                "part",
                [res["secular_parts"][k] * cfg.year_days * SECONDS_PER_DAY for k in SECULAR_PARTS],
            ),
            "dv_total_kms_per_year": ("model_all", [res["dv_total"][m] for m in MODELS]),
            "dv_opt_kms_per_year": ("model_all", [res["dv_opt"][m] for m in MODELS]),
        },
        coords={
            "time": t,
            "element": list(RATE_NAMES),
            "natural": list(NATURAL_RATE_NAMES),
            "model": osc,
            "rtn": ["R", "T", "N"],
            "part": list(SECULAR_PARTS),
            "model_all": list(MODELS),
            "sat": sat,
        },
        attrs={
            "deltav_model": cfg.model,
            "dv_total_kms_per_year": float(res["dv_total"][cfg.model]),
            "dv_opt_kms_per_year": float(res["dv_opt"][cfg.model]),
            "per_year_factor": res["per_year_factor"],
            "element_frame": cfg.gve_frame,
            "settings": repr(dict(sorted(dataclasses.asdict(cfg).items()))),
            "units": "elements km and rad; rates km/s, 1/s, rad/s; thrust km/s^2; Delta-V km/s per satellite per year",
            "sign": "T is the acceleration that produces the drift; the station-keeping thrust is -T",
        },
    )
    out["time"].attrs.update(units="s", long_name="TDB seconds past J2000")
    return out


def _satellite_arrays(
    cfg: DeltaVSettings,
    dynamics: Dynamics,
    t: np.ndarray,
    states_mci: np.ndarray,
    sat: int,
    models: tuple[str, ...],
) -> dict:
    """:func:`deltav_arrays` of ``models`` for satellite ``sat``'s states (n, 6) in Moon-centred J2000, rotated into
    ``cfg.gve_frame``; ValueError when a state is not finite."""
    if not np.all(np.isfinite(states_mci)):
        raise ValueError(
            f"satellite {sat} has non-finite states (impact or failed propagation); no Delta-V"
        )
    rot = element_frame_to_j2000(dynamics, float(t[0]), cfg.gve_frame)
    return deltav_arrays(
        t, _rotate_states(states_mci, rot), dynamics.gravity.gm_km3_s2, cfg, models
    )


def chosen_budget(
    deltav: DeltaVSettings,
    dynamics: Dynamics,
    t_tdb_s: np.ndarray,
    states_mci: np.ndarray,
    sat: int = 0,
) -> dict:
    """``deltav.model``'s ``dv_total_kms_per_year`` and ``dv_opt_kms_per_year`` of one satellite's states (n, 6)
    (Moon-centred J2000) at ``t_tdb_s``: the attributes :func:`deltav_from_propagation` gives, with that model
    alone computed and no Dataset (the campaign's path). ValueError naming ``sat`` for non-finite states."""
    res = _satellite_arrays(
        deltav, dynamics, np.asarray(t_tdb_s, dtype=float), states_mci, sat, (deltav.model,)
    )
    return {
        "dv_total_kms_per_year": float(res["dv_total"][deltav.model]),
        "dv_opt_kms_per_year": float(res["dv_opt"][deltav.model]),
    }


def deltav_per_satellite(
    deltav: DeltaVSettings,
    dynamics: Dynamics,
    ds: xr.Dataset,
    model: str | None = None,
    **overrides,
) -> xr.Dataset:
    """Per-satellite budgets of every model (dims sat, model_all), km/s per satellite per year.

    Satellites with non-finite states (impact) get NaN. Attributes name the chosen model. Arguments as
    :func:`deltav_from_propagation`.
    """
    cfg = with_overrides(deltav, model=model, **overrides)
    t = ds["time"].values.astype(float)
    states = _states_from_dataset(ds)
    finite = np.all(np.isfinite(states), axis=(1, 2))
    gm = dynamics.gravity.gm_km3_s2
    total = np.full((states.shape[0], len(MODELS)), np.nan)
    opt = np.full_like(total, np.nan)
    if np.any(finite):
        rot = element_frame_to_j2000(dynamics, float(t[0]), cfg.gve_frame)
        res = deltav_arrays(t, _rotate_states(states[finite], rot), gm, cfg)
        total[finite] = np.stack([res["dv_total"][m] for m in MODELS], axis=-1)
        opt[finite] = np.stack([res["dv_opt"][m] for m in MODELS], axis=-1)
    return xr.Dataset(
        {
            "dv_total_kms_per_year": (("sat", "model_all"), total),
            "dv_opt_kms_per_year": (("sat", "model_all"), opt),
        },
        coords={"sat": ds["sat"].values, "model_all": list(MODELS)},
        attrs={
            "deltav_model": cfg.model,
            "element_frame": cfg.gve_frame,
            "units": "km/s per satellite per year",
        },
    )


def dataset_states(ds: xr.Dataset, sat: int = 0) -> np.ndarray:
    """States (time, 6) [km, km/s] in Moon-centred J2000 of satellite index ``sat`` of a propagator Dataset."""
    return np.concatenate(
        [
            ds["r_mci_km"].transpose("sat", "time", "xyz").values[sat],
            ds["v_mci_kms"].transpose("sat", "time", "xyz").values[sat],
        ],
        axis=-1,
    )
