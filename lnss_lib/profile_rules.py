"""The rules a profile's values obey, read from the section classes of :mod:`lnss_lib.sections`.

The schema's keys and their :class:`~lnss_lib.setting_rule.Rule` (:func:`rules`), the check of one
value's type and number (finite, in range, an integer an output can store), the rules across keys
and those of the campaign's free tables. Each refusal is a :class:`ConfigError` naming the key, the
value and what is allowed, with the file and line when the value came from a file.
:func:`lnss_lib.config.validate_profile` walks a profile and calls these.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .constants import INTEGER_SETTING_MAX
from .errors import ConfigError
from .keys import (
    DESIGN_KEYS,
    INTEGER_DESIGN_KEYS,
    LIFE_NAVIGATION_KEYS,
    METRIC_KEYS,
    NEEDS_ALL_SATELLITES,
)
from .sections import (
    CR_AREA_MASS,
    CR_AREA_MASS_WHY,
    GNSS_SYSTEMS,
    SEMI_MAJOR_AXIS,
    SEMI_MAJOR_AXIS_WHY,
    ProfileSections,
    walker_splits,
)
from .setting_rule import Rule, allowed_range_text, in_range, rule_of

PROFILE_SCHEMA = ProfileSections  # every key, its type and its rule (lnss_lib.sections)


_hints = functools.cache(typing.get_type_hints)  # field types of a section class, resolved once


def schema_fields(cls) -> dict:
    """``{key: (type, Rule)}`` of a section class: the keys a profile may write (not the derived fields)."""
    hints = _hints(cls)
    return {
        item.name: (hints[item.name], rule_of(item))
        for item in dataclasses.fields(cls)
        if item.init and not rule_of(item).derived
    }


def entry_class(hint):
    """The section class of a table of named sections (``Mapping[str, IntegratorSetting]``), else None."""
    args = typing.get_args(hint)
    named = (
        typing.get_origin(hint) is Mapping and len(args) == 2 and dataclasses.is_dataclass(args[1])
    )
    return args[1] if named else None


def rules(cls=PROFILE_SCHEMA, prefix: str = ""):
    """Every ``(dotted key, Rule)`` of the schema (a named entry of ``[integrator.settings]`` is ``*``)."""
    for name, (hint, rule) in schema_fields(cls).items():
        key = f"{prefix}{name}"
        yield key, rule
        if dataclasses.is_dataclass(hint):
            yield from rules(hint, f"{key}.")
        elif entry_class(hint) is not None and not rule.free:
            yield from rules(entry_class(hint), f"{key}.*.")


def keys_with(flag: str) -> tuple[str, ...]:
    """Dotted keys whose :class:`~lnss_lib.setting_rule.Rule` sets ``flag`` (e.g. ``"pair"``)."""
    return tuple(key for key, rule in rules() if getattr(rule, flag))


KIND_OF_TYPE = {
    bool: "a boolean (true or false)",
    int: "an integer",
    float: "a number",
    str: "a string",
    list: "a list",
    dict: "a table",
}


def kind_of(value) -> str:
    """A value's kind in words, for messages."""
    return KIND_OF_TYPE.get(type(value), type(value).__name__)


def expected_kind(hint) -> str:
    """The kind of value a field's type ``hint`` takes, in words."""
    if hint in KIND_OF_TYPE:
        return KIND_OF_TYPE[hint]
    if typing.get_origin(hint) is types.UnionType:
        return "a number"
    if typing.get_origin(hint) is tuple:
        return "a list"
    return "a table"


def type_ok(value, hint) -> bool:
    """Whether a TOML ``value`` has the field type ``hint`` (a float field takes an integer)."""
    if hint is Any:
        return True
    if hint is bool or isinstance(value, bool):
        return hint is bool and isinstance(value, bool)
    if hint is int:
        return isinstance(value, int)
    if hint is float or typing.get_origin(hint) is types.UnionType:
        return isinstance(value, (int, float))
    if hint is str:
        return isinstance(value, str)
    if typing.get_origin(hint) is tuple:
        return isinstance(value, list)
    return isinstance(value, dict)


def _line_of(source, key: str) -> str:
    """ ", line N" of ``key``'s last component in a TOML file (for messages), or ""."""
    if not isinstance(source, Path) or not source.is_file():
        return ""
    leaf = key.rsplit(".", 1)[-1]
    for number, line in enumerate(source.read_text().splitlines(), start=1):
        if line.split("#", 1)[0].split("=", 1)[0].strip().strip('"') == leaf and "=" in line:
            return f", line {number}"
    return ""


def fail(message: str, key: str, source) -> None:
    where = f"{source}{_line_of(source, key)}: " if source not in (None, "overrides") else ""
    raise ConfigError(f"{where}{message}", key=key, source=None if source is None else str(source))


