"""Lunar gravity field: fully normalised spherical harmonics (AIUB-GRL350B, frame MOON_PA).

The acceleration uses the Cunningham V/W recursion (Montenbruck & Gill, Satellite Orbits, 3.2.4)
rewritten for fully normalised coefficients. It works in Cartesian body-fixed coordinates, so it
has no singularity at the poles, and the normalised recursion stays in range to degree 100.

The compiled acceleration is linear in the V/W terms of one degree higher, so the field's coefficients
and the recursion's x/y/z factors are folded once per field into six tables (:func:`acceleration_tables`)
and each evaluation computes a degree row of V and W and its six dot products in one loop over whole
SIMD vectors (rows padded to :data:`LANES`). The per-evaluation degree truncation is a lookup in radii
tabulated once per field (:func:`truncation_radii`), equal to :func:`truncation_degree`'s loop.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numba as nb
import numpy as np

from .config import data_path
from .errors import ConfigError
from .settings import GravitySettings

__all__ = [
    "MAX_FILE_DEGREE",
    "LANES",
    "GravityField",
    "recursion_coefficients",
    "degree_bound_factors",
    "acceleration_tables",
    "padded_width",
    "new_workspace",
    "fill_vw",
    "truncation_degree",
    "truncation_radii",
    "tabulated_truncation_degree",
    "omitted_bound",
    "harmonic_acceleration",
    "harmonic_potential",
]

MAX_FILE_DEGREE = 100
LANES = 8  # rows of the acceleration tables and of V/W are padded to a multiple of this (one AVX-512 vector)


@lru_cache(maxsize=4)
def _read_rows(path: str) -> np.ndarray:
    """The ``n m Cnm Snm`` table of a coefficient file (read once per process); ConfigError naming the file
    and the row of a malformed line (never the line itself)."""
    try:
        return np.loadtxt(path, dtype=float, ndmin=2)
    except ValueError as error:
        where = re.search(r"at row \d+(, column \d+)?", str(error))
        raise ConfigError(
            f"{path}: not a table of four numbers per line (n m Cnm Snm)"
            + (f"; the first bad value is {where.group(0)} (numpy's count)" if where else ""),
            key="gravity.file",
            source=path,
        ) from None


@dataclass(frozen=True)
class GravityField:
    """Fully normalised coefficients ``cnm[n, m]``, ``snm[n, m]`` up to ``degree``, GM, R and recursion factors.

    ``coef[5, n, 0]`` holds the per-degree acceleration bound factor K_n of :func:`degree_bound_factors`;
    ``truncation_kms2`` > 0 lets the compiled force model drop, per evaluation, the degrees whose
    summed bound at the current radius stays below it (:func:`truncation_degree`); 0 keeps every degree.
    Derived on construction (also by ``dataclasses.replace``): ``tables``, the compiled acceleration's
    coefficient tables (:func:`acceleration_tables`), and ``truncation_radii_km`` (:func:`truncation_radii`).
    """

    degree: int
    gm_km3_s2: float
    r_ref_km: float
    cnm: np.ndarray
    snm: np.ndarray
    coef: np.ndarray
    truncation_kms2: float = 0.0
    tables: np.ndarray = field(init=False, repr=False, compare=False)
    truncation_radii_km: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "tables", acceleration_tables(self.cnm, self.snm, self.coef))
        object.__setattr__(
            self,
            "truncation_radii_km",
            truncation_radii(
                self.coef, self.gm_km3_s2, self.r_ref_km, self.degree, self.truncation_kms2
            ),
        )

    @classmethod
    def from_file(
        cls,
        path: Path,
        degree: int,
        gm_km3_s2: float,
        r_ref_km: float,
        truncation_kms2: float = 0.0,
    ) -> GravityField:
        """Read ``n m Cnm Snm`` rows (fully normalised) and truncate to ``degree`` (0..100; 0 or 1 = point mass)."""
        if not isinstance(degree, (int, np.integer)) or not 0 <= degree <= MAX_FILE_DEGREE:
            raise ValueError(
                f"gravity degree must be an integer in [0, {MAX_FILE_DEGREE}] (0 = point mass); got {degree!r}"
            )
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(
                f"gravity field file not found: {path} (see params/data/README.md)"
            )
        rows = _read_rows(str(path.resolve()))
        n_idx = rows[:, 0].astype(int)
        m_idx = rows[:, 1].astype(int)
        keep = n_idx <= degree
        cnm = np.zeros((degree + 1, degree + 1))
        snm = np.zeros((degree + 1, degree + 1))
        cnm[n_idx[keep], m_idx[keep]] = rows[keep, 2]
        snm[n_idx[keep], m_idx[keep]] = rows[keep, 3]
        if np.max(n_idx) < degree:
            raise ValueError(f"{path} holds degree {np.max(n_idx)} only; requested {degree}")
        if not (np.isfinite(truncation_kms2) and truncation_kms2 >= 0.0):
            raise ValueError(
                f"gravity truncation must be >= 0 km/s^2 (0 = full field); got {truncation_kms2!r}"
            )
        coef = recursion_coefficients(int(degree))
        coef[5, : degree + 1, 0] = degree_bound_factors(cnm, snm)
        return cls(
            int(degree), float(gm_km3_s2), float(r_ref_km), cnm, snm, coef, float(truncation_kms2)
        )

    @classmethod
    def from_settings(cls, gravity: GravitySettings, degree: int | None = None) -> GravityField:
        """The field the gravity settings name, at their degree unless ``degree`` overrides it."""
        chosen = gravity.degree if degree is None else degree
        return cls.from_file(
            data_path(gravity.file),
            chosen,
            gravity.gm_km3_s2,
            gravity.r_ref_km,
            gravity.truncation_kms2,
        )

    def workspace(self) -> np.ndarray:
        """Scratch array for :func:`harmonic_acceleration` and :func:`harmonic_potential` (:func:`new_workspace`)."""
        return new_workspace(self.degree)


def recursion_coefficients(degree: int) -> np.ndarray:
    """Constant factors of the normalised V/W recursion and of the acceleration sums.

    Shape (6, degree + 2, degree + 2), indexed [kind, n, m]: 0, 1 the column recursion
    V_nm = a z0 V_n-1,m - b rho V_n-2,m (kind 0 at m = n is the sectorial factor); 2, 3, 4 the
    x/y factors towards orders m + 1 and m - 1 and the z factor of term (n, m); kind 5 is left for the
    field's per-degree bound factors (:func:`degree_bound_factors`, set by :class:`GravityField`).
    """
    size = degree + 2
    coef = np.zeros((6, size, size))
    for n in range(1, size):
        coef[0, n, n] = np.sqrt(3.0) if n == 1 else np.sqrt((2.0 * n + 1.0) / (2.0 * n))
        for m in range(n):
            coef[0, n, m] = np.sqrt((2.0 * n + 1.0) * (2.0 * n - 1.0) / ((n - m) * (n + m)))
            if m <= n - 2:
                coef[1, n, m] = np.sqrt(
                    (2.0 * n + 1.0)
                    * (n + m - 1.0)
                    * (n - m - 1.0)
                    / ((2.0 * n - 3.0) * (n + m) * (n - m))
                )
    for n in range(degree + 1):
        k_n = (2.0 * n + 1.0) / (2.0 * n + 3.0)
        coef[2, n, 0] = np.sqrt(0.5 * k_n * (n + 1.0) * (n + 2.0))
        coef[4, n, 0] = np.sqrt(k_n) * (n + 1.0)
        for m in range(1, n + 1):
            coef[2, n, m] = 0.5 * np.sqrt(k_n * (n + m + 1.0) * (n + m + 2.0))
            coef[3, n, m] = 0.5 * np.sqrt(
                (2.0 if m == 1 else 1.0) * k_n * (n - m + 2.0) * (n - m + 1.0)
            )
            coef[4, n, m] = np.sqrt(k_n * (n - m + 1.0) * (n + m + 1.0))
    return coef


def degree_bound_factors(cnm: np.ndarray, snm: np.ndarray) -> np.ndarray:
    """K_n = (2n + 1) sqrt(n + 1) sigma_n, sigma_n = sqrt(sum_m C_nm^2 + S_nm^2), for n = 0..degree (K_0 = K_1 = 0).

    Bound on the degree-n acceleration of a fully normalised field at radius r (any direction):
    |a_n| <= GM / r^2 (R / r)^n K_n. Derivation: a_n = sum_k c_k grad f_k over the 2n + 1 real
    harmonics f_k = GM R^n r^-(n+1) Y_k (c_k the coefficients C_nm, S_nm; Y_k of unit mean square), so
    by Cauchy-Schwarz |a_n| <= sigma_n sqrt(sum_k |grad f_k|^2). The radial part of grad f_k is
    -(n + 1) f_k / r, the tangential part GM R^n r^-(n+2) grad_S Y_k; Unsold's theorem gives
    sum_k Y_k^2 = 2n + 1 and (applying the surface Laplacian to it) sum_k |grad_S Y_k|^2 =
    n (n + 1)(2n + 1), so sum_k |grad f_k|^2 = (GM / r^2)^2 (R / r)^2n (2n + 1)^2 (n + 1).
    Degrees 0 (central term, never dropped) and 1 (zero in a centre-of-mass frame) get 0.
    """
    degree = cnm.shape[0] - 1
    factors = np.zeros(degree + 1)
    for n in range(2, degree + 1):
        sigma = np.sqrt(np.sum(cnm[n, : n + 1] ** 2) + np.sum(snm[n, : n + 1] ** 2))
        factors[n] = (2.0 * n + 1.0) * np.sqrt(n + 1.0) * sigma
    return factors


def acceleration_tables(cnm: np.ndarray, snm: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Coefficient tables of :func:`harmonic_acceleration`, shape (8, degree + 2, :func:`padded_width`), [kind, j, m].

    The degree-n acceleration (Montenbruck & Gill eq. 3.33, normalised) is linear in V and W of degree
    j = n + 1: a_x = sum_jm X_V[j, m] V_jm + X_W[j, m] W_jm, and so for y and z. Kinds 0-5 hold X_V, X_W,
    Y_V, Y_W, Z_V, Z_W (C_nm and S_nm times the x/y factors towards orders m + 1 and m - 1 and the z factor
    of ``coef`` kinds 2-4); kinds 6 and 7 the column recursion factors (``coef`` kinds 0 and 1, the sectorial
    factor on the diagonal). Entries beyond order j are zero, so a padded row adds nothing.
    """
    degree = cnm.shape[0] - 1
    size = degree + 2
    tab = np.zeros((8, size, padded_width(degree)))
    for n in range(degree + 1):
        j, m = n + 1, np.arange(1, n + 1)
        c, s = cnm[n], snm[n]
        up, down, z = coef[2, n], coef[3, n], coef[4, n]
        tab[0, j, 1] -= c[0] * up[0]
        tab[3, j, 1] -= c[0] * up[0]
        tab[4, j, 0] -= c[0] * z[0]
        tab[0, j, m + 1] -= up[m] * c[m]
        tab[1, j, m + 1] -= up[m] * s[m]
        tab[2, j, m + 1] += up[m] * s[m]
        tab[3, j, m + 1] -= up[m] * c[m]
        tab[0, j, m - 1] += down[m] * c[m]
        tab[1, j, m - 1] += down[m] * s[m]
        tab[2, j, m - 1] += down[m] * s[m]
        tab[3, j, m - 1] -= down[m] * c[m]
        tab[4, j, m] -= z[m] * c[m]
        tab[5, j, m] -= z[m] * s[m]
    tab[6:8, :, :size] = coef[0:2]
    return tab


