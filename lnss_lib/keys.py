"""Design, metric and result keys: one spelling everywhere (evaluator, campaign, tables, CLI JSON)."""

from __future__ import annotations

__all__ = ["DESIGN_KEYS", "INTEGER_DESIGN_KEYS", "ELEMENT_KEYS", "METRIC_KEYS", "EXTRA_METRIC_KEYS",
           "CAMPAIGN_METRIC_KEYS", "RESULT_KEYS", "VERDICT_KEYS", "TIMING_KEYS", "DELTAV_SATELLITES",
           "requested_extra_metrics"]

DESIGN_KEYS = ("sma_km", "ecc", "aop_deg", "inc_deg", "n_planes", "sats_per_plane")   # eq. 45 arguments
INTEGER_DESIGN_KEYS = ("n_planes", "sats_per_plane")
ELEMENT_KEYS = ("sma_km", "ecc", "inc_deg", "raan_deg", "aop_deg", "mean_anomaly_deg")  # one row per satellite

METRIC_KEYS = ("n_sat", "mean_visible_sats", "pdop_mean_3sigma", "pdop_avail_pct", "hdop_mean_3sigma",
               "hdop_avail_pct", "dv_total_kms_per_year", "dv_opt_kms_per_year", "gps_visible_mean", "gps_pdop_mean")
# operational metrics, computed only when ``[evaluator] extra_metrics`` names them (issue 11 item 5):
# geometry-keeping Delta-V estimate (sk_estimate, mean and max over satellites), design-life stability
# screen (stability: 1.0 stable, 0.0 not; minimum perilune altitude), and the eq. 45 Delta-V's maximum
# over satellites ([deltav] satellites = "all")
EXTRA_METRIC_KEYS = ("sk_dv_estimate_kms_per_year", "sk_dv_estimate_max_kms_per_year", "stable_screen",
                     "screen_min_perilune_alt_km", "dv_total_max_kms_per_year", "dv_opt_max_kms_per_year")
CAMPAIGN_METRIC_KEYS = METRIC_KEYS + EXTRA_METRIC_KEYS   # what a campaign journal record holds
# "evaluated": the design was evaluated (no impact, a closed orbit); whether it meets Table 3's bounds is VERDICT_KEYS
RESULT_KEYS = METRIC_KEYS + ("deltav_model", "evaluated", "reason", "wall_s")
VERDICT_KEYS = ("meets_bounds", "violated_bounds")   # evaluate CLI: the profile's [campaign.constraints] (Table 3)
TIMING_KEYS = ("propagation", "dop", "deltav", "gps", "operational")   # operational: the extra metrics
DELTAV_SATELLITES = ("first", "all")        # [deltav] satellites: the eq. 45 Delta-V of satellite 0, or mean over all
_NEEDS_ALL_SATELLITES = ("dv_total_max_kms_per_year", "dv_opt_max_kms_per_year")


def requested_extra_metrics(profile: dict) -> tuple[str, ...]:
    """``[evaluator] extra_metrics`` of a profile, checked: distinct names of :data:`EXTRA_METRIC_KEYS`
    (the Delta-V maxima need ``[deltav] satellites = "all"``); ConfigError naming the bad entry."""
    from .errors import ConfigError

    section = profile.get("evaluator", {})
    unknown = set(section) - {"extra_metrics"}
    if unknown:
        raise ConfigError(f"unknown [evaluator] setting(s) {sorted(unknown)}; allowed: extra_metrics",
                          key=f"evaluator.{sorted(unknown)[0]}")
    names = section.get("extra_metrics", [])
    if not isinstance(names, (list, tuple)) or any(not isinstance(n, str) or n not in EXTRA_METRIC_KEYS for n in names) \
            or len(set(names)) != len(names):
        raise ConfigError(f"[evaluator] extra_metrics must be a list of distinct names from "
                          f"{', '.join(EXTRA_METRIC_KEYS)}; got {names!r}", key="evaluator.extra_metrics")
    satellites = profile.get("deltav", {}).get("satellites", "first")
    needs_all = [n for n in names if n in _NEEDS_ALL_SATELLITES]
    if needs_all and satellites != "all":
        raise ConfigError(f"[evaluator] extra_metrics {needs_all} are maxima over satellites: they need "
                          f'[deltav] satellites = "all"; got {satellites!r}', key="deltav.satellites")
    return tuple(names)
