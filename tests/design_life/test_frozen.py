"""Frozen and librating orbits (lnss_lib.design_life.frozen): the Kozai limit, the integrals against the averaged equations,
the lunar-J2 shift of the family, the Table 4 and Ely (2005) orbits in moon_op, and one year of the full model."""

import dataclasses

import numpy as np
import pytest

from lnss_lib.catalogue import constellation_states_mci, file_epoch_profile, load_constellation
from lnss_lib.design_life import frozen as fz
from lnss_lib.design_life import screen as st
from lnss_lib.design_life import secular
from lnss_lib.propagator import elements_deg_to_states, propagate_states
from lnss_lib.studies.frozen_orbits import epoch_swap

GM, J2, R = 4902.7999671, 2.0323e-4, 1738.0
GM_EARTH, A_EARTH_KM = 398600.436233, 384400.0


def _kozai_inc_deg(e):
    """The quadrupole Lidov-Kozai frozen family at AOP 90/270 deg: e^2 + (5/3) cos^2 i = 1."""
    return np.degrees(np.arccos(np.sqrt(0.6 * (1.0 - e**2))))


@pytest.fixture(scope="module")
def kozai():
    return fz.FrozenModel.circular(GM, 0.0, R, GM_EARTH, A_EARTH_KM)


@pytest.fixture(scope="module")
def lunar(paper_profile, epoch_tdb_s):
    field = secular.SecularField.from_settings(
        paper_profile.stability, paper_profile.dynamics, epoch_tdb_s, 365.25
    )
    return field, fz.FrozenModel.from_field(field)


@pytest.mark.parametrize("sma_km", [3000.0, 6143.0, 20000.0])
@pytest.mark.parametrize("e", [0.2, 0.6, 0.75])
def test_without_lunar_j2_the_frozen_family_is_kozais(kozai, sma_km, e):
    inc = fz.frozen_inclination_deg(kozai, sma_km, e)
    assert inc == pytest.approx(_kozai_inc_deg(e), abs=1e-6)
    assert fz.frozen_eccentricity(kozai, sma_km, inc) == pytest.approx(e, abs=1e-8)
    lib = fz.libration(kozai, sma_km, e, inc, 270.0)
    assert lib["librating"] and lib["centre_aop_deg"] == 270.0
    assert lib["ecc_max"] - lib["ecc_min"] < 1e-6 and lib["aop_max_deg"] - lib["aop_min_deg"] < 0.1


@pytest.mark.parametrize("inc_deg, aop_deg", [(60.0, 90.0), (45.0, 60.0), (70.0, 10.0)])
def test_libration_ranges_are_those_of_the_averaged_equations(kozai, inc_deg, aop_deg):
    # the level curve of the integrals against the Milankovitch equations integrated over several cycles
    a, e = 6000.0, 0.5
    field = secular.SecularField.constant(kozai.tide, [0.0, 0.0, 1.0], GM, 0.0, R)
    e_vec, j_vec = fz.orbit_vectors_deg(e, inc_deg, aop_deg)
    res = secular.integrate_secular(
        [a], e_vec, j_vec, field, 6000.0, output_step_days=0.25, rtol=1e-11, atol=1e-13
    )
    el = secular.elements_from_vectors(res["e"][0], res["j"][0])
    lib = fz.libration(kozai, a, e, inc_deg, aop_deg)
    assert el["ecc"].min() == pytest.approx(lib["ecc_min"], abs=2e-4)
    assert el["ecc"].max() == pytest.approx(lib["ecc_max"], abs=2e-4)
    assert el["inc_deg"].min() == pytest.approx(lib["inc_min_deg"], abs=0.02)
    assert el["inc_deg"].max() == pytest.approx(lib["inc_max_deg"], abs=0.02)
    crosses_node = np.any(np.abs(np.sin(np.radians(el["aop_deg"]))) < 0.02)
    assert lib["librating"] == (not crosses_node)
    if lib["librating"]:
        assert el["aop_deg"].min() == pytest.approx(lib["aop_min_deg"], abs=0.1)
        assert el["aop_deg"].max() == pytest.approx(lib["aop_max_deg"], abs=0.1)