@nb.njit(cache=True)
def padded_width(degree: int) -> int:
    """Row length of the acceleration tables and V/W: degree + 2 orders rounded up to whole :data:`LANES`."""
    return (degree + 2 + LANES - 1) // LANES * LANES


@nb.njit(cache=True)
def new_workspace(degree: int) -> np.ndarray:
    """Zeroed V/W scratch array (2, degree + 2, :func:`padded_width`) for the field of ``degree``."""
    return np.zeros((2, degree + 2, padded_width(degree)))


@nb.njit(cache=True)
def omitted_bound(
    r_km: float, coef: np.ndarray, gm: float, r_ref: float, degree: int, kept: int
) -> float:
    """Bound (km/s^2) on the acceleration of degrees kept + 1 .. ``degree``: sum_n GM / r^2 (R / r)^n K_n."""
    q = r_ref / r_km
    qn = q ** (kept + 1)
    total = 0.0
    for n in range(kept + 1, degree + 1):
        total += coef[5, n, 0] * qn
        qn *= q
    return gm / (r_km * r_km) * total


@nb.njit(cache=True)
def truncation_degree(
    r_km: float, coef: np.ndarray, gm: float, r_ref: float, degree: int, tol_kms2: float
) -> int:
    """Smallest N <= ``degree`` whose omitted degrees N + 1 .. ``degree`` are bounded below ``tol_kms2``
    at radius ``r_km`` (:func:`degree_bound_factors`); ``degree`` itself when ``tol_kms2`` <= 0."""
    if tol_kms2 <= 0.0:
        return degree
    q = r_ref / r_km
    limit = tol_kms2 * r_km * r_km / gm
    qn = q**degree
    tail = 0.0
    for n in range(degree, 1, -1):
        tail += coef[5, n, 0] * qn
        if tail > limit:
            return n
        qn /= q
    return 1


