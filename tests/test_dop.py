"""South-pole grid, visibility and DOP (eq. 1-14): closed forms and independent cross-checks."""

import numpy as np
import pytest
import xarray as xr

from lnss_lib.dop import dop_from_propagation, dop_grid, dop_summary, elevation_deg
from lnss_lib.geometry import availability_pct
from lnss_lib.settings import load_settings
from lnss_lib.surface_grid import SurfaceGrid, surface_grid

R_MOON_KM = 1737.4


def enu_basis(lat_deg, lon_deg):
    """East, North, Up unit vectors (Moon-fixed axes) written out independently of the library."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    east = np.array([-np.sin(lam), np.cos(lam), 0.0])
    north = np.array([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
    up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    return east, north, up


def symmetric_geometry(
    lat_deg, lon_deg, elev_deg, azimuth0_deg=17.0, ranges_km=(900.0, 3000.0, 5000.0, 12000.0)
):
    """Positions (4, 3) km: one satellite at the zenith, three at ``elev_deg`` 120 deg apart in azimuth."""
    east, north, up = enu_basis(lat_deg, lon_deg)
    receiver = R_MOON_KM * up
    el = np.radians(elev_deg)
    directions = [up]
    for k in range(3):
        az = np.radians(azimuth0_deg + 120.0 * k)
        directions.append(
            np.cos(el) * np.sin(az) * east + np.cos(el) * np.cos(az) * north + np.sin(el) * up
        )
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
    return (
        np.sqrt(2 * a + v),
        np.sqrt(2 * a),
        np.sqrt(a * (1 + np.sin(phi) ** 2) + v * np.cos(phi) ** 2),
    )


def single_point_grid(lat_deg, lon_deg):
    return surface_grid(lat_deg, lat_deg, 10.0, lon_deg, lon_deg, 10.0, radius_km=R_MOON_KM)


def test_paper_grid_has_144_points_with_repeated_pole():
    ci = load_settings("ci")
    grid = SurfaceGrid.from_settings(ci.dop, ci.constants.r_moon_mean_km)
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
    assert cell.weight[1, 0] / cell.weight[2, 0] == pytest.approx(
        np.cos(np.radians(80.0)) / np.cos(np.radians(70.0))
    )
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


@pytest.mark.parametrize(
    "lat_deg, lon_deg", [(-90.0, 0.0), (-90.0, 130.0), (-60.0, 30.0), (-72.0, 250.0)]
)
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
                for axes, basis in (
                    ("moon_fixed", np.eye(3)),
                    ("enu", np.array([east, north, up])),
                ):
                    g = np.column_stack([los[visible] @ basis.T, np.ones(visible.sum())])
                    h_inv = np.linalg.pinv(g.T @ g)
                    pdop_ref = np.sqrt(np.trace(h_inv[:3, :3]))
                    hdop_ref = np.sqrt(h_inv[0, 0] + h_inv[1, 1])
                    assert results[axes]["pdop"].values[t, i, j] == pytest.approx(
                        pdop_ref, rel=1e-7
                    )
                    assert results[axes]["hdop"].values[t, i, j] == pytest.approx(
                        hdop_ref, rel=1e-7
                    )
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
    np.testing.assert_array_equal(
        ds["n_visible"].values, np.repeat([[4], [3], [4]], 36, axis=1)[:, None, :]
    )
    assert np.all(np.isnan(ds["pdop"].values[1])) and np.all(np.isnan(ds["hdop"].values[1]))
    assert np.all(ds["pdop"].values[2] > 15.0)
    summary = dop_summary(ds)
    assert summary["pdop_avail_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["availability_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["fewer_than_4_pct"] == pytest.approx(100.0 / 3.0)
    assert summary["mean_visible_sats"] == pytest.approx(11.0 / 3.0)
    assert availability_pct([1.0, np.nan, 14.9, 15.0, np.inf]) == pytest.approx(40.0)


def test_non_finite_positions_are_never_visible():
    r_sat = symmetric_geometry(-90.0, 0.0, 30.0)[:, None, :].repeat(2, axis=1)
    r_sat[0, 1] = np.nan
    ds = dop_grid(r_sat, single_point_grid(-90.0, 0.0))
    assert ds["n_visible"].values.ravel().tolist() == [4, 3]


def test_summary_uses_weights():
    grid = surface_grid(
        -80.0, -70.0, 10.0, 0.0, 0.0, 10.0, radius_km=R_MOON_KM, weighting="cos_lat"
    )
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
    assert summary["mean_visible_sats"] == pytest.approx((4 * w80 + 8 * w70) / (w80 + w70))
    assert summary["pdop_avail_pct"] == pytest.approx(100.0 * w80 / (w80 + w70))
    assert dop_summary(ds, weighted=False)["pdop_avail_pct"] == pytest.approx(50.0)


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

    profile = load_settings("ci")
    ensure_kernels(profile.ephemeris)
    times = tdb_seconds(profile.epoch.start_tdb) + 3600.0 * np.arange(4)
    rng = np.random.default_rng(3)
    r_mf = rng.normal(size=(8, 4, 3))
    r_mf[..., 2] = -np.abs(r_mf[..., 2]) - 0.5
    r_mf *= 6000.0 / np.linalg.norm(r_mf, axis=-1, keepdims=True)
    to_j2000 = rotation(profile.frames.moon_fixed, "J2000", times)
    r_mci = np.einsum("tij,stj->sti", to_j2000, r_mf)
    prop = xr.Dataset(
        {"r_mci_km": (("sat", "time", "xyz"), r_mci)},
        coords={"sat": np.arange(8), "time": times, "xyz": ["x", "y", "z"]},
    )
    via_propagation = dop_from_propagation(profile.dop, profile.dynamics, prop)
    direct = dop_grid(
        r_mf,
        SurfaceGrid.from_settings(profile.dop, profile.constants.r_moon_mean_km),
        t_tdb_s=times,
    )
    np.testing.assert_array_equal(via_propagation["n_visible"].values, direct["n_visible"].values)
    np.testing.assert_allclose(via_propagation["pdop"].values, direct["pdop"].values, rtol=1e-9)
    assert via_propagation["n_visible"].values.max() >= 4


# --------------------------------------------------------------------------- analysis (notebook 02)


def _walker_positions_mf(n_epochs=97, step_s=900.0):
    """Keplerian positions (20, n, 3) of a 5 x 4 ELFO Walker design, used directly as Moon-fixed (km)."""
    from lnss_lib.constellation import WalkerDesign
    from lnss_lib.elements import kepler_states

    el_deg = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 5, 4).elements_deg()
    el = np.concatenate([el_deg[:, :2], np.radians(el_deg[:, 2:])], axis=1)
    return kepler_states(el, step_s * np.arange(n_epochs), 4902.8)[..., :3]


@pytest.mark.parametrize("los_axes", ["moon_fixed", "enu"])
def test_compiled_grid_pass_matches_dop_kernel_bit_for_bit(los_axes):
    from lnss_lib.dop import dop_arrays, dop_kernel

    r = _walker_positions_mf()
    r[3, 10:20] = np.nan  # an impacted satellite is never visible
    r[7, :, :] = r[8, :, :]  # coincident satellites: singular geometries appear
    paper = load_settings("paper")
    grid = SurfaceGrid.from_settings(paper.dop, paper.constants.r_moon_mean_km)
    points, up = grid.r_mf_km.reshape(-1, 3), grid.up.reshape(-1, 3)
    for mask in (5.0, 30.0, -5.0):
        old = dop_kernel(r, points, up, mask, los_axes)
        new = dop_arrays(r, points, up, mask, los_axes)
        for a, b in zip(old, new):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("weighting", ["none", "cell_area"])
def test_dop_metrics_match_summary_of_dataset(weighting):
    from lnss_lib.dop import dop_metrics

    r = _walker_positions_mf()
    grid = surface_grid(weighting=weighting)
    for mask in (5.0, 40.0):  # 40 deg: many samples without a DOP
        old = dop_summary(dop_grid(r, grid, elevation_mask_deg=mask))
        new = dop_metrics(r, grid, elevation_mask_deg=mask)
        assert set(old) == set(new)
        for key, value in old.items():
            assert new[key] == pytest.approx(value, rel=1e-11, abs=1e-12, nan_ok=True), key
