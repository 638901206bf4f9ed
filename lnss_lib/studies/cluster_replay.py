"""Notebook 06: what a cluster would take for the seed study, from recorded per-design costs.

Question: a generation of 120 designs waits for its slowest, so one campaign cannot fill a large cluster; a study of
8 seeds side by side can. Would 8 seeds of ``paper_dv_physical``, 120 x 1000 each, keep 32 workers at least 80 %
busy and finish within 30 minutes?

The projected study: a projected campaign (:func:`projected_campaign`) has the shipped 120 x 1000 run's count of new
designs in each of its 1000 generations (``history.nc``: the journal answers the rest) at that generation's recorded
mean task cost (the ``time_*_s`` shares of ``history.nc`` less the campaign's own), and the spread and constellation
sizes of the designs of recorded journals (``costs.nc`` of a study, :mod:`lnss_lib.campaign.costs`) drawn for it:
the recorded journals give the shape of a generation, the shipped run its size and level. The level is taken from
the shipped run because a journal's task times are wall times on the machine that ran it: the seed study's ran on
two cores shared by its campaigns' two workers and other work, so its designs took several times the shipped run's
(printed beside the table); on a cluster each worker has its core, and a design takes about what it took the
shipped run, whose two workers had the machine's two cores.

Measured, then computed. The replay (:func:`lnss_lib.campaign.replay.replay`, :func:`replay_table`) sends the
projected designs through the campaign's own Dask backend as sleeping tasks; its one process hands out every task,
a few milliseconds each, so where tasks are short and workers many it measures its own dispatch: on 16 idle cores
(2026-11-29) it replayed one campaign at 2 workers 0.64 busy against the shipped run's measured 0.96, 8 campaigns at
32 workers 0.42, and 40 generations that ran in 49 s on 16 worker processes did not replay at 16 workers within
75 s. The notebook replays one campaign at 2 workers (:func:`replay_check`, beside the shipped run) and computes the
rest: :func:`lnss_lib.campaign.replay.simulate` schedules the same batches in the same order, each costing a worker
its designs' task times plus a dispatch time per batch, over :data:`SIMULATED_GENERATIONS` generations of every
projected campaign (:func:`simulated_table`), checked first against the two runs measured on that machine
(``outputs/reference/cluster_measurements``, :func:`simulation_check`): without dispatch time it is 3 % short of
the 2-worker run and 18 % short of the 16-worker one; 10 ms per batch matches the first, 30 ms the second (a Dask
scheduler's round trip grows with its workers). :data:`DISPATCH_S` brackets the projection with those.

Verdict (:func:`simulated_verdict`, printed by notebook 06): the 8 seeds' work at the shipped run's level is
8 x 114,982 designs x 0.058 s, 14.9 h of worker time, 28.0 min at perfect scaling on 32 workers, so the 30 minutes
need at least 0.93 busy. The computed schedule keeps 32 workers fully busy without dispatch time and 0.85 busy at
10 ms per batch (33 min), 0.66 at 30 ms (42 min): 8 seeds fill 32 workers (the 0.8 is met unless a batch costs
more than about 15 ms to hand out), and the 30 minutes are not, at the dispatch times measured.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from ..campaign.costs import COSTS_FILE, read_costs
from ..campaign.reference import REFERENCE_DIR
from ..campaign.replay import replay, simulate, time_scale_for

__all__ = [
    "SHIPPED_COSTS",
    "TARGET",
    "WORKERS",
    "projected_campaign",
    "projected_study",
    "projection_basis",
    "cost_levels",
    "replay_table",
    "replay_check",
    "shipped_busy_fraction",
    "shipped_costs",
    "DISPATCH_S",
    "MEASURED_DIR",
    "measured_runs",
    "simulation_check",
    "simulated_table",
    "simulated_verdict",
]

SHIPPED_COSTS = REFERENCE_DIR / "paper_dv_physical_seeds" / COSTS_FILE
WORKERS = (2, 8, 32, 128)  # the worker counts the question names
# The target: 8 seeds of 120 x 1000 at 32 workers, at least 80 % busy, within 30 minutes.
TARGET = {"campaigns": 8, "workers": 32, "busy_fraction": 0.8, "wall_s": 1800.0}
SAMPLE_GENERATIONS = (
    1  # generations of each campaign replayed (a late one; more: evenly spread over the 1000)
)
TASKS_PER_S = 60.0  # tasks a second a replay sends: its process spends a few ms of CPU on each
SEED = 0  # the draw of designs for the projected generations
MEASURED_DIR = REFERENCE_DIR / "cluster_measurements"
# Dispatch time per batch (s) bracketing the computed schedule: none; what matches the 2-worker run measured on
# 16 idle cores; what matches the 16-worker run there (simulation_check prints all three against both runs).
DISPATCH_S = (0.0, 0.010, 0.030)
SIMULATED_GENERATIONS = (
    200  # of each projected campaign, evenly spread: the busy fraction within 1 % of all 1000
)


def shipped_costs() -> dict[str, list[list[dict]]] | None:
    """The shipped study's per-design costs (``outputs/reference/paper_dv_physical_seeds/costs.nc``), or None."""
    return read_costs(SHIPPED_COSTS) if SHIPPED_COSTS.is_file() else None


