"""Replay: a recorded run's per-design costs as sleeping tasks predict the run's wall time."""

import pytest

from lnss_lib.campaign import load_checkpoint, run_campaign
from lnss_lib.campaign.replay import journal_costs, replay


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A synthetic campaign on two local workers, each design sleeping 0.1 s: its run folder."""
    overrides = {"campaign": {"evaluator": "synthetic", "population": 8, "generations": 3, "synthetic_delay_s": 0.1}}
    return run_campaign("ci", overrides=overrides, workers=2, run_dir=tmp_path_factory.mktemp("replay") / "run",
                        progress=False).run_dir


def test_journal_costs_are_the_designs_of_each_generation(recorded):
    costs = journal_costs(recorded)
    history = load_checkpoint(recorded)["history"]
    assert [len(generation) for generation in costs] == [h["n_evaluated"] for h in history]
    assert all(item["cost_s"] >= 0.1 for generation in costs for item in generation)   # the sleep, at least


def test_replay_at_two_workers_predicts_the_measured_wall_time(recorded):
    measured_s = sum(h["wall_s"] for h in load_checkpoint(recorded)["history"])
    replayed = replay([journal_costs(recorded)], 2)
    assert abs(replayed.wall_s / measured_s - 1.0) < 0.2, (replayed.wall_s, measured_s)
    assert 0.0 < replayed.busy_fraction <= 1.0


def test_replay_refuses_no_workers(recorded):
    with pytest.raises(ValueError, match="n_workers"):
        replay([journal_costs(recorded)], 0)
