"""Run profiles: TOML files in ``params/`` merged along their ``inherits`` chain, and every rule they obey.

:func:`load_profile` returns the merged TOML as a plain nested ``dict`` with the chain resolved and
``profile.name`` set, checked by :func:`validate_profile` against the one table of each kind of rule
(:data:`RANGES` with :data:`WHY`, :data:`CHOICES`, :data:`FORMS`, the rules across keys); the workbook
reads it once, to freeze it into typed sections (:mod:`lnss_lib.settings`). :func:`profile_hash`
fingerprints everything that can change a result, so caches and manifests can tell runs apart. Profiles are names of files in ``params/`` (or a file
made loadable by :func:`use_profile_file`); data paths in a profile are relative to ``params/`` and
must lie under ``params/data/``.
"""

from __future__ import annotations

import copy
import datetime as dt
import difflib
import hashlib
import math
import json
import os
import re
import tomllib
from functools import lru_cache
from pathlib import Path

from .constants import (CR_AREA_MASS_MAX_M2_KG, CR_MAX, INTEGER_SETTING_MAX, MAX_GRID_POINTS, MAX_POPULATION,
                        MOON_HILL_RADIUS_KM, SECONDS_PER_DAY, SPACECRAFT_MASS_RANGE_KG, TOLERANCE_CEILING,
                        TOLERANCE_FLOOR, WGS84_A_KM)
from .errors import ConfigError
from .keys import (DELTAV_SATELLITES, DESIGN_KEYS, EXTRA_METRIC_KEYS, GNSS_NAMES, INTEGER_DESIGN_KEYS,
                   LIFE_NAVIGATION_KEYS, METRIC_KEYS, NAVIGATION_ERROR_KEYS, NEEDS_ALL_SATELLITES)

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent
PARAMS_DIR = PROJECT_DIR / "params"
OUTPUTS_DIR = PROJECT_DIR / "outputs"
REFERENCE_DIR = OUTPUTS_DIR / "reference"     # shipped results, one folder per profile (lnss_lib.campaign.reference)
RESERVED_PROFILE_NAMES = (REFERENCE_DIR.name,)  # outputs/<name>/ is not a profile's: no profile may take the name


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
        raise ConfigError(f"{path}: not a TOML text file (byte {error.start} is not UTF-8 text)",
                          source=str(path)) from None
    except tomllib.TOMLDecodeError as error:
        where = re.search(r"\(at line (\d+), column \d+\)", str(error))
        line = f", line {where.group(1)}" if where else ""
        raise ConfigError(f"{path}{line}: TOML syntax error", source=str(path)) from None
    except (ValueError, RecursionError) as error:       # an integer of more than 4300 digits, arrays nested too deep
        raise ConfigError(f"{path}: not a TOML file the workbook reads ({type(error).__name__}: a number too long or "
                          f"nesting too deep)", source=str(path)) from None


PROFILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
PROFILE_FILES_ENV = "LNSS_PROFILE_FILES"   # {name: path} of use_profile_file, inherited by kernels and workers


def _profile_file_problem(name, path) -> str | None:
    """Why ``name`` -> ``path`` cannot be a profile file (:func:`use_profile_file`'s rules), or None."""
    if not isinstance(name, str) or not PROFILE_NAME.fullmatch(name):
        return (f"the name {name!r} is not allowed as a profile name; allowed: letters, digits, '_' and '-' (at most "
                f"64, first a letter or digit)")
    if name in RESERVED_PROFILE_NAMES:
        return f"the name {name!r} is reserved (outputs/{name}/ holds the shipped results of every profile)"
    if name in available_profiles():
        return (f"params/{name}.toml already has the name {name!r}; rename the file (profiles in params/: "
                f"{', '.join(available_profiles())})")
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
        raise ConfigError(f"environment variable {PROFILE_FILES_ENV} is not a JSON table of profile files",
                          key=PROFILE_FILES_ENV)
    for name, path in files.items():
        problem = _profile_file_problem(name, path)
        if problem:
            raise ConfigError(f"environment variable {PROFILE_FILES_ENV}: {problem}; unset it (it is set by "
                              f"--profile-file for the processes the workbook starts)", key=PROFILE_FILES_ENV)
    return files


def use_profile_file(path) -> str:
    """Make the TOML file ``path`` loadable as profile ``<stem>`` (outputs in ``outputs/<stem>/``) by this
    process and the processes it starts (notebook kernels, local workers); returns the name.

    The stem must be a profile name (letters, digits, ``_``, ``-``) that no file in ``params/`` has and that is not
    reserved (:data:`RESERVED_PROFILE_NAMES`).
    """
    path = Path(path)
    if path.suffix != ".toml" or not path.is_file():
        raise ConfigError(f"--profile-file {path}: need an existing regular file ending in .toml", key="--profile-file")
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
    path = PARAMS_DIR / f"{name}.toml" if isinstance(name, str) and PROFILE_NAME.fullmatch(name) else None
    if path is None or not path.is_file():
        raise ConfigError(f"{key}: unknown profile {name!r}; allowed: {', '.join(available_profiles() + sorted(files))} "
                          f"(names of params/*.toml; a file elsewhere: --profile-file PATH)", key=key)
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
        except (ValueError, RecursionError) as error:    # JSONDecodeError, a 5000-digit integer, deep nesting
            raise ConfigError(f"overrides are not JSON the workbook reads ({type(error).__name__}: "
                              f"{str(error)[:120]})") from None
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


