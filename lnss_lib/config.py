"""Run profiles: TOML files in ``params/`` merged along their ``inherits`` chain.

A profile is a plain nested ``dict``; :func:`load_profile` returns it with the chain resolved and
``profile.name`` set. :func:`profile_hash` fingerprints everything that can change a result, so
caches and manifests can tell runs apart. Data paths in a profile are relative to ``params/``.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import math
import json
import platform
import tomllib
from importlib import metadata
from functools import lru_cache
from pathlib import Path

from .errors import ConfigError

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent
PARAMS_DIR = PROJECT_DIR / "params"
OUTPUTS_DIR = PROJECT_DIR / "outputs"


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


def _read_toml(path: Path) -> dict:
    """A TOML file as a dict; ConfigError naming the file and line of a syntax error."""
    try:
        with path.open("rb") as handle:
            return tomllib.load(handle)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: TOML syntax error: {error}", source=str(path)) from None


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
        except json.JSONDecodeError as error:
            raise ConfigError(f"overrides are not valid JSON ({error}): {overrides!r}") from None
    if overrides is not None and not isinstance(overrides, dict):
        raise ConfigError(f"overrides must be a nested dict of profile sections; got {overrides!r}")
    chain: list[dict] = []
    seen: set[str] = set()
    current: str | None = name
    while current is not None:
        path = PARAMS_DIR / f"{current}.toml"
        if not path.is_file():
            raise ConfigError(
                f"unknown profile {current!r}: expected {path}; available profiles: "
                f"{', '.join(available_profiles())}", source=str(path)
            )
        if current in seen:
            raise ConfigError(f"profile {name!r} has an inheritance cycle through {current!r}")
        seen.add(current)
        data = _read_toml(path)
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
    return profile


def _own_settings(name: str) -> dict:
    """The settings profile ``name``'s own file sets (not what it inherits), for ``[profile] also``."""
    path = PARAMS_DIR / f"{name}.toml"
    if not isinstance(name, str) or not path.is_file():
        raise ConfigError(f"[profile] also names unknown profile {name!r}; available profiles: "
                          f"{', '.join(available_profiles())}", key="profile.also")
    data = _read_toml(path)
    validate_profile(data, partial=True, source=path)
    return {section: table for section, table in data.items() if section != "profile"}


REFERENCE_PROFILE = "paper"          # its TOML fixes the keys and value types of every profile
FREE_TABLES = ("gps.launch_dates", "campaign.constraints", "campaign.hypervolume", "campaign.variables")
PROFILE_TABLE = {"name": "", "description": "", "inherits": "", "also": [""]}
ALLOW_INFINITE = ("gps.sidelobe_offset_db",)   # -inf = main lobe only
# Allowed ranges of physical settings: key -> (low, high, low open, high open); None = unbounded.
# integrator.settings.<any name> is "integrator.settings.*"; campaign.overrides.<section> uses the section's keys.
POSITIVE, NON_NEGATIVE = (0.0, None, True, False), (0.0, None, False, False)
RANGES = {
    "epoch.duration_days": POSITIVE, "epoch.step_s": POSITIVE,
    "spacecraft.mass_kg": POSITIVE, "spacecraft.area_m2": POSITIVE, "spacecraft.cr": POSITIVE,
    "gravity.degree": (0, 100, False, False), "gravity.gm_km3_s2": POSITIVE, "gravity.truncation_kms2": NON_NEGATIVE, "gravity.r_ref_km": POSITIVE,
    "forces.earth_albedo": (0.0, 1.0, False, False), "forces.solar_flux_w_m2": NON_NEGATIVE,
    "integrator.settings.*.rtol": POSITIVE, "integrator.settings.*.atol": POSITIVE,
    "ephemeris.table_step_s": POSITIVE, "impact.min_altitude_km": NON_NEGATIVE,
    "standalone_elfo.sma_km": POSITIVE, "standalone_elfo.ecc": (0.0, 1.0, False, True),
    "standalone_elfo.inc_deg": (0.0, 180.0, False, False), "standalone_elfo.sats_per_plane": (1, None, False, False),
    "notebooks.timeout_s": POSITIVE,
    "dop.lat_min_deg": (-90.0, 90.0, False, False), "dop.lat_max_deg": (-90.0, 90.0, False, False),
    "dop.lat_step_deg": POSITIVE, "dop.lon_min_deg": (-360.0, 360.0, False, False),
    "dop.lon_max_deg": (-360.0, 360.0, False, False), "dop.lon_step_deg": POSITIVE,
    "dop.elevation_mask_deg": (0.0, 90.0, False, False), "dop.availability_threshold": POSITIVE,
    "dop.filter_sigma": POSITIVE,
    "gps.frequency_mhz": POSITIVE, "gps.noise_temperature_k": POSITIVE, "gps.beam_mask_deg": (0.0, 180.0, True, False),
    "gps.atmosphere_margin_deg": NON_NEGATIVE, "gps.sidelobe_from_deg": (0.0, 180.0, False, False),
    "deltav.year_days": POSITIVE, "deltav.paper_divisor_floor": (0.0, 1.0, True, False),
    "deltav.paper_cap_kms2": POSITIVE, "deltav.secular_min_periods": POSITIVE, "deltav.slsqp_lambda": NON_NEGATIVE,
    "campaign.max_errors": (0, None, False, False),
    "stability.life_days": POSITIVE, "stability.average_days": POSITIVE, "stability.table_step_days": POSITIVE,
    "stability.rtol": POSITIVE, "stability.atol": POSITIVE, "stability.output_step_days": POSITIVE,
    "stability.margin_km": NON_NEGATIVE, "stability.validation_degree": (0, 100, False, False),
    "stability.validation_step_s": POSITIVE,
    "sk_estimate.year_days": POSITIVE, "sk_estimate.min_periods": POSITIVE,
    "sk_estimate.along_track_rebias_per_year": NON_NEGATIVE,
    "design_life.life_days": POSITIVE, "design_life.check_interval_days": POSITIVE,
    "design_life.samples_per_orbit": (2, None, False, False), "design_life.min_maneuver_spacing_days": NON_NEGATIVE,
    "design_life.dv_cap_kms_per_year": NON_NEGATIVE, "design_life.phasing_days": POSITIVE,
    "design_life.box_tolerance": NON_NEGATIVE,
}
for _name in ("ecc", "aop_deg", "inc_deg", "raan_rel_deg", "u_rel_deg"):
    RANGES[f"design_life.box.{_name}"] = POSITIVE
