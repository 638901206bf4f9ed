"""Real ephemeris: CAPSTONE (JPL Horizons) arcs propagated with the full model, against the recorded trajectory."""

import numpy as np
import pytest

from lnss_lib.config import data_path
from lnss_lib.ephemeris import tdb_iso
from lnss_lib.validation import (
    capstone_arcs,
    estimate_srp,
    one_step_residuals,
    propagate_arc,
    read_horizons_vectors,
)


@pytest.fixture(scope="module")
def arcs(paper_profile):
    return capstone_arcs(paper_profile.validation.capstone, paper_profile.ephemeris)


def test_arcs_split_at_the_join(arcs):
    assert tdb_iso(arcs[0].time.values[-1]).startswith("2022-11-27T13:10")
    assert tdb_iso(arcs[1].time.values[0]).startswith("2022-11-27T13:20")


def test_first_arc_with_nominal_srp_within_3_km(paper_profile, arcs):
    arc = propagate_arc(
        paper_profile.dynamics,
        paper_profile.validation.capstone,
        arcs[0],
        srp_cr_area_mass_m2_kg=0.04,
    )
    assert arc.pos_error_km.values[-1] <= 3.0
    no_srp = propagate_arc(
        paper_profile.dynamics,
        paper_profile.validation.capstone,
        arcs[0],
        srp_cr_area_mass_m2_kg=0.0,
    )
    assert no_srp.pos_error_km.values[-1] > 2 * arc.pos_error_km.values[-1]


def test_estimated_srp_fits_first_arc_and_predicts_second(paper_profile, arcs):
    est = estimate_srp(paper_profile.dynamics, paper_profile.validation.capstone, arcs[0])
    assert 0.01 < est["cr_area_mass_m2_kg"] < 0.06
    assert est["end_error_km"] <= 0.3
    second = propagate_arc(
        paper_profile.dynamics,
        paper_profile.validation.capstone,
        arcs[1],
        srp_cr_area_mass_m2_kg=est["cr_area_mass_m2_kg"],
    )
    assert second.pos_error_km.values[-1] <= 1.0


def test_one_step_residuals_find_the_orbit_solution_join(paper_profile):
    ref = read_horizons_vectors(data_path(paper_profile.validation.capstone.file))
    res = one_step_residuals(paper_profile.dynamics, paper_profile.validation.capstone, ref)
    worst = int(np.argmax(res.one_step_error_km.values))
    assert tdb_iso(res.time.values[worst]).startswith("2022-11-27T13:20")
    assert res.one_step_error_km.values[worst] > 0.1
    assert np.sort(res.one_step_error_km.values)[-2] < 1e-3


def test_horizons_reader_rejects_other_files(tmp_path):
    bad = tmp_path / "x.txt"
    bad.write_text("not a horizons file")
    with pytest.raises(ValueError, match="SOE"):
        read_horizons_vectors(bad)


def test_without_term_switches_one_term_off(paper_profile):
    from lnss_lib.validation import without_term

    forces = paper_profile.forces
    assert paper_profile.with_overrides(without_term(forces, "SUN")).forces.third_bodies == (
        "EARTH",
        "JUPITER",
    )
    assert without_term(forces, "harmonics") == {"gravity": {"degree": 0}}
    assert without_term(forces, "srp") == {"forces": {"srp": False}}
    with pytest.raises(ValueError, match="'drag'"):
        without_term(forces, "drag")


def test_variant_differences_zero_for_the_same_model_and_not_for_another(
    paper_profile, epoch_tdb_s
):
    from lnss_lib.propagator import elements_deg_to_states
    from lnss_lib.validation import variant_differences, without_term

    dynamics = paper_profile.dynamics
    state = elements_deg_to_states(dynamics, [[6143.0, 0.6, 51.7, 0.0, 90.0, 0.0]], epoch_tdb_s)[0]
    no_earth = paper_profile.with_overrides(without_term(paper_profile.forces, "EARTH")).dynamics
    variants = {"same": dynamics, "no Earth": no_earth}
    diff = variant_differences(dynamics, state, epoch_tdb_s, 7200.0, 900.0, variants).difference_km
    assert np.all(diff.sel(variant="same").values == 0.0)
    assert diff.sel(variant="no Earth").values[-1] > 1e-6
