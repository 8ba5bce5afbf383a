"""The Gauss-Markov step against Monte Carlo draws of the process's stated definition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_env.numerics.gauss_markov import gauss_markov_step


def _paths(sigma: float, tau: float, dt: float, steps: int, paths: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = sigma * rng.standard_normal(paths)  # stationary start
    out = np.empty((steps, paths))
    w = rng.standard_normal((steps, paths))
    for k in range(steps):
        out[k] = x
        x = np.array([gauss_markov_step(xi, sigma, tau, dt, wi) for xi, wi in zip(x, w[k], strict=True)])
    return out


@pytest.mark.parametrize("dt", [60.0, 3600.0])
def test_variance_and_autocorrelation(dt):
    sigma, tau, paths = 2.5, 6 * 3600.0, 4000
    lags = [0, 1, 3, 6]
    x = _paths(sigma, tau, dt, steps=7, paths=paths, seed=int(dt))
    se = 4.0 / math.sqrt(paths)  # four standard errors of a correlation estimate near 1 or below
    assert np.var(x[-1]) == pytest.approx(sigma**2, rel=4.0 * math.sqrt(2.0 / paths))
    for lag in lags:
        rho = float(np.mean(x[0] * x[lag]) / sigma**2)
        assert rho == pytest.approx(math.exp(-lag * dt / tau), abs=se)


def test_limits():
    assert gauss_markov_step(1.7, 2.0, 100.0, 0.0, 5.0) == 1.7  # no time, no change
    # Far beyond the correlation time the value forgets itself: it is sigma * w.
    assert gauss_markov_step(1.7, 2.0, 1.0, 1e4, 0.3) == pytest.approx(0.6, abs=1e-12)
