"""Objectives and constraints (eq. 45, Table 3), the non-dominated mask and the hypervolume."""

import functools
import math

import numpy as np
import pytest

from lnss_lib.campaign.fitness import (
    constraint_matrix,
    constraint_violation,
    front_of,
    hypervolume_of_front,
    hypervolume_points,
    non_dominated_mask,
    objective_matrix,
)


def hypervolume(metrics, feasible, reference):
    """The campaign's hypervolume of the feasible designs (what RunningStats chains): points, front, value."""
    return hypervolume_of_front(front_of(hypervolume_points(metrics, feasible, reference)))


def test_objectives_signs_and_nan_penalty(settings, metrics):
    metrics = metrics(
        n_sat=[8, 12],
        pdop_mean_3sigma=[2.5, math.nan],
        pdop_avail_pct=[95.0, 0.0],
        hdop_mean_3sigma=[1.0, math.nan],
        hdop_avail_pct=[90.0, 0.0],
        dv_total_kms_per_year=[0.8, 2.0],
        dv_opt_kms_per_year=[0.6, 1.5],
        gps_visible_mean=[7.0, 3.0],
        gps_pdop_mean=[900.0, math.nan],
    )
    f = objective_matrix(metrics, settings.objectives, settings.nan_objective)
    np.testing.assert_array_equal(f[0], [8, 2.5, -95.0, 1.0, -90.0, 0.8, 0.6, -7.0, 900.0])
    np.testing.assert_array_equal(f[1], [12, 1e6, -0.0, 1e6, -0.0, 2.0, 1.5, -3.0, 1e6])
    assert np.all(np.isfinite(f))


