"""Gravity field: the compiled acceleration against its potential, an independent formulation and J2."""

import numpy as np
import pytest

from lnss_lib.gravity import GravityField, harmonic_acceleration, harmonic_potential
from lnss_lib.reference import harmonic_acceleration_spherical


def _accel(field, r):
    out = np.empty(3)
    harmonic_acceleration(np.asarray(r, float), field.cnm, field.snm, field.coef, field.gm_km3_s2, field.r_ref_km,
                          field.degree, field.workspace(), out)
    return out


def _numerical_gradient(field, r, h=1e-2):
    """Central differences of the non-central part of U (the GM/r part is removed to limit cancellation)."""
    work = field.workspace()

    def disturbing(x):
        return harmonic_potential(x, field.cnm, field.snm, field.coef, field.gm_km3_s2, field.r_ref_km,
                                  field.degree, work) - field.gm_km3_s2 / np.linalg.norm(x)

    grad = np.empty(3)
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        grad[j] = (disturbing(r + e) - disturbing(r - e)) / (2 * h)
    return grad - field.gm_km3_s2 * r / np.linalg.norm(r) ** 3


@pytest.mark.parametrize("degree", [30, 100])
@pytest.mark.parametrize("r_km", [[1800.0, 300.0, -400.0], [0.0, 0.0, 1900.0], [0.0, 0.0, -2100.0],
                                  [1e-7, -1e-7, 1745.0], [-2500.0, 1000.0, 900.0]])
def test_acceleration_is_gradient_of_potential_including_poles(paper_profile, degree, r_km):
    field = GravityField.from_profile(paper_profile, degree)
    r = np.asarray(r_km)
    acc = _accel(field, r)
    grad = _numerical_gradient(field, r)
    point_mass = -field.gm_km3_s2 * r / np.linalg.norm(r) ** 3
    assert np.all(np.isfinite(acc))
    assert np.linalg.norm(acc - grad) < 1e-5 * np.linalg.norm(acc - point_mass)


def test_matches_independent_spherical_formulation(paper_profile, rng):
    field = GravityField.from_profile(paper_profile, 30)
    for _ in range(20):
        direction = rng.normal(size=3)
        r = direction / np.linalg.norm(direction) * rng.uniform(1740.0, 8000.0)
        acc = _accel(field, r)
        ref = harmonic_acceleration_spherical(r, field)
        point_mass = -field.gm_km3_s2 * r / np.linalg.norm(r) ** 3
        assert np.linalg.norm(acc - ref) < 1e-9 * np.linalg.norm(acc - point_mass)


def test_zonal_j2_matches_closed_form(paper_profile):
    full = GravityField.from_profile(paper_profile, 2)
    cnm = np.zeros_like(full.cnm)
    cnm[0, 0] = 1.0
    cnm[2, 0] = full.cnm[2, 0]
    field = GravityField(2, full.gm_km3_s2, full.r_ref_km, cnm, np.zeros_like(cnm), full.coef)
    j2 = -np.sqrt(5.0) * cnm[2, 0]
    r = np.array([1500.0, -900.0, 1200.0])
    x, y, z = r
    rn = np.linalg.norm(r)
    k = -1.5 * j2 * field.gm_km3_s2 * field.r_ref_km ** 2 / rn ** 5
    expected = -field.gm_km3_s2 * r / rn ** 3 + k * np.array([x * (1 - 5 * z * z / rn ** 2), y * (1 - 5 * z * z / rn ** 2),
                                                               z * (3 - 5 * z * z / rn ** 2)])
    assert np.allclose(_accel(field, r), expected, rtol=0, atol=1e-15)
    assert 2.0e-4 < j2 < 2.1e-4  # the lunar J2 of GRAIL-era fields


def test_bad_degree_rejected(paper_profile):
    with pytest.raises(ValueError, match="degree"):
        GravityField.from_profile(paper_profile, 101)
    with pytest.raises(ValueError, match="degree"):
        GravityField.from_profile(paper_profile, -1)
