"""Design grid (eq. 43-44), campaign settings and the evaluation hash."""

import json

import numpy as np
import pytest

from lnss_lib.campaign import CampaignPlan, evaluation_hash, run_campaign
from lnss_lib.campaign.settings import campaign_hash, reads_screen, run_differences
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings, settings_from_profile


def test_grid_eq43_44_round_trip_bounds_and_rounding(settings, rng):
    grid = settings.grid
    np.testing.assert_array_equal(grid.n_levels, [200, 80, 358, 89, 3, 3])
    x = np.column_stack([rng.integers(0, n + 1, 500) for n in grid.n_levels])
    physical = grid.descale(x)
    np.testing.assert_allclose(grid.scale(physical), x, atol=1e-9)
    assert np.all(physical >= grid.lower) and np.all(physical <= grid.upper)
    np.testing.assert_array_equal(grid.descale(np.zeros(6)), [[4000.0, 0.0, 1.0, 1.0, 2, 1]])
    np.testing.assert_array_equal(grid.descale(grid.n_levels), [[24000.0, 0.8, 359.0, 90.0, 5, 4]])
    np.testing.assert_array_equal(
        grid.descale([[-7, -1, 999, 500, 9, -3]]), [[4000.0, 0.0, 359.0, 90.0, 5, 1]]
    )
    assert (
        grid.descale([[0, 30, 0, 0, 0.6, 1.4]])[0, 1] == 0.3
    )  # no binary noise; Np and Ns rounded
    np.testing.assert_array_equal(grid.descale([[0, 0, 0, 0, 0.6, 1.4]])[0, 4:], [3, 2])
    design = grid.designs([[21, 60, 89, 50, 0, 3]])[0]
    assert design == {
        "sma_km": 6100.0,
        "ecc": 0.6,
        "aop_deg": 90.0,
        "inc_deg": 51.0,
        "n_planes": 2,
        "sats_per_plane": 4,
    }
    assert isinstance(design["n_planes"], int)
    np.testing.assert_allclose(
        grid.scale([6143.0, 0.6, 90.0, 51.7, 2, 8])[0], [21.43, 60.0, 89.0, 50.7, 0, 7]
    )


def test_bad_settings_raise_clear_errors():
    """Campaign rules are config's: load_settings refuses a bad [campaign] naming the key."""
    profile = load_settings("ci")
    cases = [
        ({"objectives": ["n_sat", "-pdop"]}, "campaign.objectives"),
        ({"constraints": {"pdop_mean_3sigma": {"max": 10.0, "min": 1.0}}}, "campaign.constraints"),
        (
            {"variables": {"ecc": {"lower": 0.5, "upper": 0.1, "step": 0.01}}},
            "campaign.variables.ecc",
        ),
        (
            {"variables": {"n_planes": {"lower": 1.5, "upper": 5, "step": 1}}},
            "campaign.variables.n_planes",
        ),
        ({"evaluator": "matlab"}, "campaign.evaluator"),
        ({"population": 1}, "campaign.population"),
        ({"crossover_prob": 1.5}, "campaign.crossover_prob"),
        (
            {"variables": {"n_planes": {"lower": 1, "upper": 5, "step": 1.5}}},
            "campaign.variables.n_planes",
        ),
        (
            {"variables": {"sma_km": {"lower": 4000.0, "upper": 1e6, "step": 100.0}}},
            "campaign.variables.sma_km",
        ),
        ({"variables": {"ecc": {"stride": 0.1}}}, "campaign.variables.ecc"),
        (
            {"variables": {"raan_deg": {"lower": 0.0, "upper": 1.0, "step": 1.0}}},
            "campaign.variables",
        ),
        (
            {"constraints": {"pdop_mean_3sigma": {"max": "ten"}}},
            "campaign.constraints.pdop_mean_3sigma",
        ),
        ({"constraints": {"nosuch": {"max": 1.0}}}, "campaign.constraints.nosuch"),
        ({"hypervolume": {"n_sat": -1.0}}, "campaign.hypervolume.n_sat"),
        ({"hypervolume": {"nosuch": 1.0}}, "campaign.hypervolume.nosuch"),
        ({"objectives": ["n_sat", "-n_sat"]}, "campaign.objectives"),
        ({"objectives": []}, "campaign.objectives"),
        ({"companion_profile": "ci"}, "campaign.companion_profile"),
    ]
    for change, message in cases:
        with pytest.raises(ConfigError, match=message) as caught:  # at load, by config
            load_settings("ci", overrides={"campaign": change})
        assert caught.value.key.startswith(message)
    profile = profile.as_dict()
    del profile["campaign"]
    with pytest.raises(ConfigError, match=r"missing key\(s\) campaign"):
        settings_from_profile(profile)


