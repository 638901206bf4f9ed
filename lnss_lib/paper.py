"""Every number quoted from Malik & Yang's paper, in one place.

The workbook compares against these values and never tunes to them; each comparison in a notebook
prints the difference and its reason. Keys use :mod:`lnss_lib.keys` spellings.
"""

from __future__ import annotations

__all__ = ["TABLE_4", "TABLE_5", "FEASIBLE_DESIGNS", "EVALUATIONS", "TABLE_4_LABEL", "SMALL_CONSTELLATION_SATS"]

TABLE_4_LABEL = "paper (Table 4)"

TABLE_4 = {                         # standalone ELFO (2 planes x 8), Section 6.1
    "mean_visible_sats": 11.22, "pdop_mean_3sigma": 2.17, "hdop_mean_3sigma": 0.83, "pdop_avail_pct": 100.0,
    "hdop_avail_pct": 100.0, "dv_total_kms_per_year": 0.50, "dv_opt_kms_per_year": 0.37, "gps_visible_mean": 7.74,
    "gps_pdop_mean": 6238.0,
}

TABLE_5 = {                         # NSGA-II settings
    "population": 120, "generations": 1000, "total_evaluations": 120_000, "crossover_fraction": 0.65,
    "mutation": "adaptive mutation", "pareto_fraction": 0.30, "function_tolerance": 1.0e-6,
}

EVALUATIONS = TABLE_5["population"] * TABLE_5["generations"]
FEASIBLE_DESIGNS = 5622             # Section 6.2: unique feasible configurations found
SMALL_CONSTELLATION_SATS = (6, 9)  # Section 6.2: Table 6 shows "significantly small LNSS constellation (6-9 satellites)"
