"""Batch-first compiled (numba) simulation core of planetnav.

Building blocks live in submodules (``ephemeris_table``, ``rng``, ...); import them directly.
"""
