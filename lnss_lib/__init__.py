"""lnss_lib: the helper library behind the LNSS design workbook (Malik & Yang, LNSS optimisation).

Layers (a module imports only from its own layer or a lower one):

1. Foundations: ``config`` (profiles), ``constants`` (units in the names), ``paper`` (numbers quoted
   from the paper), ``keys`` (one spelling of design, metric and result keys), ``errors``.
2. Physics kernels (numpy, numba, scipy, xarray; no pandas, plotting or campaign machinery):
   ``ephemeris`` (SPICE kernels, bodies, tabulated geometry), ``frames`` (element frames, Moon-fixed
   rotation, RTN, precession-nutation, TEME -> J2000, time scales), ``elements``, ``gravity``,
   ``forces``, ``propagator``, ``reference`` and ``validation`` (independent checks), ``tle`` (TLE
   reading, checks, selection), ``geometry`` (the shared position block of (G^T G)^-1, filtered means,
   availability), ``dop`` (south-pole grid), ``gps`` (GPS states and link), ``gve`` (Gauss variational
   equations and their inverses), ``deltav`` (station-keeping budgets), ``constellation``,
   ``evaluator`` (the design evaluator).
   ``design_life`` (the design-life package: averaged model and screen, estimate, manoeuvres, control,
   closed loop, evaluation, frozen orbits; its docstring draws the picture); ``catalogue`` (published
   constellations).
3. Campaign engine: ``campaign`` (settings, grid, fitness, tasks, journal, backends, problem, rundir,
   runner and callbacks, timing).
4. Presentation and studies: ``outputs``, ``pipeline``, ``figures``, ``studies`` (one module per
   notebook; each docstring states the question and the verdict), ``explorer``.
   Top: ``__main__`` (argument parsing), ``cli`` (the evaluate command's results), ``bench``.
"""

__version__ = "0.1.0"