def test_campaign_plan_is_derived_from_the_section():
    plan = CampaignPlan.of(
        load_settings(
            "ci",
            overrides={
                "campaign": {"constraints": {"n_sat": "off"}, "hypervolume": {"n_sat": "off"}}
            },
        )
    )
    assert ("n_sat", "max", 20.0) not in plan.constraints and "n_sat" not in dict(plan.hypervolume)
    assert all(isinstance(limit, float) for _, _, limit in plan.constraints)
    assert (
        plan.grid.lower.dtype == float
        and plan.objectives == load_settings("ci").campaign.objectives
    )


def test_evaluation_hash_ignores_campaign_only_keys():
    base = evaluation_hash(load_settings("ci"))
    for change in (
        {"campaign": {"population": 50, "seed": 9, "objectives": ["n_sat"], "generations": 2}},
        {"campaign": {"constraints": {"n_sat": {"max": 12}}}},
    ):
        assert evaluation_hash(load_settings("ci", overrides=change)) == base
    for change in (
        {"gravity": {"degree": 10}},
        {"campaign": {"evaluator": "synthetic"}},
        {"campaign": {"variables": {"ecc": {"lower": 0.0, "upper": 0.8, "step": 0.02}}}},
        {"campaign": {"overrides": {"epoch": {"duration_days": 1.0}}}},
    ):
        assert evaluation_hash(load_settings("ci", overrides=change)) != base
    assert evaluation_hash(load_settings("quick")) == evaluation_hash(load_settings("paper"))


def test_the_screens_settings_are_in_the_evaluation_hash_only_where_an_evaluation_screens():
    """``[stability]`` is read by a 10-day evaluation only through the screen's metrics (``stable_screen``,
    ``screen_*``) or the life estimate (``[sk_estimate] model = "life"``): a change of it moves the evaluation hash
    of such a profile and leaves the others' alone (their journals and shipped results stay theirs), while it always
    moves the profile hash."""
    screen_off = {"stability": {"monthly_terms": False}}
    paper, changed = load_settings("paper"), load_settings("paper", overrides=screen_off)
    assert not reads_screen(paper.as_dict()) and changed.hash != paper.hash
    assert evaluation_hash(changed) == evaluation_hash(paper)
    assert campaign_hash(changed) == campaign_hash(paper) and run_differences(changed, paper) == []
    for screening in (
        {"evaluator": {"extra_metrics": ["stable_screen"]}},
        {
            "evaluator": {"extra_metrics": ["sk_dv_estimate_kms_per_year"]},
            "sk_estimate": {"model": "life"},
        },
        {
            "campaign": {
                "overrides": {"evaluator": {"extra_metrics": ["screen_min_perilune_alt_km"]}}
            }
        },
    ):
        base = load_settings("paper", overrides=screening)
        assert reads_screen(base.as_dict()), screening
        assert evaluation_hash(base.with_overrides(screen_off)) != evaluation_hash(base), screening
    arc = load_settings(
        "paper",
        overrides={"evaluator": {"extra_metrics": ["sk_dv_estimate_kms_per_year"]}},
    )  # the 10-day box estimate: no screen
    assert not reads_screen(arc.as_dict())
    operational = load_settings("operational")
    assert evaluation_hash(operational.with_overrides(screen_off)) != evaluation_hash(operational)


