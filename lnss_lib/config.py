"""Run profiles: TOML files in ``params/`` merged along their ``inherits`` chain, and every rule they obey.

:func:`load_profile` returns the merged TOML as a plain nested ``dict`` with the chain resolved and
``profile.name`` set, checked by :func:`validate_profile` against the sections of
:mod:`lnss_lib.sections`, where each setting is declared once with its type and rule (range and reason,
allowed values, form), and against the rules across keys; the workbook reads it once, to freeze it into
typed sections (:mod:`lnss_lib.settings`). :func:`profile_hash` fingerprints everything that can change
a result, so caches and manifests can tell runs apart. Profiles are names of files in ``params/`` (or a
file made loadable by :func:`use_profile_file`); data paths in a profile are relative to ``params/`` and
must lie under ``params/data/``.
"""

from __future__ import annotations

import copy
import dataclasses
import datetime as dt
import difflib
import functools
import hashlib
import json
import math
import os
import re
import tomllib
import types
import typing
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

from .constants import INTEGER_SETTING_MAX, MAX_GRID_POINTS, SECONDS_PER_DAY
from .dates import ISO_DATE_FORMAT, ISO_FORMAT, is_iso_date
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
    KEYS_OFF_WHEN_ABSENT,
    LEGACY_KEYS,
    OFF_WHEN_ABSENT,
    SEMI_MAJOR_AXIS,
    SEMI_MAJOR_AXIS_WHY,
    ProfileSections,
    Rule,
    allowed_range_text,
    in_range,
    legacy_spelling,
    rule_of,
    walker_splits,
)

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent
PARAMS_DIR = PROJECT_DIR / "params"
OUTPUTS_DIR = PROJECT_DIR / "outputs"
REFERENCE_DIR = (
    OUTPUTS_DIR / "reference"
)  # shipped results, one folder per profile (lnss_lib.campaign.reference)
RESERVED_PROFILE_NAMES = (
    REFERENCE_DIR.name,
)  # outputs/<name>/ is not a profile's: no profile may take the name


def available_profiles() -> list[str]:
    """Names of the profiles in ``params/`` (one ``NAME.toml`` each)."""
    return sorted(p.stem for p in PARAMS_DIR.glob("*.toml"))


def deep_merge(base: dict, override: dict) -> dict:
    """A copy of ``base`` with the nested ``override`` applied."""
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def read_toml(path: Path) -> dict:
    """A TOML file as a dict; ConfigError naming the file and the line of a syntax error, never its content."""
    try:
        with path.open("rb") as handle:
            return tomllib.load(handle)
    except UnicodeDecodeError as error:
        raise ConfigError(
            f"{path}: not a TOML text file (byte {error.start} is not UTF-8 text)", source=str(path)
        ) from None
    except tomllib.TOMLDecodeError as error:
        where = re.search(r"\(at line (\d+), column \d+\)", str(error))
        line = f", line {where.group(1)}" if where else ""
        raise ConfigError(f"{path}{line}: TOML syntax error", source=str(path)) from None
    except (
        ValueError,
        RecursionError,
    ) as error:  # an integer of more than 4300 digits, arrays nested too deep
        raise ConfigError(
            f"{path}: not a TOML file the workbook reads ({type(error).__name__}: a number too long or "
            f"nesting too deep)",
            source=str(path),
        ) from None


PROFILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
PROFILE_FILES_ENV = (
    "LNSS_PROFILE_FILES"  # {name: path} of use_profile_file, inherited by kernels and workers
)


def _profile_file_problem(name, path) -> str | None:
    """Why ``name`` -> ``path`` cannot be a profile file (:func:`use_profile_file`'s rules), or None."""
    if not isinstance(name, str) or not PROFILE_NAME.fullmatch(name):
        return (
            f"the name {name!r} is not allowed as a profile name; allowed: letters, digits, '_' and '-' (at most "
            f"64, first a letter or digit)"
        )
    if name in RESERVED_PROFILE_NAMES:
        return f"the name {name!r} is reserved (outputs/{name}/ holds the shipped results of every profile)"
    if name in available_profiles():
        return (
            f"params/{name}.toml already has the name {name!r}; rename the file (profiles in params/: "
            f"{', '.join(available_profiles())})"
        )
    if not isinstance(path, str) or not path.endswith(".toml") or not Path(path).is_file():
        return f"{path!r} is not an existing regular file ending in .toml"
    return None


