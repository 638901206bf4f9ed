"""Robust or lucky: the loss of one satellite and insertion errors flown in closed loop (lnss_lib.studies.robustness)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from lnss_lib.design_life.evaluation import run_design_life
from lnss_lib.settings import load_settings
from lnss_lib.studies import robustness as rb
from lnss_lib.studies.design_life import flown_elements

LIFE_DAYS = 30.4375
"""One navigation month: enough for the controller's first corrections, cheap enough for the default suite."""


@pytest.fixture(scope="module")
def settings():
    return load_settings("ci_operational")


@pytest.fixture(scope="module")
def elfo(settings):
    """The Table 4 ELFO as two planes of three: six satellites, so every loss matters."""
    e = settings.standalone_elfo
    return (e.sma_km, e.ecc, e.aop_deg, e.inc_deg, 2, 3)


def test_losing_a_satellite_never_raises_the_availability(settings, elfo):
    """A satellite fewer leaves every epoch's geometry matrix a row shorter: DOP can only grow (or the fix be lost), so
    no availability of the N-1 rows exceeds the full constellation's; the worst loss comes first."""
    flight = run_design_life(settings, flown_elements(elfo), LIFE_DAYS, natural=False)["controlled"]
    table = rb.loss_table(settings, flight)
    assert table["lost_sat"][0] == -1 and sorted(table["lost_sat"][1:]) == list(range(6))
    full = table.iloc[0]
    for key in (
        "pdop_avail_pct_life",
        "pdop_avail_pct_worst_month",
        "hdop_avail_pct_life",
        "hdop_avail_pct_worst_month",
    ):
        assert (table[key][1:] <= full[key] + 1e-9).all()
    assert table["pdop_avail_pct_worst_month"][1] == table["pdop_avail_pct_worst_month"][1:].min()
    assert (
        table["pdop_avail_pct_life"][1:].min() < full["pdop_avail_pct_life"]
    )  # six satellites: a loss shows


def test_zero_dispersions_fly_the_nominal_design(settings, elfo):
    """Errors of zero insert every satellite on its design: the flight is the nominal one, bit for bit."""
    zero = dataclasses.replace(
        settings.robustness,
        sma_km=0.0,
        ecc=0.0,
        inc_deg=0.0,
        raan_deg=0.0,
        aop_deg=0.0,
        anomaly_deg=0.0,
    )
    errors = rb.insertion_errors_deg(zero, flown_elements(elfo), np.random.default_rng(1))
    assert not errors.any()
    assert rb.dispersed_flight(settings, elfo, errors, LIFE_DAYS) == rb.dispersed_flight(
        settings, elfo, None, LIFE_DAYS
    )


def test_insertion_errors_have_the_stated_spread_and_keep_e_non_negative(settings):
    """20,000 draws: each element's sample standard deviation is its 1-sigma within five standard errors
    (sigma / sqrt(2 n)); an error that would make e negative is reflected with the perilune turned half a turn."""
    robustness = settings.robustness
    elements = np.tile([6000.0, 0.3, 60.0, 0.0, 90.0, 0.0], (20_000, 1))
    errors = rb.insertion_errors_deg(robustness, elements, np.random.default_rng(7))
    sigma = [
        robustness.sma_km,
        robustness.ecc,
        robustness.inc_deg,
        robustness.raan_deg,
        robustness.aop_deg,
        robustness.anomaly_deg,
    ]
    np.testing.assert_allclose(errors.std(axis=0), sigma, rtol=5 / np.sqrt(2 * len(errors)))
    circular = np.tile([6000.0, 0.0, 60.0, 0.0, 90.0, 0.0], (1000, 1))
    errors = rb.insertion_errors_deg(robustness, circular, np.random.default_rng(8))
    flipped = np.abs(errors[:, 4] - 180.0) < 10 * robustness.aop_deg
    assert (errors[:, 1] >= 0.0).all()
    assert np.all(flipped | (np.abs(errors[:, 4]) < 10 * robustness.aop_deg))
    assert abs(flipped.mean() - 0.5) < 5 * 0.5 / np.sqrt(
        len(errors)
    )  # half the draws point e the other way
    np.testing.assert_array_equal(errors[flipped, 5] < -170.0, True)


def test_a_dispersion_table_needs_a_draw_and_summarises_its_percentiles(settings):
    with pytest.raises(ValueError, match=r"draws = 0: at least one dispersed insertion"):
        rb.dispersion_table(settings, (6143.0, 0.6, 90.0, 51.7, 2, 3), draws=0)
    table = pd.DataFrame(
        {
            "sk_dv_kms_per_year": np.arange(21.0),
            "sk_dv_max_kms_per_year": np.arange(21.0),
            "pdop_avail_pct_worst_month": np.arange(21.0),
            "hdop_avail_pct_worst_month": np.arange(21.0),
            "min_perilune_alt_km": np.arange(21.0),
            "n_lost": [0] * 20 + [1],
        }
    )
    summary = rb.dispersion_summary(table)
    assert summary["draws"] == 21 and summary["draws_losing_a_satellite"] == 1
    assert (
        summary["sk_dv_max_kms_per_year_p95"] == 19.0
        and summary["pdop_avail_pct_worst_month_p5"] == 1.0
    )
