"""Settings read once: a profile as a tree of frozen, typed sections.

:func:`load_settings` merges a profile's TOML chain (``inherits``, ``also``, ``--set``), checks it in
:mod:`lnss_lib.config` (keys, types, ranges with units, the allowed values of every text setting; the
error names the key, the value and what is allowed) and freezes the result into :class:`Settings`: one
dataclass a section (``settings.forces``, ``settings.dop``, ...). A kernel takes the section it reads,
or the :class:`Dynamics` bundle that the force model and the propagator read, never the whole tree.

The sections are declared in :mod:`lnss_lib.sections`, each setting once (type, range or allowed
values, reason); the checker reads its rules from there. Why plain frozen dataclasses and not pydantic:
the standard library's field metadata holds the rules, the checker names the TOML file and line, and a
frozen dataclass adds no dependency, cannot be changed after the check, and shows every setting a
function depends on in its signature. Numbers that TOML allows as integers in a float key become
``float``, lists become tuples; free tables (``gps.launch_dates``, ``campaign.constraints``, ...) stay
plain tables, checked with the rest (the campaign's by :func:`lnss_lib.config.validate_profile` too).

:attr:`Settings.hash` is computed once, at construction (the same fingerprint as
:func:`lnss_lib.config.profile_hash`), and :meth:`Settings.to_toml` / :func:`settings_from_toml` round
trip the merged profile, so a run folder records exactly what ran.
"""

from __future__ import annotations

import dataclasses
import functools
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .config import (
    deep_merge,
    load_profile,
    profile_hash,
    toml_literal,
    validate_profile,
    with_absent_sections,
)
from .errors import ConfigError
from .legacy_keys import migrate_legacy
from .sections import (  # the sections, importable from here as they always were
    BenchmarkSettings,
    BodyConstants,
    BoxSettings,
    CampaignSettings,
    CapstoneSettings,
    DeltaVSettings,
    DesignLifeSettings,
    DopSettings,
    EphemerisSettings,
    EpochSettings,
    EvaluatorSettings,
    ForceSettings,
    FrameSettings,
    FrontValidationSettings,
    GnssReference,
    GnssSettings,
    GnssTransmitter,
    GpsSettings,
    GravitySettings,
    ImpactSettings,
    IntegratorSetting,
    IntegratorSettings,
    LifeEvaluationSettings,
    LifeNavigationSettings,
    NavigationErrorSettings,
    NotebookSettings,
    ProfileInfo,
    ProfileSections,
    RobustnessSettings,
    ServiceSettings,
    SkEstimateSettings,
    SpacecraftSettings,
    StabilitySettings,
    StandaloneElfoSettings,
    ValidationSettings,
    VariableBounds,
)
from .setting_rule import rule_of

__all__ = [
    "Settings",
    "Dynamics",
    "load_settings",
    "settings_from_profile",
    "settings_from_toml",
    "ProfileInfo",
    "EpochSettings",
    "SpacecraftSettings",
    "GravitySettings",
    "ForceSettings",
    "BodyConstants",
    "IntegratorSetting",
    "IntegratorSettings",
    "FrameSettings",
    "EphemerisSettings",
    "ImpactSettings",
    "StandaloneElfoSettings",
    "CapstoneSettings",
    "ValidationSettings",
    "NotebookSettings",
    "DopSettings",
    "GpsSettings",
    "GnssReference",
    "GnssTransmitter",
    "GnssSettings",
    "DeltaVSettings",
    "EvaluatorSettings",
    "NavigationErrorSettings",
    "VariableBounds",
    "CampaignSettings",
    "StabilitySettings",
    "SkEstimateSettings",
    "BoxSettings",
    "ServiceSettings",
    "DesignLifeSettings",
    "BenchmarkSettings",
    "LifeEvaluationSettings",
    "LifeNavigationSettings",
    "RobustnessSettings",
    "FrontValidationSettings",
    "ProfileSections",
]  # the sections (lnss_lib.sections) are importable from here too