def truncation_radii(
    coef: np.ndarray, gm: float, r_ref: float, degree: int, tol_kms2: float
) -> np.ndarray:
    """Radii (km) ``radii[n]``, n = 2..``degree``, below which :func:`truncation_degree` keeps at least degree n.

    Each is the smallest double at which the loop keeps fewer than n degrees, found by bisection on the
    loop itself (the summed bound of degrees n..``degree`` falls with the radius, so the loop's answer
    does too), hence :func:`tabulated_truncation_degree` returns the loop's integer (tested on dense sweeps
    and on both sides of every radius). Entries 0 and 1, and every entry when ``tol_kms2`` <= 0 (no
    truncation), are +inf.
    """
    radii = np.full(degree + 1, np.inf)
    if tol_kms2 <= 0.0:
        return radii
    for n in range(2, degree + 1):
        below, above = 1e-3 * r_ref, 1e3 * r_ref
        while truncation_degree(above, coef, gm, r_ref, degree, tol_kms2) >= n:
            above *= 2.0
        while True:
            mid = 0.5 * (below + above)
            if mid in (below, above):
                break
            if truncation_degree(mid, coef, gm, r_ref, degree, tol_kms2) >= n:
                below = mid
            else:
                above = mid
        radii[n] = above
    return radii


@nb.njit(cache=True)
def tabulated_truncation_degree(r_km: float, radii_km: np.ndarray) -> int:
    """:func:`truncation_degree` at ``r_km`` (field degree >= 2) from the field's :func:`truncation_radii`:
    a scan of at most ``degree`` comparisons instead of a sum with a division per degree."""
    kept = radii_km.shape[0] - 1
    while kept >= 2 and r_km >= radii_km[kept]:
        kept -= 1
    return kept


