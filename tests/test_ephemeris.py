"""Frames, time scales, tabulated ephemerides and Keplerian conversions."""

import numpy as np
import pytest
import spiceypy as spice

from lnss_lib.elements import elements_to_state, state_to_elements, validate_elements
from lnss_lib.ephemeris import EphemerisTable, body_states_mci, load_kernels, rotation, tdb_seconds


def test_calendar_scale_is_explicit(paper_profile):
    t_tdb = tdb_seconds("2025-05-01T00:00:00", "TDB")
    t_utc = tdb_seconds("2025-05-01T00:00:00", "UTC")
    # TDB - UTC = 32.184 s + 37 leap seconds, plus the periodic TDB - TT term (below 1.7 ms)
    assert t_tdb - t_utc == pytest.approx(-69.184, abs=1.7e-3)
    with pytest.raises(ValueError, match="time scale"):
        tdb_seconds("2025-05-01T00:00:00", "GPS")


def test_missing_kernel_is_named(tmp_path):
    missing = tmp_path / "no_such_kernel.bpc"
    with pytest.raises(FileNotFoundError, match="no_such_kernel.bpc"):
        load_kernels([missing])


def test_rotations_orthonormal_and_consistent_with_spice(paper_profile, epoch_tdb_s):
    times = epoch_tdb_s + np.linspace(0.0, 10 * 86400.0, 7)
    for frame in ("MOON_PA", "MOON_ME"):
        rot = rotation("J2000", frame, times)
        assert np.allclose(rot @ np.swapaxes(rot, 1, 2), np.eye(3), atol=1e-13)
        assert np.allclose(np.linalg.det(rot), 1.0, atol=1e-13)
        back = rotation(frame, "J2000", times)
        assert np.allclose(back, np.swapaxes(rot, 1, 2), atol=1e-14)
    pa_me = rotation("MOON_PA", "MOON_ME", times[:1])[0]
    angle_arcsec = np.degrees(np.arccos((np.trace(pa_me) - 1) / 2)) * 3600
    assert 50 < angle_arcsec < 120  # the PA and ME axes differ by about 1 arcmin


def test_interpolated_tables_match_spice(paper_profile, epoch_tdb_s):
    table = EphemerisTable.build(paper_profile.dynamics, epoch_tdb_s, epoch_tdb_s + 10 * 86400.0)
    rng = np.random.default_rng(1)
    for t in epoch_tdb_s + rng.uniform(0, 10 * 86400.0, 25):
        for body in ("SUN", "EARTH", "JUPITER"):
            exact = body_states_mci(body, [t])[0, :3]
            # metre-level on 1e5..1e9 km: far below any force-model uncertainty
            assert np.linalg.norm(table.body_position(body, t) - exact) < 1e-3 * max(
                1.0, np.linalg.norm(exact) / 1e8
            )
        exact_rot = np.asarray(spice.pxform("J2000", "MOON_PA", t))
        assert np.abs(table.rotation_pa(t) - exact_rot).max() < 1e-10


def test_one_shared_basis_interpolates_every_table_as_before(paper_profile, epoch_tdb_s, rng):
    """The force model interpolates the rotation and the bodies with one interval and weight computation:
    bit for bit what a separate :func:`hermite_cubic` per table gives, at and between nodes and past both ends."""
    from lnss_lib.ephemeris import hermite_apply, hermite_basis, hermite_cubic

    table = EphemerisTable.build(paper_profile.dynamics, epoch_tdb_s, epoch_tdb_s + 86400.0)
    times = np.concatenate(
        [
            table.t0_tdb_s + table.step_s * np.arange(3),
            rng.uniform(table.t0_tdb_s - 50.0, table.t_end_tdb_s + 50.0, 200),
        ]
    )
    for t in times:
        basis = hermite_basis(table.rot_pa.shape[0], table.t0_tdb_s, table.step_s, t)
        pairs = [(table.rot_pa, table.rot_pa_rate)] + [
            (table.bodies[:, k, :3], table.bodies[:, k, 3:]) for k in range(3)
        ]
        for values, rates in pairs:
            shared, alone = np.empty(values.shape[1]), np.empty(values.shape[1])
            hermite_apply(values, rates, basis, shared)
            hermite_cubic(values, rates, table.t0_tdb_s, table.step_s, t, alone)
            assert np.array_equal(shared, alone)


def test_elements_round_trip(rng):
    gm = 4902.7999671
    n = 500
    el = np.column_stack(
        [
            rng.uniform(1800, 30000, n),
            rng.uniform(0.0, 0.95, n),
            rng.uniform(0.01, np.pi - 0.01, n),
            rng.uniform(0, 2 * np.pi, n),
            rng.uniform(0, 2 * np.pi, n),
            rng.uniform(0, 2 * np.pi, n),
        ]
    )
    back = state_to_elements(elements_to_state(el, gm), gm)
    assert np.allclose(back[:, :3], el[:, :3], rtol=1e-10, atol=1e-10)
    angle_diff = np.angle(np.exp(1j * (back[:, 3:] - el[:, 3:])))
    assert np.abs(angle_diff).max() < 1e-8


def test_state_to_elements_known_circular_orbit():
    gm = 4902.7999671
    r = 2000.0
    v = np.sqrt(gm / r)
    el = state_to_elements(np.array([r, 0, 0, 0, v * np.cos(0.3), v * np.sin(0.3)]), gm)
    assert el[0] == pytest.approx(r, rel=1e-12)
    assert el[1] < 1e-12
    assert el[2] == pytest.approx(0.3, abs=1e-12)


@pytest.mark.parametrize(
    "a, e, message",
    [
        (6000.0, 1.0, "eccentricity"),
        (6000.0, 1.3, "eccentricity"),
        (-5000.0, 0.1, "semi-major axis"),
        (6000.0, -0.1, "eccentricity"),
        (3000.0, 0.5, "hits the Moon"),
    ],
)
def test_bad_elements_rejected(a, e, message):
    with pytest.raises(ValueError, match=message):
        validate_elements(a, e, 1737.4)