def _profile_files() -> dict[str, str]:
    """The profile files this process was given ({name: path}, the environment variable :data:`PROFILE_FILES_ENV`
    that :func:`use_profile_file` sets for the processes it starts), each checked as :func:`use_profile_file`
    checks a user's file: a forged entry cannot replace a ``params/`` profile or name a device that never ends."""
    try:
        files = json.loads(os.environ.get(PROFILE_FILES_ENV) or "{}")
    except (ValueError, RecursionError):
        files = None
    if not isinstance(files, dict):
        raise ConfigError(
            f"environment variable {PROFILE_FILES_ENV} is not a JSON table of profile files",
            key=PROFILE_FILES_ENV,
        )
    for name, path in files.items():
        problem = _profile_file_problem(name, path)
        if problem:
            raise ConfigError(
                f"environment variable {PROFILE_FILES_ENV}: {problem}; unset it (it is set by "
                f"--profile-file for the processes the workbook starts)",
                key=PROFILE_FILES_ENV,
            )
    return files


def use_profile_file(path) -> str:
    """Make the TOML file ``path`` loadable as profile ``<stem>`` (outputs in ``outputs/<stem>/``) by this
    process and the processes it starts (notebook kernels, local workers); returns the name.

    The stem must be a profile name (letters, digits, ``_``, ``-``) that no file in ``params/`` has and that is not
    reserved (:data:`RESERVED_PROFILE_NAMES`).
    """
    path = Path(path)
    if path.suffix != ".toml" or not path.is_file():
        raise ConfigError(
            f"--profile-file {path}: need an existing regular file ending in .toml",
            key="--profile-file",
        )
    problem = _profile_file_problem(path.stem, str(path.resolve()))
    if problem:
        raise ConfigError(f"--profile-file {path}: {problem}", key="--profile-file")
    os.environ[PROFILE_FILES_ENV] = json.dumps({**_profile_files(), path.stem: str(path.resolve())})
    return path.stem


def profile_path(name: str, key: str = "--profile") -> Path:
    """The TOML file of profile ``name``: ``params/NAME.toml`` or a file given to :func:`use_profile_file`.

    ConfigError naming ``key`` and the available profiles for anything else (paths included).
    """
    files = _profile_files()
    if isinstance(name, str) and name in files:
        return Path(files[name])
    path = (
        PARAMS_DIR / f"{name}.toml"
        if isinstance(name, str) and PROFILE_NAME.fullmatch(name)
        else None
    )
    if path is None or not path.is_file():
        raise ConfigError(
            f"{key}: unknown profile {name!r}; allowed: {', '.join(available_profiles() + sorted(files))} "
            f"(names of params/*.toml; a file elsewhere: --profile-file PATH)",
            key=key,
        )
    return path


def load_profile(name: str = "quick", overrides: dict | str | None = None) -> dict:
    """Load profile ``name`` from ``params/NAME.toml``, resolving ``inherits``, then apply ``overrides``.

    Along the ``inherits`` chain (root first), each file's ``[profile] also = [NAMES]`` merges the
    settings those profiles' own files set (not what they inherit) before the file's own: a
    companion such as ``quick_operational`` takes operational physics and quick's sizes from one place.

    ``overrides`` is a nested dict or its JSON text (notebooks' ``overrides_json`` parameter). Every
    file and the result are checked by :func:`validate_profile`. Raises :class:`ConfigError` (a
    ValueError) naming the unknown profile, the file and line of a TOML error, or the bad key.
    """
    if not isinstance(name, str) or not name:
        raise ConfigError(f"profile name must be a non-empty string; got {name!r}")
    if isinstance(overrides, str):
        try:
            overrides = json.loads(overrides)
        except (
            ValueError,
            RecursionError,
        ) as error:  # JSONDecodeError, a 5000-digit integer, deep nesting
            raise ConfigError(
                f"overrides are not JSON the workbook reads ({type(error).__name__}: "
                f"{str(error)[:120]})"
            ) from None
    if overrides is not None and not isinstance(overrides, dict):
        raise ConfigError(f"overrides must be a nested dict of profile sections; got {overrides!r}")
    chain: list[dict] = []
    seen: set[str] = set()
    current: str | None = name
    while current is not None:
        path = profile_path(current, "--profile" if current == name else "profile.inherits")
        if current in seen:
            raise ConfigError(f"profile {name!r} has an inheritance cycle through {current!r}")
        seen.add(current)
        data = read_toml(path)
        validate_profile(data, partial=True, source=path)
        chain.append(data)
        current = data.get("profile", {}).get("inherits")
    profile: dict = {}
    for data in reversed(chain):
        for mixin in data.get("profile", {}).get("also", []):
            profile = deep_merge(profile, _own_settings(mixin))
        profile = deep_merge(profile, data)
    if overrides:
        validate_profile(overrides, partial=True, source="overrides")
    profile = deep_merge(profile, overrides or {})
    profile["profile"]["name"] = name
    profile["profile"].pop("inherits", None)
    profile["profile"].pop("also", None)
    validate_profile(profile)
    _check_data_paths(profile)
    _check_sampling(profile)
    _check_grid(profile)
    return profile


