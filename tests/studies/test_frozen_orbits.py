"""Notebook 08's frozen-orbit study: which published orbits are frozen in which frame."""

import numpy as np
import pytest

from lnss_lib.design_life.frozen import FrozenModel
from lnss_lib.studies.frozen_orbits import frozen_family, frozen_words, published_orbits


def test_table4_is_frozen_in_moon_op_only_and_ely_librates(paper_profile):
    table = published_orbits(paper_profile)
    t4 = table[table["orbit"].str.startswith("Table 4")]
    assert set(t4.loc[t4["read_in"] == "moon_op", "verdict"]) == {"frozen"}
    assert "frozen" not in set(t4.loc[t4["read_in"] == "lunar equator", "verdict"])
    ely = table[table["orbit"].str.startswith("Ely")]
    assert set(ely["verdict"]) == {"librating"} and (ely["min_mean_perilune_alt_km"] > 100.0).all()
    assert frozen_words(table) == list(table["verdict"])


def test_family_table_reaches_kozai_at_large_a():
    model = FrozenModel.circular(4902.8, 2.03e-4, 1738.0, 398600.4, 384400.0)
    family = frozen_family(model, [30000.0])
    row = family[family["curve"] == "i at e = 0.6"].iloc[0]
    assert row["inc_deg"] == pytest.approx(
        np.degrees(np.arccos(np.sqrt(0.6 * 0.64))), abs=0.02
    )  # J2 ~ a^-5: gone
