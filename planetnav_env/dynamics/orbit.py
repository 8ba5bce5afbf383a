"""Orbit dynamics: point-mass gravity, its analytic Jacobian, RK4 and the state transition matrix.

State ``x = [r, v]`` (km, km/s) relative to a central body (the Sun for cruise, Mars on
approach), in ICRF/J2000 axes. The central-body frame is not inertial when other bodies
pull on the central body too, so each perturbing point mass ``k`` contributes the direct
minus the indirect term (ERRATA 003, item 1):

    a_k = mu_k ( (r_k - r)/|r_k - r|^3 - r_k/|r_k|^3 ),

with ``r_k`` the body's position relative to the central body. Its gradient with respect to
``r`` is that of a point mass at ``r_k``; the indirect term does not depend on ``r``.

Everything is batched: ``x`` has shape ``(N, 6)``; perturber positions ``(K, 3)`` (shared by
the batch, as at one instant) or ``(N, K, 3)``.

State transition matrix. The thesis uses ``Phi = I + F dt`` (first order). The default here
integrates the variational equations ``dPhi/dt = F(x(t)) Phi`` with the same RK4 stages as
the state, which makes Phi the Jacobian of the discrete RK4 flow map to O(dt^5) instead of
O(dt^2): the position-velocity coupling ``G dt^2 / 2`` that ``I + F dt`` drops is what lets
the filter carry velocity information into position between measurements, and it matters for
long steps and near a planet (``tests/env/test_orbit.py`` measures both against finite
differences of the flow).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.errors import InvalidParameterError, require_finite, require_positive


def point_mass_accel(r: np.ndarray, mu: float) -> np.ndarray:
    """Acceleration ``-mu r / |r|^3`` [km/s^2] for ``r`` of shape (..., 3) [km]."""
    rn2 = np.sum(r * r, axis=-1, keepdims=True)
    return -mu * r / (rn2 * np.sqrt(rn2))


def gravity_gradient(r: np.ndarray, mu: float) -> np.ndarray:
    """``d(-mu r/|r|^3)/dr = mu (3 r r^T / |r|^5 - I / |r|^3)`` [1/s^2], shape (..., 3, 3)."""
    rn2 = np.sum(r * r, axis=-1)[..., None, None]
    rn3 = rn2 * np.sqrt(rn2)
    outer = r[..., :, None] * r[..., None, :]
    return mu * (3.0 * outer / (rn2 * rn3) - np.eye(3) / rn3)


@dataclass(frozen=True)
class GravityModel:
    """Central body plus perturbing point masses.

    ``central``: body name (its GM is used); ``perturbers``: names whose positions relative to
    the central body are supplied at each evaluation; ``mu_central`` / ``mu_perturbers`` may
    override the tabulated GMs [km^3/s^2].
    """

    central: str = "sun"
    perturbers: tuple[str, ...] = ()
    mu_central: float | None = None
    mu_perturbers: tuple[float, ...] | None = None
    _mus: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        body(self.central)
        for p in self.perturbers:
            body(p)
        if self.central in self.perturbers:
            raise InvalidParameterError(f"central body {self.central!r} cannot also be a perturber")
        mu_c = self.mu_central if self.mu_central is not None else body(self.central).gm
        object.__setattr__(self, "mu_central", require_positive("mu_central", mu_c))
        mus = self.mu_perturbers or tuple(body(p).gm for p in self.perturbers)
        if len(mus) != len(self.perturbers):
            raise InvalidParameterError(
                f"mu_perturbers has {len(mus)} values for {len(self.perturbers)} perturbers"
            )
        object.__setattr__(self, "mu_perturbers", tuple(require_positive("mu_perturbers", m) for m in mus))
        object.__setattr__(self, "_mus", np.asarray(self.mu_perturbers, dtype=float))

    @property
    def n_perturbers(self) -> int:
        return len(self.perturbers)

    def acceleration(self, r: np.ndarray, r_pert: np.ndarray | None = None) -> np.ndarray:
        """Total acceleration [km/s^2] at ``r`` (N, 3); ``r_pert`` (K, 3) or (N, K, 3) [km]."""
        a = point_mass_accel(r, self.mu_central)
        if self.n_perturbers:
            rk = np.asarray(r_pert, dtype=float)
            d = rk - r[..., None, :] if rk.ndim == r.ndim + 1 else rk[None, :, :] - r[..., None, :]
            dn2 = np.sum(d * d, axis=-1, keepdims=True)
            kn2 = np.sum(rk * rk, axis=-1, keepdims=True)
            mus = self._mus[:, None]
            direct = np.sum(mus * d / (dn2 * np.sqrt(dn2)), axis=-2)
            indirect = np.sum(mus * rk / (kn2 * np.sqrt(kn2)), axis=-2)
            a = a + direct - indirect
        return a

    def gradient(self, r: np.ndarray, r_pert: np.ndarray | None = None) -> np.ndarray:
        """``d a / d r`` [1/s^2] at ``r`` (N, 3): shape (N, 3, 3)."""
        g = gravity_gradient(r, self.mu_central)
        if self.n_perturbers:
            rk = np.asarray(r_pert, dtype=float)
            s = r[..., None, :] - (rk if rk.ndim == r.ndim + 1 else rk[None])
            g = g + np.einsum("k,...kij->...ij", self._mus, gravity_gradient(s, 1.0))
        return g

    def derivative(self, x: np.ndarray, r_pert: np.ndarray | None = None) -> np.ndarray:
        """``dx/dt = [v, a(r)]`` for states ``x`` (N, 6)."""
        return np.concatenate([x[..., 3:], self.acceleration(x[..., :3], r_pert)], axis=-1)

    def jacobian(self, x: np.ndarray, r_pert: np.ndarray | None = None) -> np.ndarray:
        """``F = d f / d x`` (N, 6, 6): [[0, I], [G, 0]]."""
        f = np.zeros(x.shape[:-1] + (6, 6))
        f[..., 0:3, 3:6] = np.eye(3)
        f[..., 3:6, 0:3] = self.gradient(x[..., :3], r_pert)
        return f


#: Supplies perturber positions (K, 3) [km, relative to the central body] at time t [s].
PerturberFn = Callable[[float], np.ndarray]


def _check_step(dt: float) -> float:
    return require_positive("step dt [s]", dt)


def _step_inputs(
    model: GravityModel, x: np.ndarray, t: float, dt: float, perturbers: PerturberFn | None
) -> tuple[float, np.ndarray, tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]]:
    """Validated step, state, and perturber positions at the RK4 stage times t, t + dt/2, t + dt."""
    dt = _check_step(dt)
    x = require_finite("orbit state", x)
    if not model.n_perturbers:
        return dt, x, (None, None, None)
    if perturbers is None:
        raise InvalidParameterError("the gravity model has perturbers: pass their positions function")
    return dt, x, (perturbers(t), perturbers(t + 0.5 * dt), perturbers(t + dt))


def rk4_step(
    model: GravityModel,
    x: np.ndarray,
    t: float,
    dt: float,
    perturbers: PerturberFn | None = None,
) -> np.ndarray:
    """One RK4 step of the state ``x`` (N, 6) from ``t`` to ``t + dt`` [s] (thesis, section 2.1)."""
    dt, x, (p0, p1, p2) = _step_inputs(model, x, t, dt, perturbers)
    k1 = model.derivative(x, p0)
    k2 = model.derivative(x + 0.5 * dt * k1, p1)
    k3 = model.derivative(x + 0.5 * dt * k2, p1)
    k4 = model.derivative(x + dt * k3, p2)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


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
    dt, x, (p0, p1, p2) = _step_inputs(model, x, t, dt, perturbers)
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
    dt = _check_step(dt)
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
