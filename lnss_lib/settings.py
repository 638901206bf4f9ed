"""Settings read once: a profile as a tree of frozen, typed sections.

:func:`load_settings` merges a profile's TOML chain (``inherits``, ``also``, ``--set``), checks it in
:mod:`lnss_lib.config` (keys, types, ranges with units, the allowed values of every text setting; the
error names the key, the value and what is allowed) and freezes the result into :class:`Settings`: one
dataclass a section (``settings.forces``, ``settings.dop``, ...). A kernel takes the section it reads,
or the :class:`Dynamics` bundle that the force model and the propagator read, never the whole tree.

Why plain frozen dataclasses and not pydantic: the checking already lives in one place
(:func:`lnss_lib.config.validate_profile`, with TOML file and line numbers in its messages, the allowed
set of every text setting from :data:`lnss_lib.config.CHOICES` and physical ranges with the reason),
so a second validator would duplicate it; a frozen dataclass adds no dependency, cannot be changed
after the check, and shows every setting a function depends on in its signature. The fields take the
names and value types of ``params/paper.toml``; numbers that TOML allows as integers in a float key
become ``float``, lists become tuples; free tables (``gps.launch_dates``, ``campaign.constraints``, ...) stay
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

from .config import deep_merge, load_profile, profile_hash, toml_literal, validate_profile, with_absent_sections
from .errors import ConfigError

__all__ = ["Settings", "Dynamics", "load_settings", "settings_from_profile", "settings_from_toml"]


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
    if origin is types.UnionType or hint is Any:          # e.g. int | float: the value's own type
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
        return _thawed(value)                        # a free table (a fresh copy): checked with the rest
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
        if not item.init or item.metadata.get("derived"):
            continue
        name = item.name
        if name not in table:
            raise ConfigError(f"missing key {key}.{name} (every profile has the keys of params/paper.toml)",
                              key=f"{key}.{name}")
        values[item.name] = _convert(hints[item.name], table[name], f"{key}.{name}")
    return cls(**values)


# --- the sections, in the order of params/paper.toml ------------------------------------------------------

@dataclass(frozen=True)
class ProfileInfo:
    name: str
    description: str


@dataclass(frozen=True)
class EpochSettings:
    """Study epoch (TDB) and the arc of the 10-day evaluation (Section 5.3)."""
    start_tdb: str
    duration_days: float
    step_s: float


@dataclass(frozen=True)
class SpacecraftSettings:
    """Table 2 bus: mass, SRP area and reflectivity coefficient."""
    mass_kg: float
    area_m2: float
    cr: float

    @property
    def cr_area_mass_m2_kg(self) -> float:
        """Cr A / m of the SRP acceleration (m^2/kg)."""
        return self.cr * self.area_m2 / self.mass_kg


@dataclass(frozen=True)
class GravitySettings:
    """The lunar field (fully normalised, in ``frames.gravity``), its degree and the per-evaluation truncation."""
    file: str
    degree: int
    gm_km3_s2: float
    r_ref_km: float
    truncation_kms2: float


@dataclass(frozen=True)
class ForceSettings:
    """Perturbations beyond the lunar field (Table 2)."""
    third_bodies: tuple[str, ...]
    srp: bool
    shadow: str
    relativity: bool
    albedo: bool
    earth_albedo: float
    solar_flux_w_m2: float


@dataclass(frozen=True)
class BodyConstants:
    """GMs of the third bodies (DE421), radii, the astronomical unit and the speed of light."""
    gm_sun_km3_s2: float
    gm_earth_km3_s2: float
    gm_jupiter_km3_s2: float
    r_moon_mean_km: float
    r_earth_km: float
    r_sun_km: float
    au_km: float
    c_km_s: float


@dataclass(frozen=True)
class IntegratorSetting:
    """One named integrator setting: method and tolerances."""
    method: str
    rtol: float
    atol: float
    name: str = field(default="", metadata={"derived": True})   # filled in by IntegratorSettings.named


@dataclass(frozen=True)
class IntegratorSettings:
    """The named integrator settings and the one the profile propagates with."""
    setting: str
    settings: Mapping[str, IntegratorSetting]

    def named(self, name: str | None = None) -> IntegratorSetting:
        """Setting ``name`` (default: the profile's ``integrator.setting``) with its name filled in."""
        name = self.setting if name is None else name
        if name not in self.settings:
            raise ConfigError(f"unknown integrator setting {name!r}; allowed: {', '.join(self.settings)}",
                              key="integrator.setting")
        return dataclasses.replace(self.settings[name], name=name)


@dataclass(frozen=True)
class FrameSettings:
    """Frame of the design elements, of the surface grid and of the gravity field."""
    element_frame: str
    moon_fixed: str
    gravity: str


@dataclass(frozen=True)
class EphemerisSettings:
    """SPICE kernels (relative to params/), the planetary SPK and the tabulation step of bodies and rotations."""
    kernels: tuple[str, ...]
    planetary_spk: str
    table_step_s: float


@dataclass(frozen=True)
class ImpactSettings:
    min_altitude_km: float


@dataclass(frozen=True)
class StandaloneElfoSettings:
    """Table 4: the standalone ELFO constellation."""
    sma_km: float
    ecc: float
    inc_deg: float
    aop_deg: float
    raan_deg: tuple[float, ...]
    sats_per_plane: int


@dataclass(frozen=True)
class CapstoneSettings:
    """CAPSTONE NRHO reference arc (HORIZONS) of the propagator validation."""
    file: str
    arc_break_tdb: str
    srp_cr_area_mass_m2_kg: float
    integrator_setting: str


@dataclass(frozen=True)
class ValidationSettings:
    capstone: CapstoneSettings


@dataclass(frozen=True)
class NotebookSettings:
    timeout_s: int


@dataclass(frozen=True)
class DopSettings:
    """South-pole receiver grid and DOP statistics (Section 2.1, eq. 1-14)."""
    lat_min_deg: float
    lat_max_deg: float
    lat_step_deg: float
    lon_min_deg: float
    lon_max_deg: float
    lon_step_deg: float
    area_weighting: str
    elevation_mask_deg: float
    los_axes: str
    availability_threshold: float
    filter_sigma: float


@dataclass(frozen=True)
class GpsSettings:
    """GPS-LNSS link budget and visibility (Section 2.2, eq. 15-24, Table 1)."""
    tle_file: str
    exclude_prn: tuple[int, ...]
    exclude_launched_after: str
    exclude_launches_from: str
    launch_dates: Mapping[str, str]
    gain_file: str
    gain_column: str
    sidelobe_from_deg: float
    sidelobe_offset_db: float
    p_tx_dbw: float
    l_tx_db: float
    l_pol_db: float
    g_rx_dbi: float
    frequency_mhz: float
    noise_temperature_k: float
    cn0_threshold_dbhz: float
    beam_mask_deg: float
    atmosphere_margin_deg: float
    ellipsoid_test: bool
    clock_column: bool
    pdop_filter: str


@dataclass(frozen=True)
class GnssReference:
    """GPS's ICD minimum received power and where it is specified: the reference of the other systems' EIRP."""
    min_received_power_dbw: float
    edge_elevation_deg: float
    sma_km: float


@dataclass(frozen=True)
class GnssTransmitter:
    """A system's signal frequency and its ICD minimum received power at the edge-of-coverage elevation."""
    frequency_mhz: float
    min_received_power_dbw: float
    edge_elevation_deg: float


@dataclass(frozen=True)
class GnssSettings:
    """The GNSS link (:mod:`lnss_lib.gnss`): which systems, their nominal slots and transmitters."""
    systems: tuple[str, ...]
    nominal_file: str
    gps: GnssReference
    galileo: GnssTransmitter
    beidou: GnssTransmitter
    glonass: GnssTransmitter


@dataclass(frozen=True)
class DeltaVSettings:
    """Station-keeping Delta-V of the 10-day evaluation (Section 3.1, eq. 25-41)."""
    model: str
    element_frame: str
    year_days: float
    lsq_rates: str
    paper_normal: str
    paper_radial: str
    paper_divisor_floor: float
    paper_cap_kms2: float
    secular_min_periods: float
    slsqp_lambda: float
    satellites: str


@dataclass(frozen=True)
class EvaluatorSettings:
    extra_metrics: tuple[str, ...]


@dataclass(frozen=True)
class NavigationErrorSettings:
    """The user range error budget (signal in space by ephemeris age, receiver, lunar-surface multipath), the upload
    stations on the Earth and the position-error requirement (:mod:`lnss_lib.navigation_error`)."""
    sise_law: str                                    # config.SISE_LAWS
    sise_at_upload_m: float
    sise_growth_m: float
    sise_growth_age_h: float
    receiver_noise_m: float
    lunar_multipath_zenith_m: float
    station_lat_deg: tuple[float, ...]
    station_lon_deg: tuple[float, ...]
    station_mask_deg: float
    requirement_horizontal_95_m: float
    requirement_vertical_95_m: float                 # 0: no vertical requirement


@dataclass(frozen=True)
class VariableBounds:
    """A design variable's grid (eq. 43-44): lower and upper bound and step."""
    lower: int | float
    upper: int | float
    step: int | float


@dataclass(frozen=True)
class CampaignSettings:
    """NSGA-II campaign (Section 5, Table 5) over the Table 3 grid."""
    population: int
    generations: int
    crossover_prob: float
    crossover_eta: float
    mutation_eta: float
    mutation_prob_var: float
    seed: int
    ftol: float
    ftol_period: int
    n_sat: int
    objectives: tuple[str, ...]
    nan_objective: float
    nan_violation: float
    evaluator: str
    synthetic_delay_s: float
    max_resubmits: int
    max_errors: int
    numba_threads_per_worker: int
    notebook_mode: str
    companion_profile: str
    variables: Mapping[str, VariableBounds]
    constraints: Mapping[str, Any]
    hypervolume: Mapping[str, Any]
    overrides: Mapping[str, Any]


@dataclass(frozen=True)
class StabilitySettings:
    """Doubly-averaged stability screen over the design life."""
    life_days: float
    third_bodies: tuple[str, ...]
    precession: bool
    average_days: float
    table_step_days: float
    method: str
    rtol: float
    atol: float
    step_days: float
    output_step_days: float
    margin_km: float
    monthly_terms: bool
    validity_period_fraction: float
    validity_ecc: float
    validation_degree: int
    validation_step_s: float
    validation_designs: tuple[tuple[int | float, ...], ...]   # Walker rows (a_km, e, aop, inc, planes, per plane)


@dataclass(frozen=True)
class SkEstimateSettings:
    """Campaign-grade station-keeping Delta-V estimate: the 10-day box slope or the service controller's life."""
    model: str
    element_frame: str
    year_days: float
    min_periods: float
    along_track_rebias_per_year: float


@dataclass(frozen=True)
class BoxSettings:
    """Half-widths of the fixed-element box controller."""
    ecc: float
    aop_deg: float
    inc_deg: float
    raan_rel_deg: float
    u_rel_deg: float


@dataclass(frozen=True)
class ServiceSettings:
    """What the service controller holds: a safe perilune and the navigation service."""
    perilune_margin_km: float
    safety_check_days: float
    safety_lead_days: float
    nav_window_days: float
    nav_avail_drop_pct: float
    nav_dop_rise_fraction: float
    raan_rel_deg: float
    u_rel_deg: float
    tolerances: str                                  # config.TOLERANCE_SOURCES
    tolerance_arc_days: float
    tolerance_step_s: float
    raan_rel_bounds_deg: tuple[float, float]
    u_rel_bounds_deg: tuple[float, float]


@dataclass(frozen=True)
class DesignLifeSettings:
    """Closed-loop station keeping over the design life."""
    life_days: float
    check_interval_days: float
    samples_per_orbit: int
    min_maneuver_spacing_days: float
    dv_cap_kms_per_year: float
    slot_coast_days: float
    slot_fit_days: float
    slot_quad_days: float
    target_fraction: float
    tide_period_days: float
    box_tolerance: float
    integrator_setting: str
    initial_trim: bool
    controller: str
    box: BoxSettings
    service: ServiceSettings


@dataclass(frozen=True)
class BenchmarkSettings:
    """Notebook 10: every catalogue constellation on one yardstick."""
    extra_masks_deg: tuple[float, ...]
    campaign_picks: bool
    closed_loop_life: bool
    epoch_constellations: tuple[str, ...]
    epochs_tdb: tuple[str, ...]


@dataclass(frozen=True)
class LifeEvaluationSettings:
    """A design over its design life: sampling, months, and the notebook's validation sets."""
    sample_step_s: float
    month_days: float
    notebook_life_days: float
    convergence_life_days: float
    convergence_sats: int
    validation_life_days: float
    validation_max_sats_per_plane: int
    validation_front_designs: int
    anchor_life_days: float
    validation_frames: tuple[str, ...]
    frame_rerun_designs: int
    validation_designs: tuple[tuple[int | float, ...], ...]   # Walker rows (a_km, e, aop, inc, planes, per plane)
    screen_validation_designs: int          # random Table 3 designs of studies.screen_validation
    screen_validation_life_days: float      # ... flown this long (0: the screened profile's [stability] life_days)


@dataclass(frozen=True)
class LifeNavigationSettings:
    """Notebook 08's check of the life-long availability estimate against the closed loop (studies.life_navigation)."""
    designs: int                            # whole designs flown, the first of the study's list (0: off)
    life_days: float                        # ... flown this long (0: the operational companion's [design_life] life_days)


@dataclass(frozen=True)
class RobustnessSettings:
    """Insertion dispersions flown in closed loop (studies.robustness): 1-sigma errors of the mean elements."""
    draws: int                              # dispersed insertions per design (0: off)
    life_days: float
    seed: int
    sma_km: float
    ecc: float
    inc_deg: float
    raan_deg: float
    aop_deg: float
    anomaly_deg: float


@dataclass(frozen=True)
class FrontValidationSettings:
    """The front flown in closed loop after NSGA-II (issue 20 item 4) and the headline's bounds (item 5)."""
    max_designs: int                        # 0: off
    max_sats_per_plane: int                 # 0: every satellite
    headline_sizes: tuple[int, ...]
    headline_per_size: int
    availability_min_pct: float
    dv_max_kms_per_year: float


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
class Settings:
    """A whole profile, checked and frozen; only the top of the workbook (command line, pipeline, studies,
    campaign set-up, explorer) holds it, and hands each kernel its section."""
    profile: ProfileInfo
    epoch: EpochSettings
    spacecraft: SpacecraftSettings
    gravity: GravitySettings
    forces: ForceSettings
    constants: BodyConstants
    integrator: IntegratorSettings
    frames: FrameSettings
    ephemeris: EphemerisSettings
    impact: ImpactSettings
    standalone_elfo: StandaloneElfoSettings
    validation: ValidationSettings
    notebooks: NotebookSettings
    dop: DopSettings
    gps: GpsSettings
    gnss: GnssSettings
    deltav: DeltaVSettings
    navigation_error: NavigationErrorSettings
    evaluator: EvaluatorSettings
    campaign: CampaignSettings
    stability: StabilitySettings
    sk_estimate: SkEstimateSettings
    design_life: DesignLifeSettings
    benchmark: BenchmarkSettings
    life_evaluation: LifeEvaluationSettings
    life_navigation: LifeNavigationSettings
    robustness: RobustnessSettings
    front_validation: FrontValidationSettings
    source: Mapping[str, Any] = field(repr=False, compare=False)
    hash: str = field(init=False, compare=True)

    def __post_init__(self):
        object.__setattr__(self, "hash", profile_hash(_thawed(self.source)))

    @property
    def name(self) -> str:
        return self.profile.name

    @functools.cached_property
    def dynamics(self) -> Dynamics:
        return Dynamics(self.ephemeris, self.frames, self.constants, self.gravity, self.forces, self.spacecraft,
                        self.impact, self.integrator)

    def as_dict(self) -> dict:
        """The merged, checked profile as plain TOML data (a copy)."""
        return _thawed(self.source)

    def to_toml(self) -> str:
        """The merged profile as TOML text; :func:`settings_from_toml` reads it back to equal settings."""
        lines = []
        for section, table in self.as_dict().items():
            lines.append(f"[{section}]")
            lines.extend(f"{toml_literal(key)} = {toml_literal(value)}" for key, value in table.items())
            lines.append("")
        return "\n".join(lines)

    def with_overrides(self, overrides: Mapping | None) -> "Settings":
        """These settings with the nested ``overrides`` merged in and checked (e.g. ``campaign.overrides``)."""
        if not overrides:
            return self
        validate_profile(_thawed(overrides), partial=True, source="overrides")
        return settings_from_profile(deep_merge(self.as_dict(), _thawed(overrides)))


def settings_from_profile(profile: Mapping) -> Settings:
    """Settings of a merged profile dict (as :func:`lnss_lib.config.load_profile` returns), checked again."""
    profile = with_absent_sections(_thawed(profile))   # a fresh copy of every table and list
    validate_profile(profile)
    sections = {item.name: _build(_hints(Settings)[item.name], profile[item.name], item.name)
                for item in dataclasses.fields(Settings) if item.init and item.name != "source"}
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
