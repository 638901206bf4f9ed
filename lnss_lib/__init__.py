"""lnss_lib: the helper library behind the LNSS design workbook (Malik & Yang, LNSS optimisation).

Modules follow the domain: ``config`` (profiles), ``ephemeris`` (SPICE, frames, time),
``elements`` (Keplerian conversions), ``gravity``, ``forces``, ``propagator``, ``constellation``,
``dop``, ``gps``, ``deltav``, ``objectives``, ``optimize``, ``figures``, ``pipeline``.
"""

__version__ = "0.1.0"
