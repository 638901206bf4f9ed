"""The seed question on synthetic campaigns (lnss_lib.studies.seed_question): one hypervolume normalisation for all
seeds, the spread, Table 6 and the smallest constellation per seed by notebook 07's rules, and whether they change."""

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from lnss_lib.keys import design_text
from lnss_lib.studies import seed_question as sq
from lnss_lib.studies.pareto import TABLE6_RULES, pareto_front, synthetic_campaign, table6

REFERENCE = json.dumps({"n_sat": 20.0, "pdop_mean_3sigma": 10.0})


def history(hypervolume, seed=1, reference=REFERENCE, **counts):
    n = len(hypervolume)
    data = {"hypervolume": np.asarray(hypervolume, dtype=float)}
    for key in ("n_evaluations_cum", "n_feasible_cum", "n_feasible_pop", "n_cache_hits"):
        data[key] = np.asarray(counts.get(key, 10 * np.arange(1, n + 1)))
    return xr.Dataset(
        {k: ("generation", v) for k, v in data.items()},
        coords={"generation": np.arange(1, n + 1)},
        attrs={"seed": seed, "hypervolume_reference": reference},
    )


def front(seed):
    return pareto_front(synthetic_campaign(1000, seed=seed))


def test_curves_share_one_reference_point_and_spread_is_over_the_seeds():
    histories = {"a": history([0.1, 0.2, 0.4]), "b": history([0.0, 0.3, 0.5], seed=2)}
    curves = sq.hypervolume_curves(histories)
    assert list(curves.columns) == ["a", "b"] and list(curves.index) == [1, 2, 3]
    spread = sq.curve_spread(curves)
    np.testing.assert_allclose(spread["min"], [0.0, 0.2, 0.4])
    np.testing.assert_allclose(spread["max"], [0.1, 0.3, 0.5])
    np.testing.assert_allclose(spread["spread (% of median)"], [200.0, 40.0, 100 * 0.1 / 0.45])
    other = {**histories, "c": history([0.1, 0.2, 0.3], reference=json.dumps({"n_sat": 30.0}))}
    with pytest.raises(ValueError, match="different reference points"):
        sq.hypervolume_curves(other)


def test_table6_per_seed_is_notebook_07s_table6_of_each_front():
    fronts = {"a": front(1), "b": front(2)}
    picks = sq.table6_by_seed(fronts)
    for name, f in fronts.items():
        mine = picks[picks["campaign"] == name]
        expected = table6(
            f, availability_min_pct=90.0, dv_max_kms_per_year=1.0, dv_metric="dv_total_kms_per_year"
        )
        assert len(expected) and set(mine["design"]) == {
            design_text(row) for _, row in expected.iterrows()
        }
        reasons = [r for why in expected["why selected"] for r in why.split("; ")]
        assert sorted(mine["rule"]) == sorted(reasons)
    assert set(picks["rule"]) <= set(sq.RULE_CRITERIA) == {r for r, _ in TABLE6_RULES}
    rule = picks[picks["rule"] == "best PDOP"]
    np.testing.assert_array_equal(rule["value"], [fronts[n].pdop_mean_3sigma.min() for n in "ab"])


def test_what_changes_tells_same_design_same_pattern_and_change():
    one = front(1)
    same = sq.what_changes(sq.table6_by_seed({"a": one, "b": one}), {"a": one, "b": one})
    assert set(same["answer"]) == {"the same design in every seed"}
    assert (same["distinct designs"] == 1).all() and (same["seeds with a pick"] == 2).all()
    # seed b: the same front but every orbit 100 km higher (one step of the grid): the same patterns, other designs
    moved = one.assign(sma_km=one.sma_km + 100.0)
    fronts = {"a": one, "b": moved}
    other = sq.what_changes(sq.table6_by_seed(fronts), fronts)
    assert set(other["answer"]) == {"the same constellation (pattern), another orbit"}
    assert (other["distinct designs"] == 2).all()
    fronts = {"a": one, "b": front(2)}
    changed = sq.what_changes(sq.table6_by_seed(fronts), fronts)
    assert "changes with the seed" in set(changed["answer"])
    assert list(changed.index) == [r for r, _ in TABLE6_RULES] + [sq.SMALLEST_RULE]
    lines = sq.verdict(
        sq.hypervolume_curves({"a": history([0.1, 0.2]), "b": history([0.1, 0.3], seed=2)}),
        pd.DataFrame({"generation at 99 %": [2, 2]}),
        changed,
    )
    assert "0.2000 to 0.3000" in lines[0] and "40.00 % of the median" in lines[0]
    assert sq.SMALLEST_RULE in lines[1] and "Table 6's 7 rules" in lines[2]
    assert "change with the seed" in lines[2]


def test_seed_table_reads_each_seeds_milestones_and_smallest_constellation():
    histories = {"a": history([0.5, 0.99, 1.0]), "b": history([0.0, 0.0, 0.0], seed=2)}
    fronts = {"a": front(1), "b": front(2)}
    table = sq.seed_table(histories, fronts)
    assert table.loc["a", "generation at 99 %"] == 2 and table.loc["a", "generation at 99.9 %"] == 3
    assert np.isnan(
        table.loc["b", "generation at 99 %"]
    )  # nothing feasible in the box: no milestone
    for name, f in fronts.items():
        ok = (f.pdop_avail_pct >= 90) & (f.hdop_avail_pct >= 90)
        assert table.loc[name, "smallest: satellites"] == int(f.n_sat.values[ok.values].min())
        assert table.loc[name, "front designs"] == f.sizes["design"]


def test_against_shipped_finds_where_two_runs_of_one_seed_part():
    shipped = history([0.1, 0.2, 0.3, 0.4])
    same = sq.against_shipped(history([0.1, 0.2, 0.3]), shipped)
    assert same == {
        "generations compared": 3,
        "identical through": 3,
        "searches part at": None,
        "largest relative hypervolume difference before": 0.0,
    }
    evaluated = 10 * np.arange(1, 5)
    evaluated[3] += 1  # generation 4 evaluated another design
    parted = sq.against_shipped(
        history([0.1, 0.2 * (1 + 1e-15), 0.3, 0.41], n_evaluations_cum=evaluated), shipped
    )
    assert parted["identical through"] == 1 and parted["searches part at"] == 4
    assert parted["largest relative hypervolume difference before"] == pytest.approx(1e-15, rel=0.2)
