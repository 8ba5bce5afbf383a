"""The thrust arc's execution error in truth as its documented first-order Gauss-Markov process
(``world.thrust_gauss_markov``), against the process's stated definition.

The draws are the env's own: the rows' error columns (``F_THR_GM``: magnitude fraction, two pointing
angles) of a batch of ThrustArc episodes stepped by the compiled core. By definition
(``numerics.gauss_markov``) each component is stationary with variance sigma^2 and autocorrelation
``exp(-lag / tau)``, sigma and tau the operations options; across the rows (independent episodes) the
sample variance and correlation must match within their Monte Carlo error. The filter keeps its
white-noise Q, and the matched world's draws do not move.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_env.batch import BatchCore
from planetnav_env.core import layout as L
from planetnav_env.tasks import get_version
from planetnav_env.world import WorldConfig

ID = "planetnav/ThrustArc-TCM-v0"
STAY = 3.0  # the action that holds the thrust attitude


def _core(world, rows: int, seed0: int = 100) -> BatchCore:
    core = BatchCore(get_version(ID).config(world=world), rows)
    core.reset_rows(np.arange(rows), [np.random.default_rng(seed0 + r) for r in range(rows)])
    return core


def test_the_envs_draws_have_the_processs_variance_and_autocorrelation() -> None:
    rows, steps = 1000, 120
    core = _core(WorldConfig(thrust_gauss_markov=True), rows)
    ops, dt = core.config.operations, core.config.step_s
    sig = np.array([ops.thrust_mag_sigma, *(2 * [math.radians(ops.thrust_point_sigma_deg)])])
    tau = ops.thrust_corr_time_s
    acts = np.full((rows, 1), STAY)
    path = np.empty((steps + 1, rows, 3))
    path[0] = core.f[:, L.F_THR_GM : L.F_THR_GM + 3]
    for k in range(steps):
        core.step(acts)
        path[k + 1] = core.f[:, L.F_THR_GM : L.F_THR_GM + 3]
    z = path / sig  # unit variance by definition, each component
    # Stationary: the variance is sigma^2 at the start and after 20 h (5 sigma of a variance of 1000 draws
    # is 0.22; the two pointing axes pooled: 0.16).
    for k in (0, steps // 2, steps):
        assert abs(np.var(z[k, :, 0]) - 1.0) < 0.22, k
        assert abs(np.var(z[k, :, 1:]) - 1.0) < 0.16, k
        assert abs(np.mean(z[k])) < 0.1
    # Autocorrelation exp(-lag / tau) at lags of 2, 10 and 20 h (the correlation's sampling error with
    # 3000 pairs is below 0.02: 0.06 is 3 of them and more).
    for lag in (12, 60, 120):
        rho = np.mean(z[0] * z[lag]) / math.sqrt(np.mean(z[0] ** 2) * np.mean(z[lag] ** 2))
        assert rho == pytest.approx(math.exp(-lag * dt / tau), abs=0.06), lag
    # The driving noise: w_k = (z_{k+1} - phi z_k) / sqrt(1 - phi^2) is white N(0, 1), independent of z_k.
    phi = math.exp(-dt / tau)
    w = (z[1:] - phi * z[:-1]) / math.sqrt(1.0 - phi * phi)
    assert abs(np.var(w) - 1.0) < 0.02 and abs(np.mean(w)) < 0.01
    assert abs(np.mean(w * z[:-1])) < 0.01
    assert abs(np.mean(w[1:] * w[:-1])) < 0.01  # no correlation from step to step


def test_the_error_acts_along_and_across_the_thrust() -> None:
    """One step of two cores that differ only in the error columns: the truth's velocities differ by
    ``a t_on (e_m u + e_1 p_1 + e_2 p_2)``, with (u, p_1, p_2) orthonormal: its component along the thrust
    direction u is ``a t_on e_m`` and its size ``a t_on |e|``."""
    world = WorldConfig(thrust_gauss_markov=True)
    a, b = _core(world, 1), _core(world, 1)
    e = np.array([0.03, 0.02, -0.01])
    a.f[0, L.F_THR_GM : L.F_THR_GM + 3] = e
    b.f[0, L.F_THR_GM : L.F_THR_GM + 3] = 0.0
    xe = a.f[0, L.F_XE + 3 : L.F_XE + 6]
    u = xe / np.linalg.norm(xe)  # the planned direction over the step: the estimated velocity's
    a.step(np.array([[STAY]]))
    b.step(np.array([[STAY]]))
    ops, dt = a.config.operations, a.config.step_s
    acc = ops.thrust_accel_km_s2
    t_on = dt - a.f[0, L.F_DV_STEP] / (acc * 1000.0)
    assert t_on > 0.5 * dt  # the engine thrusted
    dv = a.f[0, L.F_X + 3 : L.F_X + 6] - b.f[0, L.F_X + 3 : L.F_X + 6]
    assert np.dot(dv, u) == pytest.approx(acc * t_on * e[0], rel=1e-6)
    assert np.linalg.norm(dv) == pytest.approx(acc * t_on * np.linalg.norm(e), rel=1e-6)
    # The filter does not know the error: its estimate moved alike in both.
    assert np.array_equal(a.f[0, L.F_XE : L.F_XE + 6], b.f[0, L.F_XE : L.F_XE + 6])
    assert np.array_equal(a.p, b.p)


def test_off_it_draws_nothing_and_the_white_error_is_unchanged() -> None:
    plain = _core(WorldConfig(), 4)
    assert not plain.params.scalars[0]["thr_gm"]
    assert not np.any(plain.f[:, L.F_THR_GM : L.F_THR_GM + 3])
    on = _core(WorldConfig(thrust_gauss_markov=True), 4)
    assert on.params.scalars[0]["thr_gm"] and np.all(on.f[:, L.F_THR_GM : L.F_THR_GM + 3] != 0.0)
    mask = np.ones(L.NF, dtype=bool)
    mask[L.F_THR_GM : L.F_THR_GM + 3] = False
    assert np.array_equal(plain.f[:, mask], on.f[:, mask], equal_nan=True)  # drawn last at reset
    assert WorldConfig(preset="flight").thrust_gauss_markov_on and not WorldConfig().thrust_gauss_markov_on
