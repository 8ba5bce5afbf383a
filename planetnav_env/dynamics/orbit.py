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
long steps and near a planet. The filter's STM is compiled
(:func:`planetnav_env.estimation.ekf_kernels.rk4_stm_kernel`); its numpy form, with the thesis's
``I + F dt``, is :mod:`planetnav_validation.numpy_orbit` (``tests/env/test_orbit.py`` measures both
against finite differences of the flow).
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


def check_step(dt: float) -> float:
    """``dt`` [s] if it is a positive finite step, else the named error."""
    return require_positive("step dt [s]", dt)


def step_inputs(
    model: GravityModel, x: np.ndarray, t: float, dt: float, perturbers: PerturberFn | None
) -> tuple[float, np.ndarray, tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]]:
    """Validated step, state, and perturber positions at the RK4 stage times t, t + dt/2, t + dt."""
    dt = check_step(dt)
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
    dt, x, (p0, p1, p2) = step_inputs(model, x, t, dt, perturbers)
    k1 = model.derivative(x, p0)
    k2 = model.derivative(x + 0.5 * dt * k1, p1)
    k3 = model.derivative(x + 0.5 * dt * k2, p1)
    k4 = model.derivative(x + dt * k3, p2)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
