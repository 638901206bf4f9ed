"""Guided batches on the backend and the early stop of designs above the Delta-V bound: the
batches cover every design once, the stop is taken only when it cannot change the search, and a campaign with it
equals one without."""

import math

import numpy as np
import pytest

from lnss_lib.campaign import (
    CampaignPlan,
    final_population,
    read_cache_records,
    run_campaign,
    runner,
)
from lnss_lib.campaign.backends import early_stop_bounds, guided_batches
from lnss_lib.campaign.fitness import constraint_matrix
from lnss_lib.evaluator import context_for, evaluate_design
from lnss_lib.keys import METRIC_KEYS, violated_bound
from lnss_lib.settings import load_settings

SYNTHETIC = {"campaign": {"evaluator": "synthetic", "population": 12, "generations": 12}}


@pytest.mark.parametrize(
    "costs, workers",
    [([1.0] * 111, 2), (list(range(20, 0, -1)) * 3, 2), ([5.0], 4), ([], 2), ([20.0, 1.0, 1.0], 1)],
)
def test_guided_batches_cover_every_item_once_and_shrink_to_single_items(costs, workers):
    batches = guided_batches(costs, workers)
    assert [i for batch in batches for i in batch] == list(range(len(costs)))
    remaining = float(sum(costs))
    for batch in batches:
        held = sum(costs[i] for i in batch)
        assert len(batch) == 1 or held <= remaining / (2 * workers) + 1e-12
        remaining -= held
    if len(costs) > 10 * workers:
        assert len(batches[-1]) == 1 and len(batches) < len(costs)


class _Population:
    def __init__(self, feasible):
        self.feasible = np.array(feasible, dtype=bool).reshape(-1, 1)

    def __len__(self):
        return self.feasible.shape[0]

    def get(self, name):
        assert name == "FEAS"  # what pymoo's split_by_feasibility reads
        return self.feasible


class _Algorithm:
    def __init__(self, pop):
        self.pop = pop


def test_early_stop_only_with_a_whole_feasible_population():
    plan = CampaignPlan.of(load_settings("paper"))  # Table 3's bounds, population 120
    n = plan.population
    assert early_stop_bounds(plan, _Algorithm(None)) is None  # first generation
    assert early_stop_bounds(plan, _Algorithm(_Population([True] * (n - 1) + [False]))) is None
    assert (
        early_stop_bounds(plan, _Algorithm(_Population([True] * (n - 1)))) is None
    )  # fewer than the population
    assert early_stop_bounds(plan, _Algorithm(_Population([True] * n))) == plan.constraints
    assert ("dv_total_kms_per_year", "max", 1.0) in plan.constraints


def test_violated_bound_is_the_sign_of_the_campaign_constraint():
    for kind, limit in (("max", 4.6), ("min", 70.0), ("max", 0.0)):
        for value in (limit, np.nextafter(limit, -np.inf), np.nextafter(limit, np.inf), math.nan):
            g = constraint_matrix({"n_sat": [4], "m": [value]}, [("m", kind, limit)], 1e3)[0, 0]
            assert (violated_bound({"m": value}, [("m", kind, limit)]) is not None) is bool(
                g > 0.0
            ), (kind, value)
    assert (
        violated_bound({"other": math.nan}, [("m", "max", 1.0)]) is None
    )  # only the metrics present


