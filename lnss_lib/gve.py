"""Gauss variational equations and their inverses (paper Section 3.1, eq. 25-35).

Forward: :func:`gve_matrix` (eq. 25-29) maps an RTN acceleration to the rates of
``[a, e, i, raan, aop]``; :func:`natural_gve_matrix` recombines the rows into rates that stay
regular as e -> 0 and i -> 0. Inverse: :func:`lsq_thrust` (least squares on all five natural rates)
and :func:`paper_thrust` (the paper's sequential eq. 30-35, misprints corrected). The rates come
from finite differences of osculating elements (:func:`osculating_elements`, :func:`element_rates`)
or of the orbit vectors a, e_vec, h_hat (:func:`orbit_vectors`, :func:`natural_rates_from_states`).

Conventions: elements ``[sma_km, e, i, raan, aop, nu]`` in km and rad (nu: true anomaly), time along
axis -2 of state and element arrays, accelerations in km/s^2, rates in km/s, 1/s, rad/s.
"""

from __future__ import annotations

import numpy as np

from .elements import eccentricity_vector, state_to_elements, vis_viva_sma_km
from .sections import PAPER_NORMAL, PAPER_RADIAL

__all__ = [
    "RATE_NAMES",
    "NATURAL_RATE_NAMES",
    "PAPER_NORMAL",
    "PAPER_RADIAL",
    "check_epochs",
    "osculating_elements",
    "element_rates",
    "orbit_quantities",
    "gve_matrix",
    "gve_rates",
    "natural_rates_from_elements",
    "orbit_vectors",
    "project_natural",
    "natural_rates_from_states",
    "natural_gve_matrix",
    "lsq_thrust",
    "paper_thrust",
]

RATE_NAMES = ("a", "e", "i", "raan", "aop")


NATURAL_RATE_NAMES = ("a_dot_over_a", "e_dot", "e_apse_dot", "i_dot", "sin_i_raan_dot")


def check_epochs(t: np.ndarray, series: np.ndarray) -> None:
    """Raise ``ValueError`` unless ``t`` holds >= 3 strictly increasing epochs matching axis -2 of ``series``."""
    if t.ndim != 1 or t.size < 3 or series.ndim < 2 or series.shape[-2] != t.size:
        raise ValueError(
            f"need at least 3 epochs and series (..., {t.size}, k); "
            f"got t {t.shape}, series {series.shape}"
        )
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("epochs t_tdb_s must be strictly increasing")


