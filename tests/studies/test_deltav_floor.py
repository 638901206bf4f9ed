"""The Delta-V floor study and the profile it derives: params/paper_dv_physical.toml."""

import math

import numpy as np
import pytest

from lnss_lib.config import load_profile
from lnss_lib.paper import TABLE_4
from lnss_lib.studies import deltav_floor as study

PROFILE = "paper_dv_physical"
BOUND_KEY = ("campaign", "constraints", study.DV_KEY)


def _leaves(tree, prefix=()):
    for key, value in tree.items():
        if isinstance(value, dict):
            yield from _leaves(value, prefix + (key,))
        else:
            yield prefix + (key,), value


@pytest.fixture(scope="module")
def sample():
    return study.floor_sample("ci", n=4, paper_model=True)


def test_profile_differs_from_paper_only_at_the_deltav_bound():
    paper, physical = (dict(_leaves(load_profile(name))) for name in ("paper", PROFILE))
    differ = {
        k
        for k in paper.keys() | physical.keys()
        if paper.get(k, object()) != physical.get(k, object())
    }
    hv_key = ("campaign", "hypervolume", "dv_opt_kms_per_year")
    assert differ - {("profile", "name"), ("profile", "description")} == {
        BOUND_KEY + ("max",),
        hv_key,
    }
    assert physical[BOUND_KEY + ("max",)] > paper[BOUND_KEY + ("max",)]
    assert (
        physical[hv_key] / paper[hv_key]
        == physical[BOUND_KEY + ("max",)] / paper[BOUND_KEY + ("max",)]
    )


def test_profile_bound_follows_the_rule_from_the_recorded_elfo_deltav():
    # the profile's comment records the ELFO's workbook Delta-V (2.2530 km/s/yr) the value was derived from
    bound = study.physical_bound(2.2530, study.paper_bound("paper"))
    assert bound["ratio_bound_to_elfo"] == pytest.approx(1.0 / TABLE_4[study.DV_KEY])
    assert study.paper_bound(PROFILE) == bound["bound_kms_per_year"] == 4.6


def test_round_up_keeps_two_significant_figures_and_never_tightens():
    assert study.round_up(4.506) == 4.6
    assert study.round_up(4.6) == 4.6
    assert study.round_up(14.01) == 15.0
    assert study.round_up(0.2301) == 0.24
    for value in np.random.default_rng(0).uniform(0.01, 100.0, 200):
        assert value <= study.round_up(value) < value * 1.1 + 1e-12


def test_sample_is_the_campaign_grid_and_reproducible(sample):
    from lnss_lib.campaign.settings import CampaignPlan
    from lnss_lib.settings import load_settings

    settings = CampaignPlan.of(load_settings("ci"))
    keys = study.sample_keys(settings, 4)
    np.testing.assert_array_equal(sample["key"].values, keys)
    designs = settings.grid.designs(keys)
    assert [float(v) for v in sample["sma_km"].values] == [d["sma_km"] for d in designs]
    np.testing.assert_array_equal(study.sample_keys(settings, 4), keys)


def test_reported_numbers_are_those_of_the_evaluations(sample):
    dv = sample[study.DV_KEY].values
    ok = sample["ok"].values.astype(bool) & np.isfinite(dv)
    table = study.distribution_table(sample)
    assert table.loc["lsq", "min"] == study.floor_of(sample) == dv[ok].min()
    assert table.loc["lsq", "max"] == dv[ok].max()
    assert table.loc["lsq", "p50"] == pytest.approx(np.median(dv[ok]))
    assert table.loc["paper", "min"] == np.nanmin(sample[study.PAPER_DV_KEY].values[ok])
    assert study.floor_by_family(sample).min().min() == dv[ok].min()
    # the constraint columns are the campaign's G: Delta-V over its Table 3 limit minus one
    limit = study.paper_bound("ci")
    np.testing.assert_allclose(sample[f"g_{study.DV_KEY}"].values[ok], dv[ok] / limit - 1.0)


def test_feasible_counts_follow_the_constraints(sample):
    counts = study.feasible_counts(sample, {"none": math.inf, "zero": 0.0})["designs"]
    assert (
        counts["none: Delta-V <= inf"]
        == counts["other Table 3 constraints"]
        <= counts["evaluated (no impact)"]
    )
    assert counts["zero: Delta-V <= 0"] == 0
    alternatives = study.bound_alternatives(sample, 1.0)["bound_kms_per_year"]
    assert alternatives["ratio x floor (min)"] == pytest.approx(
        study.floor_of(sample) / TABLE_4[study.DV_KEY]
    )
