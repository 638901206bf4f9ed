"""Notebook 05's study (lnss_lib.studies.standalone_elfo): Table 4 beside the workbook."""

import pytest

from lnss_lib.paper import TABLE_4
from lnss_lib.studies import standalone_elfo as se


def test_difference_agreement_and_table():
    metrics = {
        "pdop_mean_3sigma": TABLE_4["pdop_mean_3sigma"] * 1.04,
        "mean_visible_sats": TABLE_4["mean_visible_sats"] * 0.9,
    }
    assert se.difference_pct(metrics, "pdop_mean_3sigma") == pytest.approx(4.0)
    assert se.agreement(metrics, "pdop_mean_3sigma") == "Agrees (+4.0%)."
    assert se.agreement(metrics, "mean_visible_sats") == "Differs (-10.0%)."
    table = se.table4_comparison(
        metrics, [("PDOP", "pdop_mean_3sigma", "why not"), ("visible", "mean_visible_sats", "")]
    )
    assert list(table["difference (%)"]) == [4.0, -10.0]
    assert table.loc[0, "paper"] == TABLE_4["pdop_mean_3sigma"] and table.loc[0, "why"] == "why not"
    with pytest.raises(ValueError, match="no metric 'n_sat'"):
        se.difference_pct({"n_sat": 16}, "n_sat")