REFERENCE_PROFILE = "paper"          # its TOML fixes the keys and value types of every profile
FREE_TABLES = ("gps.launch_dates", "campaign.constraints", "campaign.hypervolume", "campaign.variables")
PROFILE_TABLE = {"name": "", "description": "", "inherits": "", "also": [""]}
ALLOW_INFINITE = ("gps.sidelobe_offset_db",)   # -inf = main lobe only
NON_EMPTY = ("benchmark.epochs_tdb", "navigation_error.station_lat_deg", "gnss.systems")   # lists that need an entry
# Allowed ranges of physical settings: key -> (low, high, low open, high open); None = unbounded.
# integrator.settings.<any name> is "integrator.settings.*"; campaign.overrides.<section> uses the section's keys.
POSITIVE, NON_NEGATIVE = (0.0, None, True, False), (0.0, None, False, False)
TOLERANCE = (TOLERANCE_FLOOR, TOLERANCE_CEILING, False, False)
SEMI_MAJOR_AXIS = (0.0, MOON_HILL_RADIUS_KM, True, False)
CR_AREA_MASS = (0.0, CR_AREA_MASS_MAX_M2_KG, False, False)
CR_AREA_MASS_WHY = "solar sails reach ~10-50 m^2/kg"
SEMI_MAJOR_AXIS_WHY = f"a must be within the Moon's Hill sphere ({MOON_HILL_RADIUS_KM:,.0f} km) for a bound lunar orbit"
RANGES = {
    "epoch.duration_days": POSITIVE, "epoch.step_s": POSITIVE,
    "spacecraft.mass_kg": (*SPACECRAFT_MASS_RANGE_KG, False, False), "spacecraft.area_m2": POSITIVE,
    "spacecraft.cr": (0.0, CR_MAX, True, False),
    "gravity.degree": (0, 100, False, False), "gravity.gm_km3_s2": POSITIVE, "gravity.truncation_kms2": NON_NEGATIVE, "gravity.r_ref_km": POSITIVE,
    "forces.earth_albedo": (0.0, 1.0, False, False), "forces.solar_flux_w_m2": NON_NEGATIVE,
    "integrator.settings.*.rtol": TOLERANCE, "integrator.settings.*.atol": TOLERANCE,
    "ephemeris.table_step_s": POSITIVE, "impact.min_altitude_km": NON_NEGATIVE,
    "standalone_elfo.sma_km": SEMI_MAJOR_AXIS, "standalone_elfo.ecc": (0.0, 1.0, False, True),
    "standalone_elfo.inc_deg": (0.0, 180.0, False, False), "standalone_elfo.sats_per_plane": (1, None, False, False),
    "notebooks.timeout_s": POSITIVE,
    "dop.lat_min_deg": (-90.0, 90.0, False, False), "dop.lat_max_deg": (-90.0, 90.0, False, False),
    "dop.lat_step_deg": POSITIVE, "dop.lon_min_deg": (-360.0, 360.0, False, False),
    "dop.lon_max_deg": (-360.0, 360.0, False, False), "dop.lon_step_deg": POSITIVE,
    "dop.elevation_mask_deg": (0.0, 90.0, False, False), "dop.availability_threshold": POSITIVE,
    "dop.filter_sigma": POSITIVE,
    "gps.frequency_mhz": POSITIVE, "gps.noise_temperature_k": POSITIVE, "gps.beam_mask_deg": (0.0, 180.0, True, False),
    "gps.atmosphere_margin_deg": NON_NEGATIVE, "gps.sidelobe_from_deg": (0.0, 180.0, False, False),
    "gnss.gps.sma_km": (WGS84_A_KM, None, True, False), "gnss.gps.edge_elevation_deg": (0.0, 90.0, False, True),
    "deltav.year_days": POSITIVE, "deltav.paper_divisor_floor": (0.0, 1.0, False, True),
    "deltav.paper_cap_kms2": POSITIVE, "deltav.secular_min_periods": (1.0, None, True, False),
    "deltav.slsqp_lambda": NON_NEGATIVE,
    "campaign.max_errors": (0, None, False, False), "campaign.population": (2, MAX_POPULATION, False, False),
    "campaign.generations": (1, None, False, False), "campaign.crossover_prob": (0.0, 1.0, False, False),
    "campaign.crossover_eta": NON_NEGATIVE, "campaign.mutation_eta": NON_NEGATIVE,
    "campaign.mutation_prob_var": (0.0, 1.0, False, False), "campaign.seed": (0, None, False, False),
    "campaign.ftol": NON_NEGATIVE, "campaign.ftol_period": (1, None, False, False), "campaign.n_sat": (0, None, False, False),
    "campaign.nan_objective": NON_NEGATIVE, "campaign.nan_violation": NON_NEGATIVE,
    "campaign.synthetic_delay_s": NON_NEGATIVE, "campaign.max_resubmits": (0, None, False, False),
    "campaign.numba_threads_per_worker": (0, None, False, False),
    "stability.life_days": POSITIVE, "stability.average_days": POSITIVE, "stability.table_step_days": POSITIVE,
    "stability.rtol": TOLERANCE, "stability.atol": TOLERANCE, "stability.output_step_days": POSITIVE,
    "stability.margin_km": NON_NEGATIVE, "stability.validation_degree": (0, 100, False, False),
    "stability.validation_step_s": POSITIVE, "stability.step_days": POSITIVE,
    "stability.validity_period_fraction": POSITIVE, "stability.validity_ecc": NON_NEGATIVE,
    "sk_estimate.year_days": POSITIVE, "sk_estimate.min_periods": POSITIVE,
    "sk_estimate.along_track_rebias_per_year": NON_NEGATIVE,
    "design_life.life_days": POSITIVE, "design_life.check_interval_days": POSITIVE,
    "design_life.samples_per_orbit": (16, None, False, False), "design_life.min_maneuver_spacing_days": NON_NEGATIVE,
    "design_life.dv_cap_kms_per_year": NON_NEGATIVE, "design_life.box_tolerance": NON_NEGATIVE,
    "benchmark.extra_masks_deg": (0.0, 90.0, False, True),      # each entry of the list
    "navigation_error.sise_at_upload_m": NON_NEGATIVE, "navigation_error.sise_growth_m": NON_NEGATIVE,
    "navigation_error.sise_growth_age_h": POSITIVE, "navigation_error.receiver_noise_m": NON_NEGATIVE,
    "navigation_error.lunar_multipath_zenith_m": NON_NEGATIVE,
    "navigation_error.station_lat_deg": (-90.0, 90.0, False, False),     # each entry
    "navigation_error.station_lon_deg": (-360.0, 360.0, False, False),   # each entry
    "navigation_error.station_mask_deg": (0.0, 90.0, False, True),
    "navigation_error.requirement_horizontal_95_m": POSITIVE, "navigation_error.requirement_vertical_95_m": NON_NEGATIVE,
    "design_life.slot_coast_days": POSITIVE,
    "design_life.slot_fit_days": POSITIVE, "design_life.slot_quad_days": POSITIVE,
    "design_life.tide_period_days": POSITIVE, "design_life.target_fraction": (0.0, 1.0, False, True),
    "life_evaluation.sample_step_s": POSITIVE, "life_evaluation.month_days": POSITIVE,
    "life_evaluation.screen_validation_designs": (0, None, False, False),
    "life_evaluation.screen_validation_life_days": NON_NEGATIVE,
    "life_navigation.designs": (0, None, False, False), "life_navigation.life_days": NON_NEGATIVE,
    "robustness.draws": (0, 10_000, False, False), "robustness.life_days": (1.0, 36525.0, False, False),
    "robustness.seed": (0, 2**63 - 1, False, False), "robustness.sma_km": NON_NEGATIVE, "robustness.ecc": (0.0, 0.1, False, False),
    "robustness.inc_deg": (0.0, 10.0, False, False), "robustness.raan_deg": (0.0, 10.0, False, False),
    "robustness.aop_deg": (0.0, 180.0, False, False), "robustness.anomaly_deg": (0.0, 180.0, False, False),
    "life_evaluation.frame_rerun_designs": (0, None, False, False),
    "front_validation.max_designs": (0, None, False, False), "front_validation.max_sats_per_plane": (0, None, False, False),
    "front_validation.headline_sizes": (1, None, False, False), "front_validation.headline_per_size": (0, None, False, False),
    "front_validation.availability_min_pct": (0.0, 100.0, False, False), "front_validation.dv_max_kms_per_year": POSITIVE,
}
_TOLERANCE_WHY = (f"below about 100 machine epsilons ({TOLERANCE_FLOOR:g}) an integrator's error test asks for what "
                  f"double precision cannot resolve; above {TOLERANCE_CEILING:g} (SciPy's default rtol) it no longer "
                  f"resolves a lunar orbit")