def cost_levels(history) -> np.ndarray:
    """Mean task time per new design in each generation of a shipped run (s): the sum of ``history.nc``'s
    ``time_<part>_s`` (propagation, metrics and the rest of each task), without ``time_campaign_s`` (worker time
    outside the tasks)."""
    parts = [
        name
        for name in history.data_vars
        if str(name).startswith("time_") and name != "time_campaign_s"
    ]
    return np.sum([history[name].values for name in parts], axis=0)


def projection_basis(history, recorded: dict[str, list[list[dict]]]) -> pd.DataFrame:
    """Why the projection may repeat the recorded generations' shape at the shipped run's levels: per band of the
    shipped run's generations (the first, holding the workers' warm-up; then up to the recorded generations; then
    the rest), the mean count of new designs and mean task time per design (``history.nc``), beside the recorded
    journals' mean task time per design over the same bands where they have them."""
    n_evaluated, level_s = history["n_evaluated"].values, cost_levels(history)
    done = max(len(c) for c in recorded.values())
    bands = {"1": (0, 1), f"2-{done}": (1, done), f"{done + 1}-{len(n_evaluated)}": (done, None)}
    rows = {}
    for name, (start, stop) in bands.items():
        counts, levels = n_evaluated[start:stop], level_s[start:stop]
        mine = [i["cost_s"] for c in recorded.values() for g in c[start:stop] for i in g]
        rows[name] = {
            "generations": counts.size,
            "new designs per generation (shipped)": float(np.mean(counts))
            if counts.size
            else np.nan,
            "task time per design, shipped (s)": float(np.sum(counts * levels) / np.sum(counts))
            if counts.sum()
            else np.nan,
            "task time per design, recorded (s)": float(np.mean(mine)) if mine else np.nan,
        }
    return pd.DataFrame(rows).T.rename_axis("generations of the shipped run")


def projected_campaign(
    recorded: list[list[dict]], n_evaluated: np.ndarray, level_s: np.ndarray, rng
) -> list[list[dict]]:
    """A campaign of ``len(n_evaluated)`` generations: generation g has ``n_evaluated[g]`` designs drawn (with
    replacement) from ``recorded`` (generation 1 from its first generation, the rest from its later ones: the first
    holds the workers' warm-up), their costs scaled so that their mean is ``level_s[g]``."""
    first, later = recorded[0], [item for generation in recorded[1:] for item in generation]
    out = []
    for g, (count, level) in enumerate(zip(n_evaluated, level_s)):
        pool = first if g == 0 or not later else later
        items = [pool[i] for i in rng.integers(0, len(pool), int(count))]
        mean = np.mean([item["cost_s"] for item in items]) if items else 1.0
        out.append([{**item, "cost_s": item["cost_s"] * level / mean} for item in items])
    return out