for _name in ("safety_check_days", "safety_lead_days", "nav_window_days", "raan_rel_deg", "u_rel_deg"):
    RANGES[f"design_life.service.{_name}"] = POSITIVE
for _name in ("perilune_margin_km", "nav_avail_drop_pct", "nav_dop_rise_fraction"):
    RANGES[f"design_life.service.{_name}"] = NON_NEGATIVE
CHOICES = {"design_life.controller": ("service", "box")}
"""String settings with a fixed set of allowed values."""
for _name in ("gm_sun_km3_s2", "gm_earth_km3_s2", "gm_jupiter_km3_s2", "r_moon_mean_km", "r_earth_km", "r_sun_km",
              "au_km", "c_km_s"):
    RANGES[f"constants.{_name}"] = POSITIVE


def allowed_range_text(spec: tuple) -> str:
    """``(0, inf)``-style text of a range of :data:`RANGES`."""
    low, high, low_open, high_open = spec
    left = "(-inf" if low is None else f"{'(' if low_open else '['}{low:g}"
    right = "inf)" if high is None else f"{high:g}{')' if high_open else ']'}"
    return f"{left}, {right}"


def in_range(value: float, spec: tuple) -> bool:
    low, high, low_open, high_open = spec
    return ((low is None or (value > low if low_open else value >= low))
            and (high is None or (value < high if high_open else value <= high)))


@lru_cache(maxsize=1)
def _reference() -> dict:
    reference = _read_toml(PARAMS_DIR / f"{REFERENCE_PROFILE}.toml")
    reference["profile"] = dict(PROFILE_TABLE)
    return reference


def _kind(value) -> str:
    if isinstance(value, bool):
        return "a boolean (true or false)"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a table"
    return type(value).__name__


def _type_ok(value, ref) -> bool:
    if isinstance(ref, bool) or isinstance(value, bool):
        return isinstance(ref, bool) and isinstance(value, bool)
    if isinstance(ref, int):
        return isinstance(value, int)
    if isinstance(ref, float):
        return isinstance(value, (int, float))
    return isinstance(value, type(ref))


def _line_of(source, key: str) -> str:
    """", line N" of ``key``'s last component in a TOML file (for messages), or ""."""
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


def _check_number(key: str, rule_key: str, value, source) -> None:
    if rule_key in CHOICES and value not in CHOICES[rule_key]:
        _fail(f"{key} = {value!r} is not allowed; allowed: {', '.join(map(repr, CHOICES[rule_key]))}", key, source)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    if not math.isfinite(value) and not (rule_key in ALLOW_INFINITE and not math.isnan(value)):
        _fail(f"{key} = {value!r} is not finite; allowed: a finite number"
              + (f" in {allowed_range_text(RANGES[rule_key])}" if rule_key in RANGES else ""), key, source)
    spec = RANGES.get(rule_key)
    if spec is not None and math.isfinite(value) and not in_range(value, spec):
        _fail(f"{key} = {value!r} is out of range; allowed: {allowed_range_text(spec)}", key, source)