WHY = {   # the physical or numerical reason of a range, quoted in the message
    "integrator.settings.*.rtol": _TOLERANCE_WHY, "integrator.settings.*.atol": _TOLERANCE_WHY,
    "stability.rtol": _TOLERANCE_WHY, "stability.atol": _TOLERANCE_WHY,
    "spacecraft.mass_kg": "from a gram (chip-scale satellites) to 1000 t",
    "spacecraft.cr": "Cr = 1 + specular reflectivity: 2 is a perfect mirror",
    "standalone_elfo.sma_km": SEMI_MAJOR_AXIS_WHY,
    "deltav.paper_divisor_floor": "a floor of 0 is the paper's literal divisors (notebook 04's sweep); 1 or more "
                                  "would replace every divisor",
    "deltav.secular_min_periods": "the secular trend needs at least two one-orbit windows",
    "design_life.samples_per_orbit": "the one-orbit mean elements of the checks and the insertion trim average "
                                     "this many samples of an orbit (at least 8 to be computed at all, 16 for an "
                                     "e = 0.6 orbit's mean a to settle)",
    "design_life.target_fraction": "a correction aims this fraction of the half-width past the reference: "
                                   "1 would aim at the far edge of the box",
    "campaign.population": f"NSGA-II ranks parents and offspring through a 2N x 2N domination matrix, "
                           f"{(2 * MAX_POPULATION) ** 2 * 8 / 1e9:.1f} GB at N = {MAX_POPULATION}",
}