def test_the_evaluator_screens_exactly_where_the_evaluation_hash_covers_the_screen(monkeypatch):
    """For every request of one or two extra metrics under each ``[sk_estimate] model``, set directly or through
    ``campaign.overrides``, the evaluator runs the stability screen exactly when :func:`reads_screen` puts
    ``[stability]`` in the evaluation hash: a screen outside the hash would let a journal answer under another
    screen, a hash beyond it would orphan journals for nothing."""
    from types import SimpleNamespace

    import xarray as xr

    from lnss_lib import evaluator
    from lnss_lib.keys import EXTRA_METRIC_KEYS, LIFE_NAVIGATION_KEYS
    from lnss_lib.sections import SK_ESTIMATE_MODELS

    class Screened(Exception):
        pass

    def screen_states(*args):
        raise Screened

    monkeypatch.setattr(evaluator.screen, "screen_states", screen_states)
    paper = load_settings("paper")
    arc = xr.Dataset(  # one minute: too short for the life estimate, which then gives NaN without flying
        {
            "r_mci_km": (("satellite", "time", "xyz"), np.full((1, 2, 3), 4000.0)),
            "v_mci_kms": (("satellite", "time", "xyz"), np.full((1, 2, 3), 0.6)),
        },
        coords={"time": [0.0, 60.0]},
    )
    computed = {  # the metrics the evaluation computes before (Delta-V maxima, metres, GNSS)
        k: 0.0
        for k in EXTRA_METRIC_KEYS
        if not k.startswith(("stable", "screen", "sk_dv_estimate"))
        and k not in LIFE_NAVIGATION_KEYS
    }
    requests = [()] + [(k,) for k in EXTRA_METRIC_KEYS]
    requests += [
        (a, b) for i, a in enumerate(EXTRA_METRIC_KEYS) for b in EXTRA_METRIC_KEYS[i + 1 :]
    ]
    screening = 0
    for model in SK_ESTIMATE_MODELS:
        settings = SimpleNamespace(
            sk_estimate=SimpleNamespace(model=model, min_periods=paper.sk_estimate.min_periods),
            stability=paper.stability,
        )
        for wanted in requests:
            context = SimpleNamespace(
                settings=settings, extra_metrics=wanted, dynamics=paper.dynamics, t0_tdb_s=0.0
            )
            try:
                evaluator._operational_metrics(context, arc, np.zeros((1, 6)), computed)
                screens = False
            except Screened:
                screens = True
            request = {
                "evaluator": {"extra_metrics": list(wanted)},
                "sk_estimate": {"model": model},
            }
            overridden = {"campaign": {"overrides": request}}
            assert reads_screen(request) == reads_screen(overridden) == screens, (model, wanted)
            screening += screens
    assert 0 < screening < len(SK_ESTIMATE_MODELS) * len(requests)


