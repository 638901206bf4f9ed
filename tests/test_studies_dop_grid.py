"""Notebook 02's study (lnss_lib.studies.dop_grid): summary and latitude tables, maps, degenerate geometry."""

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from lnss_lib import frames
from lnss_lib.settings import load_settings
from lnss_lib.studies import dop_grid as dg
from lnss_lib.surface_grid import surface_grid

R_MOON_KM = 1737.4


def single_point_grid(lat_deg, lon_deg):
    return surface_grid(lat_deg, lat_deg, 10.0, lon_deg, lon_deg, 10.0, radius_km=R_MOON_KM)


def _dop_dataset(pdop, hdop, n_visible, lat, lon):
    dims = ("time", "lat", "lon")
    return xr.Dataset(
        {
            "pdop": (dims, np.asarray(pdop, float)),
            "hdop": (dims, np.asarray(hdop, float)),
            "n_visible": (dims, np.asarray(n_visible, np.int16)),
        },
        coords={"time": np.arange(np.shape(pdop)[0], dtype=float), "lat": lat, "lon": lon},
    )


def test_latitude_deg_and_summary_table():
    np.testing.assert_allclose(
        frames.latitude_deg([[1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, -3.0]]),
        [-45.0, 0.0, -90.0],
    )
    ours = {"mean_visible_sats": 11.0, "pdop_mean_3sigma": 2.0, "availability_pct": 99.0}
    table = dg.summary_table({"ours": ours, "other": {"mean_visible_sats": 5.0}}, reference="ours")
    assert list(table.columns) == ["paper (Table 4)", "ours", "other", "default vs paper (%)"]
    assert table.loc["mean visible satellites", "default vs paper (%)"] == pytest.approx(
        100.0 * (11.0 - 11.22) / 11.22
    )
    assert table.loc["PDOP (3-sigma mean)", "default vs paper (%)"] == pytest.approx(
        100.0 * (2.0 - 2.17) / 2.17
    )
    assert np.isnan(
        table.loc["PDOP and HDOP < 15 (%)", "paper (Table 4)"]
    )  # the paper gives five metrics
    assert np.isnan(table.loc["HDOP (3-sigma mean)", "other"])
    with pytest.raises(ValueError, match="reference column 'missing'"):
        dg.summary_table({"ours": ours}, reference="missing")


def test_latitude_statistics_and_maps_by_hand():
    lat, lon = [-90.0, -60.0], [0.0, 10.0]
    pdop = [[[1.0, 2.0], [20.0, np.nan]], [[3.0, 4.0], [5.0, 6.0]], [[5.0, 16.0], [7.0, 8.0]]]
    hdop = np.asarray(pdop) / 2.0
    n_vis = [[[6, 5], [4, 3]], [[6, 6], [5, 5]], [[7, 4], [5, 4]]]
    mf = _dop_dataset(pdop, hdop, n_vis, lat, lon)
    enu = _dop_dataset(pdop, hdop * 3.0, n_vis, lat, lon)
    rows = dg.latitude_statistics(mf, enu, threshold=15.0).set_index("lat (deg)")
    assert rows.loc[-90.0, "PDOP unavailable (%)"] == pytest.approx(100.0 / 6.0)  # the 16
    assert rows.loc[-60.0, "PDOP unavailable (%)"] == pytest.approx(
        200.0 / 6.0
    )  # the 20 and the NaN
    assert rows.loc[-90.0, "median PDOP"] == pytest.approx(3.5)
    assert rows.loc[-60.0, "median PDOP"] == pytest.approx(7.0)  # of 20, 5, 6, 7, 8: NaN skipped
    assert rows.loc[-60.0, "median HDOP ENU"] == pytest.approx(
        3.0 * rows.loc[-60.0, "median HDOP Moon-fixed"]
    )
    assert rows.loc[-90.0, "mean visible"] == pytest.approx(34.0 / 6.0)
    maps = dg.time_statistics_maps(mf, enu, threshold=15.0)
    np.testing.assert_allclose(
        maps["pdop_availability_pct"].values, [[100.0, 200.0 / 3.0], [200.0 / 3.0, 200.0 / 3.0]]
    )
    np.testing.assert_allclose(maps["median_pdop"].values, [[3.0, 4.0], [7.0, 7.0]])
    np.testing.assert_allclose(
        maps["median_hdop_enu"].values, 3.0 * maps["median_hdop_moon_fixed"].values
    )
    np.testing.assert_allclose(maps["mean_visible"].values, np.mean(n_vis, axis=0))


