"""Design grid (eq. 43-44), campaign settings and the evaluation hash."""

import numpy as np
import pytest

from lnss_lib.campaign import CampaignSettings, evaluation_hash
from lnss_lib.settings import load_settings


def test_grid_eq43_44_round_trip_bounds_and_rounding(settings, rng):
    grid = settings.grid
    np.testing.assert_array_equal(grid.n_levels, [200, 80, 358, 89, 3, 3])
    x = np.column_stack([rng.integers(0, n + 1, 500) for n in grid.n_levels])
    physical = grid.descale(x)
    np.testing.assert_allclose(grid.scale(physical), x, atol=1e-9)
    assert np.all(physical >= grid.lower) and np.all(physical <= grid.upper)
    np.testing.assert_array_equal(grid.descale(np.zeros(6)), [[4000.0, 0.0, 1.0, 1.0, 2, 1]])
    np.testing.assert_array_equal(grid.descale(grid.n_levels), [[24000.0, 0.8, 359.0, 90.0, 5, 4]])
    np.testing.assert_array_equal(grid.descale([[-7, -1, 999, 500, 9, -3]]), [[4000.0, 0.0, 359.0, 90.0, 5, 1]])
    assert grid.descale([[0, 30, 0, 0, 0.6, 1.4]])[0, 1] == 0.3  # no binary noise; Np and Ns rounded
    np.testing.assert_array_equal(grid.descale([[0, 0, 0, 0, 0.6, 1.4]])[0, 4:], [3, 2])
    design = grid.designs([[21, 60, 89, 50, 0, 3]])[0]
    assert design == {"sma_km": 6100.0, "ecc": 0.6, "aop_deg": 90.0, "inc_deg": 51.0, "n_planes": 2,
                      "sats_per_plane": 4}
    assert isinstance(design["n_planes"], int)
    np.testing.assert_allclose(grid.scale([6143.0, 0.6, 90.0, 51.7, 2, 8])[0], [21.43, 60.0, 89.0, 50.7, 0, 7])


def test_bad_settings_raise_clear_errors():
    profile = load_settings("ci")
    cases = [({"objectives": ["n_sat", "-pdop"]}, "campaign.objectives"),
             ({"constraints": {"pdop_mean_3sigma": {"max": 10.0, "min": 1.0}}}, "campaign.constraints"),
             ({"variables": {"ecc": {"lower": 0.5, "upper": 0.1, "step": 0.01}}}, "campaign.variables.ecc"),
             ({"variables": {"n_planes": {"lower": 1.5, "upper": 5, "step": 1}}}, "campaign.variables.n_planes"),
             ({"evaluator": "matlab"}, "campaign.evaluator"),
             ({"population": 1}, "campaign.population"),
             ({"crossover_prob": 1.5}, "campaign.crossover_prob")]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):     # at load (config) or from the campaign settings
            CampaignSettings.from_profile(load_settings("ci", overrides={"campaign": change}))
    profile = profile.as_dict()
    del profile["campaign"]
    with pytest.raises(ValueError, match=r"no \[campaign\] section"):
        CampaignSettings.from_profile(profile)


def test_evaluation_hash_ignores_campaign_only_keys():
    base = evaluation_hash(load_settings("ci"))
    for change in ({"campaign": {"population": 50, "seed": 9, "objectives": ["n_sat"], "generations": 2}},
                   {"campaign": {"constraints": {"n_sat": {"max": 12}}}}):
        assert evaluation_hash(load_settings("ci", overrides=change)) == base
    for change in ({"gravity": {"degree": 10}}, {"campaign": {"evaluator": "synthetic"}},
                   {"campaign": {"variables": {"ecc": {"lower": 0.0, "upper": 0.8, "step": 0.02}}}},
                   {"campaign": {"overrides": {"epoch": {"duration_days": 1.0}}}}):
        assert evaluation_hash(load_settings("ci", overrides=change)) != base
    assert evaluation_hash(load_settings("quick")) == evaluation_hash(load_settings("paper"))
