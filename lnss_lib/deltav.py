"""Station-keeping Delta-V from a propagated arc (paper Section 3.1, eq. 25-41; Section 4).

Pipeline (pure numpy kernels, time along axis -2 of state arrays, any leading batch dims):
osculating elements at every epoch -> unwrapped angles -> drift rates by central finite
differences (:func:`element_rates`) -> thrust in RTN by an inverse of the Gauss variational
equations (GVEs, eq. 25-29) -> T_total (eq. 36) -> Delta-V by the trapezoidal rule (eq. 37) ->
per satellite per year (x 365.25 d / arc length, Section 4).

Conventions: ``T`` is the RTN acceleration that *produces* the observed drift (R along r, N along
h = r x v, T = N x R); the station-keeping thrust is -T, of the same magnitude. Accelerations in
km/s^2, elements ``[a_km, e, i, raan, aop, nu]`` in km and rad (nu: true anomaly).

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

import numpy as np
import xarray as xr
from scipy.optimize import minimize

from .constellation import PAPER_TABLE_4 as _PAPER
from .elements import state_to_elements
from .ephemeris import ELEMENT_FRAMES, element_frame_to_j2000

MODELS = ("paper", "lsq", "secular")
OSCULATING_MODELS = ("paper", "lsq")
LSQ_RATES = ("vectors", "elements")
PAPER_NORMAL = ("weighted", "eq32", "rss")
PAPER_RADIAL = ("weighted", "eq35")
SECONDS_PER_DAY = 86400.0
RATE_NAMES = ("a", "e", "i", "raan", "aop")
SECULAR_PARTS = ("sma", "ecc_vector", "plane")
NATURAL_RATE_NAMES = ("a_dot_over_a", "e_dot", "e_apse_dot", "i_dot", "sin_i_raan_dot")

DEFAULT_SETTINGS = {
    "model": "lsq",
    "element_frame": "j2000",
    "year_days": 365.25,
    "lsq_rates": "vectors",
    "paper_normal": "weighted",
    "paper_radial": "weighted",
    "paper_divisor_floor": 1e-3,
    "paper_cap_kms2": 1.0,
    "secular_min_periods": 2.0,
    "slsqp_lambda": 20.0,
}


# ----------------------------------------------------------------------------------------------
# settings
# ----------------------------------------------------------------------------------------------

def deltav_settings(profile: dict | None = None, **overrides) -> dict:
    """The ``[deltav]`` settings of a profile (defaults :data:`DEFAULT_SETTINGS`) with ``overrides``.

    Raises ``ValueError`` naming a bad value and the allowed ones.
    """
    settings = dict(DEFAULT_SETTINGS)
    if profile is not None:
        settings.update(profile.get("deltav", {}))
    settings.update({k: v for k, v in overrides.items() if v is not None})
    unknown = set(settings) - set(DEFAULT_SETTINGS)
    if unknown:
        raise ValueError(f"unknown [deltav] setting(s) {sorted(unknown)}; allowed: {sorted(DEFAULT_SETTINGS)}")
    choices = {"model": MODELS, "element_frame": ELEMENT_FRAMES, "lsq_rates": LSQ_RATES,
               "paper_normal": PAPER_NORMAL, "paper_radial": PAPER_RADIAL}
    for key, allowed in choices.items():
        if settings[key] not in allowed:
            raise ValueError(f"[deltav] {key} = {settings[key]!r} is not allowed; allowed: {', '.join(allowed)}")
    if not 0.0 <= float(settings["paper_divisor_floor"]) < 1.0:
        raise ValueError(f"[deltav] paper_divisor_floor = {settings['paper_divisor_floor']!r} must be in [0, 1)")
    if not float(settings["paper_cap_kms2"]) > 0.0:
        raise ValueError(f"[deltav] paper_cap_kms2 = {settings['paper_cap_kms2']!r} must be positive "
                         "(km/s^2; 1.0 or more means no cap in practice)")
    if not float(settings["year_days"]) > 0.0:
        raise ValueError(f"[deltav] year_days = {settings['year_days']!r} must be positive")
    if not float(settings["secular_min_periods"]) > 1.0:
        raise ValueError(f"[deltav] secular_min_periods = {settings['secular_min_periods']!r} must be > 1 "
                         "(the trend needs at least two one-orbit windows)")
    if not float(settings["slsqp_lambda"]) >= 0.0:
        raise ValueError(f"[deltav] slsqp_lambda = {settings['slsqp_lambda']!r} must be >= 0")
    return settings


# ----------------------------------------------------------------------------------------------
# geometry and elements
# ----------------------------------------------------------------------------------------------

def rtn_basis(states: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3, 3) with rows R (along r), T (N x R), N (along r x v) in the state's frame."""
    s = np.asarray(states, dtype=float)
    r_vec, v_vec = s[..., :3], s[..., 3:6]
    r_hat = r_vec / np.linalg.norm(r_vec, axis=-1, keepdims=True)
    h_vec = np.cross(r_vec, v_vec)
    n_hat = h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)
    t_hat = np.cross(n_hat, r_hat)
    return np.stack([r_hat, t_hat, n_hat], axis=-2)