def test_lunar_j2_raises_the_family_at_low_a_and_fades_with_a(lunar):
    _, model = lunar
    inc = np.array(
        [fz.frozen_inclination_deg(model, a, 0.6) for a in (3000.0, 6143.0, 10000.0, 20000.0)]
    )
    assert np.all(np.diff(inc) < 0.0) and inc[0] > _kozai_inc_deg(0.6) + 5.0
    # J2's AOP rate over the tide's falls as a^-3.5 / a^1.5 = a^-5: negligible at 20000 km
    assert inc[-1] == pytest.approx(_kozai_inc_deg(0.6), abs=0.05)
    assert 5.5 < model.tilt_deg < 7.5  # Cassini state: 5.14 + 1.54 deg
    assert (
        1.5 < np.degrees(np.linalg.norm(model.frame_spin)) * 86400.0 * 365.25 < 2.0
    )  # 5.1 deg x 2 pi / 18.6 yr


def test_table4_elfo_is_nearly_frozen_in_moon_op(lunar):
    _, model = lunar
    inc_frozen = fz.frozen_inclination_deg(model, 6143.0, 0.6)
    assert 51.7 < inc_frozen < 53.7  # Kozai's 51.7 deg, J2 adds about 1 deg
    in_op = fz.libration(model, 6143.0, 0.6, 51.7, 90.0)
    assert in_op["librating"] and in_op["ecc_max"] - in_op["ecc_min"] < 0.03


@pytest.mark.parametrize(
    "origin, shift_days", [("inertial", 3399.0), ("lunar_equator_of_epoch", 13.6)]
)
def test_epoch_swap_of_the_two_planes_read_in_the_lunar_equator(paper_profile, origin, shift_days):
    # Read in the lunar equator, the planes (RAAN 0 and 180 deg) lie at i -+ 6.7 deg cos(RAAN - node) to the Earth's
    # plane, node: that plane's node on the lunar equator. With a RAAN origin fixed in space the node regresses in
    # 18.6 years, so half of that swaps the planes' roles; the workbook's lunar equator of epoch counts RAAN from the
    # prime meridian at the epoch, which the node circles every draconic month (27.2 d): half of that swaps them.
    swap = epoch_swap(
        paper_profile, [6.0, 6.0 + shift_days], origin=origin
    )  # day 6: near the largest split
    (_, first), (_, second) = swap.groupby("shift_days")
    split0 = first["inc_op_deg"].iloc[0] - first["inc_op_deg"].iloc[1]
    split1 = second["inc_op_deg"].iloc[0] - second["inc_op_deg"].iloc[1]
    assert abs(split0) > 4.0 and abs(split1) > 4.0 and np.sign(split0) != np.sign(split1)
    swings0, swings1 = first["ecc_swing"].to_numpy(), second["ecc_swing"].to_numpy()
    far0, far1 = int(np.argmax(swings0)), int(np.argmax(swings1))
    assert (
        far0 != far1
        and swings0[far0] > 1.5 * swings0[1 - far0]
        and swings1[far1] > 1.5 * swings1[1 - far1]
    )


def test_ely_2005_orbit_librates_about_aop_90(lunar):
    # Ely (2005) eq. 17: a 6541.4 km, e 0.6, i 56.2 deg, AOP 90 deg in the Earth-orbit-plane frame, "frozen":
    # its AOP librates about 90 deg (apolune held over the South Pole) and e and i swing and come back
    _, model = lunar
    lib = fz.libration(model, 6541.4, 0.6, 56.2, 90.0)
    assert lib["librating"] and lib["centre_aop_deg"] == 90.0
    # Ely's e-AOP portraits of this orbit (LuPNT ex_frozen_orbits: the window e 0.5-0.75, AOP 70-110 deg)
    assert (
        70.0 < lib["aop_min_deg"] < lib["aop_max_deg"] < 110.0
        and 0.5 < lib["ecc_min"] < lib["ecc_max"] < 0.75
    )
    perilune_km = 6541.4 * (1.0 - lib["ecc_max"]) - 1737.4
    assert perilune_km > 100.0  # Ely, p. 310: above 100 km


def test_bad_inputs_name_the_value(kozai):
    with pytest.raises(ValueError, match="1.2"):
        fz.frozen_inclination_deg(kozai, 6000.0, 1.2)
    with pytest.raises(ValueError, match="-5"):
        fz.libration(kozai, -5.0, 0.5, 50.0, 90.0)


