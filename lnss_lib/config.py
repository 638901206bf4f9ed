"""Run profiles: TOML files in ``params/`` merged along their ``inherits`` chain, and every rule they obey.

:func:`load_profile` returns the merged TOML as a plain nested ``dict`` with the chain resolved and
``profile.name`` set, checked by :func:`validate_profile` against the sections of
:mod:`lnss_lib.sections`, where each setting is declared once with its type and rule (range and reason,
allowed values, form), and against the rules across keys (:mod:`lnss_lib.profile_rules`); the workbook reads it once, to freeze it into
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
import hashlib
import json
import math
import os
import re
import sys
import tomllib
from functools import lru_cache
from pathlib import Path
from typing import Any

from .constants import MAX_GRID_POINTS, SECONDS_PER_DAY
from .dates import ISO_DATE_FORMAT, ISO_FORMAT, is_iso_date
from .errors import ConfigError
from .legacy_keys import KEYS_OFF_WHEN_ABSENT, LEGACY_KEYS, OFF_WHEN_ABSENT, legacy_spelling
from .profile_rules import (
    PROFILE_SCHEMA,
    check_across,
    check_campaign,
    check_integer_size,
    check_number,
    entry_class,
    expected_kind,
    fail,
    kind_of,
    lookup,
    schema_fields,
    type_ok,
)
from .setting_rule import Rule

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


def unreadable_reason(error: Exception) -> str:
    """Why a JSON or TOML text could not be read, in the text's terms: nested too deep, a JSON syntax error's line
    and column, a byte that is not UTF-8, a number past Python's digit limit (not the interpreter's advice to
    raise that limit), else the parser's message."""
    if isinstance(error, RecursionError):
        return "nested too deep"
    if isinstance(error, json.JSONDecodeError):
        return f"line {error.lineno}, column {error.colno}: {error.msg}"
    if isinstance(error, UnicodeDecodeError):
        return f"byte {error.start} is not UTF-8 text"
    if "integer string conversion" in str(error):
        return f"a number of more than {sys.get_int_max_str_digits()} digits"
    return str(error)


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
                f"overrides are not JSON the workbook reads ({unreadable_reason(error)})"
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


@lru_cache(maxsize=1)
def _reference() -> dict:
    """params/paper.toml's values (a section a stored profile lacks is read from them)."""
    return read_toml(PARAMS_DIR / f"{REFERENCE_PROFILE}.toml")


def _check_text(key: str, rule: Rule, value, source) -> None:
    """A text setting (or a list of them) against its rule's choices or form."""
    for item in value if isinstance(value, list) else [value]:
        if rule.choices is not None and item not in rule.choices:
            fail(
                f"{key} = {item!r} is not allowed; allowed: {', '.join(map(repr, rule.choices))}",
                key,
                source,
            )
        if rule.form is not None and not (isinstance(item, str) and FORMS[rule.form][0](item)):
            allowed = FORMS[rule.form][1]
            fail(
                f"{key} = {item!r} is not allowed; allowed: {allowed() if callable(allowed) else allowed}",
                key,
                source,
            )


def _unknown(key: str, known: list[str], source) -> None:
    """Refuse an unknown ``key``, naming the key that holds its quantity now or the nearest known keys."""
    if key in LEGACY_KEYS:
        fail(f"unknown key {key}: its quantity has one key, {LEGACY_KEYS[key]}", key, source)
    near = difflib.get_close_matches(key, known, n=3, cutoff=0.6)
    fail(
        f"unknown key {key}; "
        + (
            f"did you mean {' or '.join(near)}?" if near else f"known keys here: {', '.join(known)}"
        ),
        key,
        source,
    )


