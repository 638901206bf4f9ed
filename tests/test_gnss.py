"""Every GNSS at the Moon (lnss_lib.gnss): nominal slots, Kepler + J2, per-system link, one clock per system."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

from lnss_lib import gain_pattern, gnss, gps, gps_states
from lnss_lib.config import data_path
from lnss_lib.constants import WGS84_A_KM
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings

ALL = ("gps", "galileo", "beidou", "glonass")
ONE_SECOND = 1.0


@pytest.fixture(scope="module")
def shells(ci_profile):
    return gnss.load_nominal_slots(data_path(ci_profile.gnss.nominal_file), ALL[1:])


def test_nominal_slots_reproduce_the_published_periods(shells):
    """The J2 draconic period of every shell's slots gives its published ground-track repeat within 1 s, and
    GLONASS's the ICD's 11 h 15 min 44 s; the Walker patterns have their published sizes."""
    for shell in shells:
        period = float(gnss.nodal_period_s(shell.sma_km, shell.inc_deg))
        assert (
            abs(period - float(gnss.repeat_period_s(shell.sma_km, shell.inc_deg, *shell.repeat)))
            < ONE_SECOND
        ), (shell.system, shell.kind)
        if math.isfinite(shell.published_period_s):
            assert abs(period - shell.published_period_s) < ONE_SECOND, shell.system
    sizes = {}
    for shell in shells:
        sizes[shell.system] = sizes.get(shell.system, 0) + shell.raan_deg.size
    assert sizes == {"galileo": 24, "beidou": 30, "glonass": 24}
    galileo = next(s for s in shells if s.system == "galileo")
    assert sorted(set(np.round(galileo.raan_deg, 9))) == [0.0, 120.0, 240.0]
    assert galileo.sma_km == 29600.318  # the published radius, not solved


def test_kepler_j2_keeps_the_radius_and_returns_after_a_draconic_period(shells):
    meo = next(s for s in shells if s.system == "galileo")
    period = float(gnss.nodal_period_s(meo.sma_km, meo.inc_deg))
    r = gnss.nominal_positions_teme([meo], [0.0, 0.25 * period, period])
    np.testing.assert_allclose(np.linalg.norm(r, axis=-1), meo.sma_km, rtol=1e-13)
    # after one draconic period every slot is back at its argument of latitude: the same height above the equator
    np.testing.assert_allclose(r[:, 2, 2], r[:, 0, 2], atol=1e-6 * meo.sma_km)
    raan_dot, _ = gnss.secular_rates(meo.sma_km, meo.inc_deg)
    node = np.cross(r[0, 0], r[0, 1])  # the orbit normal at t = 0 and later
    later = np.cross(r[0, 2], gnss.nominal_positions_teme([meo], [1.25 * period])[0, 0])
    turned = math.atan2(
        later[1] * node[0] - later[0] * node[1], later[0] * node[0] + later[1] * node[1]
    )
    assert turned == pytest.approx(raan_dot * period, rel=1e-6)  # the node regresses at the J2 rate


def _centred_scatter(los, system, n_systems):
    counts = np.array([[np.sum(system == s) for s in range(n_systems)]])
    scatter = np.zeros((1, n_systems, 6))
    for s in range(n_systems):
        d = los[system == s] - los[system == s].mean(axis=0)
        scatter[0, s] = [
            d[:, 0] @ d[:, 0],
            d[:, 1] @ d[:, 1],
            d[:, 2] @ d[:, 2],
            d[:, 0] @ d[:, 1],
            d[:, 0] @ d[:, 2],
            d[:, 1] @ d[:, 2],
        ]
    return counts, scatter


def test_one_clock_per_system_is_the_direct_inverse():
    """The sum of centred scatters equals the position block of (G^T G)^-1 with one clock column per system;
    with one system it is the GPS PDOP (eq. 5-7 with the clock column)."""
    rng = np.random.default_rng(3)
    los = rng.normal(size=(9, 3))
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    system = np.array([0, 0, 0, 0, 1, 1, 1, 2, 2])
    counts, scatter = _centred_scatter(los, system, 3)
    g = np.hstack([los, (system[:, None] == np.arange(3)[None]).astype(float)])
    direct = math.sqrt(np.trace(np.linalg.inv(g.T @ g)[:3, :3]))
    assert gnss.combined_pdop(counts, scatter, ("a", "b", "c"), ("a", "b", "c"))[
        0
    ] == pytest.approx(direct, rel=1e-10)
    alone = gnss.combined_pdop(counts, scatter, ("a", "b", "c"), ("a",))[0]
    assert alone == pytest.approx(float(gps.pdop_kernel(los[:4], np.ones(4, bool))), rel=1e-12)
    # 4 satellites of one system and 1 of another: 5 unknowns, 5 equations; 2 + 2: too few
    assert np.isfinite(
        gnss.combined_pdop(
            counts[:, :2] * [[1, 0]] + [[0, 1]], scatter[:, :2], ("a", "b"), ("a", "b")
        )
    )
    assert np.isnan(
        gnss.combined_pdop(np.array([[2, 2]]), scatter[:, :2], ("a", "b"), ("a", "b"))[0]
    )
    with pytest.raises(ValueError, match="not among"):
        gnss.combined_pdop(counts, scatter, ("a", "b", "c"), ("d",))


@pytest.fixture(scope="module")
def elfo(ci_profile):
    from lnss_lib.constellation import standalone_elfo
    from lnss_lib.propagator import propagate_elements

    profile = ci_profile
    prop = propagate_elements(
        profile.dynamics,
        profile.epoch,
        standalone_elfo(profile.standalone_elfo, profile.dynamics)[:1],
    )
    every = dataclasses.replace(profile.gnss, systems=ALL)
    states = gnss.gnss_states_mci(every, profile.gps, profile.epoch.start_tdb, prop["time"].values)
    return profile, prop, every, states


def test_gps_alone_is_the_gps_link(elfo):
    """The compiled GNSS kernel with GPS alone gives the GPS link's (lnss_lib.gps.gps_link) visible satellites at
    every epoch and its PDOP."""
    profile, prop, every, _ = elfo
    only = dataclasses.replace(every, systems=("gps",))
    states = gnss.gnss_states_mci(only, profile.gps, profile.epoch.start_tdb, prop["time"].values)
    counts, scatter = gnss.gnss_link_arrays(
        profile.gps,
        profile.constants,
        states,
        gnss.system_transmitters(only, profile.gps, states),
        prop["r_mci_km"].values[0],
    )
    link = gps.gps_link(
        profile.gps,
        profile.constants,
        gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, prop["time"].values),
        prop,
    )
    assert np.array_equal(counts[:, 0], link["n_visible"].values[0])
    np.testing.assert_allclose(
        gnss.combined_pdop(counts, scatter, ("gps",), ("gps",)),
        link["pdop"].values[0],
        rtol=1e-9,
        equal_nan=True,
    )


def test_adding_systems_never_lowers_the_count(elfo):
    profile, prop, every, states = elfo
    tx = gnss.system_transmitters(every, profile.gps, states)
    counts, scatter = gnss.gnss_link_arrays(
        profile.gps, profile.constants, states, tx, prop["r_mci_km"].values[0]
    )
    gps_only = gps.gps_link(
        profile.gps,
        profile.constants,
        gps_states.gps_states_mci(profile.gps, profile.epoch.start_tdb, prop["time"].values),
        prop,
    )
    assert np.array_equal(
        counts[:, 0], gps_only["n_visible"].values[0]
    )  # GPS's own links unchanged
    assert np.all(counts.sum(axis=1) >= counts[:, 0]) and counts[:, 1:].sum() > 0
    summary = gnss.gnss_link_summary(
        counts,
        scatter,
        ALL,
        {"gps+galileo": ("gps", "galileo"), "all": ALL},
        profile.gps.pdop_filter,
    )
    assert (
        summary["gps"]["visible_mean"]
        <= summary["gps+galileo"]["visible_mean"]
        <= summary["all"]["visible_mean"]
    )
    assert summary["all"]["pdop_available_fraction"] >= summary["gps"]["pdop_available_fraction"]


def _behind_the_earth(states: xr.Dataset, r_lnss_mci_km: np.ndarray, n: int = 5) -> xr.Dataset:
    """``states`` with ``n`` satellites of a fourth system at 26 000 km on the far side of the Earth from the LNSS,
    within 2000 km of the Earth-LNSS line (inside the Earth's shadow cone as seen from the Moon)."""
    earth = states["earth_mci_km"].values
    e_hat = (r_lnss_mci_km - earth) / np.linalg.norm(r_lnss_mci_km - earth, axis=-1, keepdims=True)
    side = np.cross(e_hat, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    offsets = np.linspace(-2000.0, 2000.0, n)
    r_eci = -26000.0 * e_hat[None] + offsets[:, None, None] * side[None]
    rot = states["rot_teme_to_j2000"].values
    extra = xr.Dataset(
        {
            "r_eci_km": (("sat", "time", "xyz"), r_eci),
            "r_mci_km": (("sat", "time", "xyz"), r_eci + earth[None]),
            "r_teme_km": (("sat", "time", "xyz"), np.einsum("tji,gtj->gti", rot, r_eci)),
        },
        coords={
            "sat": states.sizes["sat"] + np.arange(n),
            "system": ("sat", ["glonass"] * n),
            "name": ("sat", [f"hidden {k}" for k in range(n)]),
        },
    )
    return xr.concat([states[["r_eci_km", "r_mci_km", "r_teme_km"]], extra], dim="sat").assign(
        earth_mci_km=states["earth_mci_km"], rot_teme_to_j2000=states["rot_teme_to_j2000"]
    )


def test_a_system_behind_the_earth_adds_nothing(elfo):
    profile, prop, every, _ = elfo
    pair = dataclasses.replace(every, systems=("gps", "glonass"))
    r_lnss = prop["r_mci_km"].values[0]
    only = dataclasses.replace(every, systems=("gps",))
    states = _behind_the_earth(
        gnss.gnss_states_mci(only, profile.gps, profile.epoch.start_tdb, prop["time"].values),
        r_lnss,
    )
    counts, scatter = gnss.gnss_link_arrays(
        profile.gps,
        profile.constants,
        states,
        gnss.system_transmitters(pair, profile.gps, states),
        r_lnss,
    )
    assert not counts[:, 1].any()
    pdop_pair = gnss.combined_pdop(counts, scatter, pair.systems, pair.systems)
    assert np.array_equal(
        pdop_pair, gnss.combined_pdop(counts, scatter, pair.systems, ("gps",)), equal_nan=True
    )


def test_each_system_keeps_the_gps_margin_over_its_icd_minimum(elfo):
    """At every system's edge of coverage the modelled received power (0 dBic user) exceeds its ICD minimum by
    what the Table 1 budget gives GPS over IS-GPS-200's -158.5 dBW."""
    profile, _, every, states = elfo
    tx = gnss.system_transmitters(every, profile.gps, states)
    gain = gain_pattern.gain_for_settings(profile.gps)
    cfg = profile.gps
    radius = np.linalg.norm(states["r_teme_km"].values[:, 0, :], axis=-1)

    def margin(sma_km, elevation_deg, eirp_rx_db, scale, fsl_per_km, p_min_dbw):
        e = math.radians(elevation_deg)
        d = math.sqrt(sma_km**2 - (WGS84_A_KM * math.cos(e)) ** 2) - WGS84_A_KM * math.sin(e)
        eta = math.degrees(math.asin(WGS84_A_KM * math.cos(e) / sma_km))
        return (
            eirp_rx_db
            - cfg.g_rx_dbi
            + float(gain(scale * eta))
            - 20 * math.log10(fsl_per_km * d)
            - p_min_dbw
        )

    ref = every.gps
    expected = margin(
        ref.sma_km,
        ref.edge_elevation_deg,
        tx.eirp_rx_db[0],
        1.0,
        tx.fsl_per_km[0],
        ref.min_received_power_dbw,
    )
    assert (
        tx.angle_scale[0] == 1.0
        and tx.eirp_rx_db[0] == cfg.p_tx_dbw - cfg.l_tx_db - cfg.l_pol_db + cfg.g_rx_dbi
    )
    for k in np.flatnonzero(states["system"].values != "gps"):
        system = getattr(every, str(states["system"].values[k]))
        assert margin(
            radius[k],
            system.edge_elevation_deg,
            tx.eirp_rx_db[k],
            tx.angle_scale[k],
            tx.fsl_per_km[k],
            system.min_received_power_dbw,
        ) == pytest.approx(expected, abs=1e-9)


def test_gps_only_evaluation_unchanged_and_every_system_reported(ci_profile):
    """``[gnss] systems = ["gps"]`` keeps the profile hash and gives the GPS link's metrics (lnss_lib.gps), with
    no GNSS keys; all four systems leave every metric of the paper's evaluation as it was and add each system's
    and the combined ones, GPS's equal to the GPS link's."""
    from lnss_lib.evaluator import context_for, evaluate_design

    design = (6143.0, 0.6, 90.0, 51.7, 2, 2)
    assert load_settings("ci", {"gnss": {"systems": ["gps"]}}).hash == ci_profile.hash
    before = evaluate_design(context_for(ci_profile), *design)
    assert not any(k.startswith("gnss") for k in before)
    every = load_settings("ci", {"gnss": {"systems": list(ALL)}})
    assert every.hash != ci_profile.hash
    after = evaluate_design(context_for(every), *design)
    for key, value in before.items():
        if key not in ("timing_s", "wall_s"):
            assert after[key] == value or (value != value and after[key] != after[key]), key
    assert after["gnss_gps_visible_mean"] == before["gps_visible_mean"]
    assert after["gnss_gps_pdop_mean"] == pytest.approx(before["gps_pdop_mean"], rel=1e-9)
    assert after["gnss_visible_mean"] == pytest.approx(
        sum(after[f"gnss_{s}_visible_mean"] for s in ALL), rel=1e-12
    )
    assert after["gnss_pdop_mean"] < after["gps_pdop_mean"]


def test_evaluate_json_reports_each_system_and_the_combination(capsys):
    import json

    from lnss_lib.__main__ import main
    from lnss_lib.keys import gnss_metric_keys, label

    walker = [
        "--sma-km",
        "6143",
        "--ecc",
        "0.6",
        "--aop-deg",
        "90",
        "--inc-deg",
        "51.7",
        "--planes",
        "2",
        "--sats-per-plane",
        "2",
        "--profile",
        "ci",
        "--json",
    ]
    assert main(["evaluate", *walker, "--set", 'gnss.systems=["gps", "galileo"]']) == 0
    result = json.loads(capsys.readouterr().out)
    assert gnss_metric_keys(("gps",)) == () and set(gnss_metric_keys(("gps", "galileo"))) <= set(
        result
    )
    assert result["gnss_visible_mean"] == pytest.approx(
        result["gnss_gps_visible_mean"] + result["gnss_galileo_visible_mean"], rel=1e-12
    )
    assert result["gnss_gps_visible_mean"] == result["gps_visible_mean"]
    assert (
        label("gnss_beidou_pdop_mean").startswith("BeiDou-3-LNSS PDOP")
        and label("gnss_x_pdop_mean") == "gnss_x_pdop_mean"
    )


@pytest.mark.parametrize(
    "systems, message",
    [(["gps", "gps"], "distinct"), (["gps", "compass"], "not allowed"), ([], "at least one")],
)
def test_bad_systems_are_refused(systems, message):
    with pytest.raises(ConfigError, match=message):
        load_settings("ci", {"gnss": {"systems": systems}})


def test_bad_nominal_slots_are_refused(tmp_path):
    bad = tmp_path / "slots.toml"
    bad.write_text(
        '[galileo]\n[[galileo.shell]]\nkind = "MEO"\nwalker = [24, 5, 1]\ninc_deg = 56.0\n'
        "sma_km = 29600.0\nrepeat = [17, 10]\n"
    )
    with pytest.raises(ConfigError, match="multiple of P"):
        gnss.load_nominal_slots(bad, ["galileo"])
    with pytest.raises(ConfigError, match="no \\[\\[beidou.shell\\]\\]"):
        gnss.load_nominal_slots(bad, ["beidou"])
    with pytest.raises(ConfigError, match="not found"):
        gnss.load_nominal_slots(tmp_path / "none.toml", ["galileo"])