def _frozen(value):
    """A copy of a list value as nested tuples (tables stay plain, picklable dicts)."""
    if isinstance(value, Mapping):
        return {key: _frozen(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(item) for item in value)
    return value


def _thawed(value):
    """The plain TOML value (dicts and lists) of a frozen one."""
    if isinstance(value, Mapping):
        return {key: _thawed(item) for key, item in value.items()}
    if isinstance(value, tuple):
        return [_thawed(item) for item in value]
    return value


def _convert(hint, value, key: str):
    """``value`` of a checked profile as the field type ``hint`` (section, float, tuple, mapping, ...)."""
    origin = typing.get_origin(hint)
    if dataclasses.is_dataclass(hint):
        return _build(hint, value, key)
    if hint is float:
        return float(value)
    if origin is types.UnionType or hint is Any:  # e.g. int | float: the value's own type
        return _frozen(value)
    if hint in (int, bool, str):
        return value
    if origin is tuple:
        item_hint = typing.get_args(hint)[0]
        return tuple(_convert(item_hint, item, f"{key}[{i}]") for i, item in enumerate(value))
    if origin in (Mapping, dict) or hint is Mapping:
        args = typing.get_args(hint)
        if args and dataclasses.is_dataclass(args[1]):
            return {name: _build(args[1], item, f"{key}.{name}") for name, item in value.items()}
        return _thawed(value)  # a free table (a fresh copy): checked with the rest
    return _frozen(value)


@functools.cache
def _hints(cls) -> dict:
    """Field types of a section class (resolved once)."""
    return typing.get_type_hints(cls)


def _build(cls, table: Mapping, key: str):
    """Section ``cls`` from its checked TOML table (every field's key is present: the profile is complete)."""
    hints = _hints(cls)
    values = {}
    for item in dataclasses.fields(cls):
        if not item.init or rule_of(item).derived or rule_of(item).file_only:
            continue
        name = item.name
        if name not in table:
            raise ConfigError(
                f"missing key {key}.{name} (every profile has the keys of params/paper.toml)",
                key=f"{key}.{name}",
            )
        values[item.name] = _convert(hints[item.name], table[name], f"{key}.{name}")
    return cls(**values)


@dataclass(frozen=True)
class Dynamics:
    """What the force model and the propagator read: bodies, frames, field, forces, spacecraft, integrator."""

    ephemeris: EphemerisSettings
    frames: FrameSettings
    constants: BodyConstants
    gravity: GravitySettings
    forces: ForceSettings
    spacecraft: SpacecraftSettings
    impact: ImpactSettings
    integrator: IntegratorSettings

    @property
    def r_impact_km(self) -> float:
        """Radius below which an orbit is an impact: mean lunar radius plus the minimum altitude."""
        return self.constants.r_moon_mean_km + self.impact.min_altitude_km


@dataclass(frozen=True)
class Settings(ProfileSections):
    """A whole profile, checked and frozen; only the top of the workbook (command line, pipeline, studies,
    campaign set-up, explorer) holds it, and hands each kernel its section."""

    source: Mapping[str, Any] = field(repr=False, compare=False)
    hash: str = field(init=False, compare=True)

    def __post_init__(self):
        object.__setattr__(self, "hash", profile_hash(_thawed(self.source)))

    @property
    def name(self) -> str:
        return self.profile.name

    @functools.cached_property
    def dynamics(self) -> Dynamics:
        return Dynamics(
            self.ephemeris,
            self.frames,
            self.constants,
            self.gravity,
            self.forces,
            self.spacecraft,
            self.impact,
            self.integrator,
        )

    def as_dict(self) -> dict:
        """The merged, checked profile as plain TOML data (a copy)."""
        return _thawed(self.source)

    def to_toml(self) -> str:
        """The merged profile as TOML text; :func:`settings_from_toml` reads it back to equal settings."""
        lines = []
        for section, table in self.as_dict().items():
            lines.append(f"[{section}]")
            lines.extend(
                f"{toml_literal(key)} = {toml_literal(value)}" for key, value in table.items()
            )
            lines.append("")
        return "\n".join(lines)

    def with_overrides(self, overrides: Mapping | None) -> Settings:
        """These settings with the nested ``overrides`` merged in and checked (e.g. ``campaign.overrides``)."""
        if not overrides:
            return self
        validate_profile(_thawed(overrides), partial=True, source="overrides")
        return settings_from_profile(deep_merge(self.as_dict(), _thawed(overrides)))


def _value_of(profile: Mapping, key: str):
    section, name = key.split(".")
    return profile[section][name]


def _with_derived(section, profile: Mapping):
    """``section`` with each derived field (:func:`lnss_lib.sections.derived`) set to the first of its keys whose
    value is not 0."""
    hints = _hints(type(section))
    values = {
        item.name: next((v for v in (_value_of(profile, k) for k in rule_of(item).derived) if v), 0)
        for item in dataclasses.fields(section)
        if isinstance(rule_of(item).derived, tuple)
    }
    return dataclasses.replace(
        section, **{name: _convert(hints[name], value, name) for name, value in values.items()}
    )


def settings_from_profile(profile: Mapping) -> Settings:
    """Settings of a merged profile dict (as :func:`lnss_lib.config.load_profile` returns, or as a run folder stored
    it, read in today's keys by :func:`lnss_lib.legacy_keys.migrate_legacy`), checked again."""
    profile = migrate_legacy(
        with_absent_sections(_thawed(profile))
    )  # a fresh copy of every table and list
    validate_profile(profile)
    sections = {
        item.name: _with_derived(
            _build(_hints(Settings)[item.name], profile[item.name], item.name), profile
        )
        for item in dataclasses.fields(Settings)
        if item.init and item.name != "source"
    }
    return Settings(**sections, source=profile)


def profile_data(profile: Settings | Mapping) -> dict:
    """The plain TOML data of settings or of a profile dict (what run folders store and compare)."""
    return profile.as_dict() if isinstance(profile, Settings) else _thawed(profile)


def settings_from_toml(text: str) -> Settings:
    """Settings from :meth:`Settings.to_toml` text (a run folder's record)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"recorded settings are not TOML: {error}") from None
    return settings_from_profile(data)


def load_settings(name: str = "quick", overrides: dict | str | None = None) -> Settings:
    """Profile ``name`` (``params/NAME.toml``, its ``inherits`` chain and ``overrides``), read once and frozen."""
    return settings_from_profile(load_profile(name, overrides))