# Allowed values of the text settings (one copy: the modules that read a setting import its tuple from here).
METHODS = ("RK45", "DOP853")                      # propagator: Dormand-Prince 5(4) and 8(5,3)
ELEMENT_FRAMES = ("lunar_equator_of_epoch", "j2000", "moon_op")
POLE_FRAMES = ("MOON_ME", "MOON_PA", "IAU_MOON")
THIRD_BODIES = ("SUN", "EARTH", "JUPITER")        # also the rows of the ephemeris table
SHADOW_MODELS = ("conical", "none")
LOS_AXES = ("moon_fixed", "enu")
AREA_WEIGHTINGS = ("none", "cos_lat", "cell_area")
PDOP_FILTERS = ("percentile95", "sigma2", "none")
DELTAV_MODELS = ("paper", "lsq", "secular")
LSQ_RATES = ("vectors", "elements")
PAPER_NORMAL = ("weighted", "eq32", "rss")
PAPER_RADIAL = ("weighted", "eq35")
EVALUATORS = ("walker", "synthetic")
NOTEBOOK_MODES = ("run", "load")                  # notebook 06 runs the campaign itself, or loads the latest CLI run
STABILITY_METHODS = ("DOP853", "RK45", "Radau", "LSODA", "RK4")
STABILITY_BODIES = ("EARTH", "SUN")
SK_ESTIMATE_MODELS = ("arc", "life")             # campaign estimate: the 10-day box slope, or the service controller's life
CONTROLLERS = ("service", "box")                 # design life: hold the service (design_life.service) or the fixed-element box
SISE_LAWS = ("constant", "linear", "quadratic")   # signal-in-space error growth with the ephemeris age
GNSS_SYSTEMS = tuple(GNSS_NAMES)                 # [gnss] systems: GPS from TLEs, the others nominal slots
TOLERANCE_SOURCES = ("derived", "fixed")         # service controller: node/slot tolerances from each design's navigation, or as set
CHOICES = {    # a text setting (or each entry of a list of texts) -> its allowed values
    "integrator.settings.*.method": METHODS, "frames.element_frame": ELEMENT_FRAMES, "frames.moon_fixed": POLE_FRAMES,
    "frames.gravity": POLE_FRAMES, "forces.third_bodies": THIRD_BODIES, "forces.shadow": SHADOW_MODELS,
    "dop.los_axes": LOS_AXES, "dop.area_weighting": AREA_WEIGHTINGS, "gps.pdop_filter": PDOP_FILTERS,
    "deltav.model": DELTAV_MODELS, "deltav.element_frame": ELEMENT_FRAMES, "deltav.lsq_rates": LSQ_RATES,
    "deltav.paper_normal": PAPER_NORMAL, "deltav.paper_radial": PAPER_RADIAL, "deltav.satellites": DELTAV_SATELLITES,
    "campaign.evaluator": EVALUATORS, "campaign.notebook_mode": NOTEBOOK_MODES, "stability.method": STABILITY_METHODS,
    "stability.third_bodies": STABILITY_BODIES, "sk_estimate.element_frame": ELEMENT_FRAMES,
    "sk_estimate.model": SK_ESTIMATE_MODELS,
    "evaluator.extra_metrics": EXTRA_METRIC_KEYS, "design_life.controller": CONTROLLERS,
    "design_life.service.tolerances": TOLERANCE_SOURCES, "navigation_error.sise_law": SISE_LAWS,
    "life_evaluation.validation_frames": ELEMENT_FRAMES, "gnss.systems": GNSS_SYSTEMS,
}


ISO_DATE_FORMAT = "YYYY-MM-DD"
ISO_FORMAT = ("YYYY-MM-DDTHH:MM:SS (ISO 8601; seconds and a fraction .fff optional, a bare date YYYY-MM-DD is "
              "midnight; no zone such as Z or +05:00: the time scale is given apart)")
_ISO = re.compile(r"(\d{4})-(\d{2})-(\d{2})(?:T(\d{2}):(\d{2})(?::(\d{2})(?:\.(\d{1,9}))?)?)?")
_ZONE = re.compile(r"T.*(Z|[+-]\d{2}(:?\d{2})?)$")


