"""The Moon orbital-plane element frame (Ely 2005; LuPNT MOON_OP) against its definition and the Moon's orbit."""

import numpy as np
import pytest

from lnss_lib.elements import elements_to_state, state_to_elements
from lnss_lib.ephemeris import body_states_mci, rotation, tdb_seconds
from lnss_lib.frames import (
    ELEMENT_FRAMES,
    element_frame_to_j2000,
    moon_op_axes_j2000,
    moon_op_to_j2000,
)

# Epochs across the 18.6-year nodal cycle: the study epoch, Ely's, LuPNT's two, and two more.
EPOCHS = [
    "2025-05-01T00:00:00",
    "2009-07-15T01:00:00",
    "2022-01-15T00:00:00",
    "2035-02-01T00:00:00",
    "2016-03-01T00:00:00",
    "2030-06-01T00:00:00",
]
ORTHO_TOL = 1e-12
# Osculating inclination of the Moon's orbit to the ecliptic: mean 5.145 deg, solar perturbations
# swing it by about +-0.15 deg; the lunar equator is 1.543 deg from the ecliptic on the other side.
MEAN_INC_TO_ECLIPTIC_DEG = 5.145
MEAN_INC_TO_LUNAR_EQUATOR_DEG = 5.145 + 1.543
OSCULATION_TOL_DEG = 0.3


def _angle_deg(a, b):
    return float(
        np.degrees(
            np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0))
        )
    )


@pytest.fixture(scope="module", params=EPOCHS)
def epoch(request, paper_profile):
    return tdb_seconds(request.param, "TDB")


def test_axes_are_a_right_handed_orthonormal_triad(epoch):
    rot = moon_op_to_j2000(epoch)
    assert np.allclose(rot.T @ rot, np.eye(3), atol=ORTHO_TOL)
    assert np.linalg.det(rot) == pytest.approx(1.0, abs=ORTHO_TOL)


def test_earth_moves_in_the_xy_plane_at_the_epoch(epoch):
    earth = body_states_mci("EARTH", np.array([epoch]))[0]
    earth_op = moon_op_to_j2000(epoch).T @ earth[:3], moon_op_to_j2000(epoch).T @ earth[3:]
    assert abs(earth_op[0][2]) < 1e-9 * np.linalg.norm(earth[:3])
    assert abs(earth_op[1][2]) < 1e-9 * np.linalg.norm(earth[3:])
    # the Earth's orbit about the Moon is prograde about +z
    assert np.cross(earth_op[0], earth_op[1])[2] > 0.0


def test_x_axis_is_the_node_on_the_lunar_equator(epoch):
    rot = moon_op_to_j2000(epoch)
    pole = rotation("MOON_ME", "J2000", np.array([epoch]))[0][:, 2]
    assert abs(rot[:, 0] @ pole) < ORTHO_TOL and abs(rot[:, 0] @ rot[:, 2]) < ORTHO_TOL
    # x = unit(pole x z) and y x z = x: the pole leans towards +y, with no x component
    assert rot[:, 1] @ pole > 0.0


def test_orbit_normal_is_5_deg_from_the_ecliptic_pole_and_6_7_deg_from_the_lunar_pole(epoch):
    z = moon_op_to_j2000(epoch)[:, 2]
    ecliptic_pole = rotation("ECLIPJ2000", "J2000", np.array([epoch]))[0][:, 2]
    lunar_pole = rotation("MOON_ME", "J2000", np.array([epoch]))[0][:, 2]
    assert _angle_deg(z, ecliptic_pole) == pytest.approx(
        MEAN_INC_TO_ECLIPTIC_DEG, abs=OSCULATION_TOL_DEG
    )
    assert _angle_deg(z, lunar_pole) == pytest.approx(
        MEAN_INC_TO_LUNAR_EQUATOR_DEG, abs=OSCULATION_TOL_DEG
    )


def test_iau_pole_and_me_pole_give_nearly_the_same_frame(epoch):
    """Ely's IAU pole vs LuPNT's MOON_ME pole: the poles agree to ~0.003 deg; the node, 9x more sensitive, to 0.05."""
    me, iau = moon_op_to_j2000(epoch), moon_op_to_j2000(epoch, pole_frame="IAU_MOON")
    assert np.array_equal(me[:, 2], iau[:, 2])
    assert 0.0 < _angle_deg(me[:, 0], iau[:, 0]) < 0.05


def test_elements_round_trip_through_the_frame(paper_profile, epoch, rng):
    gm = paper_profile.gravity.gm_km3_s2
    el = np.column_stack(
        [
            rng.uniform(3000, 20000, 20),
            rng.uniform(0.01, 0.7, 20),
            np.radians(rng.uniform(5, 175, 20)),
            np.radians(rng.uniform(0, 360, 20)),
            np.radians(rng.uniform(0, 360, 20)),
            np.radians(rng.uniform(0, 360, 20)),
        ]
    )
    rot = element_frame_to_j2000(paper_profile.dynamics, epoch, "moon_op")
    assert np.array_equal(rot, moon_op_to_j2000(epoch))
    s_op = elements_to_state(el, gm)
    s_j2000 = np.concatenate([s_op[:, :3] @ rot.T, s_op[:, 3:] @ rot.T], axis=1)
    back = state_to_elements(
        np.concatenate([s_j2000[:, :3] @ rot, s_j2000[:, 3:] @ rot], axis=1), gm
    )
    assert np.allclose(back[:, :2], el[:, :2], rtol=1e-10)
    assert np.allclose(np.angle(np.exp(1j * (back[:, 2:] - el[:, 2:]))), 0.0, atol=1e-9)
    # the J2000 state is a different orbit description: inclinations differ by up to the frame tilt
    assert not np.allclose(state_to_elements(s_j2000, gm)[:, 2], el[:, 2], atol=1e-3)


def test_moon_op_is_an_element_frame():
    assert "moon_op" in ELEMENT_FRAMES


def test_degenerate_geometry_is_refused():
    with pytest.raises(ValueError, match="undefined"):
        moon_op_axes_j2000(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 2.0]))
    with pytest.raises(ValueError, match="pole frame"):
        moon_op_to_j2000(0.0, pole_frame="ECLIPJ2000")
