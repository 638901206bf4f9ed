"""Every number quoted from Malik & Yang's paper, in one place.

The workbook compares against these values and never tunes to them; each comparison in a notebook
prints the difference and its reason. Keys use :mod:`lnss_lib.keys` spellings.
"""

from __future__ import annotations

__all__ = [
    "TABLE_4",
    "TABLE_5",
    "FEASIBLE_DESIGNS",
    "EVALUATIONS",
    "TABLE_4_LABEL",
    "SMALL_CONSTELLATION_SATS",
    "SMALLEST_CONSTELLATION",
    "TABLE_6",
    "FRONT_CLAIMS",
]

TABLE_4_LABEL = "paper (Table 4)"

TABLE_4 = {  # standalone ELFO (2 planes x 8), Section 6.1
    "mean_visible_sats": 11.22,
    "pdop_mean_3sigma": 2.17,
    "hdop_mean_3sigma": 0.83,
    "pdop_avail_pct": 100.0,
    "hdop_avail_pct": 100.0,
    "dv_total_kms_per_year": 0.50,
    "dv_opt_kms_per_year": 0.37,
    "gps_visible_mean": 7.74,
    "gps_pdop_mean": 6238.0,
}

TABLE_5 = {  # NSGA-II settings
    "population": 120,
    "generations": 1000,
    "total_evaluations": 120_000,
    "crossover_fraction": 0.65,
    "mutation": "adaptive mutation",
    "pareto_fraction": 0.30,
    "function_tolerance": 1.0e-6,
}

EVALUATIONS = TABLE_5["population"] * TABLE_5["generations"]
FEASIBLE_DESIGNS = 5622  # Section 6.2: unique feasible configurations found
SMALL_CONSTELLATION_SATS = (
    6,
    9,
)  # Section 6.2: Table 6 shows "significantly small LNSS constellation (6-9 satellites)"
SMALLEST_CONSTELLATION = {  # abstract: "over 90% south pole coverage ... using as few as six satellites and
    "n_sat": 6,
    "availability_pct": 90.0,  # Delta-V of less than 0.4 km/s per satellite per year"
    "dv_below_kms_per_year": 0.4,
}
TABLE_6 = {  # Table 6 (its rows are withheld in the workbook's copy of the paper): 14 designs
    "designs": 14,
    "availability_min_pct": 90.0,
    "dv_total_max_kms_per_year": 1.0,  # with PDOP and HDOP availability
}  # >= 90 % and Delta-V <= 1 km/s per satellite per year
FRONT_CLAIMS = {  # Section 6.2 on Figures 8-15: (low, high) of the front's designs as the text gives them
    "dv_opt_kms_per_year": (
        0.0,
        0.4,
    ),  # Figure 8: the best trade-offs lie below 0.4 km/s/yr (Delta-V_opt)
    "gps_pdop_mean": (3862.0, 10883.0),  # Figure 9: GPS-LNSS PDOP 3862-10883
    "hdop_mean_3sigma": (1.0, 5.0),  # Figure 11: HDOP of all solutions between 1 and 5
    "ecc": (0.6, 0.7),  # Figure 15: most solutions highly elliptical, 0.6 < e < 0.7
}
