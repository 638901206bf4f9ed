"""Replay: a recorded run's per-design costs as sleeping tasks predict the run's wall time."""

import pytest

from lnss_lib.campaign import load_checkpoint, run_campaign
from lnss_lib.campaign.backends import guided_batches
from lnss_lib.campaign.costs import costs_netcdf, read_costs
from lnss_lib.campaign.replay import (
    journal_costs,
    recorded_costs,
    replay,
    simulate,
    time_scale_for,
)


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


def test_journal_costs_carry_each_designs_own_constellation(recorded):
    """The backend orders a generation by satellite count: the costs carry the design's planes and satellites per
    plane (decoded by the run's grid), not the journal key's scaled integers, whose product orders differently."""
    from lnss_lib.campaign import read_cache_records

    records = sorted(read_cache_records(recorded), key=lambda r: (r["generation"], r["order"]))
    n_sat = [r["metrics"]["n_sat"] for r in records]
    costs = [item for generation in journal_costs(recorded) for item in generation]
    assert [i["n_planes"] * i["sats_per_plane"] for i in costs] == n_sat
    assert any(
        r["key"][4] * r["key"][5] != n for r, n in zip(records, n_sat)
    )  # the key alone would misorder


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


def _designs(costs_s, n_planes=2, sats_per_plane=3):
    return [{"n_planes": n_planes, "sats_per_plane": sats_per_plane, "cost_s": c} for c in costs_s]


def test_simulation_on_one_worker_is_the_work_plus_a_dispatch_per_batch():
    generation = _designs([0.5, 0.25, 1.0, 0.125])
    batches = len(guided_batches([6] * len(generation), 1))
    result = simulate([[generation, generation]], 1, dispatch_s=0.01)
    assert result.wall_s == pytest.approx(2 * (1.875 + 0.01 * batches), rel=1e-12)
    assert result.cost_s == pytest.approx(3.75, rel=1e-12)


def test_simulation_of_equal_designs_one_per_worker_is_perfectly_busy():
    """Four equal designs on four workers: guided batches of one design each, all running at once."""
    result = simulate([[_designs([1.0] * 4)] * 3], 4)
    assert result.wall_s == pytest.approx(3.0, rel=1e-12) and result.busy_fraction == pytest.approx(
        1.0
    )


def test_simulation_waits_for_each_generation_and_fills_workers_with_other_campaigns():
    """One long design per generation holds its campaign (NSGA-II waits for the whole generation); a second
    campaign beside it keeps the other worker busy, and an empty generation (all answered by the journal) costs
    nothing."""
    one = [_designs([2.0, 0.5], n_planes=4), [], _designs([2.0, 0.5], n_planes=4)]
    alone = simulate([one], 2)
    assert alone.wall_s == pytest.approx(4.0) and alone.busy_fraction == pytest.approx(5.0 / 8.0)
    side_by_side = simulate([one, one], 2)
    assert side_by_side.wall_s == pytest.approx(5.0) and side_by_side.busy_fraction == 1.0


def test_simulation_predicts_the_recorded_run_within_its_dispatch(recorded):
    """The recorded run's designs on its two workers: no schedule beats the work over the workers, and the
    simulated wall time is within 20 % of the measured one (the campaign's own work between generations, which
    the simulation leaves out, is a small share of its 0.2 s designs)."""
    measured_s = sum(h["wall_s"] for h in load_checkpoint(recorded)["history"])
    simulated = simulate([journal_costs(recorded)], 2)
    assert simulated.wall_s >= simulated.cost_s / 2 - 1e-9
    assert abs(simulated.wall_s / measured_s - 1.0) < 0.2, (simulated.wall_s, measured_s)


def test_simulation_refuses_bad_arguments():
    with pytest.raises(ValueError, match="n_workers"):
        simulate([[_designs([1.0])]], 0)
    with pytest.raises(ValueError, match="dispatch_s"):
        simulate([[_designs([1.0])]], 1, dispatch_s=float("nan"))
