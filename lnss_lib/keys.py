"""Design, metric and result keys: one spelling everywhere (evaluator, campaign, tables, CLI JSON)."""

from __future__ import annotations

__all__ = ["DESIGN_KEYS", "INTEGER_DESIGN_KEYS", "ELEMENT_KEYS", "METRIC_KEYS", "RESULT_KEYS", "TIMING_KEYS"]

DESIGN_KEYS = ("sma_km", "ecc", "aop_deg", "inc_deg", "n_planes", "sats_per_plane")   # eq. 45 arguments
INTEGER_DESIGN_KEYS = ("n_planes", "sats_per_plane")
ELEMENT_KEYS = ("sma_km", "ecc", "inc_deg", "raan_deg", "aop_deg", "mean_anomaly_deg")  # one row per satellite

METRIC_KEYS = ("n_sat", "mean_visible_sats", "pdop_mean_3sigma", "pdop_avail_pct", "hdop_mean_3sigma",
               "hdop_avail_pct", "dv_total_kms_per_year", "dv_opt_kms_per_year", "gps_visible_mean", "gps_pdop_mean")
RESULT_KEYS = METRIC_KEYS + ("deltav_model", "feasible", "reason", "wall_s")
TIMING_KEYS = ("propagation", "dop", "deltav", "gps")
