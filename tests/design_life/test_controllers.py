"""The controllers behind one protocol and the fleet's burn book-keeping (no propagation)."""

import numpy as np
import pytest

from lnss_lib.design_life.controllers import CONTROLLERS, NaturalDrift, box_half_widths
from lnss_lib.design_life.fleet import Burn, budget_kms, flight_plan
from lnss_lib.sections import CONTROLLERS as CONTROLLER_CHOICES
from lnss_lib.settings import load_settings


def test_every_declared_controller_choice_has_a_controller_and_no_other():
    assert set(CONTROLLERS) == set(CONTROLLER_CHOICES)
    assert {cls.name for cls in CONTROLLERS.values()} == set(CONTROLLER_CHOICES)


def test_natural_drift_never_burns_and_reports_no_correction():
    design_life = load_settings("paper").design_life
    natural = NaturalDrift(design_life, 3)
    assert natural.decide(0.0, None) == []
    report = natural.report()
    assert report["n_maneuver_sets"].tolist() == [0, 0, 0]
    assert natural.half.shape == (3, 5)
    assert np.array_equal(natural.half[2], box_half_widths(design_life))


def test_flight_plan_merges_burns_at_one_epoch_and_pads_with_nan():
    """Two impulses planned for the same epoch (to the millisecond) fly as their sum; epochs sorted; a satellite
    with fewer burns is padded with NaN epochs and zero impulses."""
    dv = np.array([0.001, 0.002, 0.0])
    queue = [
        [
            Burn(0, 200.0, dv, "phase", "perilune"),
            Burn(0, 100.0, 2 * dv, "relative_node", "node"),
            Burn(0, 200.0004, dv, "a_trim", "perilune"),
        ],
        [],
    ]
    burn_t, burn_dv = flight_plan(queue)
    assert burn_t.shape == (2, 2) and burn_dv.shape == (2, 2, 3)
    assert burn_t[0].tolist() == [100.0, 200.0] and np.all(np.isnan(burn_t[1]))
    assert np.array_equal(burn_dv[0, 1], 2 * dv) and np.array_equal(burn_dv[1], np.zeros((2, 3)))


def test_budget_is_the_cap_less_what_was_flown_and_what_is_queued():
    queued = [Burn(0, 0.0, np.array([0.003, 0.004, 0.0]), "phase", "other")]
    assert budget_kms(0.1, 0.02, queued) == pytest.approx(0.1 - 0.02 - 0.005, abs=1e-15)
    assert budget_kms(0.1, 0.02, []) == pytest.approx(0.08, abs=1e-15)


def test_the_running_mean_of_the_window_tail_is_that_of_the_whole_coast_to_the_bit():
    """A check averages e, AOP, i and the relative node over the last samples of the coast: reading only the tail that
    the running mean keeps gives the same bits as converting the whole coast."""
    from lnss_lib.design_life.control import running_mean
    from lnss_lib.design_life.controllers import _window_start

    rng = np.random.default_rng(3)
    t_s = np.cumsum(rng.uniform(0.5, 1.5, 400)) * 86400.0
    history = [(t, rng.normal(size=4)) for t in t_s]
    for n in (1, 5, 30, 400):
        coast = history[:n]
        tail = coast[_window_start(coast, 27.3) :]
        whole = running_mean(np.array([h[0] for h in coast]), np.array([h[1] for h in coast]), 27.3)
        part = running_mean(np.array([h[0] for h in tail]), np.array([h[1] for h in tail]), 27.3)
        assert np.array_equal(whole, part) and 0 < len(tail) <= n
    assert len(history[_window_start(history, 27.3) :]) < 40
