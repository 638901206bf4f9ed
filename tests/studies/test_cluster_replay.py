"""The cluster replay's projection: a recorded campaign's spread at a shipped run's counts and cost levels."""

import numpy as np
import pytest
import xarray as xr

from lnss_lib.studies.cluster_replay import (
    TARGET,
    cost_levels,
    measured_runs,
    projected_campaign,
    shipped_busy_fraction,
    simulated_table,
    simulated_verdict,
    simulation_check,
)


def _recorded():
    """Two generations: a warm-up one (1 s a design) and a later one with a 1:3 spread."""
    first = [{"n_planes": 1, "sats_per_plane": 2, "cost_s": 1.0}] * 4
    later = [
        {"n_planes": 2, "sats_per_plane": 2, "cost_s": 0.1},
        {"n_planes": 3, "sats_per_plane": 4, "cost_s": 0.3},
    ]
    return [first, later]


def test_projected_generations_have_the_shipped_counts_and_levels():
    n_evaluated, level_s = np.array([5, 7, 0, 3]), np.array([0.8, 0.05, 0.05, 0.07])
    campaign = projected_campaign(_recorded(), n_evaluated, level_s, np.random.default_rng(1))
    assert [len(g) for g in campaign] == list(n_evaluated)
    for generation, level in zip(campaign, level_s):
        if generation:
            assert np.mean([i["cost_s"] for i in generation]) == pytest.approx(level, rel=1e-12)
    later = campaign[1] + campaign[3]
    assert {(i["n_planes"], i["sats_per_plane"]) for i in later} <= {(2, 2), (3, 4)}
    assert {(i["n_planes"], i["sats_per_plane"]) for i in campaign[0]} == {(1, 2)}


def test_cost_levels_are_the_task_shares_without_the_campaigns_own():
    history = xr.Dataset(
        {
            "time_propagation_s": ("generation", [0.5, 0.04]),
            "time_dop_s": ("generation", [0.1, 0.01]),
            "time_overhead_s": ("generation", [0.2, 0.005]),
            "time_campaign_s": ("generation", [9.0, 9.0]),
            "wall_s": ("generation", [40.0, 3.0]),
        }
    )
    assert cost_levels(history) == pytest.approx([0.8, 0.055])


def test_shipped_busy_fraction_is_task_time_over_worker_time():
    """Two workers, generations of 4 and 10 designs at 0.5 and 0.1 s taking 2 s and 1 s: 3 s of tasks in 6 s."""
    history = xr.Dataset(
        {
            "n_evaluated": ("generation", [4, 10]),
            "time_propagation_s": ("generation", [0.5, 0.1]),
            "time_campaign_s": ("generation", [1.0, 1.0]),
            "wall_s": ("generation", [2.0, 1.0]),
        },
        attrs={"workers": 2},
    )
    assert shipped_busy_fraction(history) == pytest.approx(3.0 / 6.0)


def test_the_computed_schedule_of_the_measured_runs_brackets_them():
    """The two runs measured on 16 idle cores: without dispatch time the computed schedule can only be shorter than
    what was measured (it leaves the scheduler's and client's time out), and the largest dispatch time of the
    bracket is long enough to reach each measurement within the 20 % the replay is held to."""
    runs = measured_runs()
    assert runs is not None and {int(h.attrs["workers"]) for _, h in runs.values()} == {2, 16}
    check = simulation_check(runs)
    for name in runs:
        ratios = check.loc[name, "simulated / measured"]
        assert ratios.is_monotonic_increasing
        assert ratios.iloc[0] <= 1.0 and ratios.iloc[-1] >= 0.8, ratios
        assert (check.loc[name, "simulated busy"] <= 1.0).all()


def test_simulated_table_fills_workers_with_campaigns_and_never_beats_perfect_scaling():
    history = xr.Dataset(
        {
            "n_evaluated": ("generation", [4, 6, 6, 6]),
            "time_propagation_s": ("generation", [1.0, 0.1, 0.1, 0.1]),
        }
    )
    table = simulated_table(
        {"a": _recorded()}, history, campaigns=(1, 8), workers=(2, 32), dispatch=(0.0, 0.01)
    )
    assert (table["projected wall (min)"] >= table["perfect scaling (min)"] * (1 - 1e-12)).all()
    assert (table["busy fraction"] <= 1.0).all()
    one, eight = table.xs(1, level="campaigns"), table.xs(8, level="campaigns")
    assert (eight.loc[32, "busy fraction"] > one.loc[32, "busy fraction"]).all()
    verdict = simulated_verdict(table)
    assert f"{TARGET['campaigns']} campaigns" in verdict and verdict.count("ms per batch") == 2


def test_scaling_figure_draws_a_line_per_dispatch_time():
    from lnss_lib.figures import replay_scaling

    history = xr.Dataset(
        {"n_evaluated": ("generation", [4, 6]), "time_propagation_s": ("generation", [1.0, 0.1])}
    )
    table = simulated_table({"a": _recorded()}, history, workers=(2, 8), dispatch=(0.0, 0.03))
    names = [trace.name for trace in replay_scaling(table, "t").data]
    assert "8 campaigns: computed, 30 ms per batch" in names
    assert names.count("1 campaign: perfect scaling") == 1
