"""The sections of a profile, each setting declared once: its type, its allowed values and why.

A section is a frozen dataclass (``[dop]`` is :class:`DopSettings`); a field is a setting, its
annotation the type, and :func:`~lnss_lib.setting_rule.setting` puts its rule in the field's metadata: a range (each entry
of a list), the allowed values of a text, an open form (a date, a profile name), and the physical
or numerical reason quoted when a value is refused. The unit is in the field's name (``_km``,
``_deg``, ``_days``), as everywhere in the workbook. :func:`lnss_lib.config.validate_profile` reads
the rules from the fields; ``params/*.toml`` carry values and the comments that give their sources.

A new setting is one field here and its value, with its source, in ``params/paper.toml``::

    @dataclass(frozen=True)
    class StabilitySettings:
        margin_km: float = setting(range=NON_NEGATIVE, why="...")

The allowed values of the text settings are the tuples below; a module that reads a setting imports
its tuple from here. How stored profiles spelled older keys is :mod:`lnss_lib.legacy_keys`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .constants import (
    CR_AREA_MASS_MAX_M2_KG,
    CR_MAX,
    MAX_POPULATION,
    MOON_HILL_RADIUS_KM,
    SPACECRAFT_MASS_RANGE_KG,
    TOLERANCE_CEILING,
    TOLERANCE_FLOOR,
    WGS84_A_KM,
)
from .errors import ConfigError
from .keys import DELTAV_SATELLITES, EXTRA_METRIC_KEYS, GNSS_NAMES
from .setting_rule import Rule, derived, setting

# Ranges that several settings share.
POSITIVE, NON_NEGATIVE = (0.0, None, True, False), (0.0, None, False, False)
TOLERANCE = (TOLERANCE_FLOOR, TOLERANCE_CEILING, False, False)
TOLERANCE_WHY = (
    f"below about 100 machine epsilons ({TOLERANCE_FLOOR:g}) an integrator's error test asks for "
    f"what double precision cannot resolve; above {TOLERANCE_CEILING:g} (SciPy's default rtol) it no "
    f"longer resolves a lunar orbit"
)
SEMI_MAJOR_AXIS = (0.0, MOON_HILL_RADIUS_KM, True, False)
SEMI_MAJOR_AXIS_WHY = (
    f"a must be within the Moon's Hill sphere ({MOON_HILL_RADIUS_KM:,.0f} km) for a bound "
    f"lunar orbit"
)
CR_AREA_MASS = (0.0, CR_AREA_MASS_MAX_M2_KG, False, False)
CR_AREA_MASS_WHY = "solar sails reach ~10-50 m^2/kg"

# Allowed values of the text settings.
METHODS = ("RK45", "DOP853")  # propagator: Dormand-Prince 5(4) and 8(5,3)
ELEMENT_FRAMES = ("lunar_equator_of_epoch", "j2000", "moon_op")
POLE_FRAMES = ("MOON_ME", "MOON_PA", "IAU_MOON")
THIRD_BODIES = ("SUN", "EARTH", "JUPITER")  # also the rows of the ephemeris table
SHADOW_MODELS = ("conical", "none")
LOS_AXES = ("moon_fixed", "enu")
AREA_WEIGHTINGS = ("none", "cos_lat", "cell_area")
PDOP_FILTERS = ("percentile95", "sigma2", "none")
DELTAV_MODELS = ("paper", "lsq", "secular")
LSQ_RATES = ("vectors", "elements")
PAPER_NORMAL = ("weighted", "eq32", "rss")
PAPER_RADIAL = ("weighted", "eq35")
EVALUATORS = ("walker", "synthetic")
NOTEBOOK_MODES = (
    "run",
    "load",
)  # notebook 06 runs the campaign itself, or loads the latest CLI run
STABILITY_METHODS = ("DOP853", "RK45", "Radau", "LSODA", "RK4")
STABILITY_BODIES = ("EARTH", "SUN")
SK_ESTIMATE_MODELS = (
    "arc",
    "life",
)  # campaign estimate: the 10-day box slope, or the service controller's life
CONTROLLERS = (
    "service",
    "box",
)  # design life: hold the service (design_life.service) or the fixed box
SISE_LAWS = (
    "constant",
    "linear",
    "quadratic",
)  # signal-in-space error growth with the ephemeris age
GNSS_SYSTEMS = tuple(GNSS_NAMES)  # [gnss] systems: GPS from TLEs, the others nominal slots
TOLERANCE_SOURCES = (
    "derived",
    "fixed",
)  # service controller: tolerances from each design's navigation, or as set


# --- the sections, in the order of params/paper.toml ------------------------------------------------------


@dataclass(frozen=True)
class ProfileInfo:
    """What a profile is: its name (set by the loader, the file's stem) and a sentence on its purpose."""

    name: str
    description: str
    inherits: str = field(default="", metadata={"rule": Rule(file_only=True)})  # the file's parent
    also: tuple[str, ...] = field(
        default=(), metadata={"rule": Rule(file_only=True)}
    )  # profiles merged first


@dataclass(frozen=True)
class EpochSettings:
    """Study epoch (TDB) and the arc of the 10-day evaluation (Section 5.3)."""

    start_tdb: str = setting(form="iso_datetime")
    duration_days: float = setting(range=POSITIVE)
    step_s: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class SpacecraftSettings:
    """Table 2 bus: mass, SRP area and reflectivity coefficient."""

    mass_kg: float = setting(
        range=(*SPACECRAFT_MASS_RANGE_KG, False, False),
        why="from a gram (chip-scale satellites) to 1000 t",
    )
    area_m2: float = setting(range=POSITIVE)
    cr: float = setting(
        range=(0.0, CR_MAX, True, False),
        why="Cr = 1 + specular reflectivity: 2 is a perfect mirror",
    )

    @property
    def cr_area_mass_m2_kg(self) -> float:
        """Cr A / m of the SRP acceleration (m^2/kg)."""
        return self.cr * self.area_m2 / self.mass_kg


@dataclass(frozen=True)
class GravitySettings:
    """The lunar field (fully normalised, in ``frames.gravity``), its degree and the per-evaluation truncation."""

    file: str
    degree: int = setting(range=(0, 100, False, False))
    gm_km3_s2: float = setting(range=POSITIVE)
    r_ref_km: float = setting(range=POSITIVE)
    truncation_kms2: float = setting(range=NON_NEGATIVE)


@dataclass(frozen=True)
class ForceSettings:
    """Perturbations beyond the lunar field (Table 2)."""

    third_bodies: tuple[str, ...] = setting(choices=THIRD_BODIES)
    srp: bool
    shadow: str = setting(choices=SHADOW_MODELS)
    relativity: bool
    albedo: bool
    earth_albedo: float = setting(range=(0.0, 1.0, False, False))
    solar_flux_w_m2: float = setting(range=NON_NEGATIVE)


@dataclass(frozen=True)
class BodyConstants:
    """GMs of the third bodies (DE421), radii, the astronomical unit and the speed of light."""

    gm_sun_km3_s2: float = setting(range=POSITIVE)
    gm_earth_km3_s2: float = setting(range=POSITIVE)
    gm_jupiter_km3_s2: float = setting(range=POSITIVE)
    r_moon_mean_km: float = setting(range=POSITIVE)
    r_earth_km: float = setting(range=POSITIVE)
    r_sun_km: float = setting(range=POSITIVE)
    au_km: float = setting(range=POSITIVE)
    c_km_s: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class IntegratorSetting:
    """One named integrator setting: method and tolerances."""

    method: str = setting(choices=METHODS)
    rtol: float = setting(range=TOLERANCE, why=TOLERANCE_WHY)
    atol: float = setting(range=TOLERANCE, why=TOLERANCE_WHY)
    name: str = derived(
        ""
    )  # its name in [integrator.settings], filled in by IntegratorSettings.named


@dataclass(frozen=True)
class IntegratorSettings:
    """The named integrator settings and the one the profile propagates with."""

    setting: str = setting(names_integrator_setting=True)
    settings: Mapping[str, IntegratorSetting]

    def named(self, name: str | None = None) -> IntegratorSetting:
        """Setting ``name`` (default: the profile's ``integrator.setting``) with its name filled in."""
        name = self.setting if name is None else name
        if name not in self.settings:
            raise ConfigError(
                f"unknown integrator setting {name!r}; allowed: {', '.join(self.settings)}",
                key="integrator.setting",
            )
        return dataclasses.replace(self.settings[name], name=name)


@dataclass(frozen=True)
class FrameSettings:
    """Frame of the design elements, of the surface grid and of the gravity field."""

    element_frame: str = setting(choices=ELEMENT_FRAMES)
    moon_fixed: str = setting(choices=POLE_FRAMES)
    gravity: str = setting(choices=POLE_FRAMES)


@dataclass(frozen=True)
class EphemerisSettings:
    """SPICE kernels (relative to params/), the planetary SPK and the tabulation step of bodies and rotations."""

    kernels: tuple[str, ...]
    planetary_spk: str
    table_step_s: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class ImpactSettings:
    min_altitude_km: float = setting(range=NON_NEGATIVE)


@dataclass(frozen=True)
class StandaloneElfoSettings:
    """Table 4: the standalone ELFO constellation."""

    sma_km: float = setting(range=SEMI_MAJOR_AXIS, why=SEMI_MAJOR_AXIS_WHY)
    ecc: float = setting(range=(0.0, 1.0, False, True))
    inc_deg: float = setting(range=(0.0, 180.0, False, False))
    aop_deg: float
    raan_deg: tuple[float, ...]
    sats_per_plane: int = setting(range=(1, None, False, False))


@dataclass(frozen=True)
class CapstoneSettings:
    """CAPSTONE NRHO reference arc (HORIZONS) of the propagator validation."""

    file: str
    arc_break_tdb: str = setting(form="iso_datetime")
    srp_cr_area_mass_m2_kg: float
    integrator_setting: str = setting(names_integrator_setting=True)


@dataclass(frozen=True)
class ValidationSettings:
    capstone: CapstoneSettings


@dataclass(frozen=True)
class NotebookSettings:
    timeout_s: int = setting(range=POSITIVE)


@dataclass(frozen=True)
class DopSettings:
    """South-pole receiver grid and DOP statistics (Section 2.1, eq. 1-14)."""

    lat_min_deg: float = setting(range=(-90.0, 90.0, False, False))
    lat_max_deg: float = setting(range=(-90.0, 90.0, False, False))
    lat_step_deg: float = setting(range=POSITIVE)
    lon_min_deg: float = setting(range=(-360.0, 360.0, False, False))
    lon_max_deg: float = setting(range=(-360.0, 360.0, False, False))
    lon_step_deg: float = setting(range=POSITIVE)
    area_weighting: str = setting(choices=AREA_WEIGHTINGS)
    elevation_mask_deg: float = setting(range=(0.0, 90.0, False, False))
    los_axes: str = setting(choices=LOS_AXES)
    availability_threshold: float = setting(range=POSITIVE)
    filter_sigma: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class GpsSettings:
    """GPS-LNSS link budget and visibility (Section 2.2, eq. 15-24, Table 1)."""

    tle_file: str
    exclude_prn: tuple[int, ...]
    exclude_launched_after: str = setting(form="launch_cutoff")
    exclude_launches_from: str = setting(form="designator")
    launch_dates: Mapping[str, str] = setting(free=True)
    gain_file: str
    gain_column: str
    sidelobe_from_deg: float = setting(range=(0.0, 180.0, False, False))
    sidelobe_offset_db: float = setting(infinite_ok=True)
    p_tx_dbw: float
    l_tx_db: float
    l_pol_db: float
    g_rx_dbi: float
    frequency_mhz: float = setting(range=POSITIVE)
    noise_temperature_k: float = setting(range=POSITIVE)
    cn0_threshold_dbhz: float
    beam_mask_deg: float = setting(range=(0.0, 180.0, True, False))
    atmosphere_margin_deg: float = setting(range=NON_NEGATIVE)
    ellipsoid_test: bool
    clock_column: bool
    pdop_filter: str = setting(choices=PDOP_FILTERS)


@dataclass(frozen=True)
class GnssReference:
    """GPS's ICD minimum received power and where it is specified: the reference of the other systems' EIRP."""

    min_received_power_dbw: float
    edge_elevation_deg: float = setting(range=(0.0, 90.0, False, True))
    sma_km: float = setting(range=(WGS84_A_KM, None, True, False))


@dataclass(frozen=True)
class GnssTransmitter:
    """A system's signal frequency and its ICD minimum received power at the edge-of-coverage elevation."""

    frequency_mhz: float = setting(range=POSITIVE)
    min_received_power_dbw: float
    edge_elevation_deg: float = setting(range=(0.0, 90.0, False, True))


@dataclass(frozen=True)
class GnssSettings:
    """The GNSS link (:mod:`lnss_lib.gnss`): which systems, their nominal slots and transmitters."""

    systems: tuple[str, ...] = setting(choices=GNSS_SYSTEMS, non_empty=True)
    nominal_file: str
    gps: GnssReference
    galileo: GnssTransmitter
    beidou: GnssTransmitter
    glonass: GnssTransmitter


@dataclass(frozen=True)
class DeltaVSettings:
    """Station-keeping Delta-V of the 10-day evaluation (Section 3.1, eq. 25-41)."""

    model: str = setting(choices=DELTAV_MODELS)
    gve_frame: str = setting(
        choices=ELEMENT_FRAMES
    )  # the elements the GVEs difference, apart from the design's
    year_days: float = setting(range=POSITIVE)
    lsq_rates: str = setting(choices=LSQ_RATES)
    paper_normal: str = setting(choices=PAPER_NORMAL)
    paper_radial: str = setting(choices=PAPER_RADIAL)
    paper_divisor_floor: float = setting(
        range=(0.0, 1.0, False, True),
        why="a floor of 0 is the paper's literal divisors (notebook 04's "
        "sweep); 1 or more would replace every divisor",
    )
    paper_cap_kms2: float = setting(range=POSITIVE)
    secular_min_periods: float = setting(
        range=(1.0, None, True, False), why="the secular trend needs at least two one-orbit windows"
    )
    slsqp_lambda: float = setting(range=NON_NEGATIVE)
    satellites: str = setting(choices=DELTAV_SATELLITES)


@dataclass(frozen=True)
class EvaluatorSettings:
    extra_metrics: tuple[str, ...] = setting(choices=EXTRA_METRIC_KEYS)


@dataclass(frozen=True)
class NavigationErrorSettings:
    """The user range error budget (signal in space by ephemeris age, receiver, lunar-surface multipath), the upload
    stations on the Earth and the position-error requirement (:mod:`lnss_lib.navigation_error`)."""

    sise_law: str = setting(choices=SISE_LAWS)
    sise_at_upload_m: float = setting(range=NON_NEGATIVE)
    sise_growth_m: float = setting(range=NON_NEGATIVE)
    sise_growth_age_h: float = setting(range=POSITIVE)
    receiver_noise_m: float = setting(range=NON_NEGATIVE)
    lunar_multipath_zenith_m: float = setting(range=NON_NEGATIVE)
    station_lat_deg: tuple[float, ...] = setting(range=(-90.0, 90.0, False, False), non_empty=True)
    station_lon_deg: tuple[float, ...] = setting(range=(-360.0, 360.0, False, False))
    station_mask_deg: float = setting(range=(0.0, 90.0, False, True))
    requirement_horizontal_95_m: float = setting(range=POSITIVE)
    requirement_vertical_95_m: float = setting(range=NON_NEGATIVE)  # 0: no vertical requirement


@dataclass(frozen=True)
class VariableBounds:
    """A design variable's grid (eq. 43-44): lower and upper bound and step."""

    lower: int | float
    upper: int | float
    step: int | float


@dataclass(frozen=True)
class CampaignSettings:
    """NSGA-II campaign (Section 5, Table 5) over the Table 3 grid."""

    population: int = setting(
        range=(2, MAX_POPULATION, False, False),
        why=f"NSGA-II ranks parents and offspring through a 2N x 2N domination "
        f"matrix, {(2 * MAX_POPULATION) ** 2 * 8 / 1e9:.1f} GB at N = {MAX_POPULATION}",
    )
    generations: int = setting(range=(1, None, False, False))
    crossover_prob: float = setting(range=(0.0, 1.0, False, False))
    crossover_eta: float = setting(range=NON_NEGATIVE)
    mutation_eta: float = setting(range=NON_NEGATIVE)
    mutation_prob_var: float = setting(range=(0.0, 1.0, False, False))
    seed: int = setting(range=NON_NEGATIVE)
    ftol: float = setting(range=NON_NEGATIVE)
    ftol_period: int = setting(range=(1, None, False, False))
    n_sat: int = setting(
        range=NON_NEGATIVE
    )  # 0: any size; N: only the splits Np x Ns = N (campaign.grid)
    objectives: tuple[str, ...]
    nan_objective: float = setting(range=NON_NEGATIVE)
    nan_violation: float = setting(range=NON_NEGATIVE)
    evaluator: str = setting(choices=EVALUATORS)
    synthetic_delay_s: float = setting(range=NON_NEGATIVE)
    max_resubmits: int = setting(range=NON_NEGATIVE)
    max_errors: int = setting(range=NON_NEGATIVE)
    numba_threads_per_worker: int = setting(range=NON_NEGATIVE)
    notebook_mode: str = setting(choices=NOTEBOOK_MODES)
    companion_profile: str = setting(form="profile_name")
    variables: Mapping[str, VariableBounds] = setting(free=True)
    constraints: Mapping[str, Any] = setting(free=True)
    hypervolume: Mapping[str, Any] = setting(free=True)
    overrides: Mapping[str, Any] = setting(sections=True)


def walker_splits(n_sat: int, planes: range, sats_per_plane: range) -> tuple[tuple[int, int], ...]:
    """``(Np, Ns)`` with ``Np`` in ``planes``, ``Ns`` in ``sats_per_plane`` and ``Np x Ns = n_sat``, fewest planes
    first: the Walker constellations of one size that a size-restricted campaign searches."""
    return tuple((p, n_sat // p) for p in planes if n_sat % p == 0 and n_sat // p in sats_per_plane)


@dataclass(frozen=True)
class StabilitySettings:
    """Doubly-averaged stability screen over the design life."""

    span_days: float = setting(range=NON_NEGATIVE)  # 0: the design life ([design_life] life_days)
    third_bodies: tuple[str, ...] = setting(choices=STABILITY_BODIES)
    precession: bool
    average_days: float = setting(range=POSITIVE)
    table_step_days: float = setting(range=POSITIVE)
    method: str = setting(choices=STABILITY_METHODS)
    rtol: float = setting(range=TOLERANCE, why=TOLERANCE_WHY)
    atol: float = setting(range=TOLERANCE, why=TOLERANCE_WHY)
    step_days: float = setting(range=POSITIVE)
    output_step_days: float = setting(range=POSITIVE)
    margin_km: float = setting(range=NON_NEGATIVE)
    monthly_terms: bool
    validity_period_fraction: float = setting(range=POSITIVE)
    validity_ecc: float = setting(range=NON_NEGATIVE)
    validation_degree: int = setting(range=(0, 100, False, False))
    validation_step_s: float = setting(range=POSITIVE)
    validation_designs: tuple[
        tuple[int | float, ...], ...
    ]  # Walker rows (a_km, e, aop, inc, planes, per plane)
    life_days: float = derived(0.0, of=("stability.span_days", "design_life.life_days"))


@dataclass(frozen=True)
class SkEstimateSettings:
    """Campaign-grade station-keeping Delta-V estimate: the 10-day box slope or the service controller's life."""

    model: str = setting(choices=SK_ESTIMATE_MODELS)
    arc_frame: str = setting(
        choices=ELEMENT_FRAMES
    )  # the "arc" model's box (the "life" model: the design's)
    min_periods: float = setting(range=POSITIVE)
    along_track_rebias_per_year: float = setting(range=NON_NEGATIVE)
    year_days: float = derived(0.0, of=("deltav.year_days",))


@dataclass(frozen=True)
class BoxSettings:
    """Half-widths of the fixed-element box controller."""

    ecc: float = setting(life_estimate=True, range=POSITIVE)
    aop_deg: float = setting(life_estimate=True, range=POSITIVE)
    inc_deg: float = setting(life_estimate=True, range=POSITIVE)
    raan_rel_deg: float = setting(range=POSITIVE)
    u_rel_deg: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class ServiceSettings:
    """What the service controller holds: a safe perilune and the navigation service."""

    perilune_margin_km: float = setting(life_estimate=True, range=NON_NEGATIVE)
    safety_check_days: float = setting(life_estimate=True, range=POSITIVE)
    safety_lead_days: float = setting(life_estimate=True, range=POSITIVE)
    nav_window_days: float = setting(life_estimate=True, range=POSITIVE)
    nav_avail_drop_pct: float = setting(life_estimate=True, range=NON_NEGATIVE)
    nav_dop_rise_fraction: float = setting(life_estimate=True, range=NON_NEGATIVE)
    raan_rel_deg: float = setting(life_estimate=True, range=POSITIVE)
    u_rel_deg: float = setting(life_estimate=True, range=POSITIVE)
    tolerances: str = setting(life_estimate=True, choices=TOLERANCE_SOURCES)
    tolerance_arc_days: float = setting(range=POSITIVE)
    tolerance_step_s: float = setting(range=POSITIVE)
    raan_rel_bounds_deg: tuple[float, float] = setting(
        life_estimate=True, range=(0.0, 90.0, True, False), pair=True
    )
    u_rel_bounds_deg: tuple[float, float] = setting(range=(0.0, 180.0, True, False), pair=True)


@dataclass(frozen=True)
class DesignLifeSettings:
    """Closed-loop station keeping over the design life."""

    life_days: float = setting(range=POSITIVE)
    check_interval_days: float = setting(life_estimate=True, range=POSITIVE)
    samples_per_orbit: int = setting(
        range=(16, None, False, False),
        why="the one-orbit mean elements of the checks and the insertion trim "
        "average this many samples of an orbit (at least 8 to be computed at "
        "all, 16 for an e = 0.6 orbit's mean a to settle)",
    )
    min_maneuver_spacing_days: float = setting(life_estimate=True, range=NON_NEGATIVE)
    dv_cap_kms_per_year: float = setting(range=NON_NEGATIVE)
    slot_coast_days: float = setting(life_estimate=True, range=POSITIVE)
    slot_fit_days: float = setting(range=POSITIVE)
    slot_quad_days: float = setting(range=POSITIVE)
    target_fraction: float = setting(
        life_estimate=True,
        range=(0.0, 1.0, False, True),
        why="a correction aims this fraction of the half-width past the "
        "reference: 1 would aim at the far edge of the box",
    )
    tide_period_days: float = setting(range=POSITIVE)
    box_tolerance: float = setting(range=NON_NEGATIVE)
    integrator_setting: str = setting(names_integrator_setting=True)
    initial_trim: bool
    controller: str = setting(choices=CONTROLLERS)
    box: BoxSettings
    service: ServiceSettings


@dataclass(frozen=True)
class BenchmarkSettings:
    """Notebook 10: every catalogue constellation on one yardstick."""

    extra_masks_deg: tuple[float, ...] = setting(range=(0.0, 90.0, False, True))
    campaign_picks: bool
    closed_loop_life: bool
    epoch_constellations: tuple[str, ...]
    epochs_tdb: tuple[str, ...] = setting(form="iso_datetime", non_empty=True)


@dataclass(frozen=True)
class LifeEvaluationSettings:
    """A design over its design life: sampling, months, and the notebook's validation sets."""

    sample_step_s: float = setting(range=POSITIVE)
    month_days: float = setting(range=POSITIVE)
    notebook_life_days: float
    convergence_life_days: float
    convergence_sats: int
    validation_life_days: float
    validation_max_sats_per_plane: int
    validation_front_designs: int
    anchor_life_days: float
    validation_frames: tuple[str, ...] = setting(choices=ELEMENT_FRAMES)
    frame_rerun_designs: int = setting(range=NON_NEGATIVE)
    validation_designs: tuple[
        tuple[int | float, ...], ...
    ]  # Walker rows (a_km, e, aop, inc, planes, per plane)
    screen_validation_designs: int = setting(
        range=NON_NEGATIVE
    )  # random Table 3 designs of studies.screen_validation
    screen_validation_life_days: float = setting(
        range=NON_NEGATIVE
    )  # ... flown this long (0: the screened profile's screen span)


@dataclass(frozen=True)
class LifeNavigationSettings:
    """Notebook 08's check of the life-long availability estimate against the closed loop (studies.life_navigation)."""

    designs: int = setting(
        range=NON_NEGATIVE
    )  # whole designs flown, the first of the study's list (0: off)
    life_days: float = setting(
        range=NON_NEGATIVE
    )  # ... flown this long (0: the operational companion's [design_life] life_days)


@dataclass(frozen=True)
class RobustnessSettings:
    """Insertion dispersions flown in closed loop (studies.robustness): 1-sigma errors of the mean elements."""

    draws: int = setting(
        range=(0, 10_000, False, False),
        why="each draw is a closed-loop flight of every satellite of the design",
    )  # 0: off
    flown_days: float = setting(
        range=(1.0, 36525.0, False, False)
    )  # each draw flown this long (not the design life)
    seed: int = setting(range=NON_NEGATIVE)
    sma_km: float = setting(range=NON_NEGATIVE)
    ecc: float = setting(
        range=(0.0, 0.1, False, False), why="an insertion error, not another orbit"
    )
    inc_deg: float = setting(
        range=(0.0, 10.0, False, False), why="an insertion error, not another orbit"
    )
    raan_deg: float = setting(
        range=(0.0, 10.0, False, False), why="an insertion error, not another orbit"
    )
    aop_deg: float = setting(range=(0.0, 180.0, False, False))
    anomaly_deg: float = setting(range=(0.0, 180.0, False, False))


@dataclass(frozen=True)
class FrontValidationSettings:
    """The front flown in closed loop after NSGA-II and the headline's bounds."""

    max_designs: int = setting(range=NON_NEGATIVE)  # 0: off
    max_sats_per_plane: int = setting(range=NON_NEGATIVE)  # 0: every satellite
    headline_sizes: tuple[int, ...] = setting(range=(1, None, False, False))
    headline_per_size: int = setting(range=NON_NEGATIVE)
    availability_min_pct: float = setting(range=(0.0, 100.0, False, False))
    dv_max_kms_per_year: float = setting(range=POSITIVE)


@dataclass(frozen=True)
class ProfileSections:
    """Every section of a profile: the schema the loader checks a profile against, key by key."""

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
