"""Walker and explicit constellations (eq. 42, Table 4) and their validation."""

import numpy as np
import pytest

from lnss_lib.constellation import (
    WalkerDesign,
    explicit_constellation,
    standalone_elfo,
    two_body_positions_mci,
    walker_design,
)
from lnss_lib.settings import load_settings


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


def test_walker_raan_and_mean_anomaly_spacing(profile):
    design = walker_design(profile.dynamics, 8000.0, 0.3, 45.0, 60.0, n_planes=5, sats_per_plane=3)
    el = design.elements_deg()
    assert design.n_sat == 15 and el.shape == (15, 6)
    raan = el[:, 3].reshape(5, 3)
    mean_anomaly = el[:, 5].reshape(5, 3)
    np.testing.assert_allclose(raan[:, 0], [0.0, 72.0, 144.0, 216.0, 288.0])
    assert np.all(raan == raan[:, :1])
    np.testing.assert_allclose(mean_anomaly, np.tile([0.0, 120.0, 240.0], (5, 1)))
    np.testing.assert_allclose(el[:, :3], np.tile([8000.0, 0.3, 60.0], (15, 1)))
    np.testing.assert_allclose(el[:, 4], 45.0)


def test_walker_raan_offset_wraps(profile):
    el = walker_design(
        profile.dynamics, 8000.0, 0.1, 10.0, 30.0, 4, 1, raan_offset_deg=300.0
    ).elements_deg()
    np.testing.assert_allclose(el[:, 3], [300.0, 30.0, 120.0, 210.0])


def test_standalone_elfo_matches_table_4(profile):
    el = standalone_elfo(profile.standalone_elfo, profile.dynamics)
    assert el.shape == (16, 6)
    np.testing.assert_allclose(el[:8, 3], 0.0)
    np.testing.assert_allclose(el[8:, 3], 180.0)
    np.testing.assert_allclose(el[:8, 5], np.arange(8) * 45.0)
    np.testing.assert_allclose(el[:, [0, 1, 2, 4]], np.tile([6143.0, 0.6, 51.7, 90.0], (16, 1)))


@pytest.mark.parametrize("e", [1.0, 1.2, -0.1, float("nan")])
def test_bad_eccentricity(profile, e):
    with pytest.raises(ValueError, match="eccentricity"):
        walker_design(profile.dynamics, 8000.0, e, 90.0, 50.0, 2, 2)


def test_perilune_below_surface(profile):
    # a(1 - e) = 6143 * 0.3 = 1843 km > 1737.4 km is fine; e = 0.75 gives 1535.75 km: below the surface.
    walker_design(profile.dynamics, 6143.0, 0.7, 90.0, 50.0, 2, 2)
    with pytest.raises(ValueError, match="perilune"):
        walker_design(profile.dynamics, 6143.0, 0.75, 90.0, 50.0, 2, 2)
    with pytest.raises(ValueError, match="perilune"):
        walker_design(profile.dynamics, 1500.0, 0.0, 90.0, 50.0, 2, 2)
    with pytest.raises(ValueError, match="perilune"):
        explicit_constellation(
            profile.dynamics,
            [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0], [1700.0, 0.0, 10.0, 0.0, 0.0, 0.0]],
        )


def test_min_altitude_raises_the_floor():
    strict = load_settings("ci", overrides={"impact": {"min_altitude_km": 200.0}})
    with pytest.raises(ValueError, match="perilune"):
        walker_design(strict.dynamics, 1900.0, 0.0, 90.0, 50.0, 2, 2)


@pytest.mark.parametrize("value", [0, -2, 2.5, True, "3", None, float("inf")])
def test_counts_must_be_positive_integers(profile, value):
    with pytest.raises(ValueError, match="positive integer"):
        walker_design(profile.dynamics, 8000.0, 0.1, 90.0, 50.0, value, 2)
    with pytest.raises(ValueError, match="positive integer"):
        WalkerDesign(8000.0, 0.1, 90.0, 50.0, 2, value)


def test_integral_counts_accepted(profile):
    design = walker_design(profile.dynamics, 8000.0, 0.1, 90.0, 50.0, np.int64(3), 2.0)
    assert (
        design.n_planes == 3
        and design.sats_per_plane == 2
        and isinstance(design.sats_per_plane, int)
    )


def test_bad_inclination_and_shape(profile):
    with pytest.raises(ValueError, match="inclination"):
        walker_design(profile.dynamics, 8000.0, 0.1, 90.0, 190.0, 2, 2)
    with pytest.raises(ValueError, match="shape"):
        explicit_constellation(profile.dynamics, [[8000.0, 0.1, 50.0, 0.0, 90.0]])


def test_explicit_constellation_wraps_angles(profile):
    el = explicit_constellation(profile.dynamics, [8000.0, 0.1, 50.0, -90.0, 450.0, 720.0])
    np.testing.assert_allclose(el, [[8000.0, 0.1, 50.0, 270.0, 90.0, 0.0]])


def test_two_body_positions_follow_kepler(profile):
    from lnss_lib.ephemeris import ensure_kernels, tdb_seconds

    ensure_kernels(profile.ephemeris)
    el = walker_design(profile.dynamics, 6143.0, 0.6, 90.0, 51.7, 2, 2).elements_deg()
    gm = profile.gravity.gm_km3_s2
    period_s = 2.0 * np.pi * np.sqrt(6143.0**3 / gm)
    t0 = tdb_seconds(profile.epoch.start_tdb)
    r = two_body_positions_mci(profile.dynamics, el, t0 + np.array([0.0, 0.5 * period_s, period_s]))
    radius = np.linalg.norm(r, axis=-1)
    # Satellites at M = 0 start at perilune a(1 - e), reach apolune a(1 + e) half a period later, and return.
    np.testing.assert_allclose(radius[[0, 2], 0], 6143.0 * 0.4, rtol=1e-9)
    np.testing.assert_allclose(radius[[0, 2], 1], 6143.0 * 1.6, rtol=1e-9)
    np.testing.assert_allclose(r[:, 2], r[:, 0], atol=1e-6)