def projected_study(
    recorded: dict[str, list[list[dict]]], history, size: int
) -> list[list[list[dict]]]:
    """``size`` projected campaigns (:func:`projected_campaign`), each from one recorded campaign in turn, drawn
    with :data:`SEED`: the replay and the computed schedule see the same study."""
    rng = np.random.default_rng(SEED)
    n_evaluated, level_s = history["n_evaluated"].values, cost_levels(history)
    sources = list(recorded.values())
    return [
        projected_campaign(sources[k % len(sources)], n_evaluated, level_s, rng)
        for k in range(size)
    ]


def _sample(campaign: list[list[dict]], n: int) -> list[list[dict]]:
    """``n`` generations of ``campaign`` evenly spread from its second to its last (the first is warm-up)."""
    picks = np.unique(np.linspace(1, len(campaign) - 1, n).round().astype(int))
    return [campaign[g] for g in picks]


def replay_table(
    recorded: dict[str, list[list[dict]]],
    history,
    campaigns: tuple[int, ...] = (1, TARGET["campaigns"]),
    workers: tuple[int, ...] = WORKERS,
    tasks_per_s: float = TASKS_PER_S,
) -> pd.DataFrame:
    """One row per study size (``campaigns`` projected 120 x 1000 campaigns, each from one recorded campaign in
    turn) and worker count: the replayed sample's busy fraction and time scale (the replay sending ``tasks_per_s``
    tasks a second), the projected wall time of the whole study, perfect scaling (its work over the workers), and
    the recorded and projected mean cost per design."""
    study = projected_study(recorded, history, max(campaigns))
    recorded_mean_s = float(
        np.mean([i["cost_s"] for c in recorded.values() for g in c[1:] for i in g] or [np.nan])
    )
    rows = []
    for size in campaigns:
        work_s = sum(item["cost_s"] for c in study[:size] for g in c for item in g)
        designs = sum(len(g) for c in study[:size] for g in c)
        sample = [_sample(c, SAMPLE_GENERATIONS) for c in study[:size]]
        for n in workers:
            scale = time_scale_for(sample, n, tasks_per_s)
            result = replay(sample, n, time_scale=scale)
            rows.append(
                {
                    "campaigns": size,
                    "workers": n,
                    "generations replayed per campaign": len(sample[0]),
                    "time scale": scale,
                    "busy fraction": result.busy_fraction,
                    "projected wall (min)": work_s / (n * result.busy_fraction) / 60.0,
                    "perfect scaling (min)": work_s / n / 60.0,
                    "designs": designs,
                    "mean cost per design, projected (s)": work_s / designs,
                    "mean cost per design, recorded (s)": recorded_mean_s,
                }
            )
    return pd.DataFrame(rows).set_index(["campaigns", "workers"])


def shipped_busy_fraction(history) -> float:
    """The shipped run's own busy fraction: its task time (new designs times their mean task time, every
    generation) over its workers (``history.nc``'s ``workers`` attribute) times its wall time."""
    task_s = float(np.sum(history["n_evaluated"].values * cost_levels(history)))
    return task_s / (int(history.attrs["workers"]) * float(history["wall_s"].sum()))


def replay_check(table: pd.DataFrame, history) -> str:
    """The replay against a measurement: one campaign at the shipped run's worker count, replayed, beside that
    run's own busy fraction (the replay's dispatch shares this machine's cores; where it is slower than the run's,
    every busy fraction of the table is low by about as much)."""
    workers = int(history.attrs["workers"])
    if (1, workers) not in table.index:
        return f"no replay of one campaign at {workers} workers to check against the shipped run"
    replayed = float(table.loc[(1, workers), "busy fraction"])
    return (
        f"check: one campaign at {workers} workers, replayed busy {replayed:.2f}; the shipped run on {workers} "
        f"workers was busy {shipped_busy_fraction(history):.2f}"
    )


def measured_runs() -> dict[str, tuple[list[list[dict]], object]] | None:
    """The runs measured for the projection (:data:`MEASURED_DIR`): ``{campaign: (its costs, its history.nc)}``
    with the worker count in ``history.attrs["workers"]`` (from ``costs.nc``), or None when not shipped."""
    path = MEASURED_DIR / COSTS_FILE
    if not path.is_file():
        return None
    costs = read_costs(path)
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        workers = [int(n) for n in ds.attrs["workers"].split(",")]
    out = {}
    for (name, generations), n in zip(costs.items(), workers):
        history = xr.load_dataset(MEASURED_DIR / f"history_{name}.nc", engine="h5netcdf")
        history.attrs["workers"] = n
        out[name] = (generations, history)
    return out


