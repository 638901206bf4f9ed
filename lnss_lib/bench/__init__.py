"""Benchmarks: ``python -m lnss_lib bench NAME`` runs ``lnss_lib.bench.NAME.run`` and prints numbers."""
