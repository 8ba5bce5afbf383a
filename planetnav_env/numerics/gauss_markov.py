"""First-order Gauss-Markov processes: slowly varying errors (a camera's boresight drift, a thruster's
execution error) with a standard deviation and a correlation time.

The process ``dx = -x / tau dt + sqrt(2 / tau) sigma dW`` is stationary with variance ``sigma^2`` and
autocorrelation ``exp(-|lag| / tau)``. Sampled every ``dt`` it is exactly the autoregression

    x[k+1] = phi x[k] + sigma sqrt(1 - phi^2) w[k],   phi = exp(-dt / tau),   w[k] ~ N(0, 1),

whatever ``dt`` is (no discretization error), and a stationary start draws ``x[0] = sigma w``.
``tests/env/test_gauss_markov.py`` holds Monte Carlo draws of it to that variance and autocorrelation.
"""

from __future__ import annotations

import math

from planetnav_env.numerics.jit import row_kernel


@row_kernel
def gauss_markov_step(x, sigma, tau_s, dt_s, w) -> float:  # pragma: no cover - compiled
    """The process ``dt_s`` [s] after the value ``x``, driven by the standard normal draw ``w``; ``sigma``
    in the unit of ``x``, correlation time ``tau_s`` [s] > 0. ``dt_s`` = 0 returns ``x``."""
    phi = math.exp(-dt_s / tau_s)
    return phi * x + sigma * math.sqrt(max(0.0, 1.0 - phi * phi)) * w
