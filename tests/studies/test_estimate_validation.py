"""The life estimate's validation study: its design set and its statistics."""

import numpy as np
import pandas as pd
import pytest

from lnss_lib.settings import load_settings
from lnss_lib.studies import estimate_validation as ev


def test_designs_span_table3_and_the_frozen_family():
    rows = ev.estimate_validation_designs(load_settings("ci"), n_random=8)
    sources = [r["source"] for r in rows]
    assert (
        len(rows) >= 24
        and sources.count("random") == 8
        and sources.count("frozen") == len(ev.FROZEN_MEMBERS)
    )
    assert all(r["design"][5] == 1 for r in rows)  # one satellite per plane
    assert len({r["design"] for r in rows}) == len(rows)
    for a, e, _, inc, planes, _ in (r["design"] for r in rows):
        assert 4000.0 <= a <= 24000.0 and 0.0 <= e < 1.0 and 0.0 < inc <= 90.0 and 2 <= planes <= 5
        assert a * (1.0 - e) > 1737.4  # no design starts inside the Moon


def test_statistics_count_two_free_designs_as_agreeing():
    table = pd.DataFrame(
        {
            "closed_loop": [0.0, 0.1, 0.2, 0.4, 1.0, 0.3],
            "life": [0.001, 0.15, 0.5, 0.3, 0.9, np.nan],
            "campaign": [0.001, 0.15, 0.3, 0.3, 0.9, np.nan],
            "arc": [1.0, 1.0, 1.0, 1.0, 1.0, np.nan],
        }
    )
    stats = ev.estimate_statistics(table)
    assert stats["n_designs"] == 6 and stats["n_compared"] == 5
    assert stats["factor2_share_life"] == pytest.approx(0.8)  # 0.5 vs 0.2 is outside a factor 2
    assert stats["factor2_share_arc"] == pytest.approx(0.2)  # only 1.0 vs 1.0
    assert stats["factor2_share_campaign"] == pytest.approx(1.0)
    assert stats["spearman_rho_life"] == pytest.approx(0.9)
    assert list(ev.estimate_outliers(table).index) == [2]
    assert np.isnan(stats["spearman_rho_arc"])  # a constant column ranks nothing