def test_the_life_estimates_settings_are_in_the_evaluation_hash_only_where_an_evaluation_runs_it():
    """The ``[design_life]`` settings the life estimate reads (:data:`LIFE_ESTIMATE_KEYS`: declared
    in their fields) move the evaluation and campaign hashes of a profile whose evaluations run it
    (the operational study) and of no other (the paper's); a ``[design_life]`` setting the estimate
    does not read moves neither; a run recorded before they entered the hash is recognised by its
    other recorded hash."""
    from lnss_lib.campaign.settings import (
        LIFE_ESTIMATE_KEYS,
        reads_life_estimate,
        recorded_evaluation_hashes,
    )

    assert {
        "design_life.target_fraction",
        "design_life.box.ecc",
        "design_life.service.nav_window_days",
    } <= set(LIFE_ESTIMATE_KEYS)
    assert "design_life.life_days" not in LIFE_ESTIMATE_KEYS  # the screen's span: in [stability]
    read = {"design_life": {"target_fraction": 0.7, "box": {"ecc": 0.02}}}
    unread = {"design_life": {"controller": "box", "dv_cap_kms_per_year": 1.0}}
    operational, paper = load_settings("operational"), load_settings("paper")
    assert reads_life_estimate(operational.as_dict()) and not reads_life_estimate(paper.as_dict())
    for overrides in (
        {"design_life": {"target_fraction": 0.7}},
        {"design_life": {"box": {"ecc": 0.02}}},
        read,
    ):
        changed = operational.with_overrides(overrides)
        assert evaluation_hash(changed) != evaluation_hash(operational), overrides
        assert run_differences(changed, operational) != []
        assert evaluation_hash(paper.with_overrides(overrides)) == evaluation_hash(paper), overrides
    assert evaluation_hash(operational.with_overrides(unread)) == evaluation_hash(operational)
    assert campaign_hash(operational.with_overrides(unread)) == campaign_hash(operational)
    now, before = recorded_evaluation_hashes(operational)
    assert now == evaluation_hash(operational) and before != now
    assert evaluation_hash(operational.with_overrides(read)) != now
    assert (
        recorded_evaluation_hashes(operational.with_overrides(read))[1] == before
    )  # the rule before: unread
    assert recorded_evaluation_hashes(paper) == (evaluation_hash(paper),)


def test_size_restricted_grid_holds_every_split_and_no_other_size(rng):
    """``campaign.n_sat = 12`` on Table 3's counts (2-5 planes, 1-4 per plane): 3 x 4 and 4 x 3 only; every scaled
    point, the grid's corners and points beyond them included, is a 12-satellite design, and eq. 43 inverts it."""
    grid = CampaignPlan.of(load_settings("paper", {"campaign": {"n_sat": 12}})).grid
    assert grid.splits == ((3, 4), (4, 3))
    np.testing.assert_array_equal(grid.n_levels[4:], [1, 0])
    x = np.column_stack([rng.integers(-2, n + 3, 500) for n in grid.n_levels])
    physical = grid.descale(x)
    assert set(map(tuple, physical[:, 4:].astype(int))) == {(3, 4), (4, 3)}
    inside = np.clip(x, 0, grid.n_levels)
    np.testing.assert_allclose(grid.scale(grid.descale(inside)), inside, atol=1e-9)
    assert np.isnan(
        grid.scale([[6100.0, 0.6, 90.0, 51.0, 2, 4]])[0, 4]
    )  # 8 satellites: not on this grid


def test_size_restriction_refused_without_a_split_and_off_at_zero():
    with pytest.raises(
        ConfigError,
        match=r"campaign.n_sat = 7 .*allowed: 0 \(any size\) or one of 2, 3, 4, 5, 6, 8",
    ):
        load_settings("paper", {"campaign": {"n_sat": 7}})
    with pytest.raises(ConfigError, match="campaign.n_sat"):
        load_settings("paper", {"campaign": {"n_sat": -1}})
    free = load_settings("paper")
    assert CampaignPlan.of(free).grid.splits == ()
    stored = free.as_dict()
    del stored["campaign"]["n_sat"]  # a profile stored before the key existed: same settings
    assert evaluation_hash(settings_from_profile(stored)) == evaluation_hash(free)
    assert evaluation_hash(load_settings("paper", {"campaign": {"n_sat": 12}})) != evaluation_hash(
        free
    )


def test_size_restricted_search_never_proposes_another_size(tmp_path):
    """A synthetic ci campaign restricted to 9 satellites (3 x 3 alone on the grid) evaluates only 9-satellite
    designs, generation after generation."""
    run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "n_sat": 9, "generations": 4}},
        workers=0,
        run_dir=tmp_path / "run",
        progress=False,
    )
    records = [
        json.loads(line)
        for line in (tmp_path / "run" / "evaluations.jsonl").read_text().splitlines()[1:]
    ]
    plan = CampaignPlan.of(load_settings("ci", {"campaign": {"n_sat": 9}}))
    designs = plan.grid.descale([r["key"] for r in records])
    assert len(designs) > plan.population and set(map(tuple, designs[:, 4:].astype(int))) == {
        (3, 3)
    }