def simulation_check(runs: dict, dispatch: tuple[float, ...] = DISPATCH_S) -> pd.DataFrame:
    """The computed schedule of each measured run's generations after its first (which holds the workers' start),
    on its own workers, at each dispatch time per batch, against the measured wall time of those generations:
    simulated wall plus the campaign's own recorded time between generations (``time_campaign_s``: NSGA-II, the
    checkpoint), and its ratio to the measured."""
    rows = []
    for name, (costs, history) in runs.items():
        n = int(history.attrs["workers"])
        measured_s = float(history["wall_s"].values[1:].sum())
        own_s = float(history["time_campaign_s"].values[1:].sum())
        for dispatch_s in dispatch:
            result = simulate([costs[1:]], n, dispatch_s)
            rows.append(
                {
                    "run": name,
                    "workers": n,
                    "dispatch per batch (ms)": 1e3 * dispatch_s,
                    "measured wall (s)": measured_s,
                    "simulated wall (s)": result.wall_s + own_s,
                    "simulated / measured": (result.wall_s + own_s) / measured_s,
                    "measured busy": result.cost_s / (n * measured_s),
                    "simulated busy": result.cost_s / (n * (result.wall_s + own_s)),
                }
            )
    return pd.DataFrame(rows).set_index(["run", "dispatch per batch (ms)"])


def simulated_table(
    recorded: dict[str, list[list[dict]]],
    history,
    campaigns: tuple[int, ...] = (1, TARGET["campaigns"]),
    workers: tuple[int, ...] = WORKERS,
    dispatch: tuple[float, ...] = DISPATCH_S,
    generations: int = SIMULATED_GENERATIONS,
) -> pd.DataFrame:
    """The projected study of :func:`replay_table` (the same draw), ``generations`` of each campaign (evenly
    spread) scheduled by :func:`~lnss_lib.campaign.replay.simulate`: per study size, worker count and dispatch time
    per batch, the busy fraction and the wall time of the whole study (its work over the workers times the busy
    fraction) beside perfect scaling."""
    study = projected_study(recorded, history, max(campaigns))
    rows = []
    for size in campaigns:
        work_s = sum(item["cost_s"] for c in study[:size] for g in c for item in g)
        sample = [_sample(c, generations) for c in study[:size]]
        for n in workers:
            for dispatch_s in dispatch:
                busy = simulate(sample, n, dispatch_s).busy_fraction
                rows.append(
                    {
                        "campaigns": size,
                        "workers": n,
                        "dispatch per batch (ms)": 1e3 * dispatch_s,
                        "generations simulated per campaign": len(sample[0]),
                        "busy fraction": busy,
                        "projected wall (min)": work_s / (n * busy) / 60.0,
                        "perfect scaling (min)": work_s / n / 60.0,
                    }
                )
    return pd.DataFrame(rows).set_index(["campaigns", "workers", "dispatch per batch (ms)"])


def simulated_verdict(table: pd.DataFrame) -> str:
    """The target (:data:`TARGET`) judged on the computed schedule at each dispatch time of ``table``."""
    rows = table.xs((TARGET["campaigns"], TARGET["workers"]), level=("campaigns", "workers"))
    parts = []
    for dispatch_ms, row in rows.iterrows():
        busy, minutes = float(row["busy fraction"]), float(row["projected wall (min)"])
        met = busy >= TARGET["busy_fraction"] and 60.0 * minutes <= TARGET["wall_s"]
        parts.append(
            f"{dispatch_ms:g} ms per batch: busy {busy:.2f}, {minutes:.1f} min ({'met' if met else 'not met'})"
        )
    return (
        f"computed schedule, {TARGET['campaigns']} campaigns of 120 x 1000 at {TARGET['workers']} workers "
        f"(target busy >= {TARGET['busy_fraction']:g} within {TARGET['wall_s'] / 60:g} min): "
        + "; ".join(parts)
    )
