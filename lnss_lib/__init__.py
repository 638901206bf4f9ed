"""lnss_lib: the helper library behind the LNSS design workbook (Malik & Yang, LNSS optimisation).

Modules follow the domain: ``config`` (profiles), ``ephemeris`` (SPICE, frames, time),
``elements`` (Keplerian conversions), ``gravity``, ``forces``, ``propagator``, ``reference`` and
``validation`` (independent checks), ``constellation``, ``dop``, ``gps``, ``deltav``, ``evaluator``
(the design evaluator), ``optimize`` (NSGA-II campaign), ``pareto``, ``figures``, ``pipeline``.
"""

__version__ = "0.1.0"