def parse_iso_date(text, what: str = "date", *, date_only: bool = False) -> dt.datetime:
    """The one reader of calendar dates (``--epoch-tdb``, profile epochs, constellation files): ``text`` in the
    strict ISO 8601 form :data:`ISO_FORMAT` (:data:`ISO_DATE_FORMAT` with ``date_only``) as a naive datetime (the
    fraction beyond microseconds dropped). Anything else, a zone included (a time scale is never a zone), raises
    ConfigError naming ``what``, the text and the expected format: ``01-05-2025`` or ``1/5/2025`` are never read
    as some day."""
    expected = ISO_DATE_FORMAT if date_only else ISO_FORMAT
    match = _ISO.fullmatch(text) if isinstance(text, str) else None
    if match is None or (date_only and match.group(4) is not None):
        zone = isinstance(text, str) and not date_only and _ZONE.search(text) is not None
        raise ConfigError(f"{what} {text!r} is not " + ("a date with a zone, which is not allowed; expected "
                                                         if zone else "an ISO 8601 date; expected ") + expected)
    fields = [int(value) if value else 0 for value in match.groups()[:6]]
    fraction = match.group(7) or ""
    try:
        return dt.datetime(*fields, int((fraction + "000000")[:6]))
    except ValueError as error:
        raise ConfigError(f"{what} {text!r} is no calendar date and time ({error}); expected {expected}") from None


def _is_iso_date(text, date_only: bool = False) -> bool:
    try:
        parse_iso_date(text, date_only=date_only)
    except ConfigError:
        return False
    return True


ISO_TEXT = f"an ISO 8601 date and time, {ISO_FORMAT} (e.g. 2025-05-01T00:00:00)"
FORMS = {      # a text setting with an open set of values -> (test, what is allowed)
    "epoch.start_tdb": (_is_iso_date, ISO_TEXT), "validation.capstone.arc_break_tdb": (_is_iso_date, ISO_TEXT),
    "benchmark.epochs_tdb": (_is_iso_date, ISO_TEXT),
    "gps.exclude_launched_after": (lambda v: v in ("epoch", "none") or _is_iso_date(v, date_only=True),
                                   f"'epoch', 'none' or an ISO 8601 date {ISO_DATE_FORMAT} (e.g. 2025-05-30)"),
    "gps.exclude_launches_from": (lambda v: re.fullmatch(r"(\d{4}-\d{3}[A-Z]{0,3})?", v) is not None,
                                  '"" (off) or an international designator YYYY-NNN'),
    "campaign.companion_profile": (lambda v: v == "" or v in available_profiles(),
                                   '"" (none) or a profile name: ' + ", ".join(available_profiles())),
}
SETTING_NAMES = ("integrator.setting", "design_life.integrator_setting", "validation.capstone.integrator_setting")

for _name in ("ecc", "aop_deg", "inc_deg", "raan_rel_deg", "u_rel_deg"):
    RANGES[f"design_life.box.{_name}"] = POSITIVE
for _name in ("safety_check_days", "safety_lead_days", "nav_window_days", "raan_rel_deg", "u_rel_deg",
              "tolerance_arc_days", "tolerance_step_s"):
    RANGES[f"design_life.service.{_name}"] = POSITIVE
RANGES["design_life.service.raan_rel_bounds_deg"] = (0.0, 90.0, True, False)     # each entry: a tilt of the plane
RANGES["design_life.service.u_rel_bounds_deg"] = (0.0, 180.0, True, False)      # each entry: half a turn at most
BOUND_PAIRS = ("design_life.service.raan_rel_bounds_deg", "design_life.service.u_rel_bounds_deg")
for _name in ("perilune_margin_km", "nav_avail_drop_pct", "nav_dop_rise_fraction"):
    RANGES[f"design_life.service.{_name}"] = NON_NEGATIVE
for _name in GNSS_SYSTEMS[1:]:
    RANGES[f"gnss.{_name}.frequency_mhz"] = POSITIVE
    RANGES[f"gnss.{_name}.edge_elevation_deg"] = (0.0, 90.0, False, True)
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
    reference = read_toml(PARAMS_DIR / f"{REFERENCE_PROFILE}.toml")
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