def test_constraints_of_table3_normalised(settings, metrics):
    assert settings.constraints == (
        ("pdop_mean_3sigma", "max", 10.0),
        ("pdop_avail_pct", "min", 70.0),
        ("dv_total_kms_per_year", "max", 1.0),
        ("n_sat", "max", 20.0),
    )
    metrics = metrics(
        n_sat=[12, 20, 4],
        pdop_mean_3sigma=[12.0, 10.0, math.nan],
        pdop_avail_pct=[56.0, 70.0, 0.0],
        dv_total_kms_per_year=[2.5, 1.0, math.nan],
    )
    g = constraint_matrix(metrics, settings.constraints, settings.nan_violation)
    np.testing.assert_allclose(g[0], [0.2, 0.2, 1.5, -0.4])
    np.testing.assert_allclose(g[1], [0.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(g[2], [1e3, 1.0, 1e3, -0.8])
    np.testing.assert_allclose(constraint_violation(g), [1.9, 0.0, 2001.0])


def _brute_non_dominated(f):
    return np.array(
        [
            not any(np.all(f[j] <= f[i]) and np.any(f[j] < f[i]) for j in range(len(f)))
            for i in range(len(f))
        ]
    )


def test_non_dominated_mask_against_brute_force(rng):
    """Integer objectives (ties) in three dimensions and continuous ones in five (the sweep's k >= 4 branch)."""
    for f in (
        rng.integers(0, 6, size=(300, 3)).astype(float),
        rng.random((200, 5)),
        rng.random((50, 1)),
    ):
        np.testing.assert_array_equal(non_dominated_mask(f), _brute_non_dominated(f))


def test_hypervolume_closed_forms(metrics):
    ref = (("n_sat", 20.0), ("pdop_mean_3sigma", 10.0))
    one = metrics(n_sat=[10], pdop_mean_3sigma=[5.0])
    assert hypervolume(one, np.array([True]), ref) == pytest.approx(0.25)
    assert hypervolume(one, np.array([False]), ref) == 0.0
    two = metrics(
        n_sat=[10, 4, 12], pdop_mean_3sigma=[5.0, 8.0, 12.0]
    )  # third lies outside the box
    # union of [0.5, 1] x [0.5, 1] and [0.2, 1] x [0.8, 1]: 0.25 + 0.3 * 0.2
    assert hypervolume(two, np.ones(3, dtype=bool), ref) == pytest.approx(0.31)


def test_hypervolume_against_monte_carlo(rng):
    """pymoo's HV, as wrapped here (normalised by the reference, dominated and infeasible points
    dropped), against a Monte Carlo estimate of the dominated volume."""
    points = np.array(
        [[0.2, 0.5, 0.7], [0.6, 0.1, 0.4], [0.5, 0.5, 0.2], [0.2, 0.5, 0.7], [0.9, 0.9, 0.9]]
    )
    metrics = {"a": 2.0 * points[:, 0], "b": 10.0 * points[:, 1], "c": points[:, 2]}
    reference = (("a", 2.0), ("b", 10.0), ("c", 1.0))
    samples = rng.random((400_000, 3))
    kept = points[:4]
    covered = np.any(np.all(samples[:, None, :] >= kept[None, :, :], axis=2), axis=1)
    feasible = np.array([True, True, True, True, False])
    assert hypervolume(metrics, feasible, reference) == pytest.approx(covered.mean(), abs=4e-3)
    assert hypervolume(metrics, np.zeros(5, dtype=bool), reference) == 0.0


def test_fitness_is_pure_numpy_and_the_engine_stays_below_presentation():
    import subprocess
    import sys

    code = (
        "import sys, lnss_lib.campaign.fitness; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'pymoo', 'dask', 'distributed', 'xarray'}))"
    )
    assert (
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.strip()
        == "[]"
    )
    code = (
        "import sys, lnss_lib.campaign; print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('plotly', 'papermill') or m.startswith(('lnss_lib.studies', 'lnss_lib.figures', 'lnss_lib.bench'))))"
    )
    assert (
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.strip()
        == "[]"
    )


def test_bounds_verdict_names_each_violated_table3_bound():
    """evaluate's meets_bounds / violated_bounds: the profile's constraints, the campaign's test."""
    from lnss_lib.campaign.settings import bounds_verdict
    from lnss_lib.settings import load_settings

    good = {
        "n_sat": 8,
        "pdop_mean_3sigma": 3.0,
        "pdop_avail_pct": 99.0,
        "dv_total_kms_per_year": 0.2,
    }
    assert bounds_verdict(load_settings("ci").campaign, good) == {
        "meets_bounds": True,
        "violated_bounds": [],
    }
    two = {
        **good,
        "n_sat": 2,
        "pdop_mean_3sigma": None,
        "pdop_avail_pct": 0.0,
        "dv_total_kms_per_year": 2.25,
    }
    verdict = bounds_verdict(load_settings("ci").campaign, two)
    assert verdict["meets_bounds"] is False
    assert verdict["violated_bounds"] == [
        "pdop_mean_3sigma undefined (max 10)",
        "pdop_avail_pct = 0 < min 70",
        "dv_total_kms_per_year = 2.25 > max 1",
    ]
    people = bounds_verdict(load_settings("ci").campaign, two, labelled=True)["violated_bounds"]
    assert people == [
        "PDOP (3-sigma mean) undefined (bound: PDOP (3-sigma mean) <= 10)",
        "PDOP availability (%) 0.0, below its bound 70",
        "Delta-V total (km/s/yr) 2.250, above its bound 1",
    ]
    at_limit = {
        **good,
        "pdop_mean_3sigma": 10.0,
        "pdop_avail_pct": 70.0,
        "dv_total_kms_per_year": 1.0,
        "n_sat": 20,
    }
    assert (
        bounds_verdict(load_settings("ci").campaign, at_limit)["meets_bounds"] is True
    )  # the bounds are inclusive
    operational = load_settings("ci_operational")  # dv_total off, extra metrics on
    verdict = bounds_verdict(
        operational.campaign,
        {
            **two,
            "pdop_mean_3sigma": 3.0,
            "pdop_avail_pct": 90.0,
            "sk_dv_estimate_max_kms_per_year": 0.03,
            "stable_screen": 0.0,
            "pdop_avail_pct_worst_month_estimate": 80.0,
        },
    )
    assert verdict["violated_bounds"] == ["stable_screen = 0 < min 1"]


def test_non_dominated_mask_with_ties_and_duplicates(rng):
    """Equal sums, duplicates and dominators anywhere in the input, in either order: the same mask as the brute
    force (duplicates of a non-dominated row are all kept)."""
    f = rng.integers(0, 4, size=(400, 4)).astype(float)
    f = np.concatenate([f, f[:50], f[::-1]])
    brute = _brute_non_dominated(f)
    np.testing.assert_array_equal(non_dominated_mask(f), brute)
    np.testing.assert_array_equal(non_dominated_mask(f[::-1]), brute[::-1])
    assert non_dominated_mask(np.zeros((0, 3))).shape == (0,)


def test_running_statistics_equal_the_statistics_over_every_design(settings, rng):
    """A run's per-generation numbers kept up to date generation by generation (RunningStats) equal those computed
    over every design at once, and the hypervolume equals pymoo's on the brute-force front in journal order."""
    from pymoo.indicators.hv import HV

    from lnss_lib.campaign.callbacks import RunningStats, generation_stats
    from lnss_lib.keys import METRIC_KEYS

    n = 900
    values = {
        "n_sat": rng.integers(4, 24, n),
        "pdop_mean_3sigma": rng.uniform(1, 14, n),
        "pdop_avail_pct": rng.uniform(50, 100, n),
        "hdop_mean_3sigma": rng.uniform(0.5, 12, n),
        "hdop_avail_pct": rng.uniform(50, 100, n),
        "dv_total_kms_per_year": rng.uniform(0.2, 1.3, n),
        "dv_opt_kms_per_year": rng.uniform(0.1, 1.0, n),
        "gps_visible_mean": rng.uniform(3, 9, n),
        "gps_pdop_mean": rng.uniform(5, 2000, n),
        "mean_visible_sats": rng.uniform(2, 8, n),
    }
    records = [
        {
            "key": [i, 0, 0, 0, 0, 0],
            "ok": bool(i % 17),
            "metrics": {k: float(values[k][i]) for k in METRIC_KEYS},
        }
        for i in range(n)
    ]
    running = RunningStats(settings)
    for stop in (0, 1, 120, 121, 480, 900):
        running.update(records[:stop])
        pop = [tuple(r["key"]) for r in records[max(0, stop - 120) : stop]]
        whole = generation_stats(settings, records[:stop], pop)
        incremental = running.stats(pop)
        assert incremental.keys() == whole.keys()
        for key, value in whole.items():
            assert incremental[key] == pytest.approx(value, rel=1e-12, nan_ok=True), key
    assert running.n_feasible > 50
    columns = {k: values[k] for k in METRIC_KEYS}
    feasible = np.array([r["ok"] for r in records]) & np.all(
        [
            values["pdop_mean_3sigma"] <= 10,
            values["pdop_avail_pct"] >= 70,
            values["dv_total_kms_per_year"] <= 1.0,
            values["n_sat"] <= 20,
        ],
        axis=0,
    )
    assert running.n_feasible == feasible.sum()
    points = np.column_stack([columns[m][feasible] / ref for m, ref in settings.hypervolume])
    points = points[np.all(points < 1.0, axis=1)]
    brute = _brute_non_dominated(points)
    assert running.stats([])["hypervolume"] == pytest.approx(
        HV(ref_point=np.ones(points.shape[1]))(points[brute]), rel=1e-12
    )


def test_every_name_the_campaign_package_exports_resolves():
    """``lnss_lib.campaign`` loads its names lazily from its modules: each one in ``__all__`` exists there."""
    import lnss_lib.campaign as campaign

    missing = [name for name in campaign.__all__ if not hasattr(campaign, name)]
    assert missing == []


def test_smallest_constellation_is_fewest_satellites_then_cheapest_keeping_both_availabilities():
    import pandas as pd

    from lnss_lib.campaign.fitness import smallest_constellation

    designs = pd.DataFrame(
        {
            "n_sat": [4, 6, 6, 6, 6, 8],
            "pdop_avail_pct": [99.0, 95.0, 95.0, 95.0, 95.0, 99.0],
            "hdop_avail_pct": [
                99.0,
                80.0,
                95.0,
                np.nan,
                95.0,
                99.0,
            ],  # 6 at 80 % or NaN HDOP: no service
            "dv_total_kms_per_year": [0.1, 0.2, 0.9, 0.3, 0.5, 0.05],
        },
        index=[10, 11, 12, 13, 14, 15],  # positions are returned, whatever the index
    )
    every = np.ones(6, dtype=bool)
    pick = functools.partial(smallest_constellation, designs, dv_metric="dv_total_kms_per_year")
    assert pick(every, availability_min_pct=90.0) == 0  # the 4 keeps the service
    no_four = every & (designs["n_sat"].to_numpy() > 4)
    assert (
        pick(no_four, availability_min_pct=90.0) == 4
    )  # the cheaper 6 of the two keeping PDOP and HDOP
    assert pick(no_four, availability_min_pct=90.0, availability=("pdop_avail_pct",)) == 1
    assert pick(no_four, availability_min_pct=99.5) is None
    assert pick(np.zeros(6, dtype=bool), availability_min_pct=0.0) is None
    designs.loc[14, "dv_total_kms_per_year"] = (
        np.nan
    )  # an undefined Delta-V ranks last among its size
    assert pick(no_four, availability_min_pct=90.0) == 2