def check_integer_size(key: str, value, source, allowed: str = "") -> None:
    """An integer a float cannot hold or an output cannot store (|n| > :data:`INTEGER_SETTING_MAX`) is refused before
    anything compares it (``math.isfinite`` raised OverflowError; ``repr`` of 5000 digits raises ValueError).
    ``allowed``: the setting's own range where it has an upper end, else what the outputs store."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > INTEGER_SETTING_MAX:
        digits = (
            int(value.bit_length() * math.log10(2)) + 1
        )  # one too many when |value| < 10**(digits - 1)
        digits -= abs(value) < 10 ** (digits - 1)
        fail(
            f"{key} = an integer of {digits} digits is too large; allowed: "
            + (allowed or "at most 2**63 - 1 in magnitude (the int64 of the NetCDF outputs)"),
            key,
            source,
        )


def check_number(key: str, rule: Rule, value, source) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    why = f" ({rule.why})" if rule.why else ""
    bounded = rule.range is not None and rule.range[1] is not None
    check_integer_size(key, value, source, allowed_range_text(rule.range) + why if bounded else "")
    if not math.isfinite(value) and not (rule.infinite_ok and not math.isnan(value)):
        fail(
            f"{key} = {value!r} is not finite; allowed: a finite number"
            + (f" in {allowed_range_text(rule.range)}" if rule.range else ""),
            key,
            source,
        )
    if rule.range is not None and math.isfinite(value) and not in_range(value, rule.range):
        fail(
            f"{key} = {value!r} is out of range; allowed: {allowed_range_text(rule.range)}{why}",
            key,
            source,
        )


def lookup(profile: dict, key: str):
    """The value at dotted ``key``, or None where a section or key is absent (a partial profile)."""
    value = profile
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
    return value


def check_across(profile: dict, source) -> None:
    """Rules across keys, wherever a (partial) profile holds every key a rule needs: setting names name an
    ``[integrator.settings.*]`` table; ``[evaluator] extra_metrics`` are distinct, and the Delta-V maxima among
    them need ``[deltav] satellites = "all"``, the life navigation metrics ``[sk_estimate] model = "life"``; Cr A/m of the spacecraft is a spacecraft's; a pair
    (``Rule.pair``) is ``[low, high]`` with low < high."""
    settings = lookup(profile, "integrator.settings")
    for key in keys_with("names_integrator_setting"):
        name = lookup(profile, key)
        if settings is not None and name is not None and name not in settings:
            fail(
                f"{key} = {name!r} names no [integrator.settings.*]; allowed: {', '.join(settings)}",
                key,
                source,
            )
    systems = lookup(profile, "gnss.systems")
    if isinstance(systems, list) and len(set(systems)) != len(systems):
        fail(
            f"gnss.systems = {systems!r} is not allowed; allowed: distinct names from {', '.join(GNSS_SYSTEMS)}",
            "gnss.systems",
            source,
        )
    extras = lookup(profile, "evaluator.extra_metrics")
    if isinstance(extras, list) and len(set(extras)) != len(extras):
        fail(
            f"[evaluator] extra_metrics must be distinct names; got {extras!r}",
            "evaluator.extra_metrics",
            source,
        )
    for names, key, value, why in (
        (
            LIFE_NAVIGATION_KEYS,
            "sk_estimate.model",
            "life",
            "come from the life estimate's rebuilt constellation",
        ),
        (NEEDS_ALL_SATELLITES, "deltav.satellites", "all", "are maxima over satellites"),
    ):  # extra metrics that only one value of another setting computes
        needing, have = [n for n in extras or () if n in names], lookup(profile, key)
        if needing and have is not None and have != value:
            section, name = key.split(".")
            fail(
                f"[evaluator] extra_metrics {needing} {why}: they need "
                f'[{section}] {name} = "{value}"; got {have!r}',
                key,
                source,
            )
    lat, lon = (
        lookup(profile, "navigation_error.station_lat_deg"),
        lookup(profile, "navigation_error.station_lon_deg"),
    )
    if lat is not None and lon is not None and len(lat) != len(lon):
        fail(
            f"navigation_error.station_lon_deg has {len(lon)} entries for {len(lat)} station latitudes; allowed: one "
            "longitude per latitude",
            "navigation_error.station_lon_deg",
            source,
        )
    floor = [
        lookup(profile, f"navigation_error.{k}") for k in ("sise_at_upload_m", "receiver_noise_m")
    ]
    if None not in floor and max(floor) <= 0.0:
        fail(
            "navigation_error.sise_at_upload_m and receiver_noise_m are both 0; allowed: a positive range error floor "
            "(a zero-error range would take infinite weight)",
            "navigation_error.receiver_noise_m",
            source,
        )
    for key in keys_with("pair"):
        pair = lookup(profile, key)
        if pair is not None and not (len(pair) == 2 and pair[0] < pair[1]):
            fail(
                f"{key} = {pair!r} is not allowed; allowed: [low, high] with low < high",
                key,
                source,
            )
    craft = [lookup(profile, f"spacecraft.{k}") for k in ("cr", "area_m2", "mass_kg")]
    if (
        None not in craft
        and craft[2] > 0
        and not in_range(craft[0] * craft[1] / craft[2], CR_AREA_MASS)
    ):
        fail(
            f"spacecraft cr * area_m2 / mass_kg = {craft[0] * craft[1] / craft[2]:.6g} m^2/kg is out of range; "
            f"allowed: {allowed_range_text(CR_AREA_MASS)} ({CR_AREA_MASS_WHY})",
            "spacecraft.area_m2",
            source,
        )


CAMPAIGN_OFF = (
    "off"  # a campaign constraint or hypervolume entry set to "off" drops an inherited one
)


def _is_number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def check_campaign(profile: dict, source) -> None:
    """Rules of the free tables and names of a complete profile's ``[campaign]`` (the campaign plan reads them
    unchecked): objectives and bounds name metrics (:data:`METRIC_KEYS` and ``[evaluator] extra_metrics``), a
    constraint is ``{min = x}`` or ``{max = x}``, a hypervolume reference is positive, the grid of every design
    variable has finite ``lower < upper`` and ``step > 0`` (semi-major axes in the Hill sphere; integer bounds
    ``>= 1`` and integer steps for the plane and satellite counts), a companion is another profile."""
    campaign = profile["campaign"]
    metrics = METRIC_KEYS + tuple(profile["evaluator"]["extra_metrics"])
    metric_text = f"{', '.join(metrics)} (extra metrics: list them in [evaluator] extra_metrics)"
    objectives = campaign["objectives"]
    names = [o.lstrip("-") if isinstance(o, str) else o for o in objectives]
    bad = [o for o, name in zip(objectives, names) if name not in metrics]
    if not objectives or bad or len(set(names)) != len(names):
        fail(
            f"campaign.objectives = {objectives!r} is not allowed"
            + (f" ({bad!r} unknown)" if bad else "")
            + f"; allowed: distinct metric names, '-' first to maximise, from {metric_text}",
            "campaign.objectives",
            source,
        )
    entries = {  # table -> (test of an entry's value, what is allowed)
        "constraints": (
            lambda spec: (
                isinstance(spec, dict)
                and len(spec) == 1
                and next(iter(spec)) in ("min", "max")
                and _is_number(next(iter(spec.values())))
            ),
            "exactly one of {min = number}, {max = number}",
        ),
        "hypervolume": (lambda ref: _is_number(ref) and ref > 0, "a positive reference value"),
    }
    for table, (ok, allowed) in entries.items():
        for metric, value in campaign[table].items():
            key = f"campaign.{table}.{metric}"
            if value == CAMPAIGN_OFF:
                continue
            if metric not in metrics:
                fail(f"unknown metric {key}; allowed: {metric_text}", key, source)
            if not ok(value):
                fail(
                    f"{key} = {value!r} is not allowed; allowed: {allowed} or {CAMPAIGN_OFF!r}",
                    key,
                    source,
                )
    variables = campaign["variables"]
    if set(variables) != set(DESIGN_KEYS):
        fail(
            f"campaign.variables names {', '.join(variables)}; allowed: exactly {', '.join(DESIGN_KEYS)}",
            "campaign.variables",
            source,
        )
    for name in DESIGN_KEYS:
        key, spec = f"campaign.variables.{name}", variables[name]
        if (
            not isinstance(spec, dict)
            or set(spec) != {"lower", "upper", "step"}
            or not all(_is_number(spec[k]) for k in spec)
        ):
            fail(
                f"{key} = {spec!r} is not allowed; allowed: {{lower = number, upper = number, step = number}}",
                key,
                source,
            )
        lower, upper, step = (spec[k] for k in ("lower", "upper", "step"))
        if step <= 0 or upper <= lower:
            fail(
                f"{key} = {spec!r} is not allowed; allowed: lower < upper and step > 0", key, source
            )
        if name == "sma_km" and not (
            in_range(lower, SEMI_MAJOR_AXIS) and in_range(upper, SEMI_MAJOR_AXIS)
        ):
            fail(
                f"{key} = {spec!r} is out of range; allowed: bounds in {allowed_range_text(SEMI_MAJOR_AXIS)} "
                f"({SEMI_MAJOR_AXIS_WHY})",
                key,
                source,
            )
        if name in INTEGER_DESIGN_KEYS and (
            any(v != round(v) for v in (lower, upper, step)) or lower < 1
        ):
            fail(
                f"{key} = {spec!r} is not allowed; allowed: integer bounds >= 1 and an integer step (a count)",
                key,
                source,
            )
    count_ranges = [
        range(int(variables[k]["lower"]), int(variables[k]["upper"]) + 1, int(variables[k]["step"]))
        for k in INTEGER_DESIGN_KEYS
    ]
    if (n_sat := campaign["n_sat"]) and not walker_splits(n_sat, *count_ranges):
        sizes = sorted({p * s for p in count_ranges[0] for s in count_ranges[1]})
        fail(
            f"campaign.n_sat = {n_sat!r} has no planes x satellites-per-plane split on the grid of "
            f"campaign.variables; allowed: 0 (any size) or one of {', '.join(map(str, sizes))}",
            "campaign.n_sat",
            source,
        )
    companion = campaign["companion_profile"]
    if companion and companion == profile["profile"].get("name"):
        fail(
            f'campaign.companion_profile = {companion!r} is this profile; allowed: "" (none) or another profile',
            "campaign.companion_profile",
            source,
        )
