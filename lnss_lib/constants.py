"""Physical constants and unit factors, with the unit in every name (one place for each).

Profile-dependent constants (gravitational parameters, radii, the speed of light used by the
force model) live in ``params/*.toml`` under ``[constants]`` and ``[gravity]``; this module holds
the fixed definitions that the code needs independently of any profile.
"""

from __future__ import annotations

import math

__all__ = [
    "SECONDS_PER_HOUR",
    "SECONDS_PER_DAY",
    "DAYS_PER_JULIAN_YEAR",
    "SECONDS_PER_JULIAN_CENTURY",
    "ARCSEC_RAD",
    "MIN_VISIBLE",
    "BOLTZMANN_J_K",
    "C_M_S",
    "WGS84_A_KM",
    "WGS84_INV_FLATTENING",
    "WGS84_B_KM",
    "WGS84_GM_KM3_S2",
    "WGS84_OMEGA_RAD_S",
    "EARTH_J2",
    "TOLERANCE_FLOOR",
    "MOON_HILL_RADIUS_KM",
    "EARTH_MOON_DISTANCE_KM",
    "SPACECRAFT_MASS_RANGE_KG",
    "CR_MAX",
    "CR_AREA_MASS_MAX_M2_KG",
    "MAX_OUTPUT_SAMPLES",
    "INTEGER_SETTING_MAX",
    "MAX_POPULATION",
    "MAX_GRID_POINTS",
    "TOLERANCE_CEILING",
]

SECONDS_PER_HOUR = 3600.0
SECONDS_PER_DAY = 86400.0
DAYS_PER_JULIAN_YEAR = 365.25
SECONDS_PER_JULIAN_CENTURY = 100.0 * DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY
ARCSEC_RAD = math.pi / (180.0 * 3600.0)

MIN_VISIBLE = 4  # unknowns of a position + clock fix (eq. 5): fewer visible = no fix

BOLTZMANN_J_K = 1.380649e-23  # CODATA 2018, exact
C_M_S = 299792458.0  # speed of light, exact

WGS84_A_KM = 6378.137  # WGS-84 equatorial radius
WGS84_INV_FLATTENING = 298.257223563
WGS84_B_KM = WGS84_A_KM * (1.0 - 1.0 / WGS84_INV_FLATTENING)
WGS84_GM_KM3_S2 = 398600.4418  # WGS-84 (NIMA TR8350.2, Table 3.1), the GNSS orbit models' GM
WGS84_OMEGA_RAD_S = 7.292115e-5  # WGS-84 Earth rotation rate (TR8350.2, Table 3.1)
EARTH_J2 = 1.08262668e-3  # -C20 unnormalised, EGM96 / WGS-84 (TR8350.2, Section 5)

TOLERANCE_FLOOR = (
    1e-14  # integrator rtol/atol: about 100 machine epsilons (45); below, the error test asks
)
# for what rounding cannot resolve (the tightest setting in use, the DOP853 1e-12/1e-14
# reference of bench integrator and design_life.closed_loop.integrator_convergence, sits on it)

# Sanity ranges of physical inputs: values outside are no lunar spacecraft or orbit.
EARTH_MOON_DISTANCE_KM = 384400.0  # mean; beyond it the Earth, not the Moon, is the central body
MOON_HILL_RADIUS_KM = (
    61500.0  # a_moon (m_moon / (3 m_earth))^(1/3) = 384400 x (0.0123 / 3)^(1/3): a lunar
)
# orbit's semi-major axis beyond it is no bound orbit of the Moon
SPACECRAFT_MASS_RANGE_KG = (1e-3, 1e6)  # a gram (chip-scale satellites) to 1000 t (twice the ISS)
CR_MAX = 2.0  # Cr = 1 + specular reflectivity: 2 is a perfect mirror
CR_AREA_MASS_MAX_M2_KG = (
    100.0  # Cr A/m: solar sails reach ~10-50 m^2/kg (IKAROS 1.3, NanoSail-D ~5)
)
MAX_OUTPUT_SAMPLES = 10_000_000  # samples of one propagation's output grid (480 MB per satellite)
INTEGER_SETTING_MAX = (
    2**63 - 1
)  # the largest integer NetCDF-4/HDF5 outputs store (int64): a seed beyond it ran a
# whole campaign whose results could then not be written
MAX_POPULATION = (
    5000  # NSGA-II's survival ranks parents and offspring (2N designs) through a 2N x 2N
)
# domination matrix: 10^8 entries (0.8 GB) at N = 5000; the paper's N is 120
MAX_GRID_POINTS = (
    100_000  # DOP surface grid points: a whole-Moon 1-degree grid is 65,160; the DOP arrays
)
# hold epochs x points x satellites
TOLERANCE_CEILING = (
    1e-3  # integrator rtol/atol: SciPy's default rtol; above it the error test no longer
)
# resolves a lunar orbit (rtol = atol = 1e10 put a 10-day ELFO 16,000 km off)
