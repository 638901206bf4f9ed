"""Campaign fixtures: the paper settings, a real in-process ci campaign (the Dask run's reference) and an
uninterrupted synthetic campaign through the command line (the kill-and-resume reference)."""

import math

import numpy as np
import pytest

from lnss_lib.campaign import CampaignPlan, run_campaign
from lnss_lib.keys import METRIC_KEYS
from lnss_lib.settings import load_settings

from .helpers import KILL_SETTINGS, SYNTHETIC, _cli


@pytest.fixture(scope="session")
def settings():
    return CampaignPlan.of(load_settings("paper"))


@pytest.fixture
def metrics():
    """``metrics(**values)``: metric columns, NaN except the given ones."""

    def build(**values):
        base = {k: np.array([math.nan]) for k in METRIC_KEYS}
        base.update({k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()})
        return base

    return build


@pytest.fixture(scope="session")
def real_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("real") / "run"
    result = run_campaign("ci", workers=0, run_dir=run_dir, progress=False)
    return result


@pytest.fixture(scope="session")
def synthetic_reference(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("synthetic") / "reference"
    _cli(SYNTHETIC + KILL_SETTINGS + ["--workers", "0", "--run-dir", str(run_dir)])
    return run_dir