def _own_settings(name: str) -> dict:
    """The settings profile ``name``'s own file sets (not what it inherits), for ``[profile] also``."""
    path = profile_path(name, "profile.also")
    data = read_toml(path)
    validate_profile(data, partial=True, source=path)
    return {section: table for section, table in data.items() if section != "profile"}


REFERENCE_PROFILE = (
    "paper"  # the root of every profile: its values fill a section a stored profile lacks
)
PROFILE_SCHEMA = ProfileSections  # every key, its type and its rule (lnss_lib.sections)


ISO_TEXT = f"an ISO 8601 date and time, {ISO_FORMAT} (e.g. 2025-05-01T00:00:00)"
FORMS = {  # an open set of text values (Rule.form) -> (test, what is allowed)
    "iso_datetime": (is_iso_date, ISO_TEXT),
    "launch_cutoff": (
        lambda v: v in ("epoch", "none") or is_iso_date(v, date_only=True),
        f"'epoch', 'none' or an ISO 8601 date {ISO_DATE_FORMAT} (e.g. 2025-05-30)",
    ),
    "designator": (
        lambda v: re.fullmatch(r"(\d{4}-\d{3}[A-Z]{0,3})?", v) is not None,
        '"" (off) or an international designator YYYY-NNN',
    ),
    "profile_name": (
        lambda v: v == "" or v in available_profiles(),
        lambda: '"" (none) or a profile name: ' + ", ".join(available_profiles()),
    ),
}


_hints = functools.cache(typing.get_type_hints)  # field types of a section class, resolved once


def _schema_fields(cls) -> dict:
    """``{key: (type, Rule)}`` of a section class: the keys a profile may write (not the derived fields)."""
    hints = _hints(cls)
    return {
        item.name: (hints[item.name], rule_of(item))
        for item in dataclasses.fields(cls)
        if item.init and not rule_of(item).derived
    }


def _entry_class(hint):
    """The section class of a table of named sections (``Mapping[str, IntegratorSetting]``), else None."""
    args = typing.get_args(hint)
    named = (
        typing.get_origin(hint) is Mapping and len(args) == 2 and dataclasses.is_dataclass(args[1])
    )
    return args[1] if named else None


def rules(cls=PROFILE_SCHEMA, prefix: str = ""):
    """Every ``(dotted key, Rule)`` of the schema (a named entry of ``[integrator.settings]`` is ``*``)."""
    for name, (hint, rule) in _schema_fields(cls).items():
        key = f"{prefix}{name}"
        yield key, rule
        if dataclasses.is_dataclass(hint):
            yield from rules(hint, f"{key}.")
        elif _entry_class(hint) is not None and not rule.free:
            yield from rules(_entry_class(hint), f"{key}.*.")


def keys_with(flag: str) -> tuple[str, ...]:
    """Dotted keys whose :class:`~lnss_lib.sections.Rule` sets ``flag`` (e.g. ``"pair"``)."""
    return tuple(key for key, rule in rules() if getattr(rule, flag))


@lru_cache(maxsize=1)
def _reference() -> dict:
    """params/paper.toml's values (a section a stored profile lacks is read from them)."""
    return read_toml(PARAMS_DIR / f"{REFERENCE_PROFILE}.toml")