def _check_integer_size(key: str, value, source) -> None:
    """An integer a float cannot hold or an output cannot store (|n| > :data:`INTEGER_SETTING_MAX`) is refused before
    anything compares it (``math.isfinite`` raised OverflowError; ``repr`` of 5000 digits raises ValueError)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > INTEGER_SETTING_MAX:
        digits = int(value.bit_length() * math.log10(2)) + 1       # one too many when |value| < 10**(digits - 1)
        digits -= abs(value) < 10 ** (digits - 1)
        _fail(f"{key} = an integer of {digits} digits is too large; allowed: at most 2**63 - 1 in magnitude "
              f"(the int64 of the NetCDF outputs)", key, source)


def _check_number(key: str, rule_key: str, value, source) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    _check_integer_size(key, value, source)
    if not math.isfinite(value) and not (rule_key in ALLOW_INFINITE and not math.isnan(value)):
        _fail(f"{key} = {value!r} is not finite; allowed: a finite number"
              + (f" in {allowed_range_text(RANGES[rule_key])}" if rule_key in RANGES else ""), key, source)
    spec = RANGES.get(rule_key)
    if spec is not None and math.isfinite(value) and not in_range(value, spec):
        why = f" ({WHY[rule_key]})" if rule_key in WHY else ""
        _fail(f"{key} = {value!r} is out of range; allowed: {allowed_range_text(spec)}{why}", key, source)


def _check_text(key: str, rule_key: str, value, source) -> None:
    """A text setting (or a list of them) against :data:`CHOICES` or :data:`FORMS`."""
    if rule_key not in CHOICES and rule_key not in FORMS:
        return
    for item in (value if isinstance(value, list) else [value]):
        if rule_key in CHOICES and item not in CHOICES[rule_key]:
            _fail(f"{key} = {item!r} is not allowed; allowed: {', '.join(map(repr, CHOICES[rule_key]))}", key, source)
        if rule_key in FORMS and not (isinstance(item, str) and FORMS[rule_key][0](item)):
            _fail(f"{key} = {item!r} is not allowed; allowed: {FORMS[rule_key][1]}", key, source)


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
            _check_text(key, rule_key, value, source)
            if rule_key in NON_EMPTY and not value:
                _fail(f"{key} = [] is not allowed; allowed: a list of at least one entry", key, source)
            for index, item in enumerate(value if rule_key in RANGES else []):
                _check_number(f"{key}[{index}]", rule_key, item, source)
        elif isinstance(value, str):
            _check_text(key, rule_key, value, source)
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
        elif isinstance(item, (int, float)):
            inner = f"{key}.{name}" if isinstance(value, dict) else f"{key}[{name}]"
            _check_integer_size(inner, item, source)
            if isinstance(item, float) and not math.isfinite(item):
                _fail(f"{inner} = {item!r} is not finite; allowed: a finite number", inner, source)


def validate_profile(profile: dict, *, partial: bool = False, source=None) -> None:
    """Check a profile (or, with ``partial``, a fragment: one TOML file, overrides) before any work.

    Keys and value types follow ``params/paper.toml`` (integers where it has integers; floats accept
    integers); numbers are finite and inside :data:`RANGES`; ``integrator.setting`` names one of
    ``integrator.settings``. Tables in :data:`FREE_TABLES` take any keys (their numbers must be
    finite; :func:`_check_campaign` checks the campaign's). Raises :class:`ConfigError` naming the key,
    the value and what is allowed (with the file and line when ``source`` is a path).
    """
    if not isinstance(profile, dict):
        raise ConfigError(f"a profile is a table of sections; got {profile!r}")
    _walk(profile, _reference(), "", "", partial, source)
    _check_across(profile, source)
    if not partial:
        _check_campaign(profile, source)
    overrides = _lookup(profile, "campaign.overrides")
    if overrides:                                   # the profile campaign evaluations use
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
    them need ``[deltav] satellites = "all"``, the life navigation metrics ``[sk_estimate] model = "life"``; Cr A/m of the spacecraft is a spacecraft's; :data:`BOUND_PAIRS` are
    ``[low, high]`` with low < high."""
    settings = _lookup(profile, "integrator.settings")
    for key in SETTING_NAMES:
        name = _lookup(profile, key)
        if settings is not None and name is not None and name not in settings:
            _fail(f"{key} = {name!r} names no [integrator.settings.*]; allowed: {', '.join(settings)}", key, source)
    systems = _lookup(profile, "gnss.systems")
    if isinstance(systems, list) and len(set(systems)) != len(systems):
        _fail(f"gnss.systems = {systems!r} is not allowed; allowed: distinct names from {', '.join(GNSS_SYSTEMS)}",
              "gnss.systems", source)
    extras = _lookup(profile, "evaluator.extra_metrics")
    if isinstance(extras, list) and len(set(extras)) != len(extras):
        _fail(f"[evaluator] extra_metrics must be distinct names; got {extras!r}", "evaluator.extra_metrics", source)
    model = _lookup(profile, "sk_estimate.model")
    life_nav = [n for n in extras or () if n in LIFE_NAVIGATION_KEYS]
    if life_nav and model is not None and model != "life":
        _fail(f"[evaluator] extra_metrics {life_nav} come from the life estimate's rebuilt constellation: they need "
              f'[sk_estimate] model = "life"; got {model!r}', "sk_estimate.model", source)
    satellites = _lookup(profile, "deltav.satellites")
    needs_all = [n for n in extras or () if n in NEEDS_ALL_SATELLITES]
    if needs_all and satellites is not None and satellites != "all":
        _fail(f"[evaluator] extra_metrics {needs_all} are maxima over satellites: they need "
              f'[deltav] satellites = "all"; got {satellites!r}', "deltav.satellites", source)
    lat, lon = _lookup(profile, "navigation_error.station_lat_deg"), _lookup(profile, "navigation_error.station_lon_deg")
    if lat is not None and lon is not None and len(lat) != len(lon):
        _fail(f"navigation_error.station_lon_deg has {len(lon)} entries for {len(lat)} station latitudes; allowed: one "
              "longitude per latitude", "navigation_error.station_lon_deg", source)
    floor = [_lookup(profile, f"navigation_error.{k}") for k in ("sise_at_upload_m", "receiver_noise_m")]
    if None not in floor and max(floor) <= 0.0:
        _fail("navigation_error.sise_at_upload_m and receiver_noise_m are both 0; allowed: a positive range error floor "
              "(a zero-error range would take infinite weight)", "navigation_error.receiver_noise_m", source)
    for key in BOUND_PAIRS:
        pair = _lookup(profile, key)
        if pair is not None and not (len(pair) == 2 and pair[0] < pair[1]):
            _fail(f"{key} = {pair!r} is not allowed; allowed: [low, high] with low < high", key, source)
    craft = [_lookup(profile, f"spacecraft.{k}") for k in ("cr", "area_m2", "mass_kg")]
    if None not in craft and craft[2] > 0 and not in_range(craft[0] * craft[1] / craft[2], CR_AREA_MASS):
        _fail(f"spacecraft cr * area_m2 / mass_kg = {craft[0] * craft[1] / craft[2]:.6g} m^2/kg is out of range; "
              f"allowed: {allowed_range_text(CR_AREA_MASS)} ({CR_AREA_MASS_WHY})", "spacecraft.area_m2", source)


CAMPAIGN_OFF = "off"          # a campaign constraint or hypervolume entry set to "off" drops an inherited one


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
        _fail(f"campaign.objectives = {objectives!r} is not allowed" + (f" ({bad!r} unknown)" if bad else "")
              + f"; allowed: distinct metric names, '-' first to maximise, from {metric_text}", "campaign.objectives",
              source)
    entries = {   # table -> (test of an entry's value, what is allowed)
        "constraints": (lambda spec: isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("min", "max")
                        and _is_number(next(iter(spec.values()))), "exactly one of {min = number}, {max = number}"),
        "hypervolume": (lambda ref: _is_number(ref) and ref > 0, "a positive reference value")}
    for table, (ok, allowed) in entries.items():
        for metric, value in campaign[table].items():
            key = f"campaign.{table}.{metric}"
            if value == CAMPAIGN_OFF:
                continue
            if metric not in metrics:
                _fail(f"unknown metric {key}; allowed: {metric_text}", key, source)
            if not ok(value):
                _fail(f"{key} = {value!r} is not allowed; allowed: {allowed} or {CAMPAIGN_OFF!r}", key, source)
    variables = campaign["variables"]
    if set(variables) != set(DESIGN_KEYS):
        _fail(f"campaign.variables names {', '.join(variables)}; allowed: exactly {', '.join(DESIGN_KEYS)}",
              "campaign.variables", source)
    for name in DESIGN_KEYS:
        key, spec = f"campaign.variables.{name}", variables[name]
        if not isinstance(spec, dict) or set(spec) != {"lower", "upper", "step"} \
                or not all(_is_number(spec[k]) for k in spec):
            _fail(f"{key} = {spec!r} is not allowed; allowed: {{lower = number, upper = number, step = number}}",
                  key, source)
        lower, upper, step = (spec[k] for k in ("lower", "upper", "step"))
        if step <= 0 or upper <= lower:
            _fail(f"{key} = {spec!r} is not allowed; allowed: lower < upper and step > 0", key, source)
        if name == "sma_km" and not (in_range(lower, SEMI_MAJOR_AXIS) and in_range(upper, SEMI_MAJOR_AXIS)):
            _fail(f"{key} = {spec!r} is out of range; allowed: bounds in {allowed_range_text(SEMI_MAJOR_AXIS)} "
                  f"({SEMI_MAJOR_AXIS_WHY})", key, source)
        if name in INTEGER_DESIGN_KEYS and (any(v != round(v) for v in (lower, upper, step)) or lower < 1):
            _fail(f"{key} = {spec!r} is not allowed; allowed: integer bounds >= 1 and an integer step (a count)",
                  key, source)
    count_ranges = [range(int(variables[name]["lower"]), int(variables[name]["upper"]) + 1, int(variables[name]["step"]))
                    for name in INTEGER_DESIGN_KEYS]
    n_sat = campaign["n_sat"]
    if n_sat and not walker_splits(n_sat, *count_ranges):
        sizes = sorted({p * s for p in count_ranges[0] for s in count_ranges[1]})
        _fail(f"campaign.n_sat = {n_sat!r} has no planes x satellites-per-plane split on the grid of "
              f"campaign.variables; allowed: 0 (any size) or one of {', '.join(map(str, sizes))}", "campaign.n_sat",
              source)
    companion = campaign["companion_profile"]
    if companion and companion == profile["profile"].get("name"):
        _fail(f"campaign.companion_profile = {companion!r} is this profile; allowed: \"\" (none) or another profile",
              "campaign.companion_profile", source)


def walker_splits(n_sat: int, planes: range, sats_per_plane: range) -> tuple[tuple[int, int], ...]:
    """``(Np, Ns)`` with ``Np`` in ``planes``, ``Ns`` in ``sats_per_plane`` and ``Np x Ns = n_sat``, fewest planes
    first: the Walker constellations of one size that a size-restricted campaign searches."""
    return tuple((p, n_sat // p) for p in planes if n_sat % p == 0 and n_sat // p in sats_per_plane)


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
        except ValueError as error:      # TOMLDecodeError, or an integer of more than 4300 digits
            if literal.strip() and literal.strip().replace("_", "").replace("-", "").isalnum() \
                    and not literal.strip()[0].isdigit() and literal.strip().lower() not in ("nan", "inf"):
                value = literal.strip()
            else:
                shown = item if len(item) <= 80 else f"{item[:60]}... ({len(item)} characters)"
                raise ConfigError(f"--set {shown!r}: VALUE is not a TOML literal ({str(error)[:120]})",
                                  key=path) from None
        if isinstance(value, (dt.date, dt.time)):
            raise ConfigError(f"--set {item!r}: TOML reads an unquoted {literal.strip()} as a date-time, and dates are "
                              f"strings here; quote it: --set '{path.strip()}=\"{literal.strip()}\"'", key=path.strip())
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
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else ("inf" if value > 0 else "-inf"))
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(map(toml_literal, value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML literal for {type(value).__name__} {value!r}")


def data_path(relative: str, key: str = "data file") -> Path:
    """Absolute path of a data file named relative to ``params/`` (``data/...``); ConfigError naming ``key``
    unless it lies under ``params/data/`` once symbolic links are resolved."""
    root = (PARAMS_DIR / "data").resolve()
    if not isinstance(relative, str) or Path(relative).is_absolute() \
            or not (PARAMS_DIR / relative).resolve().is_relative_to(root):
        raise ConfigError(f"{key} = {relative!r} is not allowed; allowed: a file under params/data/, named relative "
                          f"to params/ (e.g. \"data/gravity/...\")", key=key)
    return PARAMS_DIR / relative


DATA_KEYS = ("gravity.file", "ephemeris.kernels", "gps.tle_file", "gps.gain_file", "gnss.nominal_file",
             "validation.capstone.file")
SKYFIELD_DATA = "skyfield-data:"      # ephemeris.planetary_spk prefix: a file of the skyfield-data package


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
            raise ConfigError(f"ephemeris.planetary_spk = {spk!r} is not allowed; allowed: {SKYFIELD_DATA}FILE_NAME "
                              f"or a file under params/data/", key="ephemeris.planetary_spk")
    else:
        data_path(spk, "ephemeris.planetary_spk")


def _check_sampling(profile: dict) -> None:
    """The arc is longer than one sampling step, so it holds at least 3 epochs (t0, t0 + step, ..., end),
    the fewest the DOP statistics and the GVE Delta-V take."""
    days, step_s = profile["epoch"]["duration_days"], profile["epoch"]["step_s"]
    if not days * SECONDS_PER_DAY > step_s * (1.0 + 1e-9):
        raise ConfigError(f"epoch.duration_days = {days!r} ({days * SECONDS_PER_DAY:g} s) is not longer than epoch.step_s = "
                          f"{step_s!r} s; allowed: an arc of more than one step (at least 3 epochs): lengthen "
                          f"epoch.duration_days or shorten epoch.step_s", key="epoch.duration_days")


def _check_grid(profile: dict) -> None:
    """The DOP surface grid holds at most :data:`MAX_GRID_POINTS` points (a step of 1e-9 deg asked for 224 GiB)."""
    dop = profile["dop"]
    n_lat = math.floor((dop["lat_max_deg"] - dop["lat_min_deg"]) / dop["lat_step_deg"]) + 1
    n_lon = math.floor((dop["lon_max_deg"] - dop["lon_min_deg"]) / dop["lon_step_deg"]) + 1
    if n_lat * n_lon > MAX_GRID_POINTS:
        raise ConfigError(f"dop.lat_step_deg = {dop['lat_step_deg']!r}, dop.lon_step_deg = {dop['lon_step_deg']!r}: a "
                          f"grid of {n_lat:,} x {n_lon:,} points; allowed: at most {MAX_GRID_POINTS:,} points (a "
                          f"whole-Moon 1-degree grid is 65,160; the DOP arrays hold epochs x points x satellites)",
                          key="dop.lat_step_deg")


OFF_WHEN_ABSENT = {
    "front_validation": lambda profile: profile["front_validation"].get("max_designs", 0) == 0,
    "navigation_error": lambda profile: not set(profile.get("evaluator", {}).get("extra_metrics", ()))
    & set(NAVIGATION_ERROR_KEYS),
    "gnss": lambda profile: list(profile["gnss"].get("systems", ["gps"])) == ["gps"],
    "life_navigation": lambda profile: profile["life_navigation"].get("designs", 0) == 0,
    "robustness": lambda profile: profile["robustness"].get("draws", 0) == 0,
}
"""Sections a profile stored before they existed lacks, each with its test of being off: read as params/paper.toml's
(front validation off, ``max_designs = 0``; the navigation error unused while no metric of
:data:`~lnss_lib.keys.NAVIGATION_ERROR_KEYS` is asked for; the GPS link alone, ``[gnss] systems = ["gps"]``; notebook
08's life navigation check off, ``designs = 0``), and left out of the profile hash while off, so runs and shipped
results from before them keep their hash."""


KEYS_OFF_WHEN_ABSENT = {("campaign", "n_sat"): 0}
"""Keys a profile stored before they existed lacks, with the value that keeps their effect off (a campaign over
every size): read so when absent and left out of the profile hash at that value, like :data:`OFF_WHEN_ABSENT`."""


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
    """SHA-256 (16 hex digits) of a profile's canonical JSON, excluding its name and description, a
    :data:`OFF_WHEN_ABSENT` section that is off and a :data:`KEYS_OFF_WHEN_ABSENT` key at its off value."""
    content = copy.deepcopy(profile)
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