# Reassociation (the padded loops vectorise) and contraction (fused multiply-adds) only: the full fastmath set gave other
# bits to a caller compiled in the same process than to the same caller loaded from numba's cache (13 designs, states
# up to 3e-5 apart after 10 days), so a run's results hung on the cache's state; these two flags give the same bits
# either way (tests/test_kernel_cache.py) at the same speed. Safe: inputs finite (propagator, ForceModel), r >= r_min > 0.
FAST = {"reassoc", "contract"}


@nb.njit(cache=True, fastmath=FAST)
def fill_vw(
    x: float,
    y: float,
    z: float,
    r_ref: float,
    nmax: int,
    coef: np.ndarray,
    V: np.ndarray,
    W: np.ndarray,
) -> None:
    """Normalised V_nm, W_nm (Montenbruck & Gill eq. 3.29-3.31) up to degree nmax, stored [n, m].

    Each degree row is computed from the two before it, so the loop over orders vectorises.
    """
    r2 = x * x + y * y + z * z
    rho = r_ref * r_ref / r2
    x0, y0, z0 = r_ref * x / r2, r_ref * y / r2, r_ref * z / r2
    V[0, 0] = r_ref / np.sqrt(r2)
    W[0, 0] = 0.0
    for n in range(1, nmax + 1):
        a_row = coef[0, n]
        b_row = coef[1, n]
        v_row, v_1, w_row, w_1 = V[n], V[n - 1], W[n], W[n - 1]
        if n >= 2:
            v_2 = V[n - 2]
            w_2 = W[n - 2]
            for m in range(n - 1):
                a = a_row[m] * z0
                b = b_row[m] * rho
                v_row[m] = a * v_1[m] - b * v_2[m]
                w_row[m] = a * w_1[m] - b * w_2[m]
        a = a_row[n - 1] * z0
        v_row[n - 1] = a * v_1[n - 1]
        w_row[n - 1] = a * w_1[n - 1]
        f = a_row[n]
        v_row[n] = f * (x0 * v_1[n - 1] - y0 * w_1[n - 1])
        w_row[n] = f * (x0 * w_1[n - 1] + y0 * v_1[n - 1])


