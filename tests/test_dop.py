"""South-pole grid, visibility and DOP (eq. 1-14): closed forms and independent cross-checks."""

import numpy as np
import pytest
import xarray as xr

from lnss_lib.config import load_profile
from lnss_lib.dop import (
    availability_pct,
    dop_from_propagation,
    dop_grid,
    dop_summary,
    elevation_deg,
    grid_from_profile,
    sigma_filtered_mean,
    surface_grid,
)

R_MOON_KM = 1737.4


def enu_basis(lat_deg, lon_deg):
    """East, North, Up unit vectors (Moon-fixed axes) written out independently of the library."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    east = np.array([-np.sin(lam), np.cos(lam), 0.0])
    north = np.array([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
    up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    return east, north, up


def symmetric_geometry(lat_deg, lon_deg, elev_deg, azimuth0_deg=17.0, ranges_km=(900.0, 3000.0, 5000.0, 12000.0)):
    """Positions (4, 3) km: one satellite at the zenith, three at ``elev_deg`` 120 deg apart in azimuth."""
    east, north, up = enu_basis(lat_deg, lon_deg)
    receiver = R_MOON_KM * up
    el = np.radians(elev_deg)
    directions = [up]
    for k in range(3):
        az = np.radians(azimuth0_deg + 120.0 * k)
        directions.append(np.cos(el) * np.sin(az) * east + np.cos(el) * np.cos(az) * north + np.sin(el) * up)
    return np.array([receiver + rho * d for rho, d in zip(ranges_km, directions)])


def symmetric_closed_form(lat_deg, elev_deg):
    """PDOP, HDOP (ENU) and HDOP (Moon-fixed x, y) of :func:`symmetric_geometry` with a clock column.

    In ENU, H = G^T G is block diagonal: H_EE = H_NN = 1.5 cos^2(el), and the (Up, clock) block
    [[1 + 3 s^2, 1 + 3 s], [1 + 3 s, 4]] (s = sin el) has determinant 3 (1 - s)^2. So the
    position block of H^-1 is diag(a, a, v) with a = 2 / (3 cos^2 el), v = 4 / (3 (1 - s)^2).
    Rotated to Moon-fixed axes, H^-1_xx + H^-1_yy = a (1 + sin^2 lat) + v cos^2 lat.
    """
    s, c = np.sin(np.radians(elev_deg)), np.cos(np.radians(elev_deg))
    a = 2.0 / (3.0 * c * c)
    v = 4.0 / (3.0 * (1.0 - s) ** 2)
    phi = np.radians(lat_deg)
    return np.sqrt(2 * a + v), np.sqrt(2 * a), np.sqrt(a * (1 + np.sin(phi) ** 2) + v * np.cos(phi) ** 2)


def single_point_grid(lat_deg, lon_deg):
    return surface_grid(lat_deg, lat_deg, 10.0, lon_deg, lon_deg, 10.0, radius_km=R_MOON_KM)


def test_paper_grid_has_144_points_with_repeated_pole():
    grid = grid_from_profile(load_profile("ci"))
    assert grid.n_points == 144 and grid.shape == (4, 36)
    np.testing.assert_allclose(grid.lat_deg, [-90.0, -80.0, -70.0, -60.0])
    np.testing.assert_allclose(grid.lon_deg, np.arange(0.0, 351.0, 10.0))
    np.testing.assert_allclose(grid.r_mf_km[0], np.tile([0.0, 0.0, -R_MOON_KM], (36, 1)), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(grid.r_mf_km, axis=-1), R_MOON_KM)
    np.testing.assert_allclose(grid.weight, 1.0 / 144.0)


def test_area_weights():
    cell = surface_grid(weighting="cell_area")
    cos_lat = surface_grid(weighting="cos_lat")
    for weights in (cell.weight, cos_lat.weight):
        assert weights.sum() == pytest.approx(1.0)
    # Interior rows: band area proportional to cos(lat); the pole row keeps its polar cap.
    assert cell.weight[1, 0] / cell.weight[2, 0] == pytest.approx(np.cos(np.radians(80.0)) / np.cos(np.radians(70.0)))
    cap_share = (1.0 - np.cos(np.radians(5.0))) / 36.0
    band_share = 2.0 * np.sin(np.radians(5.0)) * np.cos(np.radians(80.0)) / 36.0
    assert cell.weight[0, 0] / cell.weight[1, 0] == pytest.approx(cap_share / band_share)
    assert cos_lat.weight[0, 0] == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(ValueError, match="weighting"):
        surface_grid(weighting="equal_area")


def test_zenith_satellite_has_elevation_90():
    grid = surface_grid(radius_km=R_MOON_KM)
    i, j = 2, 4
    r_sat = (R_MOON_KM + 5000.0) * grid.up[i, j]
    elev = elevation_deg(r_sat[None, None, :], grid)[0, 0]
    assert elev[i, j] == pytest.approx(90.0, abs=1e-6)
    # Independent check at other grid points: tan(el) = (D cos g - R) / (D sin g), g the central angle.
    gamma = np.arccos(np.clip(grid.up @ grid.up[i, j], -1.0, 1.0))
    d = R_MOON_KM + 5000.0
    expected = np.degrees(np.arctan2(d * np.cos(gamma) - R_MOON_KM, d * np.sin(gamma)))
    np.testing.assert_allclose(elev, expected, atol=1e-9)


@pytest.mark.parametrize("lat_deg, lon_deg", [(-90.0, 0.0), (-90.0, 130.0), (-60.0, 30.0), (-72.0, 250.0)])
@pytest.mark.parametrize("elev_deg", [10.0, 30.0, 60.0])
def test_symmetric_geometry_closed_form(lat_deg, lon_deg, elev_deg):
    grid = single_point_grid(lat_deg, lon_deg)
    r_sat = symmetric_geometry(lat_deg, lon_deg, elev_deg)[:, None, :]
    pdop_cf, hdop_enu_cf, hdop_mf_cf = symmetric_closed_form(lat_deg, elev_deg)
    enu = dop_grid(r_sat, grid, los_axes="enu")
    mf = dop_grid(r_sat, grid, los_axes="moon_fixed")
    assert int(enu["n_visible"].item()) == 4
    assert enu["pdop"].item() == pytest.approx(pdop_cf, rel=1e-9)
    assert mf["pdop"].item() == pytest.approx(pdop_cf, rel=1e-9)
    assert enu["hdop"].item() == pytest.approx(hdop_enu_cf, rel=1e-9)
    assert mf["hdop"].item() == pytest.approx(hdop_mf_cf, rel=1e-9)
    if lat_deg == -90.0:
        # At the pole the Moon-fixed x-y plane is the local horizontal plane.
        assert mf["hdop"].item() == pytest.approx(enu["hdop"].item(), rel=1e-9)


def test_matches_pseudo_inverse_of_explicit_geometry_matrix():
    rng = np.random.default_rng(7)
    nsat, ntime = 9, 6
    directions = rng.normal(size=(nsat, ntime, 3))
    directions[..., 2] = -np.abs(directions[..., 2]) - 0.3
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    r_sat = directions * rng.uniform(2500.0, 12000.0, size=(nsat, ntime, 1))
    grid = surface_grid(radius_km=R_MOON_KM)
    results = {axes: dop_grid(r_sat, grid, los_axes=axes) for axes in ("moon_fixed", "enu")}
    checked = 0
    for t in range(ntime):
        for i in range(grid.shape[0]):
            for j in range(0, grid.shape[1], 5):
                east, north, up = enu_basis(grid.lat_deg[i], grid.lon_deg[j])
                los = r_sat[:, t] - R_MOON_KM * up
                los /= np.linalg.norm(los, axis=1, keepdims=True)
                visible = np.degrees(np.arcsin(los @ up)) >= 5.0
                assert results["enu"]["n_visible"].values[t, i, j] == visible.sum()
                if visible.sum() < 4:
                    assert np.isnan(results["enu"]["pdop"].values[t, i, j])
                    continue
                for axes, basis in (("moon_fixed", np.eye(3)), ("enu", np.array([east, north, up]))):
                    g = np.column_stack([los[visible] @ basis.T, np.ones(visible.sum())])
                    h_inv = np.linalg.pinv(g.T @ g)
                    pdop_ref = np.sqrt(np.trace(h_inv[:3, :3]))
                    hdop_ref = np.sqrt(h_inv[0, 0] + h_inv[1, 1])
                    assert results[axes]["pdop"].values[t, i, j] == pytest.approx(pdop_ref, rel=1e-7)
                    assert results[axes]["hdop"].values[t, i, j] == pytest.approx(hdop_ref, rel=1e-7)
                checked += 1
    assert checked > 20


def test_availability_counts_unavailable_and_too_few_visible():
    lat, lon = -90.0, 0.0
    good = symmetric_geometry(lat, lon, 30.0)
    three_visible = good.copy()
    three_visible[1] = np.array([0.0, 0.0, 8000.0])  # over the north pole: below the horizon
    poor = symmetric_geometry(lat, lon, 85.0)
    r_sat = np.stack([good, three_visible, poor], axis=1)
    grid = surface_grid(-90.0, -90.0, 10.0, 0.0, 350.0, 10.0, radius_km=R_MOON_KM)
    ds = dop_grid(r_sat, grid, t_tdb_s=[0.0, 900.0, 1800.0])
    np.testing.assert_array_equal(ds["n_visible"].values, np.repeat([[4], [3], [4]], 36, axis=1)[:, None, :])
    assert np.all(np.isnan(ds["pdop"].values[1])) and np.all(np.isnan(ds["hdop"].values[1]))
    assert np.all(ds["pdop"].values[2] > 15.0)
    summary = dop_summary(ds)
    assert summary["pdop_availability_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["availability_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["fewer_than_4_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["n_visible_mean"] == pytest.approx(11.0 / 3.0)
    assert availability_pct([1.0, np.nan, 14.9, 15.0, np.inf]) == pytest.approx(40.0)


def test_non_finite_positions_are_never_visible():
    r_sat = symmetric_geometry(-90.0, 0.0, 30.0)[:, None, :].repeat(2, axis=1)
    r_sat[0, 1] = np.nan
    ds = dop_grid(r_sat, single_point_grid(-90.0, 0.0))
    assert ds["n_visible"].values.ravel().tolist() == [4, 3]


def test_three_sigma_filter_removes_injected_outlier():
    base = 2.0 + 0.1 * np.sin(np.arange(200.0))
    values = np.concatenate([base, [1000.0, np.nan]])
    mean, kept = sigma_filtered_mean(values)
    assert kept == 200
    assert mean == pytest.approx(base.mean(), rel=1e-12)
    # Without the outlier nothing is removed: sin values stay within 3 sigma of the mean.
    mean_clean, kept_clean = sigma_filtered_mean(base)
    assert kept_clean == 200 and mean_clean == pytest.approx(base.mean())


def test_summary_uses_weights():
    grid = surface_grid(-80.0, -70.0, 10.0, 0.0, 0.0, 10.0, radius_km=R_MOON_KM, weighting="cos_lat")
    ds = xr.Dataset(
        {
            "n_visible": (("time", "lat", "lon"), np.array([[[4], [8]]])),
            "pdop": (("time", "lat", "lon"), np.array([[[2.0], [20.0]]])),
            "hdop": (("time", "lat", "lon"), np.array([[[1.0], [1.0]]])),
            "weight": (("lat", "lon"), grid.weight),
        }
    )
    w80, w70 = np.cos(np.radians(80.0)), np.cos(np.radians(70.0))
    summary = dop_summary(ds)
    assert summary["n_visible_mean"] == pytest.approx((4 * w80 + 8 * w70) / (w80 + w70))
    assert summary["pdop_availability_pct"] == pytest.approx(100.0 * w80 / (w80 + w70))
    assert dop_summary(ds, weighted=False)["pdop_availability_pct"] == pytest.approx(50.0)


def test_bad_inputs():
    grid = single_point_grid(-90.0, 0.0)
    r_sat = symmetric_geometry(-90.0, 0.0, 30.0)[:, None, :]
    with pytest.raises(ValueError, match="line-of-sight axes"):
        dop_grid(r_sat, grid, los_axes="ecef")
    with pytest.raises(ValueError, match="shape"):
        dop_grid(r_sat[:, 0, :], grid)
    with pytest.raises(ValueError, match="latitudes"):
        surface_grid(-100.0, -60.0)


def test_dop_from_propagation_rotates_to_moon_fixed():
    from lnss_lib.ephemeris import ensure_kernels, rotation, tdb_seconds

    profile = load_profile("ci")
    ensure_kernels(profile)
    times = tdb_seconds(profile["epoch"]["start_tdb"]) + 3600.0 * np.arange(4)
    rng = np.random.default_rng(3)
    r_mf = rng.normal(size=(8, 4, 3))
    r_mf[..., 2] = -np.abs(r_mf[..., 2]) - 0.5
    r_mf *= 6000.0 / np.linalg.norm(r_mf, axis=-1, keepdims=True)
    to_j2000 = rotation(profile["frames"]["moon_fixed"], "J2000", times)
    r_mci = np.einsum("tij,stj->sti", to_j2000, r_mf)
    prop = xr.Dataset(
        {"r_mci_km": (("sat", "time", "xyz"), r_mci)},
        coords={"sat": np.arange(8), "time": times, "xyz": ["x", "y", "z"]},
    )
    via_propagation = dop_from_propagation(profile, prop)
    direct = dop_grid(r_mf, grid_from_profile(profile), t_tdb_s=times)
    np.testing.assert_array_equal(via_propagation["n_visible"].values, direct["n_visible"].values)
    np.testing.assert_allclose(via_propagation["pdop"].values, direct["pdop"].values, rtol=1e-9)
    assert via_propagation["n_visible"].values.max() >= 4


# --------------------------------------------------------------------------- analysis (notebook 02)

from lnss_lib import dop as dop_module  # noqa: E402


def _dop_dataset(pdop, hdop, n_visible, lat, lon):
    dims = ("time", "lat", "lon")
    return xr.Dataset({"pdop": (dims, np.asarray(pdop, float)), "hdop": (dims, np.asarray(hdop, float)),
                       "n_visible": (dims, np.asarray(n_visible, np.int16))},
                      coords={"time": np.arange(np.shape(pdop)[0], dtype=float), "lat": lat, "lon": lon})


def test_latitude_deg_and_summary_table():
    np.testing.assert_allclose(dop_module.latitude_deg([[1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, -3.0]]),
                               [-45.0, 0.0, -90.0])
    ours = {"n_visible_mean": 11.0, "pdop_mean_3sigma": 2.0, "availability_pct": 99.0}
    table = dop_module.summary_table({"ours": ours, "other": {"n_visible_mean": 5.0}}, reference="ours")
    assert list(table.columns) == ["paper (Table 4)", "ours", "other", "default vs paper (%)"]
    assert table.loc["mean visible satellites", "default vs paper (%)"] == pytest.approx(100.0 * (11.0 - 11.22) / 11.22)
    assert table.loc["PDOP (3-sigma mean)", "default vs paper (%)"] == pytest.approx(100.0 * (2.0 - 2.17) / 2.17)
    assert np.isnan(table.loc["PDOP and HDOP < 15 (%)", "paper (Table 4)"])     # the paper gives five metrics
    assert np.isnan(table.loc["HDOP (3-sigma mean)", "other"])
    with pytest.raises(ValueError, match="reference column 'missing'"):
        dop_module.summary_table({"ours": ours}, reference="missing")


def test_latitude_statistics_and_maps_by_hand():
    lat, lon = [-90.0, -60.0], [0.0, 10.0]
    pdop = [[[1.0, 2.0], [20.0, np.nan]], [[3.0, 4.0], [5.0, 6.0]], [[5.0, 16.0], [7.0, 8.0]]]
    hdop = np.asarray(pdop) / 2.0
    n_vis = [[[6, 5], [4, 3]], [[6, 6], [5, 5]], [[7, 4], [5, 4]]]
    mf = _dop_dataset(pdop, hdop, n_vis, lat, lon)
    enu = _dop_dataset(pdop, hdop * 3.0, n_vis, lat, lon)
    rows = dop_module.latitude_statistics(mf, enu, threshold=15.0).set_index("lat (deg)")
    assert rows.loc[-90.0, "PDOP unavailable (%)"] == pytest.approx(100.0 / 6.0)      # the 16
    assert rows.loc[-60.0, "PDOP unavailable (%)"] == pytest.approx(200.0 / 6.0)      # the 20 and the NaN
    assert rows.loc[-90.0, "median PDOP"] == pytest.approx(3.5)
    assert rows.loc[-60.0, "median PDOP"] == pytest.approx(7.0)                       # of 20, 5, 6, 7, 8: NaN skipped
    assert rows.loc[-60.0, "median HDOP ENU"] == pytest.approx(3.0 * rows.loc[-60.0, "median HDOP Moon-fixed"])
    assert rows.loc[-90.0, "mean visible"] == pytest.approx(34.0 / 6.0)
    maps = dop_module.time_statistics_maps(mf, enu, threshold=15.0)
    np.testing.assert_allclose(maps["pdop_availability_pct"].values, [[100.0, 200.0 / 3.0], [200.0 / 3.0, 200.0 / 3.0]])
    np.testing.assert_allclose(maps["median_pdop"].values, [[3.0, 4.0], [7.0, 7.0]])
    np.testing.assert_allclose(maps["median_hdop_enu"].values, 3.0 * maps["median_hdop_moon_fixed"].values)
    np.testing.assert_allclose(maps["mean_visible"].values, np.mean(n_vis, axis=0))


def test_plane_visibility_closed_form():
    """Plane 1 in the x-z plane, plane 2 in the y-z plane; a receiver at lat -60, lon 0 lies in plane 1
    (angle 0) and 30 deg from plane 2 (asin of its x component 0.5)."""
    grid = single_point_grid(-60.0, 0.0)
    up = grid.up[0, 0]
    r_sat = np.array([5000.0 * up, [0.0, 0.0, 5000.0],           # plane 1: above the receiver, over the north pole
                      [0.0, 0.0, -5000.0], [0.0, 5000.0, 0.0]])[:, None, :]   # plane 2: over the south pole, over y
    normal = np.array([[0.0, 1.0, 0.0]] * 2 + [[-1.0, 0.0, 0.0]] * 2)[:, None, :]
    counts, angle = dop_module.plane_visibility(r_sat, normal, grid, 5.0, 2)
    assert counts.shape == (2, 1, 1, 1)
    assert counts.ravel().tolist() == [1, 1]
    np.testing.assert_allclose(angle.ravel(), [0.0, 30.0], atol=1e-9)
    with pytest.raises(ValueError, match="sats_per_plane"):
        dop_module.plane_visibility(r_sat, normal, grid, 5.0, 3)
    with pytest.raises(ValueError, match="normal_mf"):
        dop_module.plane_visibility(r_sat, normal[:3], grid, 5.0, 2)


def test_degenerate_geometry_rows_by_hand():
    pdop = np.array([2.0, 20.0, np.nan, 3.0]).reshape(4, 1, 1)
    counts = np.array([[3, 0, 0, 2], [3, 5, 4, 2]]).reshape(2, 4, 1, 1)
    angle = np.array([[10.0, 11.0, 12.0, 13.0], [20.0, 21.0, 22.0, 23.0]]).reshape(2, 4, 1, 1)
    bad, good = dop_module.degenerate_geometry_rows(pdop, counts, angle, 15.0)
    assert bad["samples"] == "PDOP >= 15 or none" and good["samples"] == "PDOP < 15"
    assert bad["share (%)"] == pytest.approx(50.0) and good["share (%)"] == pytest.approx(50.0)
    assert (bad["visible from plane 1"], bad["visible from plane 2"]) == (0.0, 4.5)
    assert bad["samples seeing one plane only (%)"] == 100.0 and good["samples seeing one plane only (%)"] == 0.0
    assert bad["median angle receiver-majority plane (deg)"] == pytest.approx(21.5)   # plane 2 supplies most
    assert good["median angle receiver-majority plane (deg)"] == pytest.approx(11.5)  # ties go to plane 1
    only_good = dop_module.degenerate_geometry_rows(np.ones((4, 1, 1)), counts, angle)
    assert [r["samples"] for r in only_good] == ["PDOP < 15"]
    with pytest.raises(ValueError, match="do not match"):
        dop_module.degenerate_geometry_rows(pdop[:3], counts, angle)


@pytest.fixture(scope="module")
def elfo_study():
    from lnss_lib.constellation import standalone_elfo

    profile = load_profile("ci")
    return profile, dop_module.element_frame_study("ci", standalone_elfo(profile))


def test_frame_study_tables_are_consistent(elfo_study):
    """Apolune latitude -i for AOP 90 deg in the lunar-equatorial frame; per-row and per-class tables
    average back to the summary metrics computed by the independent dop_kernel path."""
    profile, study = elfo_study
    cfg = profile["standalone_elfo"]
    apolune = dop_module.apolune_latitude_table(study, cfg["sats_per_plane"]).set_index("element frame")
    np.testing.assert_allclose(apolune.loc["lunar_equator_of_epoch"].values, -cfg["inc_deg"], atol=0.05)
    assert abs(apolune.loc["j2000"].values[0] - apolune.loc["j2000"].values[1]) > 10.0   # J2000 tilts the planes apart
    summaries = dop_module.frame_study_summaries(study)
    assert len(summaries) == 2 * len(study.frames) + 3   # (frame, axes) pairs and three checks
    rows = dop_module.latitude_table(study)
    diagnosis = dop_module.degenerate_geometry_table(study, cfg["sats_per_plane"])
    for frame in study.frames:
        summary = summaries[f"{frame} / moon_fixed"]
        block = rows[rows["element frame"] == frame]
        assert block["mean visible"].mean() == pytest.approx(summary["n_visible_mean"], rel=1e-12)
        assert block["PDOP unavailable (%)"].mean() == pytest.approx(100.0 - summary["pdop_availability_pct"], abs=1e-9)
        classes = diagnosis[diagnosis["element frame"] == frame]
        assert classes["share (%)"].sum() == pytest.approx(100.0)
        visible = (classes["share (%)"] / 100.0 * (classes["visible from plane 1"] + classes["visible from plane 2"])).sum()
        assert visible == pytest.approx(summary["n_visible_mean"], rel=1e-12)
    assert summaries["lunar_equator_of_epoch / moon_fixed"]["pdop_mean_3sigma"] == pytest.approx(
        summaries["lunar_equator_of_epoch / enu"]["pdop_mean_3sigma"], rel=1e-12)   # PDOP does not depend on the axes
