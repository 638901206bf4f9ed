"""Notebook 01's study (lnss_lib.studies.propagator_validation): ephemeris-table interpolation errors."""

from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.ephemeris import EphemerisTable
from lnss_lib.studies.propagator_validation import table_interpolation_errors


def test_interpolation_error_table_is_far_below_modelled_forces(paper_profile, epoch_tdb_s):
    table = EphemerisTable.build(
        paper_profile.dynamics, epoch_tdb_s, epoch_tdb_s + 2 * SECONDS_PER_DAY
    )
    errors = table_interpolation_errors(paper_profile.dynamics, table, n_probe=40)
    assert len(errors) == 4
    assert (
        errors["acceleration error (km/s^2)"] < 1e-15
    ).all()  # relativity on a lunar orbit is ~1e-14
