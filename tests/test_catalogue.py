"""The constellation catalogue: every file loads and round-trips, user files equal Walker designs, bad files are named."""

import math

import numpy as np
import pytest

from lnss_lib.catalogue import (
    CATALOGUE_DIR,
    EXTRA_RESULT_KEYS,
    FILE_FRAMES,
    constellation_states_mci,
    evaluate_catalogue,
    list_catalogue,
    load_constellation,
    true_to_mean_anomaly_deg,
)
from lnss_lib.cli.evaluate import evaluate_catalogue_cli
from lnss_lib.constellation import WalkerDesign
from lnss_lib.elements import elements_to_state, state_to_elements
from lnss_lib.ephemeris import file_sha256
from lnss_lib.errors import ConfigError
from lnss_lib.evaluator import METRIC_KEYS, context_for, evaluate_design
from lnss_lib.keys import RESULT_KEYS
from lnss_lib.propagator import elements_deg_to_states
from lnss_lib.settings import load_settings

CATALOGUE = sorted(p.stem for p in CATALOGUE_DIR.glob("*.toml"))
EXACT = [k for k in CATALOGUE if not load_constellation(k).approximate]
SMA_TOL_KM = 1e-6
ANGLE_TOL_DEG = 1e-8
WALKER = WalkerDesign(6143.0, 0.6, 90.0, 51.7, 2, 2)


def _user_file(
    path,
    elements_deg,
    frame="lunar_equator_of_epoch",
    epoch="not given",
    time_scale="not given",
    anomaly="mean",
):
    """A user constellation file in the catalogue format; elements written with repr (exact floats)."""
    lines = [
        'name = "user test"',
        f'element_frame = "{frame}"',
        f'epoch = "{epoch}"',
        f'time_scale = "{time_scale}"',
        f'anomaly = "{anomaly}"',
        "approximate = false",
    ]
    for k, row in enumerate(np.asarray(elements_deg, dtype=float)):
        lines += ["", "[[satellite]]", f'name = "S{k}"']
        lines += [
            f"{key} = {float(v)!r}"
            for key, v in zip(("a_km", "e", "inc_deg", "raan_deg", "aop_deg", "anomaly_deg"), row)
        ]
    path.write_text("\n".join(lines) + "\n")
    return path


def _wrap_deg(x):
    return np.abs(np.mod(np.asarray(x) + 180.0, 360.0) - 180.0)


def test_catalogue_is_the_shared_data_unchanged():
    lines = (CATALOGUE_DIR / "SHA256SUMS").read_text().splitlines()
    assert sorted(line.split()[1] for line in lines) == [f"{k}.toml" for k in CATALOGUE]
    for line in lines:
        digest, name = line.split()
        assert file_sha256(CATALOGUE_DIR / name) == digest, name


def test_listing_labels_the_approximate_entry():
    rows = {r["key"]: r for r in list_catalogue()}
    assert set(rows) == set(CATALOGUE)
    assert [k for k, r in rows.items() if r["approximate"]] == ["moonlight_lcns_approx"]
    assert (
        rows["bhamidipati2023_case_c"]["n_sat"] == 16
        and rows["bhamidipati2023_case_c"]["element_frame"] == "moon_op"
    )
    assert rows["bhamidipati2023_case_c"]["epoch"] is None


@pytest.mark.parametrize("key", EXACT)
@pytest.mark.parametrize("epoch", ["study", "file"])
def test_every_file_round_trips_in_its_own_frame(paper_profile, key, epoch):
    c = load_constellation(key, paper_profile.dynamics)
    if epoch == "file" and c.epoch is None:
        with pytest.raises(ConfigError, match="no epoch"):
            constellation_states_mci(
                paper_profile.dynamics, paper_profile.epoch.start_tdb, c, epoch
            )
        return
    s = constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, c, epoch)
    assert s.states_mci.shape == (c.n_sat, 6) and np.all(np.isfinite(s.states_mci))
    assert s.epoch_source == "file" if epoch == "file" else s.epoch_source.startswith("study epoch")
    rot = s.rot_to_j2000
    in_frame = np.concatenate([s.states_mci[:, :3] @ rot, s.states_mci[:, 3:] @ rot], axis=1)
    back = state_to_elements(in_frame, paper_profile.gravity.gm_km3_s2)
    back[:, 2:] = np.degrees(back[:, 2:])
    el = c.elements_deg
    assert np.allclose(back[:, 0], el[:, 0], atol=SMA_TOL_KM) and np.allclose(
        back[:, 1], el[:, 1], atol=1e-12
    )
    assert np.all(_wrap_deg(back[:, 2] - el[:, 2]) < ANGLE_TOL_DEG)
    regular = (el[:, 1] > 1e-9) & (el[:, 2] > 1e-9)
    assert np.all(_wrap_deg(back[regular, 3:] - el[regular, 3:]) < 1e-6)
    # circular equatorial (LuPNT ISL sat1): only the sum RAAN + AOP + M is defined
    assert np.all(_wrap_deg(back[~regular, 3:].sum(axis=1) - el[~regular, 3:].sum(axis=1)) < 1e-6)


