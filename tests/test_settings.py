"""Settings read once: every profile freezes into typed sections, hashes like config.profile_hash,
and round-trips through TOML; bad values are refused by the one checker in config."""

from __future__ import annotations

import dataclasses

import pytest

from lnss_lib.config import available_profiles, load_profile, profile_hash
from lnss_lib.errors import ConfigError
from lnss_lib.settings import Settings, load_settings, settings_from_profile, settings_from_toml


@pytest.mark.parametrize("name", available_profiles())
def test_every_profile_freezes_hashes_and_round_trips(name):
    settings = load_settings(name)
    assert settings.hash == profile_hash(load_profile(name))
    again = settings_from_toml(settings.to_toml())
    assert again == settings and again.hash == settings.hash
    assert again.as_dict() == load_profile(name)


def test_sections_are_typed_and_frozen():
    settings = load_settings("paper")
    assert isinstance(settings.epoch.duration_days, float) and isinstance(
        settings.gravity.degree, int
    )
    assert settings.forces.third_bodies == ("SUN", "EARTH", "JUPITER")
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.forces.srp = False
    assert isinstance(
        settings.stability.validation_designs[0][4], int
    )  # plane counts stay integers
    assert isinstance(settings.campaign.variables["n_planes"].lower, int)


def test_integer_in_a_float_key_becomes_float_and_hashes_as_written():
    settings = load_settings("ci", {"epoch": {"duration_days": 3}})
    assert settings.epoch.duration_days == 3.0 and isinstance(settings.epoch.duration_days, float)
    assert settings.hash == profile_hash(load_profile("ci", {"epoch": {"duration_days": 3}}))


def test_named_integrator_setting():
    integrator = load_settings("paper").integrator
    assert integrator.named().name == "paper" and integrator.named().method == "RK45"
    assert integrator.named("converged").rtol == 1e-10
    with pytest.raises(ConfigError, match="unknown integrator setting 'nosuch'"):
        integrator.named("nosuch")


def test_overrides_are_checked_and_change_the_hash():
    settings = load_settings("ci")
    assert settings.with_overrides({}) is settings
    changed = settings.with_overrides({"dop": {"elevation_mask_deg": 10.0}})
    assert changed.dop.elevation_mask_deg == 10.0 and changed.hash != settings.hash
    with pytest.raises(
        ConfigError, match=r"frames.element_frame = 'nosuch' is not allowed; allowed: "
    ):
        settings.with_overrides({"frames": {"element_frame": "nosuch"}})


def test_a_damaged_record_is_refused():
    text = load_settings("ci").to_toml().replace("[gps]", "[gpz]")
    with pytest.raises(ConfigError, match="unknown key gpz"):
        settings_from_toml(text)
    with pytest.raises(ConfigError, match="not TOML"):
        settings_from_toml("[epoch\n")
    assert isinstance(settings_from_profile(load_profile("ci")), Settings)
