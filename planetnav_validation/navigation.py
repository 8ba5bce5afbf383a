"""Monte Carlo harness: truth orbit + planet measurements + batched EKF, without attitude.

Used by the thesis reproduction and the consistency tests. The camera is assumed to be
stabilised on the scheduled planet (the thesis's assumption in chapter 3), so a measurement
is the true line of sight perturbed by the camera's isotropic angular noise and, with the
size models, the true apparent diameter plus Gaussian noise. Runs are independent filters of
one :class:`~planetnav_validation.numpy_ekf.BatchEKF` (leading axis = run).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import Ephemeris
from planetnav_env.dynamics.orbit import GravityModel, rk4_step
from planetnav_env.errors import InvalidParameterError, require_positive
from planetnav_env.estimation.ekf import FilterConfig, process_noise
from planetnav_env.estimation.ekf_kernels import (
    KIND_CODES,
    FixModel,
    PlanetFixes,
    orbit_model,
    predict_batch_kernel,
    rk4_batch_kernel,
    update_batch_kernel,
)
from planetnav_env.estimation.measurements import MeasurementModel, los_basis
from planetnav_validation.numpy_ekf import BatchEKF, nees

_NONE = np.zeros((0, 3))
_NO_MU = np.zeros(0)


def perturb_direction(rng: np.random.Generator, u: np.ndarray, sigma: float) -> np.ndarray:
    """Unit vectors ``u`` (N, 3) rotated by two independent N(0, sigma^2) angles [rad] about
    axes orthogonal to ``u`` (isotropic pointing noise of a camera centroid)."""
    basis = los_basis(u)
    a = rng.normal(0.0, sigma, size=u.shape[:-1] + (2,))
    # Rotation by the small angle vector a1 e1 + a2 e2 (exact, Rodrigues) keeps |u| = 1.
    axis = a[..., 0:1] * basis[..., 0, :] + a[..., 1:2] * basis[..., 1, :]
    ang = np.linalg.norm(axis, axis=-1, keepdims=True)
    k = np.divide(axis, ang, out=np.zeros_like(axis), where=ang > 0)
    return (
        u * np.cos(ang)
        + np.cross(k, u) * np.sin(ang)
        + k * np.sum(k * u, -1, keepdims=True) * (1 - np.cos(ang))
    )


@dataclass
class NavigationResult:
    """Histories of a Monte Carlo run; time axis first, run axis second.

    t (K+1,) [s]; x_true, x_est (K+1, N, 6); P (K+1, N, 6, 6); nees (K+1, N);
    nis (K, N) (NaN without a measurement); measured, accepted (K, N); target (K,) planet names.
    """

    t: np.ndarray
    x_true: np.ndarray
    x_est: np.ndarray
    P: np.ndarray
    nees: np.ndarray
    nis: np.ndarray
    measured: np.ndarray
    accepted: np.ndarray
    target: list[str | None]

    @property
    def pos_err(self) -> np.ndarray:
        """|r_est - r_true| [km], (K+1, N)."""
        return np.linalg.norm(self.x_est[..., :3] - self.x_true[..., :3], axis=-1)

    @property
    def vel_err(self) -> np.ndarray:
        """|v_est - v_true| [km/s], (K+1, N)."""
        return np.linalg.norm(self.x_est[..., 3:] - self.x_true[..., 3:], axis=-1)

    @property
    def pos_sigma(self) -> np.ndarray:
        """sqrt(trace P_rr) [km], (K+1, N)."""
        return np.sqrt(np.trace(self.P[..., :3, :3], axis1=-2, axis2=-1))

    @property
    def vel_sigma(self) -> np.ndarray:
        return np.sqrt(np.trace(self.P[..., 3:, 3:], axis1=-2, axis2=-1))


def simulate_navigation(
    *,
    x0: np.ndarray,
    t0: float,
    dt: float,
    n_steps: int,
    schedule: Callable[[int, float, np.ndarray], str | None],
    ephemeris: Ephemeris,
    measurement: MeasurementModel,
    config: FilterConfig,
    n_runs: int,
    rng: np.random.Generator,
    gravity: GravityModel | None = None,
    truth_process_noise: bool = False,
    measure_every: int = 1,
    engine: str = "compiled",
) -> NavigationResult:
    """Run ``n_runs`` filters against truths starting at ``x0`` (6,) at ``t0`` [s].

    Each run draws its initial estimate error from P0, its measurement noise from ``rng`` and,
    if ``truth_process_noise``, a discrete process-noise sample ``w ~ N(0, Q)`` per step added
    to the truth (the noise the filter assumes; for consistency tests). ``schedule(k, t, x_est)``
    names the planet measured after step k at time t (or None), given the filters' current
    estimates ``x_est`` (N, 6); one target serves all runs. ``measure_every`` thins measurements.
    ``engine``: ``"compiled"`` (numba kernels, default) or ``"numpy"`` (the reference core); both
    run the same equations (``tests/env/test_fast_ekf.py``).
    """
    if engine not in ("compiled", "numpy"):
        raise InvalidParameterError(f"engine must be 'compiled' or 'numpy', got {engine!r}")
    dt = require_positive("dt", dt)
    if int(n_steps) < 1 or int(n_runs) < 1:
        raise InvalidParameterError(f"n_steps and n_runs must be >= 1, got {n_steps}, {n_runs}")
    gravity = gravity or GravityModel("sun")
    if gravity.n_perturbers:
        raise InvalidParameterError("simulate_navigation supports two-body truth only")
    p0 = config.initial_covariance()
    x_true = np.broadcast_to(np.asarray(x0, float), (n_runs, 6)).copy()
    x_est = x_true + rng.multivariate_normal(np.zeros(6), p0, size=n_runs)
    ekf = BatchEKF(gravity, x_est, p0, config)
    q = process_noise(dt, config.accel_psd)
    orbit = orbit_model(gravity.mu_central, _NONE, _NONE, _NONE, _NO_MU)  # the compiled engine's field
    fix_model = FixModel(
        kind=KIND_CODES[measurement.kind],
        sig_dir=float(measurement.sigma_dir),
        sig_size=float(measurement.sigma_size),
        gate=float(config.gate_threshold(measurement.dim)),
    )
    q_chol = (
        np.linalg.cholesky(q + 1e-300 * np.eye(6)) if truth_process_noise and config.accel_psd > 0 else None
    )

    k_total = int(n_steps)
    t = t0 + dt * np.arange(k_total + 1)
    xs_true = np.empty((k_total + 1, n_runs, 6))
    xs_est = np.empty_like(xs_true)
    ps = np.empty((k_total + 1, n_runs, 6, 6))
    nis = np.full((k_total, n_runs), np.nan)
    measured = np.zeros((k_total, n_runs), bool)
    accepted = np.zeros((k_total, n_runs), bool)
    targets: list[str | None] = []
    all_active = np.ones(n_runs, dtype=bool)
    planet_table: dict[str, np.ndarray] = {}
    xs_true[0], xs_est[0], ps[0] = x_true, ekf.x, ekf.P
    for k in range(k_total):
        if engine == "numpy":
            x_true = rk4_step(gravity, x_true, t[k], dt)
        else:
            rk4_batch_kernel(x_true, dt, gravity.mu_central, _NONE, _NONE, _NONE, _NO_MU)
        if q_chol is not None:
            x_true = x_true + rng.standard_normal((n_runs, 6)) @ q_chol.T
        if engine == "numpy":
            ekf.predict(t[k], dt)
        else:
            predict_batch_kernel(ekf.x, ekf.P, dt, orbit, q, config.stm == "euler")
        name = schedule(k, t[k + 1], ekf.x) if (k + 1) % measure_every == 0 else None
        targets.append(name)
        if name is not None:
            if name not in planet_table:
                planet_table[name] = ephemeris.position(name, t)  # one vectorised call per planet
            planet = planet_table[name][k + 1]
            diameter = body(name).diameter
            d_true = planet - x_true[:, :3]
            rho_true = np.linalg.norm(d_true, axis=-1, keepdims=True)
            u_meas = perturb_direction(rng, d_true / rho_true, measurement.sigma_dir)
            alpha = None
            if measurement.uses_size:
                # The image of a sphere subtends 2 asin(R/L); the filter models 2 atan(D/2L).
                alpha = 2.0 * np.arcsin(0.5 * diameter / rho_true[:, 0]) + rng.normal(
                    0.0, measurement.sigma_size, n_runs
                )
            basis = None
            if measurement.kind.startswith("los"):
                d_pred = planet - ekf.x[:, :3]
                basis = los_basis(d_pred / np.linalg.norm(d_pred, axis=-1, keepdims=True))
            z = measurement.from_unit_vector(u_meas, alpha, basis)
            if engine == "numpy":
                h, jac, cov = measurement.evaluate(ekf.x[:, :3], planet, diameter, basis)
                res = ekf.update(z, h, jac, cov, measurement.angle_mask)
                nis[k], accepted[k] = res.nis, res.accepted
            else:
                fixes = PlanetFixes(
                    z=np.ascontiguousarray(z),
                    planet=np.broadcast_to(planet, (n_runs, 3)),
                    diameter=float(diameter),
                    basis=basis if basis is not None else np.zeros((n_runs, 2, 3)),
                    active=all_active,
                )
                update_batch_kernel(ekf.x, ekf.P, fixes, fix_model, nis[k], accepted[k])
                ekf.rejected += ~accepted[k]
            measured[k] = True
        xs_true[k + 1], xs_est[k + 1], ps[k + 1] = x_true, ekf.x, ekf.P
    nees_hist = nees(xs_est, ps, xs_true)
    return NavigationResult(t, xs_true, xs_est, ps, nees_hist, nis, measured, accepted, targets)
