"""Shared DOP geometry (lnss_lib.geometry): filtered means, availability and the position block of (G^T G)^-1."""

import numpy as np
import pytest

from lnss_lib import geometry


def test_filtered_means():
    values = np.concatenate([np.arange(1.0, 101.0), [np.nan]])
    mean, kept = geometry.filtered_mean(values, "percentile95")     # 95th percentile 95.05: 1..95 kept
    assert kept == 95 and mean == pytest.approx(48.0)
    mean, kept = geometry.filtered_mean(values, "none")
    assert kept == 100 and mean == pytest.approx(50.5)
    spiky = np.array([1.0] * 20 + [100.0])                      # the spike is > 2 sigma away
    assert geometry.filtered_mean(spiky, "sigma2") == (1.0, 20)
    with pytest.raises(ValueError, match="unknown PDOP filter"):
        geometry.filtered_mean(values, "sigma9")


def test_three_sigma_filter_removes_injected_outlier():
    base = 2.0 + 0.1 * np.sin(np.arange(200.0))
    values = np.concatenate([base, [1000.0, np.nan]])
    mean, kept = geometry.sigma_filtered_mean(values)
    assert kept == 200
    assert mean == pytest.approx(base.mean(), rel=1e-12)
    # Without the outlier nothing is removed: sin values stay within 3 sigma of the mean.
    mean_clean, kept_clean = geometry.sigma_filtered_mean(base)
    assert kept_clean == 200 and mean_clean == pytest.approx(base.mean())
