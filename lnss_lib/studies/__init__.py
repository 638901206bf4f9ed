"""Studies: one module per notebook. Each module's docstring states the question it answers and the verdict.

Only notebooks, ``__main__``, ``bench`` and tests import this package (and ``lnss_lib.figures``).
"""