KIND_OF_TYPE = {
    bool: "a boolean (true or false)",
    int: "an integer",
    float: "a number",
    str: "a string",
    list: "a list",
    dict: "a table",
}


def _kind(value) -> str:
    """A value's kind in words, for messages."""
    return KIND_OF_TYPE.get(type(value), type(value).__name__)


def _expected(hint) -> str:
    """The kind of value a field's type ``hint`` takes, in words."""
    if hint in KIND_OF_TYPE:
        return KIND_OF_TYPE[hint]
    if typing.get_origin(hint) is types.UnionType:
        return "a number"
    if typing.get_origin(hint) is tuple:
        return "a list"
    return "a table"


def _type_ok(value, hint) -> bool:
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


def _fail(message: str, key: str, source) -> None:
    where = f"{source}{_line_of(source, key)}: " if source not in (None, "overrides") else ""
    raise ConfigError(f"{where}{message}", key=key, source=None if source is None else str(source))


def _check_integer_size(key: str, value, source) -> None:
    """An integer a float cannot hold or an output cannot store (|n| > :data:`INTEGER_SETTING_MAX`) is refused before
    anything compares it (``math.isfinite`` raised OverflowError; ``repr`` of 5000 digits raises ValueError)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > INTEGER_SETTING_MAX:
        digits = (
            int(value.bit_length() * math.log10(2)) + 1
        )  # one too many when |value| < 10**(digits - 1)
        digits -= abs(value) < 10 ** (digits - 1)
        _fail(
            f"{key} = an integer of {digits} digits is too large; allowed: at most 2**63 - 1 in magnitude "
            f"(the int64 of the NetCDF outputs)",
            key,
            source,
        )


def _check_number(key: str, rule: Rule, value, source) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    _check_integer_size(key, value, source)
    if not math.isfinite(value) and not (rule.infinite_ok and not math.isnan(value)):
        _fail(
            f"{key} = {value!r} is not finite; allowed: a finite number"
            + (f" in {allowed_range_text(rule.range)}" if rule.range else ""),
            key,
            source,
        )
    if rule.range is not None and math.isfinite(value) and not in_range(value, rule.range):
        why = f" ({rule.why})" if rule.why else ""
        _fail(
            f"{key} = {value!r} is out of range; allowed: {allowed_range_text(rule.range)}{why}",
            key,
            source,
        )


def _check_text(key: str, rule: Rule, value, source) -> None:
    """A text setting (or a list of them) against its rule's choices or form."""
    for item in value if isinstance(value, list) else [value]:
        if rule.choices is not None and item not in rule.choices:
            _fail(
                f"{key} = {item!r} is not allowed; allowed: {', '.join(map(repr, rule.choices))}",
                key,
                source,
            )
        if rule.form is not None and not (isinstance(item, str) and FORMS[rule.form][0](item)):
            allowed = FORMS[rule.form][1]
            _fail(
                f"{key} = {item!r} is not allowed; allowed: {allowed() if callable(allowed) else allowed}",
                key,
                source,
            )


def _unknown(key: str, known: list[str], source) -> None:
    """Refuse an unknown ``key``, naming the key that holds its quantity now or the nearest known keys."""
    if key in LEGACY_KEYS:
        _fail(f"unknown key {key}: its quantity has one key, {LEGACY_KEYS[key]}", key, source)
    near = difflib.get_close_matches(key, known, n=3, cutoff=0.6)
    _fail(
        f"unknown key {key}; "
        + (
            f"did you mean {' or '.join(near)}?" if near else f"known keys here: {', '.join(known)}"
        ),
        key,
        source,
    )