def test_a_design_stopped_early_breaks_its_bound_and_the_rest_is_bit_for_bit():
    profile = load_settings("ci")
    context = context_for(profile)
    design = {
        "sma_km": 6142.0,
        "ecc": 0.6,
        "aop_deg": 90.0,
        "inc_deg": 57.7,
        "n_planes": 2,
        "sats_per_plane": 2,
    }
    full = evaluate_design(context, **design)
    dv, pdop = full["dv_total_kms_per_year"], full["pdop_mean_3sigma"]
    assert full["evaluated"] and dv > 0.0 and math.isfinite(pdop)
    at_bounds = evaluate_design(
        context,
        **design,
        stop_bounds=[("dv_total_kms_per_year", "max", dv), ("pdop_mean_3sigma", "max", pdop)],
    )
    assert all(at_bounds[k] == full[k] for k in METRIC_KEYS)  # value == limit: kept
    by_dv = evaluate_design(
        context, **design, stop_bounds=[("dv_total_kms_per_year", "max", np.nextafter(dv, 0.0))]
    )
    assert not by_dv["evaluated"] and "dv_total_kms_per_year" in by_dv["reason"]
    assert (
        by_dv["dv_total_kms_per_year"] == dv
        and by_dv["dv_opt_kms_per_year"] == full["dv_opt_kms_per_year"]
    )
    assert math.isnan(by_dv["pdop_mean_3sigma"]) and by_dv["n_sat"] == 4
    by_dop = evaluate_design(
        context, **design, stop_bounds=[("pdop_mean_3sigma", "max", np.nextafter(pdop, 0.0))]
    )
    assert not by_dop["evaluated"] and "pdop_mean_3sigma" in by_dop["reason"]
    assert by_dop["pdop_mean_3sigma"] == pdop and math.isnan(by_dop["gps_pdop_mean"])
    by_size = evaluate_design(context, **design, stop_bounds=[("n_sat", "max", 3.0)])
    assert not by_size["evaluated"] and math.isnan(by_size["dv_total_kms_per_year"])
    # the time of the parts a stopped design went through is kept (the campaign's time split counts it there)
    assert by_dv["timing_s"]["propagation"] > 0.0 and by_dv["timing_s"]["deltav"] > 0.0
    assert (
        by_dv["timing_s"]["dop"] == 0.0
        and by_dop["timing_s"]["dop"] > 0.0
        and by_dop["timing_s"]["gps"] == 0.0
    )
    assert sum(by_size["timing_s"].values()) == 0.0
    for result in (full, by_dv, by_dop):
        assert 0.0 < sum(result["timing_s"].values()) <= result["wall_s"]


def _feasible(record):
    plan = CampaignPlan.of(load_settings("ci", overrides=SYNTHETIC))
    return violated_bound(record["metrics"], plan.constraints) is None


def _run(tmp_path, name):
    result = run_campaign(
        "ci", overrides=SYNTHETIC, workers=0, run_dir=tmp_path / name, progress=False
    )
    records = {tuple(r["key"]): r for r in read_cache_records(result.run_dir)}
    return result, records


def test_a_campaign_with_the_early_stop_equals_one_without(tmp_path, monkeypatch):
    import xarray as xr

    with_stop, records = _run(tmp_path, "with")
    stopped = [r for r in records.values() if r["reason"].startswith("stopped early")]
    assert stopped, "the early stop never acted: the test would not see a difference"
    monkeypatch.setattr(runner, "early_stop_bounds", lambda plan, algorithm: None)
    without, records_full = _run(tmp_path, "without")
    assert set(records) == set(records_full)
    assert not any(
        records_full[tuple(r["key"])]["ok"]
        and records_full[tuple(r["key"])]["reason"] == ""
        and _feasible(records_full[tuple(r["key"])])
        for r in stopped
    )
    feasible = {k: r["metrics"] for k, r in records_full.items() if r["ok"]}
    for key, metrics in feasible.items():
        if records[key]["ok"]:
            assert records[key]["metrics"] == metrics
    for a, b in zip(final_population(with_stop.run_dir), final_population(without.run_dir)):
        np.testing.assert_array_equal(a, b)
    for name in ("history.nc", "front.nc"):
        a, b = xr.open_dataset(with_stop.run_dir / name), xr.open_dataset(without.run_dir / name)
        for var in a.data_vars:
            if not var.startswith(("time_", "wall", "designs_per")) and var not in ("reason", "ok"):
                np.testing.assert_array_equal(a[var].values, b[var].values, err_msg=f"{name} {var}")
        a.close()
        b.close()
