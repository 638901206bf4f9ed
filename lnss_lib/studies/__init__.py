"""Studies: one module per notebook. Each module's docstring states the question it answers and the verdict.

``propagator_validation`` (01), ``dop_grid`` (02), ``gps_link`` (03), ``deltav_models`` (04),
``standalone_elfo`` (05). Only notebooks, ``__main__``, ``bench`` and tests import this package (and
``lnss_lib.figures``).
"""