# FAST as fill_vw; a NaN stage stops the integrator (status 4). error_model="numpy": a non-finite position gives a
# non-finite result, not a ZeroDivisionError; r >= r_min > 0 in every integration, so the check never fires there
@nb.njit(cache=True, fastmath=FAST, error_model="numpy")
def harmonic_acceleration(
    r_bf_km: np.ndarray,
    tables: np.ndarray,
    gm: float,
    r_ref: float,
    degree: int,
    work: np.ndarray,
    out: np.ndarray,
) -> None:
    """Acceleration (km/s^2, body-fixed) of the field of degree/order ``degree`` at ``r_bf_km``, into ``out``.

    Includes the central term (C00 = 1). ``tables`` from :func:`acceleration_tables`; ``work`` from
    :func:`new_workspace`. Row j of V and W (Montenbruck & Gill eq. 3.29-3.31) comes from rows j - 1 and
    j - 2 over whole padded vectors, the sectorial term (kept in registers) at m = j and zero beyond, so a
    non-finite value left in ``work`` by an earlier call is never read into this one.
    """
    V = work[0]
    W = work[1]
    x, y, z = r_bf_km[0], r_bf_km[1], r_bf_km[2]
    r2 = x * x + y * y + z * z
    rho = r_ref * r_ref / r2
    x0, y0, z0 = r_ref * x / r2, r_ref * y / r2, r_ref * z / r2
    v_nn = r_ref / np.sqrt(r2)
    V[0, 0] = v_nn
    W[0, 0] = 0.0
    v_10 = tables[6, 1, 0] * z0 * v_nn
    V[1, 0] = v_10
    W[1, 0] = 0.0
    f = tables[6, 1, 1]
    v_nn, w_nn = f * x0 * v_nn, f * y0 * v_nn
    V[1, 1] = v_nn
    W[1, 1] = w_nn
    ax = tables[0, 1, 0] * v_10 + tables[0, 1, 1] * v_nn + tables[1, 1, 1] * w_nn
    ay = tables[2, 1, 1] * v_nn + tables[3, 1, 1] * w_nn
    az = tables[4, 1, 0] * v_10 + tables[4, 1, 1] * v_nn + tables[5, 1, 1] * w_nn
    for j in range(2, degree + 2):
        f = tables[6, j, j]
        v_nn, w_nn = f * (x0 * v_nn - y0 * w_nn), f * (x0 * w_nn + y0 * v_nn)
        a_row, b_row = tables[6, j], tables[7, j]
        v_1, v_2, w_1, w_2, v_row, w_row = V[j - 1], V[j - 2], W[j - 1], W[j - 2], V[j], W[j]
        xv, xw, yv, yw, zv, zw = (
            tables[0, j],
            tables[1, j],
            tables[2, j],
            tables[3, j],
            tables[4, j],
            tables[5, j],
        )
        for m in range((j + LANES) // LANES * LANES):
            a = a_row[m] * z0
            b = b_row[m] * rho
            v = a * v_1[m] - b * v_2[m]
            w = a * w_1[m] - b * w_2[m]
            v = v_nn if m == j else (v if m < j else 0.0)
            w = w_nn if m == j else (w if m < j else 0.0)
            v_row[m] = v
            w_row[m] = w
            ax += xv[m] * v + xw[m] * w
            ay += yv[m] * v + yw[m] * w
            az += zv[m] * v + zw[m] * w
    scale = gm / (r_ref * r_ref)
    out[0] = scale * ax
    out[1] = scale * ay
    out[2] = scale * az


@nb.njit(cache=True)
def harmonic_potential(
    r_bf_km: np.ndarray,
    cnm: np.ndarray,
    snm: np.ndarray,
    coef: np.ndarray,
    gm: float,
    r_ref: float,
    degree: int,
    work: np.ndarray,
) -> float:
    """Gravitational potential U (km^2/s^2, U = GM/r for a point mass) from the same V/W terms."""
    V = work[0]
    W = work[1]
    fill_vw(r_bf_km[0], r_bf_km[1], r_bf_km[2], r_ref, degree, coef, V, W)
    total = 0.0
    for n in range(degree + 1):
        for m in range(n + 1):
            total += cnm[n, m] * V[n, m] + snm[n, m] * W[n, m]
    return gm / r_ref * total
