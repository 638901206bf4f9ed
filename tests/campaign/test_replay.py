"""Replay: a recorded run's per-design costs as sleeping tasks predict the run's wall time."""

import pytest

from lnss_lib.campaign import load_checkpoint, run_campaign
from lnss_lib.campaign.costs import costs_netcdf, read_costs
from lnss_lib.campaign.replay import journal_costs, recorded_costs, replay, time_scale_for


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A synthetic campaign on two local workers, each design sleeping 0.2 s: its run folder. Generations of 20
    designs, so that their evaluation (about 2 s a generation) outweighs the campaign's own work between them
    (NSGA-II, checkpoint, dispatch), which a replay leaves out, even on a loaded machine."""
    overrides = {
        "campaign": {
            "evaluator": "synthetic",
            "population": 20,
            "generations": 3,
            "synthetic_delay_s": 0.2,
        }
    }
    return run_campaign(
        "ci",
        overrides=overrides,
        workers=2,
        run_dir=tmp_path_factory.mktemp("replay") / "run",
        progress=False,
    ).run_dir


def test_journal_costs_are_the_designs_of_each_generation(recorded):
    costs = journal_costs(recorded)
    history = load_checkpoint(recorded)["history"]
    assert [len(generation) for generation in costs] == [h["n_evaluated"] for h in history]
    assert all(
        item["cost_s"] >= 0.2 for generation in costs for item in generation
    )  # the sleep, at least


def test_replay_at_two_workers_predicts_the_measured_wall_time(recorded):
    measured_s = sum(h["wall_s"] for h in load_checkpoint(recorded)["history"])
    replayed = replay([journal_costs(recorded)], 2)
    assert abs(replayed.wall_s / measured_s - 1.0) < 0.2, (replayed.wall_s, measured_s)
    assert 0.0 < replayed.busy_fraction <= 1.0


def test_replay_refuses_no_workers(recorded):
    with pytest.raises(ValueError, match="n_workers"):
        replay([journal_costs(recorded)], 0)


def test_replay_command_prints_a_row_per_worker_count(recorded, capsys):
    from lnss_lib.__main__ import main

    argv = [
        "study",
        "--replay",
        str(recorded),
        "--replay-workers",
        "2",
        "4",
        "--copies",
        "2",
        "--time-scale",
        "0.25",
    ]
    assert main(argv) == 0
    rows = [[float(v) for v in line.split()] for line in capsys.readouterr().out.splitlines()[2:]]
    cost_s = 2 * sum(
        item["cost_s"] for generation in journal_costs(recorded) for item in generation
    )
    assert [row[0] for row in rows] == [2, 4]
    for n, wall_s, busy, perfect_s in rows:
        assert perfect_s == pytest.approx(cost_s / n, abs=0.1)
        assert (
            wall_s >= perfect_s - 0.1 and 0.0 < busy <= 1.0
        )  # no schedule beats the work over the workers


def test_replay_of_a_folder_without_a_run(tmp_path, capsys):
    from lnss_lib.__main__ import main

    assert main(["study", "--replay", str(tmp_path)]) == 2
    assert "neither a campaign run folder" in capsys.readouterr().err


def test_a_costs_file_holds_the_journals_costs(recorded, tmp_path):
    """costs.nc of two campaigns reads back as each journal's costs (float32: 6e-8 relative) and replays as they do."""
    path = tmp_path / "costs.nc"
    path.write_bytes(costs_netcdf({"a": recorded, "b": recorded}, export_commit="test"))
    costs, journal = read_costs(path), journal_costs(recorded)
    assert list(costs) == ["a", "b"] and recorded_costs(path) == costs
    for name in costs:
        assert [[(i["n_planes"], i["sats_per_plane"]) for i in g] for g in costs[name]] == [
            [(i["n_planes"], i["sats_per_plane"]) for i in g] for g in journal
        ]
        got = [i["cost_s"] for g in costs[name] for i in g]
        assert got == pytest.approx([i["cost_s"] for g in journal for i in g], rel=1e-7)


def test_time_scale_for_sends_the_asked_tasks_per_second():
    """One generation of k designs of cost c on k workers: k single-design tasks; at rate R the replay lasts k / R
    seconds, so the scale is k / (R * c) over the generation's wall time c on k workers."""
    k, cost_s, rate = 10, 0.05, 40.0
    generation = [{"n_planes": 2, "sats_per_plane": 3, "cost_s": cost_s}] * k
    scale = time_scale_for([[generation]], k, rate)
    assert scale * cost_s == pytest.approx(k / rate)