def test_plane_visibility_closed_form():
    """Plane 1 in the x-z plane, plane 2 in the y-z plane; a receiver at lat -60, lon 0 lies in plane 1
    (angle 0) and 30 deg from plane 2 (asin of its x component 0.5)."""
    grid = single_point_grid(-60.0, 0.0)
    up = grid.up[0, 0]
    r_sat = np.array(
        [
            5000.0 * up,
            [0.0, 0.0, 5000.0],  # plane 1: above the receiver, over the north pole
            [0.0, 0.0, -5000.0],
            [0.0, 5000.0, 0.0],
        ]
    )[:, None, :]  # plane 2: over the south pole, over y
    normal = np.array([[0.0, 1.0, 0.0]] * 2 + [[-1.0, 0.0, 0.0]] * 2)[:, None, :]
    counts, angle = dg.plane_visibility(r_sat, normal, grid, 5.0, 2)
    assert counts.shape == (2, 1, 1, 1)
    assert counts.ravel().tolist() == [1, 1]
    np.testing.assert_allclose(angle.ravel(), [0.0, 30.0], atol=1e-9)
    with pytest.raises(ValueError, match="sats_per_plane"):
        dg.plane_visibility(r_sat, normal, grid, 5.0, 3)
    with pytest.raises(ValueError, match="normal_mf"):
        dg.plane_visibility(r_sat, normal[:3], grid, 5.0, 2)


def test_degenerate_geometry_rows_by_hand():
    pdop = np.array([2.0, 20.0, np.nan, 3.0]).reshape(4, 1, 1)
    counts = np.array([[3, 0, 0, 2], [3, 5, 4, 2]]).reshape(2, 4, 1, 1)
    angle = np.array([[10.0, 11.0, 12.0, 13.0], [20.0, 21.0, 22.0, 23.0]]).reshape(2, 4, 1, 1)
    bad, good = dg.degenerate_geometry_rows(pdop, counts, angle, 15.0)
    assert bad["samples"] == "PDOP >= 15 or none" and good["samples"] == "PDOP < 15"
    assert bad["share (%)"] == pytest.approx(50.0) and good["share (%)"] == pytest.approx(50.0)
    assert (bad["visible from plane 1"], bad["visible from plane 2"]) == (0.0, 4.5)
    assert (
        bad["samples seeing one plane only (%)"] == 100.0
        and good["samples seeing one plane only (%)"] == 0.0
    )
    assert bad["median angle receiver-majority plane (deg)"] == pytest.approx(
        21.5
    )  # plane 2 supplies most
    assert good["median angle receiver-majority plane (deg)"] == pytest.approx(
        11.5
    )  # ties go to plane 1
    only_good = dg.degenerate_geometry_rows(np.ones((4, 1, 1)), counts, angle)
    assert [r["samples"] for r in only_good] == ["PDOP < 15"]
    with pytest.raises(ValueError, match="do not match"):
        dg.degenerate_geometry_rows(pdop[:3], counts, angle)


@pytest.fixture(scope="module")
def elfo_study():
    from lnss_lib.constellation import standalone_elfo

    profile = load_settings("ci")
    return profile, dg.element_frame_study(
        "ci", standalone_elfo(profile.standalone_elfo, profile.dynamics)
    )


