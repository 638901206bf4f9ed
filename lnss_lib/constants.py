"""Physical constants and unit factors, with the unit in every name (one place for each).

Profile-dependent constants (gravitational parameters, radii, the speed of light used by the
force model) live in ``params/*.toml`` under ``[constants]`` and ``[gravity]``; this module holds
the fixed definitions that the code needs independently of any profile.
"""

from __future__ import annotations

import math

__all__ = ["SECONDS_PER_DAY", "DAYS_PER_JULIAN_YEAR", "SECONDS_PER_JULIAN_CENTURY", "ARCSEC_RAD",
           "MIN_VISIBLE", "BOLTZMANN_J_K", "C_M_S", "WGS84_A_KM", "WGS84_INV_FLATTENING", "WGS84_B_KM"]

SECONDS_PER_DAY = 86400.0
DAYS_PER_JULIAN_YEAR = 365.25
SECONDS_PER_JULIAN_CENTURY = 36525.0 * SECONDS_PER_DAY
ARCSEC_RAD = math.pi / (180.0 * 3600.0)

MIN_VISIBLE = 4                     # unknowns of a position + clock fix (eq. 5): fewer visible = no fix

BOLTZMANN_J_K = 1.380649e-23        # CODATA 2018, exact
C_M_S = 299792458.0                 # speed of light, exact

WGS84_A_KM = 6378.137               # WGS-84 equatorial radius
WGS84_INV_FLATTENING = 298.257223563
WGS84_B_KM = WGS84_A_KM * (1.0 - 1.0 / WGS84_INV_FLATTENING)
