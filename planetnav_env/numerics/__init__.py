"""Numerical support: the numba compile settings, its on-disk cache, and portable math."""