def test_frame_study_tables_are_consistent(elfo_study):
    """Apolune latitude -i for AOP 90 deg in the lunar-equatorial frame; per-row and per-class tables
    average back to the summary metrics computed by the independent dop_kernel path."""
    profile, study = elfo_study
    cfg = profile.standalone_elfo
    apolune = dg.apolune_latitude_table(study, cfg.sats_per_plane).set_index("element frame")
    np.testing.assert_allclose(
        apolune.loc["lunar_equator_of_epoch"].values, -cfg.inc_deg, atol=0.05
    )
    assert (
        abs(apolune.loc["j2000"].values[0] - apolune.loc["j2000"].values[1]) > 10.0
    )  # J2000 tilts the planes apart
    summaries = dg.frame_study_summaries(study)
    assert len(summaries) == 2 * len(study.frames) + 3  # (frame, axes) pairs and three checks
    rows = dg.latitude_table(study)
    diagnosis = dg.degenerate_geometry_table(study, cfg.sats_per_plane)
    for frame in study.frames:
        summary = summaries[f"{frame} / moon_fixed"]
        block = rows[rows["element frame"] == frame]
        assert block["mean visible"].mean() == pytest.approx(
            summary["mean_visible_sats"], rel=1e-12
        )
        assert block["PDOP unavailable (%)"].mean() == pytest.approx(
            100.0 - summary["pdop_avail_pct"], abs=1e-9
        )
        classes = diagnosis[diagnosis["element frame"] == frame]
        assert classes["share (%)"].sum() == pytest.approx(100.0)
        visible = (
            classes["share (%)"]
            / 100.0
            * (classes["visible from plane 1"] + classes["visible from plane 2"])
        ).sum()
        assert visible == pytest.approx(summary["mean_visible_sats"], rel=1e-12)
    assert summaries["lunar_equator_of_epoch / moon_fixed"]["pdop_mean_3sigma"] == pytest.approx(
        summaries["lunar_equator_of_epoch / enu"]["pdop_mean_3sigma"], rel=1e-12
    )  # PDOP does not depend on the axes


def test_frame_findings_read_the_tables():
    base = {
        "mean_visible_sats": 11.0,
        "pdop_mean_3sigma": 2.0,
        "hdop_mean_3sigma": 0.8,
        "pdop_avail_pct": 100.0,
        "hdop_avail_pct": 100.0,
    }
    summaries = {
        "lunar_equator_of_epoch / moon_fixed": base,
        "lunar_equator_of_epoch / enu": {**base, "hdop_mean_3sigma": 0.9},
        "j2000 / moon_fixed": {**base, "pdop_mean_3sigma": 300.0, "pdop_avail_pct": 90.0},
        "lunar_equator_of_epoch / moon_fixed, two-body": {**base, "pdop_mean_3sigma": 2.02},
    }
    table = dg.summary_table(summaries, reference="lunar_equator_of_epoch / moon_fixed")
    apolune = pd.DataFrame(
        [
            {
                "element frame": "j2000",
                "apolune latitude plane 1 (deg)": -30.04,
                "apolune latitude plane 2 (deg)": -74.0,
            }
        ]
    )
    text = "\n".join(dg.frame_findings(table, apolune))
    worst = 100.0 * abs(2.0 - 2.17) / 2.17  # PDOP differs most from Table 4 here
    assert f"largest difference from Table 4 {worst:.1f}% (PDOP (3-sigma mean))" in text
    assert "local East-North 0.900, +12.5%" in text
    assert "PDOP (3-sigma mean) 300.0, PDOP availability 90.0%, i.e. 10.0%" in text
    assert "-30.0 / -74.0 deg" in text
    assert "two-body: the DOP metrics move by at most 1.00%" in text
    with pytest.raises(ValueError, match="not in the summary table"):
        dg.frame_findings(table.drop(columns="j2000 / moon_fixed"), apolune)