def _walk(data: dict, cls, prefix: str, partial: bool, source) -> None:
    """Check the table ``data`` at ``prefix`` against the section class ``cls``: keys, types, rules."""
    fields = _schema_fields(cls)
    for name, value in data.items():
        key = f"{prefix}{name}"
        if name not in fields:
            _unknown(key, [f"{prefix}{k}" for k in fields], source)
        hint, rule = fields[name]
        if not _type_ok(value, hint):
            _fail(
                f"{key} = {value!r} has the wrong type: expected {_expected(hint)}, got {_kind(value)}",
                key,
                source,
            )
        if rule.sections:  # profile sections changed for campaign evaluations
            _walk_sections(key, value, source)
        elif isinstance(value, dict) and (
            rule.free
            or hint is Any
            or _entry_class(hint) is None
            and not dataclasses.is_dataclass(hint)
        ):
            _check_free(key, value, source)
        elif isinstance(value, dict):
            for entry, table in value.items() if _entry_class(hint) else [(None, value)]:
                inner = key if entry is None else f"{key}.{entry}"
                if not isinstance(table, dict):
                    _fail(
                        f"{inner} = {table!r} has the wrong type: expected a table, got {_kind(table)}",
                        inner,
                        source,
                    )
                _walk(table, _entry_class(hint) or hint, f"{inner}.", True, source)
        elif isinstance(value, list):
            _check_free(key, value, source)
            _check_text(key, rule, value, source)
            if rule.non_empty and not value:
                _fail(
                    f"{key} = [] is not allowed; allowed: a list of at least one entry", key, source
                )
            for index, item in enumerate(value if rule.range else []):
                _check_number(f"{key}[{index}]", rule, item, source)
        elif isinstance(value, str):
            _check_text(key, rule, value, source)
        else:
            _check_number(key, rule, value, source)
    if not partial:
        missing = [
            f"{prefix}{k}"
            for k, item in ((f.name, f) for f in dataclasses.fields(cls))
            if k in fields and k not in data and item.default is dataclasses.MISSING
        ]
        if missing:
            _fail(
                f"missing key(s) {', '.join(missing)} (every profile has the keys of params/{REFERENCE_PROFILE}.toml; "
                f'inherit it with [profile] inherits = "{REFERENCE_PROFILE}")',
                missing[0],
                source,
            )


def _walk_sections(key: str, sections: dict, source) -> None:
    """``campaign.overrides``: a table of profile sections other than campaign and profile, each checked as its own."""
    known = {
        name: hint
        for name, (hint, _) in _schema_fields(PROFILE_SCHEMA).items()
        if name not in ("campaign", "profile")
    }
    for name, table in sections.items():
        if name not in known:
            _fail(
                f"unknown key {key}.{name}: campaign.overrides holds profile sections other than campaign; known: "
                f"{', '.join(known)}",
                f"{key}.{name}",
                source,
            )
        if not isinstance(table, dict):
            _fail(
                f"{key}.{name} = {table!r} has the wrong type: expected a table, got {_kind(table)}",
                f"{key}.{name}",
                source,
            )
        _walk(table, known[name], f"{key}.{name}.", True, source)


def _check_free(key: str, value, source) -> None:
    """Numbers anywhere inside a free-form table or list must be finite."""
    items = value.items() if isinstance(value, dict) else enumerate(value)
    for name, item in items:
        if isinstance(item, (dict, list)):
            _check_free(
                f"{key}.{name}" if isinstance(value, dict) else f"{key}[{name}]", item, source
            )
        elif isinstance(item, (int, float)):
            inner = f"{key}.{name}" if isinstance(value, dict) else f"{key}[{name}]"
            _check_integer_size(inner, item, source)
            if isinstance(item, float) and not math.isfinite(item):
                _fail(f"{inner} = {item!r} is not finite; allowed: a finite number", inner, source)


def validate_profile(profile: dict, *, partial: bool = False, source=None) -> None:
    """Check a profile (or, with ``partial``, a fragment: one TOML file, overrides) before any work.

    Keys and value types are the fields of :data:`PROFILE_SCHEMA` (a float field takes an integer);
    numbers are finite and inside their field's range; texts are among its choices or of its form;
    ``integrator.setting`` names one of ``integrator.settings``. A free table takes any keys (its
    numbers must be finite; :func:`_check_campaign` checks the campaign's). Raises :class:`ConfigError` naming the key,
    the value and what is allowed (with the file and line when ``source`` is a path).
    """
    if not isinstance(profile, dict):
        raise ConfigError(f"a profile is a table of sections; got {profile!r}")
    _walk(profile, PROFILE_SCHEMA, "", partial, source)
    _check_across(profile, source)
    if not partial:
        _check_campaign(profile, source)
    overrides = _lookup(profile, "campaign.overrides")
    if overrides:  # the profile campaign evaluations use
        _check_across(deep_merge(profile, overrides), source)


def _lookup(profile: dict, key: str):
    """The value at dotted ``key``, or None where a section or key is absent (a partial profile)."""
    value = profile
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
    return value


