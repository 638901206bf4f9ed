"""Frames and time scales (lnss_lib.frames): element frames, RTN, UTC and TT, precession-nutation, TEME -> J2000.

Independent references: SPICE's calendar and its own IAU-1976 / IAU-1980 frames of date, the size
of the precession since J2000, the lunar pole from SPICE, orthonormality.
"""

import datetime as dt
import math

import numpy as np
import pytest
import spiceypy as spice
from orbit_cases import random_elements, state_from_nu

from lnss_lib import frames
from lnss_lib.ephemeris import rotation, tdb_seconds
from lnss_lib.settings import load_settings


def _spice_dynamic_frames():
    """True- and mean-of-date Earth frames of SPICE (full 106-term IAU-1980 nutation, IAU-1976 precession)."""
    pool = []
    for code, name, family in (
        (1400901, "LNSS_TEST_TOD", "TRUE_EQUATOR_AND_EQUINOX_OF_DATE"),
        (1400902, "LNSS_TEST_MOD", "MEAN_EQUATOR_AND_EQUINOX_OF_DATE"),
    ):
        pool += [
            f"FRAME_{name} = {code}",
            f"FRAME_{code}_NAME = '{name}'",
            f"FRAME_{code}_CLASS = 5",
            f"FRAME_{code}_CLASS_ID = {code}",
            f"FRAME_{code}_CENTER = 399",
            f"FRAME_{code}_RELATIVE = 'J2000'",
            f"FRAME_{code}_DEF_STYLE = 'PARAMETERIZED'",
            f"FRAME_{code}_FAMILY = '{family}'",
            f"FRAME_{code}_PREC_MODEL = 'EARTH_IAU_1976'",
            f"FRAME_{code}_ROTATION_STATE = 'ROTATING'",
        ]
        if "TRUE" in family:
            pool.append(f"FRAME_{code}_NUT_MODEL = 'EARTH_IAU_1980'")
    spice.lmpool(pool)


