"""The scheduling model behind ``bench campaign --scaling`` (list scheduling of one generation)."""

import numpy as np
import pytest

from lnss_lib.bench.campaign import _busy_fraction, _greedy_makespan


def test_greedy_makespan_by_hand():
    assert _greedy_makespan(np.array([3.0, 1.0, 1.0, 1.0]), 2, 0.0) == 3.0           # 3 | 1 + 1 + 1
    assert _greedy_makespan(np.array([1.0, 1.0, 1.0, 3.0]), 2, 0.0) == 4.0           # in order: 1+1 | 1+3
    assert _greedy_makespan(np.ones(4), 4, 0.5) == pytest.approx(2.5)                # last task handed out at 1.5 s
    assert _greedy_makespan(np.ones(6), 1, 0.0) == 6.0


def test_busy_fraction_is_one_for_perfect_balance_and_drops_with_idle_workers():
    assert _busy_fraction(np.ones(8), 4, 0.0, 0.0) == pytest.approx(1.0)
    assert _busy_fraction(np.ones(8), 16, 0.0, 0.0) == pytest.approx(0.5)            # half the workers idle
    assert _busy_fraction(np.array([4.0, 1.0, 1.0, 1.0, 1.0]), 2, 0.0, 0.0) == pytest.approx(1.0)
    assert _busy_fraction(np.array([8.0, 1.0]), 2, 0.0, 0.0) == pytest.approx(9.0 / 16.0)
