"""Shared fixtures: profiles and the standalone-ELFO set-up, loaded once per test session."""

import numpy as np
import pytest

from lnss_lib.ephemeris import ensure_kernels, tdb_seconds
from lnss_lib.settings import load_settings


def _loaded(name: str) -> dict:
    profile = load_settings(name)
    ensure_kernels(profile.ephemeris)
    return profile


@pytest.fixture(scope="session")
def paper_profile():
    return _loaded("paper")


@pytest.fixture(scope="session")
def ci_profile():
    return _loaded("ci")


@pytest.fixture(scope="session")
def epoch_tdb_s(paper_profile):
    return tdb_seconds(paper_profile.epoch.start_tdb, "TDB")


@pytest.fixture(scope="session")
def two_body_profile():
    """Point-mass Moon only: every perturbation switched off."""
    profile = load_settings(
        "paper",
        overrides={
            "gravity": {"degree": 0},
            "forces": {"third_bodies": [], "srp": False, "albedo": False, "relativity": False},
            "integrator": {"setting": "converged"},
        },
    )
    ensure_kernels(profile.ephemeris)
    return profile


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20250501)