def _check_across(profile: dict, source) -> None:
    """Rules across keys, wherever a (partial) profile holds every key a rule needs: setting names name an
    ``[integrator.settings.*]`` table; ``[evaluator] extra_metrics`` are distinct, and the Delta-V maxima among
    them need ``[deltav] satellites = "all"``, the life navigation metrics ``[sk_estimate] model = "life"``; Cr A/m of the spacecraft is a spacecraft's; a pair
    (``Rule.pair``) is ``[low, high]`` with low < high."""
    settings = _lookup(profile, "integrator.settings")
    for key in keys_with("names_integrator_setting"):
        name = _lookup(profile, key)
        if settings is not None and name is not None and name not in settings:
            _fail(
                f"{key} = {name!r} names no [integrator.settings.*]; allowed: {', '.join(settings)}",
                key,
                source,
            )
    systems = _lookup(profile, "gnss.systems")
    if isinstance(systems, list) and len(set(systems)) != len(systems):
        _fail(
            f"gnss.systems = {systems!r} is not allowed; allowed: distinct names from {', '.join(GNSS_SYSTEMS)}",
            "gnss.systems",
            source,
        )
    extras = _lookup(profile, "evaluator.extra_metrics")
    if isinstance(extras, list) and len(set(extras)) != len(extras):
        _fail(
            f"[evaluator] extra_metrics must be distinct names; got {extras!r}",
            "evaluator.extra_metrics",
            source,
        )
    model = _lookup(profile, "sk_estimate.model")
    life_nav = [n for n in extras or () if n in LIFE_NAVIGATION_KEYS]
    if life_nav and model is not None and model != "life":
        _fail(
            f"[evaluator] extra_metrics {life_nav} come from the life estimate's rebuilt constellation: they need "
            f'[sk_estimate] model = "life"; got {model!r}',
            "sk_estimate.model",
            source,
        )
    satellites = _lookup(profile, "deltav.satellites")
    needs_all = [n for n in extras or () if n in NEEDS_ALL_SATELLITES]
    if needs_all and satellites is not None and satellites != "all":
        _fail(
            f"[evaluator] extra_metrics {needs_all} are maxima over satellites: they need "
            f'[deltav] satellites = "all"; got {satellites!r}',
            "deltav.satellites",
            source,
        )
    lat, lon = (
        _lookup(profile, "navigation_error.station_lat_deg"),
        _lookup(profile, "navigation_error.station_lon_deg"),
    )
    if lat is not None and lon is not None and len(lat) != len(lon):
        _fail(
            f"navigation_error.station_lon_deg has {len(lon)} entries for {len(lat)} station latitudes; allowed: one "
            "longitude per latitude",
            "navigation_error.station_lon_deg",
            source,
        )
    floor = [
        _lookup(profile, f"navigation_error.{k}") for k in ("sise_at_upload_m", "receiver_noise_m")
    ]
    if None not in floor and max(floor) <= 0.0:
        _fail(
            "navigation_error.sise_at_upload_m and receiver_noise_m are both 0; allowed: a positive range error floor "
            "(a zero-error range would take infinite weight)",
            "navigation_error.receiver_noise_m",
            source,
        )
    for key in keys_with("pair"):
        pair = _lookup(profile, key)
        if pair is not None and not (len(pair) == 2 and pair[0] < pair[1]):
            _fail(
                f"{key} = {pair!r} is not allowed; allowed: [low, high] with low < high",
                key,
                source,
            )
    craft = [_lookup(profile, f"spacecraft.{k}") for k in ("cr", "area_m2", "mass_kg")]
    if (
        None not in craft
        and craft[2] > 0
        and not in_range(craft[0] * craft[1] / craft[2], CR_AREA_MASS)
    ):
        _fail(
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


def _check_campaign(profile: dict, source) -> None:
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
        _fail(
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
                _fail(f"unknown metric {key}; allowed: {metric_text}", key, source)
            if not ok(value):
                _fail(
                    f"{key} = {value!r} is not allowed; allowed: {allowed} or {CAMPAIGN_OFF!r}",
                    key,
                    source,
                )
    variables = campaign["variables"]
    if set(variables) != set(DESIGN_KEYS):
        _fail(
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
            _fail(
                f"{key} = {spec!r} is not allowed; allowed: {{lower = number, upper = number, step = number}}",
                key,
                source,
            )
        lower, upper, step = (spec[k] for k in ("lower", "upper", "step"))
        if step <= 0 or upper <= lower:
            _fail(
                f"{key} = {spec!r} is not allowed; allowed: lower < upper and step > 0", key, source
            )
        if name == "sma_km" and not (
            in_range(lower, SEMI_MAJOR_AXIS) and in_range(upper, SEMI_MAJOR_AXIS)
        ):
            _fail(
                f"{key} = {spec!r} is out of range; allowed: bounds in {allowed_range_text(SEMI_MAJOR_AXIS)} "
                f"({SEMI_MAJOR_AXIS_WHY})",
                key,
                source,
            )
        if name in INTEGER_DESIGN_KEYS and (
            any(v != round(v) for v in (lower, upper, step)) or lower < 1
        ):
            _fail(
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
        _fail(
            f"campaign.n_sat = {n_sat!r} has no planes x satellites-per-plane split on the grid of "
            f"campaign.variables; allowed: 0 (any size) or one of {', '.join(map(str, sizes))}",
            "campaign.n_sat",
            source,
        )
    companion = campaign["companion_profile"]
    if companion and companion == profile["profile"].get("name"):
        _fail(
            f'campaign.companion_profile = {companion!r} is this profile; allowed: "" (none) or another profile',
            "campaign.companion_profile",
            source,
        )


def parse_sets(items) -> dict:
    """``SECTION.KEY=VALUE`` strings (VALUE a TOML literal; a bare word counts as a string) as a nested
    overrides dict; the keys and values are checked by :func:`load_profile`."""
    overrides: dict = {}
    for item in items or []:
        path, sep, literal = item.partition("=")
        parts = [part.strip() for part in path.split(".")]
        if not sep or not all(parts):
            raise ConfigError(f"--set needs SECTION.KEY=VALUE (VALUE in TOML syntax); got {item!r}")
        try:
            value = tomllib.loads(f"v = {literal}")["v"]
        except ValueError as error:  # TOMLDecodeError, or an integer of more than 4300 digits
            if (
                literal.strip()
                and literal.strip().replace("_", "").replace("-", "").isalnum()
                and not literal.strip()[0].isdigit()
                and literal.strip().lower() not in ("nan", "inf")
            ):
                value = literal.strip()
            else:
                shown = item if len(item) <= 80 else f"{item[:60]}... ({len(item)} characters)"
                raise ConfigError(
                    f"--set {shown!r}: VALUE is not a TOML literal ({str(error)[:120]})", key=path
                ) from None
        if isinstance(value, (dt.date, dt.time)):
            raise ConfigError(
                f"--set {item!r}: TOML reads an unquoted {literal.strip()} as a date-time, and dates are "
                f"strings here; quote it: --set '{path.strip()}=\"{literal.strip()}\"'",
                key=path.strip(),
            )
        nested: dict = value
        for part in reversed(parts):
            nested = {part: nested}
        overrides = deep_merge(overrides, nested)
    return overrides


def toml_literal(value) -> str:
    """``value`` (bool, number, string, list or table) as a TOML literal, the syntax ``--set`` and profiles read."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return (
            repr(value)
            if math.isfinite(value)
            else ("nan" if math.isnan(value) else ("inf" if value > 0 else "-inf"))
        )
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(map(toml_literal, value)) + "]"
    if isinstance(value, dict):
        return (
            "{"
            + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v)}" for k, v in value.items())
            + "}"
        )
    raise TypeError(f"no TOML literal for {type(value).__name__} {value!r}")


def data_path(relative: str, key: str = "data file") -> Path:
    """Absolute path of a data file named relative to ``params/`` (``data/...``); ConfigError naming ``key``
    unless it lies under ``params/data/`` once symbolic links are resolved."""
    root = (PARAMS_DIR / "data").resolve()
    if (
        not isinstance(relative, str)
        or Path(relative).is_absolute()
        or not (PARAMS_DIR / relative).resolve().is_relative_to(root)
    ):
        raise ConfigError(
            f"{key} = {relative!r} is not allowed; allowed: a file under params/data/, named relative "
            f'to params/ (e.g. "data/gravity/...")',
            key=key,
        )
    return PARAMS_DIR / relative


DATA_KEYS = (
    "gravity.file",
    "ephemeris.kernels",
    "gps.tle_file",
    "gps.gain_file",
    "gnss.nominal_file",
    "validation.capstone.file",
)
SKYFIELD_DATA = (
    "skyfield-data:"  # ephemeris.planetary_spk prefix: a file of the skyfield-data package
)


def _check_data_paths(profile: dict) -> None:
    """Every data-file key of a profile names a file under ``params/data/`` (or a skyfield-data file)."""
    for key in DATA_KEYS:
        value = profile
        for part in key.split("."):
            value = value[part]
        for item in value if isinstance(value, list) else [value]:
            data_path(item, key)
    spk = profile["ephemeris"]["planetary_spk"]
    if spk.startswith(SKYFIELD_DATA):
        name = spk.removeprefix(SKYFIELD_DATA)
        if name in ("", ".", "..") or Path(name).name != name:
            raise ConfigError(
                f"ephemeris.planetary_spk = {spk!r} is not allowed; allowed: {SKYFIELD_DATA}FILE_NAME "
                f"or a file under params/data/",
                key="ephemeris.planetary_spk",
            )
    else:
        data_path(spk, "ephemeris.planetary_spk")


def _check_sampling(profile: dict) -> None:
    """The arc is longer than one sampling step, so it holds at least 3 epochs (t0, t0 + step, ..., end),
    the fewest the DOP statistics and the GVE Delta-V take."""
    days, step_s = profile["epoch"]["duration_days"], profile["epoch"]["step_s"]
    if not days * SECONDS_PER_DAY > step_s * (1.0 + 1e-9):
        raise ConfigError(
            f"epoch.duration_days = {days!r} ({days * SECONDS_PER_DAY:g} s) is not longer than epoch.step_s = "
            f"{step_s!r} s; allowed: an arc of more than one step (at least 3 epochs): lengthen "
            f"epoch.duration_days or shorten epoch.step_s",
            key="epoch.duration_days",
        )


def _check_grid(profile: dict) -> None:
    """The DOP surface grid holds at most :data:`MAX_GRID_POINTS` points (a step of 1e-9 deg asked for 224 GiB)."""
    dop = profile["dop"]
    n_lat = math.floor((dop["lat_max_deg"] - dop["lat_min_deg"]) / dop["lat_step_deg"]) + 1
    n_lon = math.floor((dop["lon_max_deg"] - dop["lon_min_deg"]) / dop["lon_step_deg"]) + 1
    if n_lat * n_lon > MAX_GRID_POINTS:
        raise ConfigError(
            f"dop.lat_step_deg = {dop['lat_step_deg']!r}, dop.lon_step_deg = {dop['lon_step_deg']!r}: a "
            f"grid of {n_lat:,} x {n_lon:,} points; allowed: at most {MAX_GRID_POINTS:,} points (a "
            f"whole-Moon 1-degree grid is 65,160; the DOP arrays hold epochs x points x satellites)",
            key="dop.lat_step_deg",
        )


def with_absent_sections(profile: dict) -> dict:
    """``profile`` (changed in place) with every section of :data:`OFF_WHEN_ABSENT` it lacks taken from paper.toml
    and every key of :data:`KEYS_OFF_WHEN_ABSENT` its sections lack set off."""
    for section in OFF_WHEN_ABSENT:
        profile.setdefault(section, copy.deepcopy(_reference()[section]))
    for (section, key), off in KEYS_OFF_WHEN_ABSENT.items():
        if isinstance(profile.get(section), dict):
            profile[section].setdefault(key, off)
    return profile


def profile_hash(profile: dict) -> str:
    """SHA-256 (16 hex digits) of a profile's canonical JSON in :func:`legacy_spelling`, excluding its name and
    description, a :data:`OFF_WHEN_ABSENT` section that is off and a :data:`KEYS_OFF_WHEN_ABSENT` key at its off
    value."""
    content = legacy_spelling(profile)
    content.get("profile", {}).pop("name", None)
    content.get("profile", {}).pop("description", None)
    for section, off in OFF_WHEN_ABSENT.items():
        if section in content and off(content):
            content.pop(section)
    for (section, key), off in KEYS_OFF_WHEN_ABSENT.items():
        if content.get(section, {}).get(key, off) == off:
            content.get(section, {}).pop(key, None)
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]