def test_a_frozen_and_a_librating_orbit_flown_a_year_with_the_full_model_stay_within_their_libration(
    paper_profile, epoch_tdb_s, lunar
):
    # in moon_op: the frozen orbit at a 6143 km, e 0.6, and the Table 4 ELFO's far plane (i 45 deg), which librates
    # down to e 0.36 within the year. Elements are read against the Earth's plane of the time (mean_plane_axes).
    field, model = lunar
    a, e = 6143.0, 0.6
    orbits = [(a, e, fz.frozen_inclination_deg(model, a, e), 90.0), (a, e, 45.0, 90.0)]
    profile = paper_profile.with_overrides({"frames": {"element_frame": "moon_op"}})
    states = elements_deg_to_states(
        profile.dynamics, [[a_, e_, i_, 0.0, w_, 0.0] for a_, e_, i_, w_ in orbits], epoch_tdb_s
    )
    ds = propagate_states(
        paper_profile.dynamics,
        states,
        epoch_tdb_s,
        365.0 * 86400.0,
        6 * 3600.0,
        setting="design_life",
        degree=8,
        batch=True,
    )
    rot = fz.mean_plane_axes(field, (ds["time"].values - epoch_tdb_s) / 86400.0)
    for k, orbit in enumerate(orbits):
        sv = np.concatenate([ds["r_mci_km"].values[k], ds["v_mci_kms"].values[k]], axis=-1)
        _, e_vec, j_vec = secular.orbit_vectors_ej(sv, GM)
        el = secular.elements_from_vectors(
            np.einsum("tji,tj->ti", rot, e_vec), np.einsum("tji,tj->ti", rot, j_vec)
        )
        lib, allow = fz.libration(model, *orbit), fz.allowances(model, *orbit)
        assert (
            lib["ecc_min"] - allow["ecc"] <= el["ecc"].min()
            and el["ecc"].max() <= lib["ecc_max"] + allow["ecc"]
        )
        assert lib["inc_min_deg"] - allow["inc_deg"] <= el["inc_deg"].min()
        assert el["inc_deg"].max() <= lib["inc_max_deg"] + allow["inc_deg"]
        assert np.all(
            np.sin(np.radians(el["aop_deg"])) > 0.9
        )  # apolune held south: AOP 90 +- 25 deg
        assert np.ptp(el["ecc"]) > allow["ecc"]  # the band is not slack
    # the libration is real: the far plane reaches the predicted lowest e (within the allowance) in the year
    assert el["ecc"].min() < lib["ecc_min"] + allow["ecc"] and lib["ecc_max"] - lib["ecc_min"] > 0.2


def test_ely_phased_constellation_keeps_its_mean_perilune_above_100_km_for_ten_years(paper_profile):
    # Ely (2005, p. 310): ten years with no manoeuvre, perilune above 100 km. Averaged model (cheap) here; the
    # full model is notebook 08's anchor. The mean perilune clears 100 km by more than the monthly tidal swing.
    c = load_constellation("ely2005_elfo_3sat_phased", paper_profile.dynamics)
    cs = constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, c, "file")
    file_profile = file_epoch_profile(paper_profile, c)
    mean_model = dataclasses.replace(
        file_profile.stability, monthly_terms=False
    )  # the mean perilune; the screen (monthly terms restored) must call it stable too
    screen, verdict = (
        st.screen_states(
            stability, file_profile.dynamics, cs.states_mci, cs.t_epoch_tdb_s, life_days=3652.5
        )
        for stability in (mean_model, file_profile.stability)
    )
    assert verdict.attrs["stable"] and verdict.attrs["monthly_terms"]
    field = secular.SecularField.from_settings(
        paper_profile.stability, paper_profile.dynamics, cs.t_epoch_tdb_s, 30.0
    )
    read = fz.mean_plane_elements(field, c.elements_deg[:1], cs.rot_to_j2000)
    assert read["inc_deg"][0] == pytest.approx(56.2, abs=0.3)  # the file's moon_op, month-averaged
    allow = fz.allowances(
        fz.FrozenModel.from_field(field), 6541.4, 0.6, float(read["inc_deg"][0]), 90.0
    )
    assert screen.attrs["stable"]
    assert screen.attrs["min_perilune_alt_km"] > 100.0 + 6541.4 * allow["ecc_monthly"]