def test_epoch_choice_matters_only_for_frames_that_follow_the_moon(paper_profile):
    inertial = load_constellation("lupnt_example_isl_3sat", paper_profile.dynamics)
    a, b = (
        constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, inertial, e)
        for e in ("study", "file")
    )
    assert np.array_equal(a.states_mci, b.states_mci) and a.t_epoch_tdb_s != b.t_epoch_tdb_s
    op = load_constellation("ely2005_elfo_3sat", paper_profile.dynamics)
    a, b = (
        constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, op, e)
        for e in ("study", "file")
    )
    assert np.max(np.abs(a.states_mci[:, :3] - b.states_mci[:, :3])) > 100.0
    assert b.epoch_used.startswith("2009-07-15T01:00:00") and a.epoch_used.startswith(
        "2025-05-01T00:00:00"
    )
    assert a.epoch_source == "study epoch (file gives 2009-07-15T01:00:00 TDB)"


def test_true_anomaly_becomes_mean_anomaly(paper_profile):
    """Independent check: the state built from the converted M has the written true anomaly."""
    c = load_constellation("cislunar_nav_6sat_optimized", paper_profile.dynamics)
    assert c.anomaly == "true"
    el = c.elements_deg.copy()
    el[:, 2:] = np.radians(el[:, 2:])
    state = elements_to_state(el, paper_profile.gravity.gm_km3_s2)
    r = state[:, :3]
    p_hat = elements_to_state(np.column_stack([el[:, :5], np.zeros(len(el))]), 1.0)[:, :3]
    h = np.cross(r, state[:, 3:])
    nu = np.degrees(
        np.arctan2(
            np.einsum("ij,ij->i", np.cross(p_hat, r), h / np.linalg.norm(h, axis=1)[:, None]),
            np.einsum("ij,ij->i", p_hat, r),
        )
    )
    assert np.all(_wrap_deg(nu - c.anomaly_as_written_deg) < 1e-9)
    # and a known value: e = 0.6, nu = 90 deg -> E = 2 atan(sqrt(0.4 / 1.6)), M = E - e sin E
    e_anom = 2.0 * math.atan(math.sqrt(0.4 / 1.6))
    assert true_to_mean_anomaly_deg(90.0, 0.6) == pytest.approx(
        math.degrees(e_anom - 0.6 * math.sin(e_anom)), abs=1e-12
    )
    assert true_to_mean_anomaly_deg(180.0, 0.6) == pytest.approx(180.0, abs=1e-9)


@pytest.mark.parametrize("frame", ["lunar_equator_of_epoch", "j2000", "moon_op"])
def test_user_file_in_a_workbook_frame_gives_the_walker_states_exactly(
    paper_profile, tmp_path, frame
):
    c = load_constellation(
        _user_file(tmp_path / "walker.toml", WALKER.elements_deg(), frame), paper_profile.dynamics
    )
    s = constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, c)
    profile = paper_profile.with_overrides({"frames": {"element_frame": frame}})
    assert np.array_equal(
        s.states_mci,
        elements_deg_to_states(profile.dynamics, WALKER.elements_deg(), s.t_epoch_tdb_s),
    )


@pytest.fixture(scope="module")
def ci_context():
    return context_for(load_settings("ci"))


def test_user_file_and_walker_design_give_identical_metrics(ci_context, tmp_path):
    assert ci_context.settings.frames.element_frame == "lunar_equator_of_epoch"
    c = load_constellation(
        _user_file(tmp_path / "walker.toml", WALKER.elements_deg()), ci_context.dynamics
    )
    ours = evaluate_catalogue(ci_context, c)
    walker = evaluate_design(
        ci_context,
        WALKER.sma_km,
        WALKER.ecc,
        WALKER.aop_deg,
        WALKER.inc_deg,
        WALKER.n_planes,
        WALKER.sats_per_plane,
    )
    assert ours["evaluated"] and ours["n_sat"] == 4
    for key in METRIC_KEYS:
        assert ours[key] == walker[key] or (math.isnan(ours[key]) and math.isnan(walker[key])), key
    assert ours["epoch_source"] == "study epoch (file gives none)" and ours["approximate"] is False


def test_cli_function_returns_the_evaluate_keys_plus_labels():
    result = evaluate_catalogue_cli("ci", "ely2005_elfo_3sat")
    assert list(result) == list(RESULT_KEYS + EXTRA_RESULT_KEYS)
    assert (
        result["name"] == "ely2005_elfo_3sat"
        and result["element_frame"] == "moon_op"
        and result["n_sat"] == 3
    )
    assert (
        result["epoch_used"].startswith("2025-05-01T00:00:00")
        and "2009-07-15T01:00:00 TDB" in result["epoch_source"]
    )
    assert result["evaluated"] and 0.0 < result["mean_visible_sats"] <= 3.0


