"""What-if updates for planning agents: the core's own measurement model and Joseph update on copies of the
filter's state, returning the position-covariance trace [km^2] a measurement would leave."""

from __future__ import annotations

import numpy as np
from numba import njit

from planetnav_env.estimation.ekf_kernels import (
    planet_model_kernel,
    update_kernel,
)
from planetnav_env.estimation.measurement_kernels import los_basis_kernel


@njit(cache=True)
def coasted_position_trace(p, lookahead_s) -> float:  # pragma: no cover - compiled
    """``trace`` [km^2] of the position covariance ``lookahead_s`` [s] ahead in free flight (r + T v):
    ``trace(P_rr) + 2 T trace(P_rv) + T^2 trace(P_vv)``; exactly ``trace(P_rr)`` for T = 0. A scoring
    horizon for planning agents, not the filter's propagation: the gravity gradient's share, ~mu T^2 /
    r^3, is below 1e-4 at 1 AU for T up to 12 h."""
    tr = p[0, 0] + p[1, 1] + p[2, 2]
    if lookahead_s != 0.0:
        t = lookahead_s
        tr += 2.0 * t * (p[0, 3] + p[1, 4] + p[2, 5]) + t * t * (p[3, 3] + p[4, 4] + p[5, 5])
    return tr


@njit(cache=True)
def predicted_planet_trace(prm, x, p, planet, idx, n_meas, lookahead_s=0.0) -> float:  # pragma: no cover
    """``trace(P_rr)`` [km^2] after ``n_meas`` images of planet ``idx`` (at ``planet``, the filter's frame)
    from estimate ``x`` (6,) and covariance ``p`` (6, 6), neither modified: the core's measurement model
    and Joseph update, with R / n_meas (n identical measurements of a nearly static state equal one with
    R / n) and zero innovation (the covariance does not depend on it). Ungated. With ``lookahead_s`` > 0,
    the trace of the updated position covariance coasted that far ahead (:func:`coasted_position_trace`)."""
    ps = prm.scalars[0]
    kind = ps.kind
    xc = x.copy()
    pc = p.copy()
    basis = np.zeros((2, 3))
    if kind >= 2:
        los_basis_kernel(planet, xc, basis)
    h = np.empty(3)
    jac = np.empty((3, 6))
    rcov = np.empty((3, 3))
    m = planet_model_kernel(
        xc[:3], planet, 2.0 * prm.radii[idx], kind, ps.sig_dir, ps.sig_size, basis, h, jac, rcov
    )
    for a in range(m):
        for c in range(m):
            rcov[a, c] /= n_meas
    update_kernel(xc, pc, h.copy(), h, jac, rcov, m, 1 if kind <= 1 else -1, np.inf, np.empty((5, 6, 6)))
    return coasted_position_trace(pc, lookahead_s)


@njit(cache=True)
def predicted_pulsar_trace(prm, p, j, lookahead_s=0.0) -> float:  # pragma: no cover - compiled
    """``trace(P_rr)`` [km^2] after one phase of pulsar ``j`` (``H = n / lambda`` on the position,
    ``R = sigma_phase^2``): the core's scalar update on a copy of ``p`` (coasted ``lookahead_s`` ahead, as
    in :func:`predicted_planet_trace`)."""
    pc = p.copy()
    x = np.zeros(6)
    jac = np.zeros((3, 6))
    for k in range(3):
        jac[0, k] = prm.psr[j, k] / prm.psr[j, 3]
    rcov = np.zeros((3, 3))
    rcov[0, 0] = prm.psr[j, 4] ** 2
    h = np.zeros(3)
    update_kernel(x, pc, h.copy(), h, jac, rcov, 1, -1, np.inf, np.empty((5, 6, 6)))
    return coasted_position_trace(pc, lookahead_s)