def osculating_elements(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Osculating ``[sma_km, e, i, raan, aop, nu]`` (..., n, 6) of states (..., n, 6), angles unwrapped in time.

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
    theta = np.arctan2(
        np.sum(np.cross(node_hat, r_hat) * h_hat, axis=-1), np.sum(node_hat * r_hat, axis=-1)
    )
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
    check_epochs(t, el)
    return np.gradient(el[..., :5], t, axis=-2, edge_order=2)


def orbit_quantities(elements: np.ndarray, gm_km3_s2: float):
    """(a, e, i, nu, theta = aop + nu, p = a (1 - e^2), h = sqrt(GM p), r = p / (1 + e cos(nu))) of elements
    (..., 6) ``[sma_km, e, i, raan, aop, nu]`` (km, rad): the conic quantities every GVE form here uses."""
    el = np.asarray(elements, dtype=float)
    a, e, inc, _, aop, nu = (el[..., k] for k in range(6))
    p = a * (1.0 - e * e)
    h = np.sqrt(gm_km3_s2 * p)
    r = p / (1.0 + e * np.cos(nu))
    theta = aop + nu
    return a, e, inc, nu, theta, p, h, r


def gve_matrix(elements: np.ndarray, gm_km3_s2: float, *, e_times_aop: bool = False) -> np.ndarray:
    """Matrix B (..., 5, 3) of the GVEs (eq. 25-29): d[a, e, i, raan, aop]/dt = B [T_R, T_T, T_N].

    Standard forms (e.g. Vallado, Fundamentals of Astrodynamics, Gauss form); eq. 26 with its
    ``r e`` term inside the T_T bracket: e-dot = [p sin(nu) T_R + ((p + r) cos(nu) + r e) T_T] / h.
    Singular for e = 0 (aop row) and sin(i) = 0 (raan, aop rows). With ``e_times_aop`` the last row
    is e aop-dot = [-p cos(nu) T_R + (p + r) sin(nu) T_T - e r sin(theta) cot(i) T_N] / h instead,
    finite as e -> 0 (the form the impulsive control set of :mod:`lnss_lib.design_life.manoeuvres` builds on).
    Impulsive form: the same B maps an RTN impulse (km/s) to the element changes.
    """
    a, e, inc, nu, theta, p, h, r = orbit_quantities(elements, gm_km3_s2)
    sn, cn, st, ct = np.sin(nu), np.cos(nu), np.sin(theta), np.cos(theta)
    zero = np.zeros_like(a)
    cot_i = np.cos(inc) / np.sin(inc)
    if e_times_aop:
        row_aop = [-p * cn / h, (p + r) * sn / h, -e * r * st * cot_i / h]
    else:
        row_aop = [-p * cn / (h * e), (p + r) * sn / (h * e), -r * st * cot_i / h]
    rows = [
        [2.0 * a * a / h * e * sn, 2.0 * a * a / h * p / r, zero],
        [p * sn / h, ((p + r) * cn + r * e) / h, zero],
        [zero, zero, r * ct / h],
        [zero, zero, r * st / (h * np.sin(inc))],
        row_aop,
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def gve_rates(elements: np.ndarray, acc_rtn_kms2: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """Forward GVEs (eq. 25-29): rates (..., 5) of [a, e, i, raan, aop] under RTN acceleration (..., 3)."""
    return np.einsum(
        "...ij,...j->...i", gve_matrix(elements, gm_km3_s2), np.asarray(acc_rtn_kms2, dtype=float)
    )


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
    return np.stack(
        [
            rt[..., 0] / a,
            rt[..., 1],
            e * (rt[..., 4] + np.cos(inc) * rt[..., 3]),
            rt[..., 2],
            np.sin(inc) * rt[..., 3],
        ],
        axis=-1,
    )


def orbit_vectors(states: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """[sma_km, e_vec (3), h_hat (3)] (..., n, 7) of states (..., n, 6): SMA, eccentricity vector, orbit normal."""
    s = np.asarray(states, dtype=float)
    r_vec, v_vec = s[..., :3], s[..., 3:6]
    r = np.linalg.norm(r_vec, axis=-1, keepdims=True)
    v2 = np.sum(v_vec * v_vec, axis=-1, keepdims=True)
    h_vec = np.cross(r_vec, v_vec)
    e_vec = eccentricity_vector(r_vec, v_vec, gm_km3_s2, h_vec, r[..., 0])
    a = vis_viva_sma_km(r, v2, gm_km3_s2)
    return np.concatenate(
        [a, e_vec, h_vec / np.linalg.norm(h_vec, axis=-1, keepdims=True)], axis=-1
    )


def project_natural(vectors: np.ndarray, vector_rates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural rates (..., 5) and |cos| of the angle between e_hat and the plane-rotation axis."""
    a, e_vec, h_hat = vectors[..., 0], vectors[..., 1:4], vectors[..., 4:7]
    a_dot, e_dot_vec, h_dot = vector_rates[..., 0], vector_rates[..., 1:4], vector_rates[..., 4:7]
    h_hat = h_hat / np.linalg.norm(h_hat, axis=-1, keepdims=True)
    e_vec = e_vec - np.sum(e_vec * h_hat, axis=-1, keepdims=True) * h_hat
    node = np.cross(np.array([0.0, 0.0, 1.0]), h_hat)
    node_norm = np.linalg.norm(node, axis=-1, keepdims=True)
    inclined = node_norm > 1e-12
    node_hat = np.where(
        inclined, node / np.where(inclined, node_norm, 1.0), np.array([1.0, 0.0, 0.0])
    )
    e = np.linalg.norm(e_vec, axis=-1, keepdims=True)
    e_hat = np.where(e > 1e-12, e_vec / np.where(e > 1e-12, e, 1.0), node_hat)
    across = np.cross(h_hat, e_hat)
    natural = np.stack(
        [
            a_dot / a,
            np.sum(e_hat * e_dot_vec, axis=-1),
            np.sum(across * e_dot_vec, axis=-1),
            -np.sum(np.cross(h_hat, node_hat) * h_dot, axis=-1),
            np.sum(node_hat * h_dot, axis=-1),
        ],
        axis=-1,
    )
    axis = np.cross(h_hat, h_dot)
    axis_norm = np.linalg.norm(axis, axis=-1, keepdims=True)
    axis_hat = axis / np.where(axis_norm > 0.0, axis_norm, 1.0)
    return natural, np.abs(np.sum(axis_hat * e_hat, axis=-1))


def natural_rates_from_states(
    t_tdb_s: np.ndarray, states: np.ndarray, gm_km3_s2: float
) -> np.ndarray:
    """Natural rates (..., n, 5) (see :func:`natural_rates_from_elements`) by central differences of vectors.

    The same central differences as :func:`element_rates`, taken on a, the eccentricity vector and
    the orbit normal (Cartesian, no angle wrapping) and projected at each epoch: regular where
    aop (e -> 0) or raan (i -> 0) is ill-defined.
    """
    t = np.asarray(t_tdb_s, dtype=float)
    vectors = orbit_vectors(states, gm_km3_s2)
    check_epochs(t, vectors)
    return project_natural(vectors, np.gradient(vectors, t, axis=-2, edge_order=2))[0]


def natural_gve_matrix(elements: np.ndarray, gm_km3_s2: float) -> np.ndarray:
    """GVEs for the natural rates (..., 5, 3): rows of eq. 25-29 recombined, no 1/e or 1/sin(i) left.

    a-dot/a = (2a/h)(e sin(nu) T_R + (p/r) T_T); e-dot = eq. 26 (corrected);
    e (aop-dot + cos(i) raan-dot) = (-p cos(nu) T_R + (p + r) sin(nu) T_T) / h (eq. 29 + cos(i) eq. 28:
    the T_N coupling cancels); i-dot = r cos(theta) T_N / h; sin(i) raan-dot = r sin(theta) T_N / h.
    """
    a, e, inc, nu, theta, p, h, r = orbit_quantities(elements, gm_km3_s2)
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


def paper_thrust(
    elements: np.ndarray,
    rates: np.ndarray,
    gm_km3_s2: float,
    *,
    normal: str = "weighted",
    radial: str = "weighted",
    divisor_floor: float = 1e-3,
    cap_kms2: float = np.inf,
    t_t_kms2: np.ndarray | None = None,
) -> dict:
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
        raise ValueError(
            f"unknown paper normal combination {normal!r}; allowed: {', '.join(PAPER_NORMAL)}"
        )
    if radial not in PAPER_RADIAL:
        raise ValueError(
            f"unknown paper radial combination {radial!r}; allowed: {', '.join(PAPER_RADIAL)}"
        )
    a, e, inc, nu, theta, p, h, r = orbit_quantities(elements, gm_km3_s2)
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
    return {
        "T_R": t_r,
        "T_T": t_t,
        "T_N": t_n,
        "T_sma": t_sma,
        "T_i": t_i,
        "T_raan": t_raan,
        "T_e": t_e,
        "T_aop": t_aop,
    }
