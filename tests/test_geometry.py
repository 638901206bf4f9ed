"""Shared DOP geometry (lnss_lib.geometry): filtered means, availability and the position block of (G^T G)^-1."""

from fractions import Fraction

import numpy as np
import pytest

from lnss_lib import geometry


def test_filtered_means():
    values = np.concatenate([np.arange(1.0, 101.0), [np.nan]])
    mean, kept = geometry.filtered_mean(values, "percentile95")  # 95th percentile 95.05: 1..95 kept
    assert kept == 95 and mean == pytest.approx(48.0)
    mean, kept = geometry.filtered_mean(values, "none")
    assert kept == 100 and mean == pytest.approx(50.5)
    spiky = np.array([1.0] * 20 + [100.0])  # the spike is > 2 sigma away
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


def _explicit_position_block(los, clock_column=True):
    """Position block of (G^T G)^-1 from the explicit geometry matrix, in exact rational arithmetic."""
    rows = [
        [Fraction(float(x)) for x in row] + ([Fraction(1)] if clock_column else []) for row in los
    ]
    k = len(rows[0])
    h = [
        [sum(r[i] * r[j] for r in rows) for j in range(k)]
        + [Fraction(int(i == j)) for j in range(k)]
        for i in range(k)
    ]
    for c in range(k):  # Gauss-Jordan on [H | I]
        p = next(r for r in range(c, k) if h[r][c] != 0)
        h[c], h[p] = h[p], h[c]
        h[c] = [x / h[c][c] for x in h[c]]
        for r in range(k):
            if r != c and h[r][c] != 0:
                h[r] = [a - h[r][c] * b for a, b in zip(h[r], h[c])]
    return np.array([[float(h[i][k + j]) for j in range(3)] for i in range(3)])


def _entries_inverse(los, visible, clock_column=True):
    n, entries = geometry.normal_matrix_entries(
        los[..., 0], los[..., 1], los[..., 2], visible, clock_column=clock_column
    )
    ixx, iyy, izz, ixy, ixz, iyz, ok = geometry.position_block_inverse(*entries)
    return n, np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]), ok


@pytest.mark.parametrize("clock_column", [True, False])
def test_position_block_matches_explicit_inverse(clock_column):
    rng = np.random.default_rng(4)
    los = rng.normal(size=(7, 3))
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    visible = np.array([True, True, False, True, True, True, False])
    n, q, ok = _entries_inverse(los, visible, clock_column)
    assert n == 5 and ok
    np.testing.assert_allclose(q, _explicit_position_block(los[visible], clock_column), rtol=1e-11)


def test_centred_form_keeps_precision_for_nearly_parallel_lines_of_sight():
    """GPS seen from the Moon: lines of sight within ~1 deg of each other. The uncentred Schur complement
    A - b b^T / n loses about six digits here; the centred form matches exact arithmetic to ~1e-9."""
    rng = np.random.default_rng(7)
    axis = np.array([0.3, -0.5, 0.81])
    axis /= np.linalg.norm(axis)
    los = axis + 0.01 * rng.normal(size=(8, 3))
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    _, q, ok = _entries_inverse(los, np.ones(8, bool))
    exact = _explicit_position_block(los)
    assert ok
    assert abs(np.trace(q) / np.trace(exact) - 1.0) < 1e-9
    w = los.sum(axis=0)
    s_uncentred = los.T @ los - np.outer(w, w) / 8
    uncentred = np.linalg.inv(s_uncentred)
    assert abs(np.trace(uncentred) / np.trace(exact) - 1.0) > 100 * abs(
        np.trace(q) / np.trace(exact) - 1.0
    )


def test_singular_geometry_is_flagged():
    """Four lines of sight on one cone about z (equal elevation) leave the vertical and the clock inseparable."""
    az = np.radians([0.0, 90.0, 180.0, 270.0])
    el = np.radians(30.0)
    los = np.stack(
        [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.full(4, np.sin(el))], axis=1
    )
    _, _, ok = _entries_inverse(los, np.ones(4, bool))
    assert not ok
    _, _, ok_without_clock = _entries_inverse(los, np.ones(4, bool), clock_column=False)
    assert ok_without_clock


def test_dop_and_gps_share_one_pdop():
    """The lunar grid kernel and the GPS link kernel give the same PDOP for the same lines of sight."""
    from lnss_lib import dop, gps

    rng = np.random.default_rng(11)
    receiver = np.array([[0.0, 0.0, -1737.4]])
    up = np.array([[0.0, 0.0, -1.0]])
    sats = receiver[0] + rng.normal(size=(6, 1, 3)) * 3000.0 + np.array([0.0, 0.0, -6000.0])
    n, pdop, _ = dop.dop_kernel(sats, receiver, up, elevation_mask_deg=-90.0)
    los = sats[:, 0] - receiver[0]
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    assert n[0, 0] == 6
    assert pdop[0, 0] == pytest.approx(gps.pdop_kernel(los, np.ones(6, bool)), rel=1e-12)


def test_compiled_statistics_match_numpy_filters():
    rng = np.random.default_rng(3)
    values = (
        np.abs(rng.standard_cauchy((50, 12))) + 1.0
    )  # heavy tail: the 3-sigma filter drops samples
    values[0, :3] = np.nan
    values[1, 4] = np.inf
    weights = rng.uniform(0.5, 2.0, 12)
    mean, kept, raw, avail = geometry.weighted_dop_stats(values, weights, 3.0, 15.0)
    w = np.broadcast_to(weights, values.shape)
    ref_mean, ref_kept = geometry.sigma_filtered_mean(values, w, 3.0)
    finite = np.isfinite(values)
    assert kept == ref_kept and kept < finite.sum()
    assert mean == pytest.approx(ref_mean, rel=1e-13)
    assert raw == pytest.approx(np.sum(w[finite] * values[finite]) / np.sum(w[finite]), rel=1e-13)
    assert avail == pytest.approx(geometry.availability_pct(values, 15.0, w), rel=1e-13)
    nothing = np.full((3, 4), np.nan)
    m, k, _, a = geometry.weighted_dop_stats(nothing, np.ones(4), 3.0, 15.0)
    assert np.isnan(m) and k == 0 and a == 0.0


def test_singularity_decision_is_the_powers_without_computing_it_away_from_the_threshold():
    """``geometry._regular`` decides ``det > SINGULAR_RTOL * t ** 3.0`` (the DOP grid's and the GPS link's singular
    test) from t * t * t outside a 1e-14 band around the threshold: the same answer as the power on determinants
    one ulp either side of the threshold, in the band, far from it, and on zero, negative and non-finite inputs."""
    rng = np.random.default_rng(5)
    t_values = np.concatenate(
        [10.0 ** rng.uniform(-120, 120, 400), [0.0, 1.0, 1e-90, 1e90, np.inf, np.nan]]
    )
    cases = 0
    with np.errstate(over="ignore"):  # t ** 3.0 overflows to inf past 1e103: a case under test
        thresholds = [geometry.SINGULAR_RTOL * t**3.0 for t in t_values]
    for t, threshold in zip(t_values, thresholds):
        dets = [
            threshold,
            np.nextafter(threshold, np.inf),
            np.nextafter(threshold, -np.inf),
            threshold * (1 + 3e-15),
            threshold * (1 - 3e-15),
            threshold * (1 + 1e-13),
            threshold * (1 - 1e-13),
            2 * threshold,
            -threshold,
            0.0,
            np.nan,
            np.inf,
            -np.inf,
        ]
        for det in dets:
            assert geometry._regular(det, t) == (det > threshold), (det, t)
            cases += 1
    assert cases == len(t_values) * 13