def to_rtn(vectors: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Components (..., 3) [R, T, N] of vectors (..., 3) given in the states' frame."""
    return np.einsum("...ij,...j->...i", rtn_basis(states), np.asarray(vectors, dtype=float))


def from_rtn(components_rtn: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Vectors (..., 3) in the states' frame from RTN components (..., 3)."""
    return np.einsum("...ji,...j->...i", rtn_basis(states), np.asarray(components_rtn, dtype=float))


def osculating_elements(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Osculating ``[a_km, e, i, raan, aop, nu]`` (..., n, 6) of states (..., n, 6), angles unwrapped in time.

    Time runs along axis -2. The argument of latitude theta is taken from the geometry (well
    defined for circular orbits) and nu = theta - aop, so theta = aop + nu holds exactly.
    """
    s = np.asarray(states, dtype=float)
    if s.ndim < 2 or s.shape[-1] != 6:
        raise ValueError(f"states must have shape (..., n_time, 6) [km, km/s]; got {s.shape}")
    el = state_to_elements(s, gm_km3_s2)
    a, e, inc, raan, aop = (el[..., k] for k in range(5))
    r_vec = s[..., :3]
    h_vec = np.cross(r_vec, s[..., 3:6])
    h_hat = h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)
    node_hat = np.stack([np.cos(raan), np.sin(raan), np.zeros_like(raan)], axis=-1)
    r_hat = r_vec / np.linalg.norm(r_vec, axis=-1, keepdims=True)
    theta = np.arctan2(np.sum(np.cross(node_hat, r_hat) * h_hat, axis=-1), np.sum(node_hat * r_hat, axis=-1))
    raan_u = np.unwrap(raan, axis=-1)
    aop_u = np.unwrap(aop, axis=-1)
    nu = np.mod(theta - aop_u, 2.0 * np.pi)
    return np.stack([a, e, inc, raan_u, aop_u, nu], axis=-1)


def element_rates(t_tdb_s: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Drift rates (..., n, 5) of ``[a, e, i, raan, aop]`` by central finite differences (Section 3.1.1).

    ``numpy.gradient`` along time: second-order central differences inside, second-order
    one-sided at the two ends. Units km/s, 1/s, rad/s.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    el = np.asarray(elements, dtype=float)
    _check_times(t, el)
    return np.gradient(el[..., :5], t, axis=-2, edge_order=2)


def _check_times(t: np.ndarray, series: np.ndarray) -> None:
    if t.ndim != 1 or t.size < 3 or series.ndim < 2 or series.shape[-2] != t.size:
        raise ValueError(f"need at least 3 epochs and series (..., {t.size}, k); "
                         f"got t {t.shape}, series {series.shape}")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("epochs t_tdb_s must be strictly increasing")


def _orbit_quantities(elements: np.ndarray, gm_km3_s2: float):
    el = np.asarray(elements, dtype=float)
    a, e, inc, _, aop, nu = (el[..., k] for k in range(6))
    p = a * (1.0 - e * e)
    h = np.sqrt(gm_km3_s2 * p)
    r = p / (1.0 + e * np.cos(nu))
    theta = aop + nu
    return a, e, inc, nu, theta, p, h, r


# ----------------------------------------------------------------------------------------------
# forward and inverse GVEs
# ----------------------------------------------------------------------------------------------

def gve_matrix(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Matrix B (..., 5, 3) of the GVEs (eq. 25-29): d[a, e, i, raan, aop]/dt = B [T_R, T_T, T_N].

    Standard forms (e.g. Vallado, Fundamentals of Astrodynamics, Gauss form); eq. 26 with its
    ``r e`` term inside the T_T bracket: e-dot = [p sin(nu) T_R + ((p + r) cos(nu) + r e) T_T] / h.
    Singular for e = 0 (aop row) and sin(i) = 0 (raan, aop rows).
    """
    a, e, inc, nu, theta, p, h, r = _orbit_quantities(elements, gm_km3_s2)
    sn, cn, st, ct = np.sin(nu), np.cos(nu), np.sin(theta), np.cos(theta)
    zero = np.zeros_like(a)
    cot_i = np.cos(inc) / np.sin(inc)
    rows = [
        [2.0 * a * a / h * e * sn, 2.0 * a * a / h * p / r, zero],
        [p * sn / h, ((p + r) * cn + r * e) / h, zero],
        [zero, zero, r * ct / h],
        [zero, zero, r * st / (h * np.sin(inc))],
        [-p * cn / (h * e), (p + r) * sn / (h * e), -r * st * cot_i / h],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def gve_rates(elements: np.ndarray, acc_rtn_kms2: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Forward GVEs (eq. 25-29): rates (..., 5) of [a, e, i, raan, aop] under RTN acceleration (..., 3)."""
    return np.einsum("...ij,...j->...i", gve_matrix(elements, gm_km3_s2), np.asarray(acc_rtn_kms2, dtype=float))


def natural_rates_from_elements(elements: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """Natural rates (..., 5) [a-dot/a, e-dot, e (aop-dot + cos(i) raan-dot), i-dot, sin(i) raan-dot] (1/s).

    From element rates (..., 5) [a-dot, e-dot, i-dot, raan-dot, aop-dot]. These are the rate of
    the dimensionless a, the components of the eccentricity-vector rate along and across itself
    (in the orbit plane), and the components of the orbit-normal rate across and along the node
    line: all 1/s and bounded as e -> 0 and i -> 0 (taking them from finite differences of aop and
    raan is not; :func:`natural_rates_from_states` avoids those angles).
    """
    el = np.asarray(elements, dtype=float)
    rt = np.asarray(rates, dtype=float)
    a, e, inc = el[..., 0], el[..., 1], el[..., 2]
    return np.stack([rt[..., 0] / a, rt[..., 1], e * (rt[..., 4] + np.cos(inc) * rt[..., 3]), rt[..., 2],
                     np.sin(inc) * rt[..., 3]], axis=-1)


def orbit_vectors(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """[a_km, e_vec (3), h_hat (3)] (..., n, 7) of states (..., n, 6): SMA, eccentricity vector, orbit normal."""
    s = np.asarray(states, dtype=float)
    r_vec, v_vec = s[..., :3], s[..., 3:6]
    r = np.linalg.norm(r_vec, axis=-1, keepdims=True)
    v2 = np.sum(v_vec * v_vec, axis=-1, keepdims=True)
    h_vec = np.cross(r_vec, v_vec)
    e_vec = np.cross(v_vec, h_vec) / gm_km3_s2 - r_vec / r
    a = 1.0 / (2.0 / r - v2 / gm_km3_s2)
    return np.concatenate([a, e_vec, h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)], axis=-1)


def _project_natural(vectors: np.ndarray, vector_rates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural rates (..., 5) and |cos| of the angle between e_hat and the plane-rotation axis."""
    a, e_vec, h_hat = vectors[..., 0], vectors[..., 1:4], vectors[..., 4:7]
    a_dot, e_dot_vec, h_dot = vector_rates[..., 0], vector_rates[..., 1:4], vector_rates[..., 4:7]
    h_hat = h_hat / np.linalg.norm(h_hat, axis=-1, keepdims=True)
    e_vec = e_vec - np.sum(e_vec * h_hat, axis=-1, keepdims=True) * h_hat
    node = np.cross(np.array([0.0, 0.0, 1.0]), h_hat)
    node_norm = np.linalg.norm(node, axis=-1, keepdims=True)
    inclined = node_norm > 1e-12
    node_hat = np.where(inclined, node / np.where(inclined, node_norm, 1.0), np.array([1.0, 0.0, 0.0]))
    e = np.linalg.norm(e_vec, axis=-1, keepdims=True)
    e_hat = np.where(e > 1e-12, e_vec / np.where(e > 1e-12, e, 1.0), node_hat)
    across = np.cross(h_hat, e_hat)
    natural = np.stack([
        a_dot / a,
        np.sum(e_hat * e_dot_vec, axis=-1),
        np.sum(across * e_dot_vec, axis=-1),
        -np.sum(np.cross(h_hat, node_hat) * h_dot, axis=-1),
        np.sum(node_hat * h_dot, axis=-1),
    ], axis=-1)
    axis = np.cross(h_hat, h_dot)
    axis_norm = np.linalg.norm(axis, axis=-1, keepdims=True)
    axis_hat = axis / np.where(axis_norm > 0.0, axis_norm, 1.0)
    return natural, np.abs(np.sum(axis_hat * e_hat, axis=-1))


def natural_rates_from_states(t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Natural rates (..., n, 5) (see :func:`natural_rates_from_elements`) by central differences of vectors.

    The same central differences as :func:`element_rates`, taken on a, the eccentricity vector and
    the orbit normal (Cartesian, no angle wrapping) and projected at each epoch: regular where
    aop (e -> 0) or raan (i -> 0) is ill-defined.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    vectors = orbit_vectors(states, gm_km3_s2)
    _check_times(t, vectors)
    return _project_natural(vectors, np.gradient(vectors, t, axis=-2, edge_order=2))[0]


def natural_gve_matrix(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """GVEs for the natural rates (..., 5, 3): rows of eq. 25-29 recombined, no 1/e or 1/sin(i) left.

    a-dot/a = (2a/h)(e sin(nu) T_R + (p/r) T_T); e-dot = eq. 26 (corrected);
    e (aop-dot + cos(i) raan-dot) = (-p cos(nu) T_R + (p + r) sin(nu) T_T) / h (eq. 29 + cos(i) eq. 28:
    the T_N coupling cancels); i-dot = r cos(theta) T_N / h; sin(i) raan-dot = r sin(theta) T_N / h.
    """
    a, e, inc, nu, theta, p, h, r = _orbit_quantities(elements, gm_km3_s2)
    sn, cn = np.sin(nu), np.cos(nu)
    zero = np.zeros_like(a)
    rows = [
        [2.0 * a / h * e * sn, 2.0 * a / h * p / r, zero],
        [p * sn / h, ((p + r) * cn + r * e) / h, zero],
        [-p * cn / h, (p + r) * sn / h, zero],
        [zero, zero, r * np.cos(theta) / h],
        [zero, zero, r * np.sin(theta) / h],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def lsq_thrust(elements: np.ndarray, natural_rates: np.ndarray, gm_km3_s2: float):
    """Least-squares RTN acceleration (..., 3) from all five drift rates, and the fit residual (...,) (1/s).

    Solves min |N T - q| per epoch, N = :func:`natural_gve_matrix`, q the natural rates: eq. 25-29
    with rows scaled by their natural size (a-dot by a; e-dot, i-dot by 1; raan-dot by sin(i);
    aop-dot by e after adding cos(i) raan-dot), so every row is a rate in 1/s and no element's units
    dominate. The system splits into three in-plane rows for (T_R, T_T), solved by their 2 x 2
    normal equations (well conditioned: the in-plane block has full rank on every closed orbit),
    and two out-of-plane rows for T_N, whose solution (h / r)(cos(theta) i-dot + sin(theta) sin(i)
    raan-dot) has the form of the weighted eq. 32 of :func:`paper_thrust`. The residual is zero for
    consistent rates and measures finite-difference error otherwise.
    """
    matrix = natural_gve_matrix(elements, gm_km3_s2)
    target = np.asarray(natural_rates, dtype=float)
    plane, normal = matrix[..., :3, :2], matrix[..., 3:, 2]
    gram = np.einsum("...ki,...kj->...ij", plane, plane)
    rhs = np.einsum("...ki,...k->...i", plane, target[..., :3])
    det = gram[..., 0, 0] * gram[..., 1, 1] - gram[..., 0, 1] * gram[..., 1, 0]
    t_r = (gram[..., 1, 1] * rhs[..., 0] - gram[..., 0, 1] * rhs[..., 1]) / det
    t_t = (gram[..., 0, 0] * rhs[..., 1] - gram[..., 1, 0] * rhs[..., 0]) / det
    t_n = np.sum(normal * target[..., 3:], axis=-1) / np.sum(normal * normal, axis=-1)
    solution = np.stack([t_r, t_t, t_n], axis=-1)
    residual = np.linalg.norm(np.einsum("...ij,...j->...i", matrix, solution) - target, axis=-1)
    return solution, residual


def _clip_divisor(d: np.ndarray, floor: float) -> np.ndarray:
    """d with |d| raised to at least ``floor``, sign kept (sign(0) taken as +)."""
    return np.where(d < 0.0, -1.0, 1.0) * np.maximum(np.abs(d), floor)


def paper_thrust(elements: np.ndarray, rates: np.ndarray, gm_km3_s2: float, *, normal: str = "weighted",
                 radial: str = "weighted", divisor_floor: float = 1e-3, cap_kms2: float = np.inf,
                 t_t_kms2: np.ndarray | None = None) -> dict:
    """The paper's sequential inverse (eq. 30-35), misprints corrected; dict of (...,) arrays (km/s^2).

    Keys ``T_R, T_T, T_N`` (the result) and the single-equation estimates ``T_sma`` (eq. 30),
    ``T_i``, ``T_raan`` (eq. 31), ``T_e`` (eq. 33), ``T_aop`` (eq. 34, corrected).

    * eq. 30 (kept): T_T = h r a-dot / (2 p a^2), i.e. the radial part of the SMA drift neglected.
      ``t_t_kms2`` replaces it in eq. 33-34 (for tests that isolate eq. 31-35).
    * eq. 31: T_i = h i-dot / (r cos theta), T_raan = h sin(i) raan-dot / (r sin theta).
    * eq. 32: ``normal="weighted"`` (default) T_N = cos^2(theta) T_i + sin^2(theta) T_raan
      = (h / r)(cos(theta) i-dot + sin(theta) sin(i) raan-dot), the least-squares combination of the
      two estimates of the one normal acceleration (the orbit normal turns at rate r T_N / h), free
      of divisions; ``"eq32"``: literal, sqrt(T_i^2 + T_raan^2) cos(atan(T_raan / T_i)) = |T_i|;
      ``"rss"``: sqrt(T_i^2 + T_raan^2) (double counting).
    * eq. 33: T_e = [h e-dot - T_T((p + r) cos(nu) + r e)] / (p sin(nu)).
    * eq. 34 corrected (divide by cos(nu), as the inversion of eq. 29 requires):
      T_aop = [-h e (aop-dot + T_N r sin(theta) cos(i) / (h sin(i))) + T_T (p + r) sin(nu)] / (p cos(nu)).
    * eq. 35: ``radial="weighted"`` (default) T_R = sin^2(nu) T_e + cos^2(nu) T_aop, the
      least-squares combination of the two estimates of the one radial acceleration (rates of the
      eccentricity vector along and across itself), free of divisions by sin(nu), cos(nu);
      ``"eq35"``: literal sum T_e + T_aop (double counting).

    Singularities: every division by sin(nu), cos(nu), sin(theta), cos(theta) and sin(i) uses a
    divisor raised to at least ``divisor_floor`` in magnitude (sign kept); each estimate is then
    capped to |T| <= ``cap_kms2``. Neither is needed by the weighted forms except sin(i) in
    eq. 34 (i -> 0); the literal forms diverge as the floor goes to zero. Small e is harmless here
    (eq. 34 multiplies by e).
    """
    if normal not in PAPER_NORMAL:
        raise ValueError(f"unknown paper normal combination {normal!r}; allowed: {', '.join(PAPER_NORMAL)}")
    if radial not in PAPER_RADIAL:
        raise ValueError(f"unknown paper radial combination {radial!r}; allowed: {', '.join(PAPER_RADIAL)}")
    a, e, inc, nu, theta, p, h, r = _orbit_quantities(elements, gm_km3_s2)
    rate = np.asarray(rates, dtype=float)
    a_dot, e_dot, i_dot, raan_dot, aop_dot = (rate[..., k] for k in range(5))
    sn, cn, st, ct, si = np.sin(nu), np.cos(nu), np.sin(theta), np.cos(theta), np.sin(inc)

    def cap(x):
        return np.clip(x, -cap_kms2, cap_kms2)

    def div(d):
        return _clip_divisor(d, divisor_floor)

    t_sma = cap(h * r * a_dot / (2.0 * p * a * a))
    t_t = t_sma if t_t_kms2 is None else np.asarray(t_t_kms2, dtype=float)
    t_i = cap(h * i_dot / (r * div(ct)))
    t_raan = cap(h * si * raan_dot / (r * div(st)))
    if normal == "weighted":
        t_n = cap(h / r * (ct * i_dot + st * si * raan_dot))
    elif normal == "eq32":
        t_n = np.abs(t_i)
    else:
        t_n = cap(np.hypot(t_i, t_raan))
    x_e = h * e_dot - t_t * ((p + r) * cn + r * e)
    x_aop = -h * e * (aop_dot + t_n * r * st * np.cos(inc) / (h * div(si))) + t_t * (p + r) * sn
    t_e = cap(x_e / (p * div(sn)))
    t_aop = cap(x_aop / (p * div(cn)))
    t_r = cap((sn * x_e + cn * x_aop) / p) if radial == "weighted" else cap(t_e + t_aop)
    return {"T_R": t_r, "T_T": t_t, "T_N": t_n, "T_sma": t_sma, "T_i": t_i, "T_raan": t_raan,
            "T_e": t_e, "T_aop": t_aop}


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
        raise ValueError(f"thrust samples must have shape (m, 3) [T_R, T_T, T_N]; got {samples.shape}")
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
            return np.array([target[0] - tm * np.cos(beta) * np.cos(alpha),
                             target[1] - tm * np.cos(beta) * np.sin(alpha),
                             target[2] - tm * np.sin(beta)])

        x0 = np.array([1.0, np.arctan2(c[1], c[0]), np.arcsin(np.clip(c[2], -1.0, 1.0))])
        res = minimize(lambda x: x[0] + lam * (x[0] - 1.0) ** 2, x0, method="SLSQP",
                       constraints=[{"type": "eq", "fun": equalities}],
                       bounds=[(0.0, 1.0), (-np.pi, np.pi), (-np.pi / 2, np.pi / 2)],
                       options={"ftol": 1e-12, "maxiter": 200})
        out[k] = res.x[0] * total
        ok[k] = np.max(np.abs(equalities(res.x))) < 1e-7
    return out, ok


def trapezoid_deltav(t_tdb_s: np.ndarray, t_total_kms2: np.ndarray) -> np.ndarray:
    """Delta-V (km/s) = integral of T_total dt by the trapezoidal rule over time (last axis) (eq. 37)."""
    return np.trapezoid(np.asarray(t_total_kms2, dtype=float), np.asarray(t_tdb_s, dtype=float), axis=-1)


def per_year_factor(t_tdb_s: np.ndarray, year_days: float = 365.25) -> float:
    """Scale from an arc's Delta-V to a year's: year_days * 86400 s / (t_end - t_start) (Section 4)."""
    t = np.asarray(t_tdb_s, dtype=float)
    span = float(t[-1] - t[0])
    if not span > 0.0:
        raise ValueError(f"arc length must be positive to scale to a year; got {span} s")
    return year_days * SECONDS_PER_DAY / span


# ----------------------------------------------------------------------------------------------
# secular (mean-element) model
# ----------------------------------------------------------------------------------------------

def orbit_mean(t_tdb_s: np.ndarray, values: np.ndarray, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Running mean over one period: window mid-times (m,) and means (..., m, k) of values (..., n, k).

    Windows [t_j, t_j + P] start at every sample with t_j + P <= t_end; the mean is the exact
    integral of the piecewise-linear interpolant divided by P.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    v = np.asarray(values, dtype=float)
    starts = t[t + period_s <= t[-1] + 1e-9 * period_s]
    if starts.size < 2:
        raise ValueError(f"arc of {t[-1] - t[0]:.0f} s holds fewer than two one-period windows (P = {period_s:.0f} s)")
    dt = np.diff(t)
    increments = 0.5 * (v[..., 1:, :] + v[..., :-1, :]) * dt[:, None]
    cumulative = np.concatenate([np.zeros_like(v[..., :1, :]), np.cumsum(increments, axis=-2)], axis=-2)
    ends = starts + period_s
    k = np.clip(np.searchsorted(t, ends, side="right") - 1, 0, t.size - 2)
    u = (ends - t[k]) / dt[k]
    v_end = v[..., k, :] + (v[..., k + 1, :] - v[..., k, :]) * u[:, None]
    cum_end = cumulative[..., k, :] + 0.5 * (v[..., k, :] + v_end) * (ends - t[k])[:, None]
    k0 = np.searchsorted(t, starts)
    means = (cum_end - cumulative[..., k0, :]) / period_s
    return starts + 0.5 * period_s, means


def secular_drift(t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float, min_periods: float = 2.0,
                  short_arc: str = "raise") -> dict:
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
    return _secular_from_vectors(t, orbit_vectors(states, gm_km3_s2), gm_km3_s2, min_periods, short_arc)


def _secular_from_vectors(t: np.ndarray, vectors: np.ndarray, gm_km3_s2: float, min_periods: float,
                          short_arc: str) -> dict:
    if vectors.ndim > 2:
        flat = [_secular_from_vectors(t, one, gm_km3_s2, min_periods, short_arc)
                for one in vectors.reshape(-1, *vectors.shape[-2:])]
        return {k: np.stack([f[k] for f in flat]).reshape(*vectors.shape[:-2], *np.shape(flat[0][k])) for k in flat[0]}
    _check_times(t, vectors)
    period = 2.0 * np.pi * np.sqrt(np.mean(vectors[:, 0]) ** 3 / gm_km3_s2)
    if t[-1] - t[0] < min_periods * period:
        if short_arc == "nan":
            return {"a_km": np.nan, "e": np.nan, "inc_rad": np.nan, "natural_rates": np.full(5, np.nan),
                    "raan_dot": np.nan, "aop_dot": np.nan, "axis_cos": np.nan, "period_s": float(period)}
        raise ValueError(f"the secular model needs an arc of at least {min_periods:g} orbital periods "
                         f"({min_periods * period:.0f} s); got {t[-1] - t[0]:.0f} s")
    t_mid, means = orbit_mean(t, vectors, period)
    x = t_mid - t_mid.mean()
    slope = x @ (means - means.mean(axis=0)) / np.sum(x * x)
    mean = means.mean(axis=0)
    natural, axis_cos = _project_natural(mean, slope)
    h_hat = mean[4:7] / np.linalg.norm(mean[4:7])
    e_vec = mean[1:4] - np.dot(mean[1:4], h_hat) * h_hat
    e = float(np.linalg.norm(e_vec))
    inc = float(np.arccos(np.clip(h_hat[2], -1.0, 1.0)))
    raan_dot = natural[4] / np.sin(inc) if np.sin(inc) > 0.0 else np.nan
    aop_dot = natural[2] / e - np.cos(inc) * raan_dot if e > 0.0 else np.nan
    return {"a_km": float(mean[0]), "e": e, "inc_rad": inc, "natural_rates": natural, "raan_dot": raan_dot,
            "aop_dot": aop_dot, "axis_cos": float(axis_cos), "period_s": float(period)}


def secular_deltav_rates(a_km, e, natural_rates: np.ndarray, axis_cos, gm_km3_s2: float) -> dict:
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
    a = np.asarray(a_km, dtype=float)
    e = np.asarray(e, dtype=float)
    p = a * (1.0 - e * e)
    h = np.sqrt(gm_km3_s2 * p)
    n = np.sqrt(gm_km3_s2 / a**3)
    parts = {
        "sma": 0.5 * n * a * np.sqrt(1.0 - e * e) * np.abs(q[..., 0]),
        "ecc_vector": h * np.hypot(q[..., 1], q[..., 2]) / (2.0 * p),
        "plane": h * np.hypot(q[..., 3], q[..., 4]) * (1.0 - e * np.asarray(axis_cos, dtype=float)) / p,
    }
    parts["total"] = sum(parts[k] for k in SECULAR_PARTS)
    return parts


# ----------------------------------------------------------------------------------------------
# the whole kernel on arrays
# ----------------------------------------------------------------------------------------------

def deltav_arrays(t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float, settings: dict | None = None) -> dict:
    """Every model's Delta-V from one arc of states (..., n, 6) in the GVE element frame.

    Returns a dict of arrays: ``elements`` (..., n, 6) and their finite-difference ``rates``
    (..., n, 5); ``natural_rates`` (..., n, 5) used by ``lsq``; for ``paper`` and ``lsq``:
    ``T_rtn_<model>`` (..., n, 3), ``T_total_<model>``, ``T_opt_<model>`` (..., n);
    ``lsq_residual`` (..., n); ``paper_estimates`` (the single-equation estimates); ``secular``
    (:func:`secular_drift`) and ``secular_parts`` (km/s per s); ``dv_total`` and ``dv_opt`` (dicts
    model -> (...,) km/s per year); ``per_year_factor``. The secular model has no instantaneous
    thrust; its optimised budget equals its total (already a minimum-cost impulsive budget, so
    eq. 38-41 do not apply); it is NaN for an arc shorter than ``secular_min_periods`` orbits.
    """
    cfg = deltav_settings(None, **(settings or {}))
    t = np.asarray(t_tdb_s, dtype=float)
    elements = osculating_elements(states, gm_km3_s2)
    rates = element_rates(t, elements)
    vectors = orbit_vectors(states, gm_km3_s2)
    _check_times(t, vectors)
    if cfg["lsq_rates"] == "vectors":
        natural = _project_natural(vectors, np.gradient(vectors, t, axis=-2, edge_order=2))[0]
    else:
        natural = natural_rates_from_elements(elements, rates)
    factor = per_year_factor(t, cfg["year_days"])
    out = {"elements": elements, "rates": rates, "natural_rates": natural, "per_year_factor": factor,
           "dv_total": {}, "dv_opt": {}}
    paper = paper_thrust(elements, rates, gm_km3_s2, normal=cfg["paper_normal"], radial=cfg["paper_radial"],
                         divisor_floor=float(cfg["paper_divisor_floor"]), cap_kms2=float(cfg["paper_cap_kms2"]))
    lsq, residual = lsq_thrust(elements, natural, gm_km3_s2)
    out["paper_estimates"] = paper
    out["lsq_residual"] = residual
    for name, t_rtn in (("paper", np.stack([paper["T_R"], paper["T_T"], paper["T_N"]], axis=-1)), ("lsq", lsq)):
        total = thrust_total(t_rtn)
        opt = tmax_closed_form(t_rtn)
        out[f"T_rtn_{name}"] = t_rtn
        out[f"T_total_{name}"] = total
        out[f"T_opt_{name}"] = opt
        out["dv_total"][name] = trapezoid_deltav(t, total) * factor
        out["dv_opt"][name] = trapezoid_deltav(t, opt) * factor
    sec = _secular_from_vectors(t, vectors, gm_km3_s2, float(cfg["secular_min_periods"]), "nan")
    parts = secular_deltav_rates(sec["a_km"], sec["e"], sec["natural_rates"], sec["axis_cos"], gm_km3_s2)
    year_s = float(cfg["year_days"]) * SECONDS_PER_DAY
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


def perturbing_acceleration_rtn(profile: dict, t_tdb_s: np.ndarray, states_mci: np.ndarray, *,
                                degree: int | None = None) -> np.ndarray:
    """The force model's non-Keplerian acceleration (n, 3) in RTN (km/s^2): all terms but ``central``."""
    from .forces import acceleration_breakdown

    terms = acceleration_breakdown(profile, t_tdb_s, states_mci, degree=degree)
    perturbing = sum(value for key, value in terms.items() if key != "central")
    return to_rtn(perturbing, states_mci)


def deltav_from_propagation(profile: dict, ds: xr.Dataset, sat: int = 0, model: str | None = None,
                            **overrides) -> xr.Dataset:
    """Delta-V of satellite ``sat`` of a propagator Dataset, every model; time series and summary.

    Data variables: the osculating elements and their rates (time), ``T_rtn_kms2`` (model, time,
    rtn), ``T_total_kms2`` and ``T_opt_kms2`` (model, time) for the osculating models,
    ``natural_rate`` (time, natural) and ``lsq_residual_per_s`` (time), the secular mean orbit, its
    natural rates and cost parts (part), and the summary
    ``dv_total_kms_per_year`` and ``dv_opt_kms_per_year`` (model_all: paper, lsq, secular).
    Attributes name the chosen model (``model`` or the profile's ``[deltav] model``) and its two
    budgets. ``overrides`` replace ``[deltav]`` settings (e.g. ``element_frame="lunar_equator_of_epoch"``).
    """
    cfg = deltav_settings(profile, model=model, **overrides)
    if sat not in ds["sat"].values:
        raise ValueError(f"satellite {sat!r} is not in the dataset; available: {ds['sat'].values.tolist()}")
    one = ds.sel(sat=sat)
    t = one["time"].values.astype(float)
    states = _states_from_dataset(one)
    if not np.all(np.isfinite(states)):
        raise ValueError(f"satellite {sat} has non-finite states (impact or failed propagation); no Delta-V")
    gm = float(profile["gravity"]["gm_km3_s2"])
    rot = element_frame_to_j2000(profile, float(t[0]), cfg["element_frame"])
    res = deltav_arrays(t, _rotate_states(states, rot), gm, {k: v for k, v in cfg.items() if k != "model"})
    el, rates = res["elements"], res["rates"]
    osc = list(OSCULATING_MODELS)
    out = xr.Dataset(
        {
            "a_km": ("time", el[:, 0]), "ecc": ("time", el[:, 1]), "inc_rad": ("time", el[:, 2]),
            "raan_rad": ("time", el[:, 3]), "aop_rad": ("time", el[:, 4]), "nu_rad": ("time", el[:, 5]),
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
            "secular_dv_kms_per_year": ("part", [res["secular_parts"][k] * float(cfg["year_days"]) * SECONDS_PER_DAY
                                                 for k in SECULAR_PARTS]),
            "dv_total_kms_per_year": ("model_all", [res["dv_total"][m] for m in MODELS]),
            "dv_opt_kms_per_year": ("model_all", [res["dv_opt"][m] for m in MODELS]),
        },
        coords={"time": t, "element": list(RATE_NAMES), "natural": list(NATURAL_RATE_NAMES), "model": osc,
                "rtn": ["R", "T", "N"],
                "part": list(SECULAR_PARTS), "model_all": list(MODELS), "sat": sat},
        attrs={
            "deltav_model": cfg["model"],
            "dv_total_kms_per_year": float(res["dv_total"][cfg["model"]]),
            "dv_opt_kms_per_year": float(res["dv_opt"][cfg["model"]]),
            "per_year_factor": res["per_year_factor"],
            "element_frame": cfg["element_frame"],
            "settings": repr({k: cfg[k] for k in sorted(cfg)}),
            "units": "elements km and rad; rates km/s, 1/s, rad/s; thrust km/s^2; Delta-V km/s per satellite per year",
            "sign": "T is the acceleration that produces the drift; the station-keeping thrust is -T",
        },
    )
    out["time"].attrs.update(units="s", long_name="TDB seconds past J2000")
    return out


def deltav_per_satellite(profile: dict, ds: xr.Dataset, model: str | None = None, **overrides) -> xr.Dataset:
    """Per-satellite budgets of every model (dims sat, model_all), km/s per satellite per year.

    Satellites with non-finite states (impact) get NaN. Attributes name the chosen model.
    """
    cfg = deltav_settings(profile, model=model, **overrides)
    t = ds["time"].values.astype(float)
    states = _states_from_dataset(ds)
    finite = np.all(np.isfinite(states), axis=(1, 2))
    gm = float(profile["gravity"]["gm_km3_s2"])
    total = np.full((states.shape[0], len(MODELS)), np.nan)
    opt = np.full_like(total, np.nan)
    if np.any(finite):
        rot = element_frame_to_j2000(profile, float(t[0]), cfg["element_frame"])
        res = deltav_arrays(t, _rotate_states(states[finite], rot), gm, {k: v for k, v in cfg.items() if k != "model"})
        total[finite] = np.stack([res["dv_total"][m] for m in MODELS], axis=-1)
        opt[finite] = np.stack([res["dv_opt"][m] for m in MODELS], axis=-1)
    return xr.Dataset(
        {"dv_total_kms_per_year": (("sat", "model_all"), total), "dv_opt_kms_per_year": (("sat", "model_all"), opt)},
        coords={"sat": ds["sat"].values, "model_all": list(MODELS)},
        attrs={"deltav_model": cfg["model"], "element_frame": cfg["element_frame"],
               "units": "km/s per satellite per year"},
    )


# ----------------------------------------------------------------------------------------------
# analysis: model comparison and sensitivity sweeps (notebook 04; paper Table 4, Section 3.1)
# ----------------------------------------------------------------------------------------------

PAPER_TABLE_4 = {"dv_total": _PAPER["dv_total_kms_per_year"], "dv_opt": _PAPER["dv_opt_kms_per_year"]}  # km/s/yr
PAPER_LABEL = "paper (Table 4)"
PAPER_VARIANTS = {"corrected (weighted eq. 32, 35)": ("weighted", "weighted"),
                  "literal eq. 32, corrected eq. 35": ("eq32", "weighted"),
                  "corrected eq. 32, literal eq. 35": ("weighted", "eq35"),
                  "literal eq. 32 and 35": ("eq32", "eq35")}
DIVISOR_FLOORS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 0.0)
COMPONENT_CAPS_KMS2 = (1e-5, 1e-6, 1e-7, 5e-8, 2e-8)


def dataset_states(ds: xr.Dataset, sat: int = 0) -> np.ndarray:
    """States (time, 6) [km, km/s] in Moon-centred J2000 of satellite index ``sat`` of a propagator Dataset."""
    return np.concatenate([ds["r_mci_km"].transpose("sat", "time", "xyz").values[sat],
                           ds["v_mci_kms"].transpose("sat", "time", "xyz").values[sat]], axis=-1)


def kernel_settings(settings: dict) -> dict:
    """``settings`` without ``model`` (the choice of the campaign model does not enter :func:`deltav_arrays`)."""
    return {k: v for k, v in settings.items() if k != "model"}


def budget_row(out: dict) -> dict:
    """``"<model> total"`` for every model and ``"<model> opt"`` for the osculating ones, from :func:`deltav_arrays`."""
    return {**{f"{m} total": out["dv_total"][m] for m in MODELS},
            **{f"{m} opt": out["dv_opt"][m] for m in OSCULATING_MODELS}}


def model_comparison_table(res: xr.Dataset, paper: dict | None = None):
    """Total and optimised budgets (km/s per year) of every model of :func:`deltav_from_propagation` beside
    Table 4, and their ratio opt / total (eq. 37-41)."""
    import pandas as pd

    paper = PAPER_TABLE_4 if paper is None else paper
    table = pd.DataFrame({"dv_total_kms_per_year": res["dv_total_kms_per_year"].to_series(),
                          "dv_opt_kms_per_year": res["dv_opt_kms_per_year"].to_series()})
    table.loc[PAPER_LABEL] = [paper["dv_total"], paper["dv_opt"]]
    table["opt / total"] = table["dv_opt_kms_per_year"] / table["dv_total_kms_per_year"]
    return table


def secular_rates_table(results: dict):
    """Mean orbit and secular rates (deg/day, m/day, 1/day) of the secular model, one column per named
    :func:`deltav_from_propagation` result (e.g. one per GVE element frame)."""
    import pandas as pd

    return pd.DataFrame({
        name: {"mean a (km)": r["secular_mean_a_km"].item(), "mean e": r["secular_mean_ecc"].item(),
               "mean i (deg)": np.degrees(r["secular_mean_inc_rad"].item()),
               "dRAAN/dt (deg/day)": np.degrees(r["secular_raan_dot_rad_s"].item()) * 86400,
               "dAOP/dt (deg/day)": np.degrees(r["secular_aop_dot_rad_s"].item()) * 86400,
               "di/dt (deg/day)": np.degrees(r["secular_natural_rate"].sel(natural="i_dot").item()) * 86400,
               "da/dt (m/day)": r["secular_natural_rate"].sel(natural="a_dot_over_a").item()
               * r["secular_mean_a_km"].item() * 86400e3,
               "de/dt (1/day)": r["secular_natural_rate"].sel(natural="e_dot").item() * 86400}
        for name, r in results.items()})


def lsq_recovery(profile: dict, t_tdb_s: np.ndarray, states_mci: np.ndarray, settings: dict) -> tuple[dict, np.ndarray, dict]:
    """How well the ``lsq`` inverse recovers the force model's perturbing acceleration on one arc.

    Returns (row, truth (n, 3) km/s^2 RTN, :func:`deltav_arrays` output). The row holds the median
    per-epoch relative error, the rms error over the rms acceleration, the Delta-V of the truth (total
    and eq. 40 optimised) against ``lsq`` and ``paper``, all per year.
    """
    gm = float(profile["gravity"]["gm_km3_s2"])
    truth = perturbing_acceleration_rtn(profile, t_tdb_s, states_mci)
    out = deltav_arrays(t_tdb_s, states_mci, gm, kernel_settings(settings))
    err = np.linalg.norm(out["T_rtn_lsq"] - truth, axis=1)
    mag = np.linalg.norm(truth, axis=1)
    dv_truth = trapezoid_deltav(t_tdb_s, mag) * out["per_year_factor"]
    dv_truth_opt = trapezoid_deltav(t_tdb_s, tmax_closed_form(truth)) * out["per_year_factor"]
    row = {"median |dT|/|T|": np.median(err / mag), "rms |dT| / rms |T|": np.sqrt(np.mean(err**2) / np.mean(mag**2)),
           "dv truth (km/s/yr)": dv_truth, "dv lsq": out["dv_total"]["lsq"], "lsq / truth": out["dv_total"]["lsq"] / dv_truth,
           "dv_opt truth": dv_truth_opt, "dv_opt lsq": out["dv_opt"]["lsq"],
           "dv paper": out["dv_total"]["paper"], "paper / truth": out["dv_total"]["paper"] / dv_truth}
    return row, truth, out


def lsq_recovery_study(profile: dict, elements_deg, steps_s, *, integrators=("paper", "converged"),
                       settings: dict | None = None):
    """:func:`lsq_recovery` of one satellite (``elements_deg`` (1, 6)) propagated with each integrator setting
    and output step; returns (table indexed by (integrator, step_s), {(integrator, step): (t, truth, out)})."""
    import pandas as pd

    from .propagator import propagate_elements

    settings = deltav_settings(profile) if settings is None else settings
    rows, data = {}, {}
    for setting in integrators:
        for step in steps_s:
            d = propagate_elements(profile, elements_deg, step_s=step, setting=setting)
            t = d["time"].values
            rows[(setting, step)], truth, out = lsq_recovery(profile, t, dataset_states(d), settings)
            data[(setting, step)] = (t, truth, out)
    table = pd.DataFrame(rows).T
    table.index.names = ["integrator", "step_s"]
    return table, data


def sampling_sweep(profile: dict, elements_deg, steps_s=(60.0, 300.0, 900.0, 1800.0), *,
                   integrators=("paper", "converged"), settings: dict | None = None):
    """Budgets (:func:`budget_row`) of one satellite propagated with each integrator setting and output step
    (the finite differences of Section 3.1.1 depend on the step); index (integrator, step_s)."""
    import pandas as pd

    from .propagator import propagate_elements

    settings = deltav_settings(profile) if settings is None else settings
    gm = float(profile["gravity"]["gm_km3_s2"])
    rows = []
    for setting in integrators:
        for step in steps_s:
            d = propagate_elements(profile, elements_deg, step_s=step, setting=setting)
            out = deltav_arrays(d["time"].values, dataset_states(d), gm, kernel_settings(settings))
            rows.append({"integrator": setting, "step_s": step, **budget_row(out)})
    return pd.DataFrame(rows).set_index(["integrator", "step_s"])


def singularity_sweep(t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float, *, floors=DIVISOR_FLOORS,
                      caps_kms2=COMPONENT_CAPS_KMS2, variants: dict | None = None,
                      capped_variants=("corrected (weighted eq. 32, 35)", "literal eq. 32 and 35")):
    """``paper``-model budgets (eq. 30-35) against the singularity handling, every other setting at its default.

    Each variant (label -> (paper_normal, paper_radial), default :data:`PAPER_VARIANTS`) with each divisor
    floor and no cap, then each of ``capped_variants`` with no floor and each component cap. Index
    (variant, divisor floor, cap (km/s^2)); the cap is text ("none" or the value).
    """
    import pandas as pd

    variants = PAPER_VARIANTS if variants is None else variants
    rows = []

    def add(label, floor, cap_text, overrides):
        out = deltav_arrays(t_tdb_s, states, gm_km3_s2, overrides)
        rows.append({"variant": label, "divisor floor": floor, "cap (km/s^2)": cap_text,
                     "dv total": out["dv_total"]["paper"], "dv opt": out["dv_opt"]["paper"]})

    for label, (normal, radial) in variants.items():
        for floor in floors:
            add(label, floor, "none", dict(paper_normal=normal, paper_radial=radial, paper_divisor_floor=floor))
    for cap in caps_kms2:
        for label in capped_variants:
            normal, radial = variants[label]
            add(label, 0.0, f"{cap:g}", dict(paper_normal=normal, paper_radial=radial, paper_divisor_floor=0.0,
                                             paper_cap_kms2=cap))
    return pd.DataFrame(rows).set_index(["variant", "divisor floor", "cap (km/s^2)"])


def singular_proximity(res: xr.Dataset) -> dict[str, float]:
    """Smallest |sin(nu)| and |cos(theta)| (theta = AOP + nu) over the samples of a
    :func:`deltav_from_propagation` result: how close the arc comes to the divisors of eq. 31-34."""
    nu = res["nu_rad"].values
    return {"min_abs_sin_nu": float(np.min(np.abs(np.sin(nu)))),
            "min_abs_cos_theta": float(np.min(np.abs(np.cos(nu + res["aop_rad"].values))))}


def element_frame_table(profile: dict, ds: xr.Dataset, sat: int = 0):
    """Budgets of every model of satellite ``sat`` with the GVE elements taken in each element frame."""
    import pandas as pd

    rows = {}
    for frame in ELEMENT_FRAMES:
        r = deltav_from_propagation(profile, ds, sat=sat, element_frame=frame)
        rows[frame] = {**{f"{m} total": r["dv_total_kms_per_year"].sel(model_all=m).item() for m in MODELS},
                       **{f"{m} opt": r["dv_opt_kms_per_year"].sel(model_all=m).item() for m in OSCULATING_MODELS}}
    return pd.DataFrame(rows).T


def secular_window_sweep(t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float, window_s: float,
                         settings: dict | None = None):
    """Budgets and secular parts (km/s per year) over windows of ``window_s`` of a longer arc, starting every
    quarter window, then over the whole arc: how much the secular trend of a short arc depends on its start.

    Index (window start (days), span (days)); columns ``"<model> total"`` and ``"secular <part>"``.
    """
    import pandas as pd

    cfg = kernel_settings(deltav_settings(None, **(settings or {})))
    year_s = float(cfg["year_days"]) * SECONDS_PER_DAY
    t = np.asarray(t_tdb_s, dtype=float)
    st = np.asarray(states, dtype=float)
    n_win = int(round(window_s / (t[1] - t[0])))
    if not 2 <= n_win <= t.size - 1:
        raise ValueError(f"window of {window_s} s spans {n_win} steps; it must be at least 2 steps and no longer "
                         f"than the arc ({t.size - 1} steps)")

    def row(start_days, span_days, out):
        return {"window start (days)": start_days, "span (days)": span_days,
                **{f"{m} total": out["dv_total"][m] for m in MODELS},
                **{f"secular {k}": out["secular_parts"][k] * year_s for k in SECULAR_PARTS}}

    rows = []
    for start in range(0, t.size - n_win, max(1, n_win // 4)):
        sl = slice(start, start + n_win + 1)
        rows.append(row((t[start] - t[0]) / SECONDS_PER_DAY, window_s / SECONDS_PER_DAY,
                        deltav_arrays(t[sl], st[sl], gm_km3_s2, cfg)))
    rows.append(row(0.0, (t[-1] - t[0]) / SECONDS_PER_DAY, deltav_arrays(t, st, gm_km3_s2, cfg)))
    return pd.DataFrame(rows).set_index(["window start (days)", "span (days)"])


def window_spread(windows, span_days: float) -> dict[str, tuple[float, float]]:
    """(min, max) of each model's total budget over the windows of :func:`secular_window_sweep` of one span."""
    sub = windows.xs(span_days, level="span (days)")
    return {m: (float(sub[f"{m} total"].min()), float(sub[f"{m} total"].max())) for m in MODELS}


def slsqp_check_table(t_rtn_kms2: np.ndarray, lam: float = 20.0, n_sample: int = 60, label: str = "lsq thrust"):
    """Eq. 41 by SLSQP (:func:`slsqp_tmax`) against the closed form (:func:`tmax_closed_form`) on ``n_sample``
    evenly spaced epochs of a thrust series (n, 3): converged count, largest relative difference and the
    range of T_max / T_total."""
    import pandas as pd

    tr = np.asarray(t_rtn_kms2, dtype=float)
    sample = np.linspace(0, tr.shape[0] - 1, min(int(n_sample), tr.shape[0])).astype(int)
    closed = tmax_closed_form(tr[sample])
    solved, ok = slsqp_tmax(tr[sample], lam=lam)
    ratio = closed / thrust_total(tr[sample])
    return pd.DataFrame({"epochs": [len(sample)], "SLSQP converged": [int(ok.sum())],
                         "max |SLSQP - closed| / closed": [np.max(np.abs(solved - closed) / closed)],
                         "min T_max / T_total": [np.min(ratio)], "max T_max / T_total": [np.max(ratio)]}, index=[label])


def constellation_table(per_sat: xr.Dataset, paper: dict | None = None):
    """Mean, min and max total and mean optimised budget over the satellites of :func:`deltav_per_satellite`,
    per model, with Table 4's per-satellite values."""
    import pandas as pd

    paper = PAPER_TABLE_4 if paper is None else paper
    table = pd.DataFrame({
        "mean total": per_sat["dv_total_kms_per_year"].mean("sat").to_series(),
        "min total": per_sat["dv_total_kms_per_year"].min("sat").to_series(),
        "max total": per_sat["dv_total_kms_per_year"].max("sat").to_series(),
        "mean opt": per_sat["dv_opt_kms_per_year"].mean("sat").to_series(),
    })
    table.loc[PAPER_LABEL] = [paper["dv_total"], np.nan, np.nan, paper["dv_opt"]]
    return table