def _walk(data: dict, cls, prefix: str, partial: bool, source) -> None:
    """Check the table ``data`` at ``prefix`` against the section class ``cls``: keys, types, rules."""
    fields = schema_fields(cls)
    for name, value in data.items():
        key = f"{prefix}{name}"
        if name not in fields:
            _unknown(key, [f"{prefix}{k}" for k in fields], source)
        hint, rule = fields[name]
        if not type_ok(value, hint):
            fail(
                f"{key} = {value!r} has the wrong type: expected {expected_kind(hint)}, got {kind_of(value)}",
                key,
                source,
            )
        if rule.sections:  # profile sections changed for campaign evaluations
            _walk_sections(key, value, source)
        elif isinstance(value, dict) and (
            rule.free
            or hint is Any
            or entry_class(hint) is None
            and not dataclasses.is_dataclass(hint)
        ):
            _check_free(key, value, source)
        elif isinstance(value, dict):
            for entry, table in value.items() if entry_class(hint) else [(None, value)]:
                inner = key if entry is None else f"{key}.{entry}"
                if not isinstance(table, dict):
                    fail(
                        f"{inner} = {table!r} has the wrong type: expected a table, got {kind_of(table)}",
                        inner,
                        source,
                    )
                _walk(table, entry_class(hint) or hint, f"{inner}.", True, source)
        elif isinstance(value, list):
            _check_free(key, value, source)
            _check_text(key, rule, value, source)
            if rule.non_empty and not value:
                fail(
                    f"{key} = [] is not allowed; allowed: a list of at least one entry", key, source
                )
            for index, item in enumerate(value if rule.range else []):
                check_number(f"{key}[{index}]", rule, item, source)
        elif isinstance(value, str):
            _check_text(key, rule, value, source)
        else:
            check_number(key, rule, value, source)
    if not partial:
        missing = [
            f"{prefix}{k}"
            for k, item in ((f.name, f) for f in dataclasses.fields(cls))
            if k in fields and k not in data and item.default is dataclasses.MISSING
        ]
        if missing:
            fail(
                f"missing key(s) {', '.join(missing)} (every profile has the keys of params/{REFERENCE_PROFILE}.toml; "
                f'inherit it with [profile] inherits = "{REFERENCE_PROFILE}")',
                missing[0],
                source,
            )


def _walk_sections(key: str, sections: dict, source) -> None:
    """``campaign.overrides``: a table of profile sections other than campaign and profile, each checked as its own."""
    known = {
        name: hint
        for name, (hint, _) in schema_fields(PROFILE_SCHEMA).items()
        if name not in ("campaign", "profile")
    }
    for name, table in sections.items():
        if name not in known:
            fail(
                f"unknown key {key}.{name}: campaign.overrides holds profile sections other than campaign; known: "
                f"{', '.join(known)}",
                f"{key}.{name}",
                source,
            )
        if not isinstance(table, dict):
            fail(
                f"{key}.{name} = {table!r} has the wrong type: expected a table, got {kind_of(table)}",
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
            check_integer_size(inner, item, source)
            if isinstance(item, float) and not math.isfinite(item):
                fail(f"{inner} = {item!r} is not finite; allowed: a finite number", inner, source)


def validate_profile(profile: dict, *, partial: bool = False, source=None) -> None:
    """Check a profile (or, with ``partial``, a fragment: one TOML file, overrides) before any work.

    Keys and value types are the fields of :data:`PROFILE_SCHEMA` (a float field takes an integer);
    numbers are finite and inside their field's range; texts are among its choices or of its form;
    ``integrator.setting`` names one of ``integrator.settings``. A free table takes any keys (its
    numbers must be finite; :func:`check_campaign` checks the campaign's). Raises :class:`ConfigError` naming the key,
    the value and what is allowed (with the file and line when ``source`` is a path).
    """
    if not isinstance(profile, dict):
        raise ConfigError(f"a profile is a table of sections; got {profile!r}")
    _walk(profile, PROFILE_SCHEMA, "", partial, source)
    check_across(profile, source)
    if not partial:
        check_campaign(profile, source)
    overrides = lookup(profile, "campaign.overrides")
    if overrides:  # the profile campaign evaluations use
        check_across(deep_merge(profile, overrides), source)


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
                    f"--set {shown!r}: VALUE is not a TOML literal ({unreadable_reason(error)})",
                    key=path,
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
        value = lookup(profile, key)
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