def _angle_mas(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle between two nearby rotations (mas), from the antisymmetric part of a b^T (sin theta)."""
    d = a @ b.T
    axial = 0.5 * np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
    return float(np.degrees(np.arcsin(min(np.linalg.norm(axial), 1.0))) * 3.6e6)


@pytest.fixture(scope="module")
def profile(ci_profile):
    return ci_profile


def test_utc_julian_date_matches_spice_calendar(profile):
    et = tdb_seconds("2025-05-01T12:00:00")
    jd, fr = frames.utc_julian_dates(et)
    utc = dt.datetime.fromisoformat(spice.et2utc(et, "ISOC", 6))
    jd_spice = 2451545.0 + (utc - dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0
    assert abs((jd[0] - jd_spice) + fr[0]) * 86400.0 < 1e-4
    # TDB - UTC = 32.184 s + 37 leap seconds (+/- 2 ms periodic terms) in 2025.
    assert abs((2451545.0 + et / 86400.0 - (jd[0] + fr[0])) * 86400.0 - 69.184) < 2e-3


def test_teme_rotation_orthonormal_and_precession_sized(profile):
    t = tdb_seconds("2025-05-01T00:00:00") + np.array([0.0, 5 * 86400.0])
    tc = frames.tt_centuries(t)
    rot = frames.teme_to_j2000(tc)
    assert np.allclose(rot @ np.swapaxes(rot, 1, 2), np.eye(3), atol=1e-14)
    assert np.allclose(np.linalg.det(rot), 1.0, atol=1e-14)
    # The TEME pole is the true pole of date: its angle to the J2000 pole is theta_A of the precession
    # (2004.31 arcsec per century, ~0.141 deg in 25 years) within the nutation (|deps|, |dpsi sin eps| < 10 arcsec).
    pole = rot[:, :, 2]
    tilt_arcsec = np.degrees(np.arccos(pole[:, 2])) * 3600.0
    assert np.all(np.abs(tilt_arcsec - 2004.3109 * tc) < 10.0)
    # Total rotation angle: general precession in longitude, ~50.3 arcsec per year (0.354 deg since J2000).
    angle_deg = np.degrees(np.arccos((np.trace(rot, axis1=1, axis2=2) - 1.0) / 2.0))
    assert np.all(np.abs(angle_deg - 5029.0966 * tc / 3600.0) < 0.01)
    r = np.array([26560.0, -1200.0, 300.0])
    assert np.allclose(np.linalg.norm(rot @ r, axis=-1), np.linalg.norm(r), rtol=1e-14)


def test_precession_nutation_against_spice_frames(profile):
    """Independent cross-check: SPICE's own IAU-1976 / full IAU-1980 frames of date."""
    _spice_dynamic_frames()
    start = tdb_seconds("2025-05-01T00:00:00")
    # The paper's epochs (where dpsi happens to be only ~0.3 arcsec) and one with dpsi ~ 17 arcsec.
    for et in (
        start,
        start + 3.3 * 86400.0,
        start + 9.7 * 86400.0,
        tdb_seconds("2029-06-01T00:00:00"),
    ):
        tc = frames.tt_centuries(et)
        p = frames.precession_iau1976(tc)[0]
        n = frames.nutation_matrix(tc)[0]
        mod_to_j2000 = np.asarray(spice.pxform("LNSS_TEST_MOD", "J2000", et))
        tod_to_j2000 = np.asarray(spice.pxform("LNSS_TEST_TOD", "J2000", et))
        assert _angle_mas(p.T, mod_to_j2000) < 1.0
        # Truncated nutation: bounded by the sum of the skipped terms' amplitudes.
        bound = frames.NUTATION_SKIPPED_DPSI_MAS + frames.NUTATION_SKIPPED_DEPS_MAS
        assert _angle_mas(p.T @ n.T, tod_to_j2000) < bound
        # ... and with all of them left out the error would be the full nutation (~ 10 arcsec), far above it.
        assert _angle_mas(p.T, tod_to_j2000) > 20 * bound
        # TEME = true equator of date rotated about its pole by the equation of the equinoxes
        # EqE = dpsi cos(eps), which is -N[0, 1] of SPICE's mean-to-true nutation matrix.
        n_spice = np.asarray(spice.pxform("LNSS_TEST_MOD", "LNSS_TEST_TOD", et))
        eqe = -n_spice[0, 1]
        c, s = math.cos(eqe), math.sin(eqe)
        teme_to_tod = np.array(
            [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        )  # r_TOD = R3(-EqE) r_TEME
        assert _angle_mas(frames.teme_to_j2000(tc)[0], tod_to_j2000 @ teme_to_tod) < bound
    assert 2.0 * abs(eqe) * 206264806.2 > 20 * bound  # a sign error in EqE would be resolved


def test_lunar_equator_element_frame(paper_profile, epoch_tdb_s):
    rot = frames.element_frame_to_j2000(paper_profile.dynamics, epoch_tdb_s)
    pole_j2000 = rot[:, 2]
    moon_pole = rotation("MOON_ME", "J2000", [epoch_tdb_s])[0][:, 2]
    assert np.allclose(pole_j2000, moon_pole, atol=1e-14)
    tilt_deg = np.degrees(np.arccos(pole_j2000[2]))
    assert 20.0 < tilt_deg < 26.0  # the lunar pole is about 22 deg from the J2000 pole
    j2000 = load_settings("paper", overrides={"frames": {"element_frame": "j2000"}})
    assert np.array_equal(frames.element_frame_to_j2000(j2000.dynamics, epoch_tdb_s), np.eye(3))
    with pytest.raises(ValueError, match="ecliptic"):  # refused when the profile loads
        load_settings("paper", overrides={"frames": {"element_frame": "ecliptic"}})
    with pytest.raises(
        ValueError, match="ecliptic"
    ):  # and by the kernel, for a frame passed in code
        frames.element_frame_to_j2000(paper_profile.dynamics, epoch_tdb_s, "ecliptic")


def test_tabulated_moon_fixed_rotation_agrees_with_spice_within_the_hermite_remainder(
    paper_profile, epoch_tdb_s
):
    """The force model's J2000 -> MOON_PA table turned by the fixed MOON_PA -> MOON_ME offset, against SPICE at the
    middle of every table interval over a year (where the cubic Hermite error peaks). For an entry turning at the
    Moon's spin rate omega the remainder is (omega h)^4 / 384 (1.4e-12 at h = 1800 s); the binary PCK's libration
    angles are Chebyshev records whose derivatives are only piecewise smooth, allowed a factor 4 (measured 1.2).
    At 20 000 km that is 0.1 mm."""
    from lnss_lib.ephemeris import EphemerisTable

    dyn = paper_profile.dynamics
    table = EphemerisTable.build(dyn, epoch_tdb_s, epoch_tdb_s + 365.25 * 86400.0)
    offset = frames.fixed_offset(dyn.frames.gravity, "MOON_ME", table.t0_tdb_s, table.t_end_tdb_s)
    assert offset is not None
    t = table.t0_tdb_s + table.step_s * (np.arange(2, table.bodies.shape[0] - 3) + 0.5)
    error = np.max(
        np.abs(frames.moon_fixed_rotations(offset, table, t) - rotation("J2000", "MOON_ME", t))
    )
    spin_rad_s = 2.0 * np.pi / (27.321661 * 86400.0)
    remainder = (spin_rad_s * table.step_s) ** 4 / 384.0
    assert 0.1 * remainder < error < 4.0 * remainder
    assert frames.fixed_offset(dyn.frames.gravity, "IAU_MOON", t[0], t[-1]) is None
    with pytest.raises(ValueError, match="outside the ephemeris table"):
        table.rotations_pa([table.t_end_tdb_s + 1.0])


def test_rtn_basis_orthonormal_and_round_trip():
    rng = np.random.default_rng(3)
    states = np.stack([state_from_nu(el) for el in random_elements(rng, 20)])
    basis = frames.rtn_basis(states)
    np.testing.assert_allclose(
        basis @ np.swapaxes(basis, -1, -2), np.broadcast_to(np.eye(3), basis.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(basis), 1.0, atol=1e-13)
    vec = rng.normal(size=(20, 3))
    np.testing.assert_allclose(frames.from_rtn(frames.to_rtn(vec, states), states), vec, atol=1e-13)
    np.testing.assert_allclose(
        frames.to_rtn(states[:, :3], states)[:, 0], np.linalg.norm(states[:, :3], axis=1)
    )


@pytest.mark.parametrize(
    "function, call",
    [
        ("deltet", lambda real, e, kind: real(e, "NOSUCH")),
        ("unitim", lambda real, e, insys, outsys: real(e, "NOSUCH", outsys)),
    ],
)
def test_time_scale_spice_errors_are_named(profile, monkeypatch, function, call):
    """The TDB -> UTC (deltet) and TDB -> TT (unitim) conversions raise SpiceError naming what was asked and the leap-
    second kernel, like every other SPICE call (a bare SpiceyError and its banner before)."""
    from lnss_lib.errors import SpiceError

    real = getattr(spice, function)
    monkeypatch.setattr(
        frames.spice, function, lambda *args: call(real, *args)
    )  # SPICE fails on the time system
    convert = frames.utc_julian_dates if function == "deltet" else frames.tt_centuries
    with pytest.raises(
        SpiceError, match=f"SPICE could not .*\\({function}\\) .*leap-second kernel"
    ) as raised:
        convert(np.array([tdb_seconds("2025-05-01T00:00:00")]))
    assert "=====" not in str(raised.value) and raised.value.code.startswith("SPICE(")
