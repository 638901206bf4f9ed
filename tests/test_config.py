"""Profiles: inheritance, unknown names, fingerprints."""

import datetime as dt

import pytest

from lnss_lib.config import available_profiles, load_profile, profile_hash
from lnss_lib.errors import ConfigError


def test_profiles_inherit_from_paper():
    paper, quick, ci = load_profile("paper"), load_profile("quick"), load_profile("ci")
    assert {"paper", "quick", "ci"} <= set(available_profiles())
    assert paper["epoch"]["start_tdb"] == "2025-05-01T00:00:00"
    assert paper["epoch"]["step_s"] == 900.0
    assert (
        paper["spacecraft"]["mass_kg"],
        paper["spacecraft"]["area_m2"],
        paper["spacecraft"]["cr"],
    ) == (1080.0, 23.78, 1.3)
    assert paper["integrator"]["settings"]["paper"] == {
        "method": "RK45",
        "rtol": 1e-6,
        "atol": 1e-9,
    }
    assert paper["gravity"]["degree"] == 30
    assert ci["profile"]["name"] == "ci" and ci["gravity"]["file"] == paper["gravity"]["file"]
    assert quick["spacecraft"] == paper["spacecraft"]


def test_unknown_profile_names_the_choices():
    with pytest.raises(ValueError, match=r"unknown profile 'fast'.*paper"):
        load_profile("fast")


def test_hash_tracks_parameters_only():
    base = load_profile("paper")
    assert profile_hash(base) == profile_hash(load_profile("paper"))
    assert profile_hash(base) != profile_hash(
        load_profile("paper", overrides={"gravity": {"degree": 20}})
    )


def test_also_merges_other_profiles_own_settings():
    """`[profile] also` takes the named profiles' own settings on top of the inherited chain."""
    from lnss_lib.config import _own_settings
    from lnss_lib.errors import ConfigError

    quick, ci, operational = load_profile("quick"), load_profile("ci"), load_profile("operational")
    companion = load_profile("ci_operational")
    assert (
        companion["campaign"]["population"]
        == ci["campaign"]["population"]
        != operational["campaign"]["population"]
    )
    assert companion["gravity"]["degree"] == ci["gravity"]["degree"]
    assert (
        companion["dop"]["los_axes"] == operational["dop"]["los_axes"] != quick["dop"]["los_axes"]
    )
    assert companion["campaign"]["objectives"] == operational["campaign"]["objectives"]
    assert companion["campaign"]["companion_profile"] == "" and "also" not in companion["profile"]
    with pytest.raises(ConfigError, match="profile.also: unknown profile 'nowhere'"):
        _own_settings("nowhere")


def _leaves(table: dict, prefix: str = ""):
    for key, value in table.items():
        if isinstance(value, dict):
            yield from _leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def test_every_setting_round_trips_through_set():
    """toml_literal writes what `--set` reads, for every value type of every profile (booleans were `False`)."""
    from lnss_lib.config import parse_sets, toml_literal

    for name in available_profiles():
        for key, value in _leaves(load_profile(name)):
            parsed = parse_sets([f"{key}={toml_literal(value)}"])
            expected: object = value
            for part in reversed(key.split(".")):
                expected = {part: expected}
            assert parsed == expected, (name, key, toml_literal(value))
    extremes = {
        "gps": {"sidelobe_offset_db": float("-inf")},
        "forces": {"relativity": False, "third_bodies": []},
        "campaign": {"constraints": {"pdop_mean_3sigma": {"max": 1e300}}},
        "profile": {"description": 'a "q" \\'},
    }
    assert parse_sets([f"{k}={toml_literal(v)}" for k, v in _leaves(extremes)]) == extremes
    relativity_off = parse_sets([f"forces.relativity={toml_literal(False)}"])
    assert load_profile("ci", overrides=relativity_off)["forces"]["relativity"] is False


@pytest.mark.parametrize(
    "text, expected",
    [
        ("2025-05-01", dt.datetime(2025, 5, 1)),
        ("2025-05-01T12:30", dt.datetime(2025, 5, 1, 12, 30)),
        ("2025-05-01T12:30:15", dt.datetime(2025, 5, 1, 12, 30, 15)),
        ("2025-05-01T12:30:15.1234567", dt.datetime(2025, 5, 1, 12, 30, 15, 123456)),
    ],
)
def test_iso_dates_are_read_in_one_strict_form(text, expected):
    """The one date reader: ISO 8601 calendar dates and times, never another order, a zone or a week date."""
    from lnss_lib.dates import parse_iso_date

    assert parse_iso_date(text) == expected
    for bad in (
        "01-05-2025",
        "1/5/2025",
        "20250501",
        "2025-W18-4",
        "2025-05-01 12:30",
        "2025-05-01T12:30Z",
        "2025-05-01T12:30+01:00",
        "2025-5-1",
        " 2025-05-01",
        20250501,
        None,
    ):
        with pytest.raises(ConfigError, match="expected YYYY-MM-DD"):
            parse_iso_date(bad)
    with pytest.raises(ConfigError, match="expected YYYY-MM-DD$"):
        parse_iso_date("2025-05-01T00:00:00", date_only=True)
