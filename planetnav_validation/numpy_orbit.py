"""Numpy orbit propagation checks: the RK4 state transition matrix, the thesis's ``I + F dt``, trajectories
and two-body invariants.

Over :mod:`planetnav_env.dynamics.orbit` (state ``x = [r, v]`` [km, km/s] relative to the central body,
ICRF axes, time TDB [s], batched ``(N, 6)``). The numpy EKF (:mod:`planetnav_validation.numpy_ekf`) runs
:func:`rk4_step_stm` and :func:`euler_stm`; the compiled filter's STM
(:func:`planetnav_env.estimation.ekf_kernels.rk4_stm_kernel`) is held to it. ``tests/env/test_orbit.py``
measures both STMs against finite differences of the flow and checks energy and angular momentum.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.dynamics.orbit import GravityModel, PerturberFn, check_step, rk4_step, step_inputs
from planetnav_env.errors import InvalidParameterError, require_finite


def rk4_step_stm(
    model: GravityModel,
    x: np.ndarray,
    t: float,
    dt: float,
    perturbers: PerturberFn | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """RK4 step of the state and of the variational equations ``dPhi/dt = F Phi``, ``Phi(t) = I``.

    Returns ``(x(t+dt), Phi)`` with ``Phi`` of shape (N, 6, 6). Because ``F = [[0, I], [G, 0]]``,
    ``F @ M = [M_lower; G M_upper]`` is formed without a 6x6 product.
    """
    dt, x, (p0, p1, p2) = step_inputs(model, x, t, dt, perturbers)
    eye = np.broadcast_to(np.eye(6), x.shape[:-1] + (6, 6))

    def f_phi(xs: np.ndarray, phi: np.ndarray, rp: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        g = model.gradient(xs[..., :3], rp)
        dphi = np.concatenate([phi[..., 3:6, :], g @ phi[..., 0:3, :]], axis=-2)
        return model.derivative(xs, rp), dphi

    k1, m1 = f_phi(x, eye, p0)
    k2, m2 = f_phi(x + 0.5 * dt * k1, eye + 0.5 * dt * m1, p1)
    k3, m3 = f_phi(x + 0.5 * dt * k2, eye + 0.5 * dt * m2, p1)
    k4, m4 = f_phi(x + dt * k3, eye + dt * m3, p2)
    x_new = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    phi = eye + (dt / 6.0) * (m1 + 2.0 * m2 + 2.0 * m3 + m4)
    return x_new, phi


def euler_stm(
    model: GravityModel, x: np.ndarray, t: float, dt: float, perturbers: PerturberFn | None = None
) -> np.ndarray:
    """The thesis's ``Phi = I + F(x(t)) dt`` (first order), shape (N, 6, 6)."""
    dt = check_step(dt)
    rp = perturbers(t) if model.n_perturbers else None
    return np.eye(6) + model.jacobian(np.asarray(x, float), rp) * dt


def propagate(
    model: GravityModel,
    x0: np.ndarray,
    t0: float,
    dt: float,
    n_steps: int,
    perturbers: PerturberFn | None = None,
) -> np.ndarray:
    """RK4 trajectory: states at ``t0 + k dt`` for k = 0..n_steps, shape (n_steps+1, N, 6)."""
    if int(n_steps) < 0:
        raise InvalidParameterError(f"n_steps must be >= 0, got {n_steps}")
    x = require_finite("initial state", np.atleast_2d(np.asarray(x0, float)))
    out = np.empty((int(n_steps) + 1,) + x.shape)
    out[0] = x
    for k in range(int(n_steps)):
        x = rk4_step(model, x, t0 + k * dt, dt, perturbers)
        out[k + 1] = x
    return out


def specific_energy(x: np.ndarray, mu: float) -> np.ndarray:
    """Two-body specific orbital energy ``v^2/2 - mu/r`` [km^2/s^2]."""
    r = np.linalg.norm(x[..., :3], axis=-1)
    return 0.5 * np.sum(x[..., 3:] ** 2, axis=-1) - mu / r


def angular_momentum(x: np.ndarray) -> np.ndarray:
    """Specific angular momentum ``r x v`` [km^2/s]."""
    return np.cross(x[..., :3], x[..., 3:])