def _walk(data: dict, ref: dict, prefix: str, rule_prefix: str, partial: bool, source) -> None:
    for name, value in data.items():
        key, rule_key = f"{prefix}{name}", f"{rule_prefix}{name}"
        if rule_prefix == "integrator.settings.":          # a setting of any name, shaped like the reference's
            ref_value, rule_key = ref.get(name, next(iter(ref.values()))), "integrator.settings.*"
        elif rule_prefix == "campaign.overrides.":          # profile sections changed for campaign evaluations
            ref_value, rule_key = _reference().get(name), name
            if name in ("campaign", "profile") or ref_value is None:
                _fail(f"unknown key {key}: campaign.overrides holds profile sections other than campaign; known: "
                      f"{', '.join(k for k in _reference() if k not in ('campaign', 'profile'))}", key, source)
        elif name not in ref:
            known = [f"{prefix}{k}" for k in ref]
            near = difflib.get_close_matches(key, known, n=3, cutoff=0.6)
            _fail(f"unknown key {key}; " + (f"did you mean {' or '.join(near)}?" if near else
                                              f"known keys here: {', '.join(known)}"), key, source)
        else:
            ref_value = ref[name]
        if not _type_ok(value, ref_value):
            _fail(f"{key} = {value!r} has the wrong type: expected {_kind(ref_value)} (as in params/"
                  f"{REFERENCE_PROFILE}.toml), got {_kind(value)}", key, source)
        if isinstance(value, dict):
            if rule_key in FREE_TABLES:
                _check_free(key, value, source)
            else:
                _walk(value, ref_value, f"{key}.", f"{rule_key}.", True, source)
        elif isinstance(value, list):
            _check_free(key, value, source)
        else:
            _check_number(key, rule_key, value, source)
    if not partial:
        missing = [f"{prefix}{k}" for k in ref if k not in data and f"{prefix}{k}" not in ("profile.inherits", "profile.also")]
        if missing:
            _fail(f"missing key(s) {', '.join(missing)} (every profile has the keys of params/{REFERENCE_PROFILE}.toml; "
                  f"inherit it with [profile] inherits = \"{REFERENCE_PROFILE}\")", missing[0], source)


def _check_free(key: str, value, source) -> None:
    """Numbers anywhere inside a free-form table or list must be finite."""
    items = value.items() if isinstance(value, dict) else enumerate(value)
    for name, item in items:
        if isinstance(item, (dict, list)):
            _check_free(f"{key}.{name}" if isinstance(value, dict) else f"{key}[{name}]", item, source)
        elif isinstance(item, float) and not math.isfinite(item):
            inner = f"{key}.{name}" if isinstance(value, dict) else f"{key}[{name}]"
            _fail(f"{inner} = {item!r} is not finite; allowed: a finite number", inner, source)


def validate_profile(profile: dict, *, partial: bool = False, source=None) -> None:
    """Check a profile (or, with ``partial``, a fragment: one TOML file, overrides) before any work.

    Keys and value types follow ``params/paper.toml`` (integers where it has integers; floats accept
    integers); numbers are finite and inside :data:`RANGES`; ``integrator.setting`` names one of
    ``integrator.settings``. Tables in :data:`FREE_TABLES` take any keys (their numbers must be
    finite; the campaign settings check their content). Raises :class:`ConfigError` naming the key,
    the value and what is allowed (with the file and line when ``source`` is a path).
    """
    if not isinstance(profile, dict):
        raise ConfigError(f"a profile is a table of sections; got {profile!r}")
    _walk(profile, _reference(), "", "", partial, source)
    integ = profile.get("integrator", {})
    if not partial and integ.get("setting") not in integ.get("settings", {}):
        _fail(f"integrator.setting = {integ.get('setting')!r} names no [integrator.settings.*]; allowed: "
              f"{', '.join(integ.get('settings', {}))}", "integrator.setting", source)


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
        except tomllib.TOMLDecodeError as error:
            if literal.strip() and literal.strip().replace("_", "").replace("-", "").isalnum() \
                    and not literal.strip()[0].isdigit() and literal.strip().lower() not in ("nan", "inf"):
                value = literal.strip()
            else:
                raise ConfigError(f"--set {item!r}: VALUE is not a TOML literal ({error})", key=path) from None
        nested: dict = value
        for part in reversed(parts):
            nested = {part: nested}
        overrides = deep_merge(overrides, nested)
    return overrides


def data_path(relative: str) -> Path:
    """Absolute path of a data file named relative to ``params/``."""
    return PARAMS_DIR / relative


def profile_hash(profile: dict) -> str:
    """SHA-256 (16 hex digits) of a profile's canonical JSON, excluding its name and description."""
    content = copy.deepcopy(profile)
    content.get("profile", {}).pop("name", None)
    content.get("profile", {}).pop("description", None)
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def integrator_setting(profile: dict, setting: str | None = None) -> dict:
    """The integrator settings (method, rtol, atol) named ``setting`` (default: the profile's)."""
    settings = profile["integrator"]["settings"]
    name = setting or profile["integrator"]["setting"]
    if name not in settings:
        raise ValueError(f"unknown integrator setting {name!r}; available: {', '.join(settings)}")
    return {"name": name, **settings[name]}



MANIFEST_PACKAGES = ("numpy", "scipy", "spiceypy", "sgp4", "numba", "xarray", "pymoo", "plotly", "dask",
                     "distributed", "papermill", "skyfield-data", "h5netcdf", "pandas")


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
    versions = {"python": platform.python_version()}
    for name in MANIFEST_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions
