"""Design, metric and result keys: one spelling everywhere (evaluator, campaign, tables, CLI JSON)."""

from __future__ import annotations

__all__ = [
    "DESIGN_KEYS",
    "INTEGER_DESIGN_KEYS",
    "ELEMENT_KEYS",
    "METRIC_KEYS",
    "LIFE_NAVIGATION_KEYS",
    "NAVIGATION_ERROR_KEYS",
    "EXTRA_METRIC_KEYS",
    "CAMPAIGN_METRIC_KEYS",
    "GNSS_SYSTEM_METRICS",
    "GNSS_NAMES",
    "gnss_metric_keys",
    "RESULT_KEYS",
    "VERDICT_KEYS",
    "TIMING_KEYS",
    "DELTAV_SATELLITES",
    "NEEDS_ALL_SATELLITES",
    "CLOSED_LOOP_DV_BY_PURPOSE",
    "closed_loop_dv_key",
    "requested_extra_metrics",
    "wants_life_estimate",
    "runs_screen",
    "NON_NAVIGATION_METRICS",
    "LABELS",
    "label",
    "bound_text",
    "value_format",
    "format_value",
    "design_text",
    "violated_bound",
]

DESIGN_KEYS = (
    "sma_km",
    "ecc",
    "aop_deg",
    "inc_deg",
    "n_planes",
    "sats_per_plane",
)  # eq. 45 arguments
INTEGER_DESIGN_KEYS = ("n_planes", "sats_per_plane")
ELEMENT_KEYS = (
    "sma_km",
    "ecc",
    "inc_deg",
    "raan_deg",
    "aop_deg",
    "mean_anomaly_deg",
)  # one row per satellite

METRIC_KEYS = (
    "n_sat",
    "mean_visible_sats",
    "pdop_mean_3sigma",
    "pdop_avail_pct",
    "hdop_mean_3sigma",
    "hdop_avail_pct",
    "dv_total_kms_per_year",
    "dv_opt_kms_per_year",
    "gps_visible_mean",
    "gps_pdop_mean",
)
# operational metrics, computed only when ``[evaluator] extra_metrics`` names them:
# geometry-keeping Delta-V estimate (sk_estimate, mean and max over satellites), design-life stability
# screen (stability: 1.0 stable, 0.0 not; minimum perilune altitude), and the eq. 45 Delta-V's maximum
# over satellites ([deltav] satellites = "all")
# navigation over the design life, from the life estimate's rebuilt constellation ([sk_estimate] model = "life"):
# PDOP and HDOP availability, mean over the life and worst month
LIFE_NAVIGATION_KEYS = (
    "pdop_avail_pct_life_estimate",
    "pdop_avail_pct_worst_month_estimate",
    "hdop_avail_pct_life_estimate",
    "hdop_avail_pct_worst_month_estimate",
)
# the user's position error in metres ([navigation_error], lnss_lib/navigation_error.py): 95th percentiles over the
# grid-epoch samples of the horizontal (2 sigma_H) and vertical (1.96 sigma_V) 95 % errors, availability of the
# profile's position-error requirement, the oldest broadcast ephemeris and the satellites no station ever uploads
NAVIGATION_ERROR_KEYS = (
    "horizontal_error_95_m",
    "vertical_error_95_m",
    "position_error_avail_pct",
    "ephemeris_age_max_h",
    "satellites_never_uploaded",
)
# and the multi-GNSS link over ``[gnss] systems`` (mean visible satellites, filtered mean PDOP with one clock per system)
EXTRA_METRIC_KEYS = (
    "sk_dv_estimate_kms_per_year",
    "sk_dv_estimate_max_kms_per_year",
    "stable_screen",
    "screen_min_perilune_alt_km",
    "dv_total_max_kms_per_year",
    "dv_opt_max_kms_per_year",
    *LIFE_NAVIGATION_KEYS,
    *NAVIGATION_ERROR_KEYS,
    "gnss_visible_mean",
    "gnss_pdop_mean",
)
GNSS_SYSTEM_METRICS = (
    "gnss_{}_visible_mean",
    "gnss_{}_pdop_mean",
)  # per system, when [gnss] names more than GPS
GNSS_NAMES = {
    "gps": "GPS",
    "galileo": "Galileo",
    "beidou": "BeiDou-3",
    "glonass": "GLONASS",
}  # [gnss] systems


def gnss_metric_keys(systems) -> tuple[str, ...]:
    """The GNSS link's keys of an evaluation under ``[gnss] systems``: none for GPS alone (the paper's link), else
    the combined ``gnss_visible_mean``, ``gnss_pdop_mean`` and each system's (:data:`GNSS_SYSTEM_METRICS`)."""
    if tuple(systems) == ("gps",):
        return ()
    return ("gnss_visible_mean", "gnss_pdop_mean") + tuple(
        key.format(s) for s in systems for key in GNSS_SYSTEM_METRICS
    )


CAMPAIGN_METRIC_KEYS = METRIC_KEYS + EXTRA_METRIC_KEYS  # what a campaign journal record holds
# "evaluated": the design was evaluated (no impact, a closed orbit); whether it meets Table 3's bounds is VERDICT_KEYS
RESULT_KEYS = METRIC_KEYS + ("deltav_model", "evaluated", "reason", "wall_s")
VERDICT_KEYS = (
    "meets_bounds",
    "violated_bounds",
)  # evaluate CLI: the profile's [campaign.constraints] (Table 3)
TIMING_KEYS = (
    "propagation",
    "dop",
    "deltav",
    "gps",
    "operational",
)  # operational: the extra metrics
DELTAV_SATELLITES = (
    "first",
    "all",
)  # [deltav] satellites: the eq. 45 Delta-V of satellite 0, or mean over all
NEEDS_ALL_SATELLITES = ("dv_total_max_kms_per_year", "dv_opt_max_kms_per_year")
# metrics of station keeping and stability: a campaign's bounds on anything else are its navigation bounds
NON_NAVIGATION_METRICS = (
    "dv_total_kms_per_year",
    "dv_opt_kms_per_year",
    "sk_dv_estimate_kms_per_year",
    "sk_dv_estimate_max_kms_per_year",
    "dv_total_max_kms_per_year",
    "dv_opt_max_kms_per_year",
    "stable_screen",
    "screen_min_perilune_alt_km",
)

LABELS = {  # key -> human label with its unit: figures, tables, explorer, ``evaluate``
    "sma_km": "semi-major axis (km)",
    "ecc": "eccentricity",
    "aop_deg": "argument of perilune (deg)",
    "inc_deg": "inclination (deg)",
    "raan_deg": "RAAN (deg)",
    "mean_anomaly_deg": "mean anomaly (deg)",
    "n_planes": "planes",
    "sats_per_plane": "satellites per plane",
    "n_sat": "satellites",
    "mean_visible_sats": "mean visible LNSS satellites",
    "pdop_mean_3sigma": "PDOP (3-sigma mean)",
    "pdop_avail_pct": "PDOP availability (%)",
    "hdop_mean_3sigma": "HDOP (3-sigma mean)",
    "hdop_avail_pct": "HDOP availability (%)",
    "dv_total_kms_per_year": "Delta-V total (km/s/yr)",
    "dv_opt_kms_per_year": "Delta-V optimised (km/s/yr)",
    "gps_visible_mean": "GPS satellites visible (mean, first LNSS satellite)",
    "gps_pdop_mean": "GPS-LNSS PDOP (first LNSS satellite)",
    "gnss_visible_mean": "GNSS satellites visible, every [gnss] system (mean, first LNSS satellite)",
    "gnss_pdop_mean": "GNSS-LNSS PDOP, every [gnss] system, one clock each (first LNSS satellite)",
    "sk_dv_estimate_kms_per_year": "geometry-keeping Delta-V, mean (km/s/yr)",
    "sk_dv_estimate_max_kms_per_year": "geometry-keeping Delta-V, worst satellite (km/s/yr)",
    "stable_screen": "stable over the life (screen)",
    "screen_min_perilune_alt_km": "lowest perilune over the life (km)",
    "dv_total_max_kms_per_year": "Delta-V total, worst satellite (km/s/yr)",
    "dv_opt_max_kms_per_year": "Delta-V optimised, worst satellite (km/s/yr)",
    "deltav_model": "Delta-V model",
    "horizontal_error_95_m": "horizontal 95 % error, 95th percentile (m)",
    "vertical_error_95_m": "vertical 95 % error, 95th percentile (m)",
    "position_error_avail_pct": "position-error requirement availability (%)",
    "ephemeris_age_max_h": "oldest broadcast ephemeris (h)",
    "satellites_never_uploaded": "satellites never uploaded",
    "wall_s": "wall time (s)",
    "evaluated": "evaluated (closed orbit, no impact)",
    "reason": "reason not evaluated",
    "meets_bounds": "meets every Table 3 bound",
    "violated_bounds": "Table 3 bounds violated",
    "element_frame": "element frame",
    "epoch_used": "epoch (TDB)",
    "epoch_source": "epoch from",
    # the front flown in closed loop (validated.nc, lnss_lib.campaign.validation)
    "closed_loop_dv_kms_per_year": "closed-loop Delta-V, mean (km/s/yr)",
    "closed_loop_dv_max_kms_per_year": "closed-loop Delta-V, worst satellite (km/s/yr)",
    "pdop_avail_pct_life": "PDOP availability over the life (%)",
    "hdop_avail_pct_life": "HDOP availability over the life (%)",
    "pdop_avail_pct_worst_month": "PDOP availability, worst month (%)",
    "hdop_avail_pct_worst_month": "HDOP availability, worst month (%)",
    "n_minus_1_sat": "satellite whose loss costs most (N-1)",
    "pdop_avail_pct_worst_month_n_minus_1": "PDOP availability, worst month, worst satellite lost (%)",
    "pdop_avail_pct_life_n_minus_1": "PDOP availability over the life, worst satellite lost (%)",
    "hdop_avail_pct_worst_month_n_minus_1": "HDOP availability, worst month, worst satellite lost (%)",
    "hdop_avail_pct_life_n_minus_1": "HDOP availability over the life, worst satellite lost (%)",
    "pdop_avail_pct_life_estimate": "PDOP availability over the life, estimated (%)",
    "pdop_avail_pct_worst_month_estimate": "PDOP availability, worst month, estimated (%)",
    "pdop_avail_pct_worst_month_error": "PDOP availability, worst month, estimate - closed loop (points)",
    "hdop_avail_pct_life_estimate": "HDOP availability over the life, estimated (%)",
    "hdop_avail_pct_worst_month_estimate": "HDOP availability, worst month, estimated (%)",
    "min_perilune_alt_km": "lowest perilune under control (km)",
    "impact_day": "first satellite lost (day)",
    "n_lost": "satellites lost",
    "requirement_held": "every tolerance held",
    "n_maneuvers": "manoeuvres",
    "status": "closed-loop status",
    "selected_for": "flown as",
    # the campaign's life-long estimate against the closed loop (lnss_lib.studies.front_validation.estimate_table)
    "estimate_mean": "estimated Delta-V, mean (km/s/yr)",
    "closed_loop_mean": "closed-loop Delta-V, mean (km/s/yr)",
    "ratio_mean": "estimate / closed loop, mean",
    "estimate_worst_satellite": "estimated Delta-V, worst satellite (km/s/yr)",
    "closed_loop_worst_satellite": "closed-loop Delta-V, worst satellite (km/s/yr)",
    "ratio_worst_satellite": "estimate / closed loop, worst satellite",
    "estimate_navigation": "estimated navigation Delta-V (km/s/yr)",
    "closed_loop_navigation": "closed-loop navigation Delta-V (km/s/yr)",
    "ratio_navigation": "estimate / closed loop, navigation",
    "constraint_violation": "constraint violation (pymoo CV: sum of the bounds' excesses)",
    # the GPS and multi-GNSS links (notebook 03: lnss_lib.studies.gps_link, gnss_link)
    "visible_mean": "satellites visible (mean)",
    "pdop_mean": "PDOP (mean)",
    "pdop_median": "PDOP (median)",
    "pdop_available_fraction": "PDOP defined (fraction of time)",
    "pdop_ratio_to_paper": "PDOP / paper's",
    "gps_pdop_median": "GPS-LNSS PDOP (median)",
    "gps_pdop_available_fraction": "GPS-LNSS PDOP defined (fraction of time)",
    "gps_pdop_samples_kept": "GPS-LNSS PDOP samples kept",
    "gps_pdop_unfiltered_mean": "GPS-LNSS PDOP, unfiltered (mean)",
    "noise_temperature_k": "noise temperature (K)",
    "cn0_dbhz": "C/N0 (dB-Hz)",
    "eirp_dbw": "EIRP (dBW)",
    "fsl_db": "free-space loss (dB)",
    "g_rx_dbi": "receive antenna gain (dBi)",
    "gain_dbi": "antenna gain (dBi)",
    "ktn_dbw_hz": "noise density kTN (dBW/Hz)",
    "off_boresight_deg": "off-boresight angle (deg)",
    "launch_date": "launch date",
    "launch_date_source": "launch date from",
    "tle_epoch_utc": "TLE epoch (UTC)",
    "days_back_from_tle": "days from the TLE epoch back to the start",
    # the Delta-V models (notebook 04: lnss_lib.deltav, lnss_lib.studies.deltav_models)
    "model_all": "Delta-V model",
    "step_s": "sampling step (s)",
    "lunar_equator_of_epoch": "lunar equator of epoch",  # an element frame, as a column of notebook 04's tables
    "moon_op": "Moon orbital plane (moon_op)",  # the other element frame of those tables
    # the user's position error over the grid (lnss_lib.navigation_error.error_percentiles; notebook 05)
    "horizontal_95_series_m": "horizontal 95 % error, 95th percentile over the grid (m)",
    "vertical_95_series_m": "vertical 95 % error, 95th percentile over the grid (m)",
    "horizontal_95_map_m": "horizontal 95 % error, 95th percentile over the arc (m)",
    "vertical_95_map_m": "vertical 95 % error, 95th percentile over the arc (m)",
    # notebook 10's epoch table
    "epoch_tdb": "epoch (TDB)",
    "moon_node_deg": "longitude of the Moon's ascending node, J2000 ecliptic (deg)",
    # notebook 08's tables (design life, frozen orbits, screen validation)
    "aop_max_deg": "AOP, largest (deg)",
    "aop_min_deg": "AOP, smallest (deg)",
    "aop_op_deg": "AOP in moon_op (deg)",
    "box_held": "box held",
    "ecc_max": "e, largest",
    "ecc_min": "e, smallest",
    "ecc_op": "e in moon_op",
    "ecc_swing": "e, monthly swing",
    "fewer_than_4_pct": "fewer than 4 satellites in view (%)",
    "frozen_inc_deg": "frozen inclination (deg)",
    "inc_off_frozen_deg": "inclination off the frozen one (deg)",
    "inc_op_deg": "inclination in moon_op (deg)",
    "life_days": "design life (days)",
    "min_mean_perilune_alt_km": "lowest mean perilune altitude (km)",
    "month_end_day": "month ends (day)",
    "month_start_day": "month starts (day)",
    "n_epochs": "epochs",
    "n_sat_flown": "satellites flown",
    "natural_impact_day": "natural drift: impact (day)",
    "natural_lost": "natural drift: satellites lost",
    "natural_min_perilune_alt_km": "natural drift: lowest perilune altitude (km)",
    "natural_survives": "natural drift: survives",
    "raan_rel_tolerance_deg": "relative node tolerance (deg)",
    "u_rel_tolerance_deg": "slot tolerance (deg)",
    "read_in": "elements read in",
    "screen_call": "screen's call",
    "screen_impact_day": "screen: impact (day)",
    "screen_wall_s": "screen: wall time (s)",
    "shift_days": "epoch shift (days)",
    "short_period_km": "short-period perilune swing (km)",
    "sk_dv_kms_per_year": "closed-loop Delta-V, mean (km/s/yr)",
    "sk_dv_max_kms_per_year": "closed-loop Delta-V, worst satellite (km/s/yr)",
    "trial_deg": "trial offset (deg)",
    "truth_impact_day": "full model: impact (day)",
    "truth_min_perilune_alt_km": "full model: lowest perilune altitude (km)",
    "truth_wall_s": "full model: wall time (s)",
    "screen_outside_validity": "screen: outside the averaged model's validity",
    "n_designs": "designs",
    "n_agree": "designs agreeing",
    "agreement_pct": "agreement (%)",
    "n_truth_unstable": "designs reaching the surface (full model)",
    "missed_impacts": "missed impacts (designs)",
    "false_alarms": "false alarms (designs)",
    "validity_limit_calls": "called unstable by the validity limit (designs)",
    "validity_limit_false_alarms": "of which surviving (designs)",
}
CLOSED_LOOP_DV_BY_PURPOSE = (
    "closed_loop_dv_{}_kms_per_year"  # the closed loop's Delta-V paid for one burn purpose
)


def closed_loop_dv_key(purpose: str) -> str:
    """The key of the closed-loop Delta-V paid for ``purpose`` (a burn purpose of the design-life controller)."""
    return CLOSED_LOOP_DV_BY_PURPOSE.format(purpose)


def label(key: str) -> str:
    """The human label (with unit) of a design, metric or result key, also with an elevation-mask suffix
    (``pdop_avail_pct_mask20deg`` -> ``"PDOP availability (%), 20 deg mask"``) and the closed loop's Delta-V by purpose
    (``closed_loop_dv_relative_node_kms_per_year`` -> ``"closed-loop Delta-V, relative node (km/s/yr)"``); other text
    is returned as is."""
    base, mask = _unmasked(key)
    if mask and base in LABELS:
        return f"{LABELS[base]}, {mask} deg mask"
    for pattern, text in zip(
        GNSS_SYSTEM_METRICS,
        (
            "{} satellites visible (mean, first LNSS satellite)",
            "{}-LNSS PDOP, own clock (first LNSS satellite)",
        ),
    ):
        head, tail = pattern.split("{}")
        if (
            key.startswith(head)
            and key.endswith(tail)
            and key[len(head) : -len(tail)] in GNSS_NAMES
        ):
            return text.format(GNSS_NAMES[key[len(head) : -len(tail)]])
    head, tail = CLOSED_LOOP_DV_BY_PURPOSE.split("{}")
    if (
        key not in LABELS
        and key.startswith(head)
        and key.endswith(tail)
        and len(key) > len(head) + len(tail)
    ):
        return f"closed-loop Delta-V, {key[len(head) : -len(tail)].replace('_', ' ')} (km/s/yr)"
    for tail, unit in (("_kms_per_year", "km/s/yr"), ("_m_s_per_year", "m/s/yr")):
        if key not in LABELS and key.startswith("dv_") and key.endswith(tail):
            what = key[3 : -len(tail)].replace("_", " ")
            return f"Delta-V{', ' + what if what else ''} ({unit})"
    return LABELS.get(key, key)


def _unmasked(key: str) -> tuple[str, str]:
    """(key without an ``_mask<N>deg`` suffix, N) or (key, "")."""
    base, _, mask = key.rpartition("_mask")
    return (base, mask[:-3]) if base and mask.endswith("deg") and mask[:-3].isdigit() else (key, "")


UNITS = ("km", "deg", "%", "km/s/yr", "s", "m", "h")  # the units a label ends with, in parentheses


def bound_text(key: str, kind: str, limit: float) -> str:
    """A bound in words with the unit after the limit: ``("pdop_avail_pct", "min", 70)`` ->
    ``"PDOP availability >= 70 %"``; ``kind`` is ``"max"`` (<=) or ``"min"`` (>=)."""
    name, _, unit = label(key).rpartition(" (")
    name, unit = (name, " " + unit[:-1]) if name and unit[:-1] in UNITS else (label(key), "")
    return f"{name} {'<=' if kind == 'max' else '>='} {limit:g}{unit}"


def value_format(key: str) -> str:
    """Format spec for a quantity by its key's unit: km as integers, DOP to 2 decimals, Delta-V (km/s/yr)
    to 3, mean counts to 2, percentages and degrees to 1, eccentricity to 3; ``".4g"`` otherwise. An
    elevation-mask suffix (``_mask20deg``) does not change the format."""
    key = _unmasked(key)[0]
    if key.endswith("_kms_per_year") or key in ("ecc",):
        return ".3f"
    if "_pct_" in key:  # a percentage over a span (pdop_avail_pct_life)
        return ".1f"
    if "dop" in key and not key.endswith("_pct"):
        return ".2f"
    if key.endswith("_km"):
        return ".0f"
    if key.endswith(("_m", "_h")):
        return ".1f"
    if (
        key in ("mean_visible_sats", "gps_visible_mean")
        or key.startswith("gnss_")
        and key.endswith("_visible_mean")
    ):
        return ".2f"
    if key.endswith(("_pct", "_deg")):
        return ".1f"
    return ".4g"


def format_value(key: str, value) -> str:
    """``value`` written in the format of ``key`` (:func:`value_format`); NaN as ``"-"``, text unchanged."""
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return str(value)
    if value != value:
        return "-"
    if (
        isinstance(value, numbers.Integral)
        or float(value).is_integer()
        and key in INTEGER_DESIGN_KEYS + ("n_sat",)
    ):
        return str(int(value))
    return format(float(value), value_format(key))


def design_text(design) -> str:
    """A design in words, as the findings and the captions name it (``design``: a mapping or a table row with the
    :data:`DESIGN_KEYS`): ``"a 6100 km, e 0.600, i 82.0 deg, AOP 90.0 deg, 2 planes x 3"``."""
    return (
        f"a {format_value('sma_km', float(design['sma_km']))} km, e {format_value('ecc', float(design['ecc']))}, "
        f"i {format_value('inc_deg', float(design['inc_deg']))} deg, "
        f"AOP {format_value('aop_deg', float(design['aop_deg']))} deg, "
        f"{int(float(design['n_planes']))} planes x {int(float(design['sats_per_plane']))}"
    )


def requested_extra_metrics(evaluator) -> tuple[str, ...]:
    """``[evaluator] extra_metrics`` of the ``[evaluator]`` section (:class:`lnss_lib.settings.EvaluatorSettings`;
    keys sits below settings, so no import): distinct names of :data:`EXTRA_METRIC_KEYS` (the Delta-V maxima need
    ``[deltav] satellites = "all"``), all checked at load (:mod:`lnss_lib.config`)."""
    return tuple(evaluator.extra_metrics)


def wants_life_estimate(extra_metrics) -> bool:
    """Whether ``extra_metrics`` ask for the station-keeping Delta-V estimate or the navigation over the life it
    rebuilds (``sk_dv_estimate*``, :data:`LIFE_NAVIGATION_KEYS`)."""
    return any(k.startswith("sk_dv_estimate") or k in LIFE_NAVIGATION_KEYS for k in extra_metrics)


def runs_screen(extra_metrics, sk_estimate_model: str | None) -> bool:
    """Whether a 10-day evaluation asking for ``extra_metrics`` runs the stability screen (``[stability]``): a
    metric of the screen (``stable_*``, ``screen_*``), or the life estimate (:func:`wants_life_estimate`) under
    ``[sk_estimate] model = "life"``, which starts from the screen's verdict. The one rule of the evaluator (which
    runs the screen) and of the evaluation hash (which covers ``[stability]`` only then)."""
    return any(k.startswith(("stable", "screen")) for k in extra_metrics) or (
        wants_life_estimate(extra_metrics) and sk_estimate_model == "life"
    )


def violated_bound(metrics: dict, bounds) -> str | None:
    """The first of ``bounds`` ``(metric, "min" | "max", limit)`` that ``metrics`` (those present) break, as text,
    else None: ``value > limit`` for a max bound, ``value < limit`` for a min bound, or an undefined (NaN) value;
    the sign of the campaign's normalised constraint (:func:`~lnss_lib.campaign.fitness.constraint_matrix`, where
    an undefined metric violates by ``[campaign] nan_violation``)."""
    for metric, kind, limit in bounds:
        if metric in metrics:
            value = float(metrics[metric])
            if value != value or (value > limit if kind == "max" else value < limit):
                return f"{metric} = {value:.6g} breaks its {kind} {limit:g}"
    return None