def test_approximate_entry_loads_but_is_not_evaluated(paper_profile):
    c = load_constellation("moonlight_lcns_approx", paper_profile.dynamics)
    assert c.approximate and c.elements_deg is None and c.element_frame is None and c.n_sat == 5
    assert list(c.approximate_a_km) == [6000.0, 10000.0, 10000.0, 10000.0, 10000.0]
    with pytest.raises(ConfigError, match="approximate") as info:
        constellation_states_mci(paper_profile.dynamics, paper_profile.epoch.start_tdb, c)
    assert info.value.key == "approximate"
    with pytest.raises(ConfigError, match="approximate"):
        evaluate_catalogue_cli("ci", "moonlight_lcns_approx")


GOOD = WALKER.elements_deg()


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda t: t.replace("e = 0.6\n", "", 1), "satellite[0].e"),
        (lambda t: t.replace("inc_deg = 51.7", 'inc_deg = "51.7"', 1), "satellite[0].inc_deg"),
        (lambda t: t.replace("e = 0.6\n", "e = 1.2\n", 1), "satellite[0].e"),
        (lambda t: t.replace('"lunar_equator_of_epoch"', '"moon_fixed"'), "element_frame"),
        (lambda t: t.replace("raan_deg = 180.0", "raan_deg = nan", 1), "satellite[2].raan_deg"),
        (lambda t: t.replace("a_km = 6143.0", "a_km = inf", 1), "satellite[0].a_km"),
        (lambda t: t.replace("a_km = 6143.0", "a_km = 2000.0", 1), "satellite[0].a_km"),
        (lambda t: t.replace('name = "user test"\n', ""), "name"),
        (lambda t: t + 'colour = "red"\n', "satellite[3].colour"),
        (lambda t: "colour = 1\n" + t, "colour"),
        (lambda t: t.replace('anomaly = "mean"', 'anomaly = "eccentric"'), "anomaly"),
        (lambda t: t.replace('epoch = "not given"', 'epoch = "1 May 2025"'), "epoch"),
        (lambda t: t.replace('epoch = "not given"', 'epoch = "2025-05-01T00:00:00"'), "time_scale"),
        (lambda t: t.replace("approximate = false", 'approximate = "no"'), "approximate"),
    ],
)
def test_malformed_user_file_names_the_file_and_the_key(tmp_path, edit, key):
    path = _user_file(tmp_path / "bad.toml", GOOD)
    load_constellation(path)
    path.write_text(edit(path.read_text()))
    with pytest.raises(ConfigError) as info:
        load_constellation(path)
    assert info.value.key == key and info.value.source == str(path)
    assert str(path) in str(info.value) and repr(key) in str(info.value)


def test_unreadable_toml_and_unknown_names_are_errors(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("name = \n")
    with pytest.raises(ConfigError, match="broken.toml, line 1: TOML syntax error") as info:
        load_constellation(path)
    assert info.value.source == str(path)
    with pytest.raises(ValueError, match="unknown constellation 'no_such'.*bhamidipati2023_case_a"):
        load_constellation("no_such")
    with pytest.raises(FileNotFoundError):
        load_constellation(tmp_path / "missing.toml")


def test_frames_of_the_catalogue_are_known():
    assert {load_constellation(k).element_frame for k in EXACT} <= set(FILE_FRAMES)


def test_bhamidipati_case_c_is_the_table_4_elfo_in_the_moon_op_frame(ci_context):
    """Same a, e, i, AOP, RAANs and phasing as Table 4: identical to the profile path with element_frame = moon_op."""
    from lnss_lib.constellation import standalone_elfo
    from lnss_lib.evaluator import evaluate_constellation

    c = load_constellation("bhamidipati2023_case_c", ci_context.dynamics)
    assert np.array_equal(
        c.elements_deg, standalone_elfo(ci_context.settings.standalone_elfo, ci_context.dynamics)
    )
    ours = evaluate_catalogue(ci_context, c)
    op_profile = ci_context.settings.with_overrides({"frames": {"element_frame": "moon_op"}})
    theirs = evaluate_constellation(
        context_for(op_profile), standalone_elfo(op_profile.standalone_elfo, op_profile.dynamics)
    )
    for key in METRIC_KEYS:
        assert ours[key] == theirs[key], key
    lunar = evaluate_constellation(
        ci_context, standalone_elfo(ci_context.settings.standalone_elfo, ci_context.dynamics)
    )
    assert ours["mean_visible_sats"] != lunar["mean_visible_sats"]  # the frame changes the geometry
