"""The numpy EKF: the oracle of the compiled filter, and filterpy's ``ExtendedKalmanFilter`` as its check.

:class:`BatchEKF` is a batched numpy filter (leading axis = independent filters, a filter is a batch of
one) with the equations of :mod:`planetnav_env.estimation.ekf` (its docstring gives the cycle) written as
matrix algebra; the compiled kernels (:mod:`planetnav_env.estimation.ekf_kernels`, the environments'
filter) write them as scalar loops, and ``tests/env/test_fast_ekf.py`` holds them to this one.
:class:`FilterpyEKF` runs the same filter on filterpy, ``tests/env/test_ekf.py`` holds the two together.
The Monte Carlo harnesses (:mod:`planetnav_validation.navigation`,
:mod:`planetnav_validation.approach_methods`) run :class:`BatchEKF`.

Units: state [km, km/s], covariance [km^2, km^2/s, km^2/s^2], time TDB [s].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planetnav_env.dynamics.orbit import GravityModel, PerturberFn
from planetnav_env.errors import InvalidParameterError, require_finite
from planetnav_env.estimation.ekf import EKFBase, FilterConfig, process_noise
from planetnav_env.estimation.measurements import wrap_angle
from planetnav_validation.numpy_orbit import euler_stm, rk4_step_stm


def symmetrize(p: np.ndarray) -> np.ndarray:
    return 0.5 * (p + np.swapaxes(p, -1, -2))


def predict(
    model: GravityModel,
    x: np.ndarray,
    p: np.ndarray,
    t: float,
    dt: float,
    q: np.ndarray,
    perturbers: PerturberFn | None = None,
    stm: str = "rk4",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Propagate estimates ``x`` (N, 6) and covariances ``p`` (N, 6, 6) from ``t`` to ``t + dt``.

    Returns ``(x, P, Phi)``.
    """
    if stm == "rk4":
        x_new, phi = rk4_step_stm(model, x, t, dt, perturbers)
    elif stm == "euler":
        phi = euler_stm(model, x, t, dt, perturbers)
        x_new, _ = rk4_step_stm(model, x, t, dt, perturbers)
    else:
        raise InvalidParameterError(f"stm must be 'rk4' or 'euler', got {stm!r}")
    p_new = symmetrize(phi @ p @ np.swapaxes(phi, -1, -2) + q)
    return x_new, p_new, phi


@dataclass
class UpdateResult:
    """Outcome of a batched update: innovation (N, m), its covariance S (N, m, m), NIS (N,), accepted (N,)."""

    innovation: np.ndarray
    s: np.ndarray
    nis: np.ndarray
    accepted: np.ndarray


def update(
    x: np.ndarray,
    p: np.ndarray,
    z: np.ndarray,
    h: np.ndarray,
    jac: np.ndarray,
    r: np.ndarray,
    angle_mask: np.ndarray | None = None,
    gate_threshold: float = float("inf"),
    active: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, UpdateResult]:
    """Joseph-form EKF update of a batch.

    ``z``, ``h`` (N, m): measured and predicted; ``jac`` (N, m, 6); ``r`` (N, m, m) or (m, m);
    ``angle_mask`` (m,) bool: components wrapped to (-pi, pi]; ``active`` (N,) bool: filters
    that have a measurement this step (the others pass through). Returns ``(x, P, result)``.
    """
    z = require_finite("measurement z", z)
    y = z - h
    if angle_mask is not None and np.any(angle_mask):
        y[..., angle_mask] = wrap_angle(y[..., angle_mask])
    pht = p @ np.swapaxes(jac, -1, -2)
    s = jac @ pht + r
    s_inv = np.linalg.inv(s)
    nis = np.einsum("...i,...ij,...j->...", y, s_inv, y)
    accepted = nis <= gate_threshold
    if active is not None:
        accepted &= np.asarray(active, bool)
    k = pht @ s_inv
    ikh = np.eye(x.shape[-1]) - k @ jac
    x_upd = x + np.einsum("...ij,...j->...i", k, y)
    p_upd = symmetrize(ikh @ p @ np.swapaxes(ikh, -1, -2) + k @ r @ np.swapaxes(k, -1, -2))
    keep = accepted[..., None]
    x_out = np.where(keep, x_upd, x)
    p_out = np.where(keep[..., None], p_upd, p)
    return x_out, p_out, UpdateResult(y, s, nis, accepted)


def nees(x_est: np.ndarray, p: np.ndarray, x_true: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``e^T P^-1 e`` (N,)."""
    e = np.asarray(x_est, float) - np.asarray(x_true, float)
    return np.einsum("...i,...i->...", e, np.linalg.solve(p, e[..., None])[..., 0])


class BatchEKF(EKFBase):
    """N independent EKFs over one gravity model, advanced in lock step.

    ``x`` (N, 6) [km, km/s] and ``P`` (N, 6, 6) are public arrays. ``rejected`` counts gated
    measurements per filter.
    """

    def _start(self, x: np.ndarray, p: np.ndarray) -> None:
        self.x = np.atleast_2d(x)
        self.P = np.broadcast_to(p, self.x.shape[:-1] + (6, 6)).copy()
        self.rejected = np.zeros(self.x.shape[0], dtype=int)

    @property
    def n(self) -> int:
        return self.x.shape[0]

    def predict(self, t: float, dt: float) -> np.ndarray:
        """Advance every filter from ``t`` to ``t + dt``; returns Phi (N, 6, 6)."""
        self.x, self.P, phi = predict(
            self.model, self.x, self.P, t, dt, self.q(dt), self.perturbers, self.config.stm
        )
        return phi

    def update(
        self,
        z: np.ndarray,
        h: np.ndarray,
        jac: np.ndarray,
        r: np.ndarray,
        angle_mask: np.ndarray | None = None,
        active: np.ndarray | None = None,
    ) -> UpdateResult:
        """Process one measurement per active filter (see :func:`update`)."""
        m = np.shape(z)[-1]
        self.x, self.P, res = update(
            self.x, self.P, z, h, jac, r, angle_mask, self.config.gate_threshold(m), active
        )
        act = np.ones(self.n, bool) if active is None else np.asarray(active, bool)
        self.rejected += act & ~res.accepted
        return res


class FilterpyEKF:
    """The same filter on filterpy's ``ExtendedKalmanFilter`` (a reference, not a fast path).

    filterpy propagates ``x`` with ``F x``; here ``predict_x`` is replaced by our RK4 and ``F``
    is set to the RK4 state transition matrix before each covariance prediction, so both
    filters run the same equations. filterpy's update is already in Joseph form.
    """

    def __init__(
        self,
        model: GravityModel,
        x0: np.ndarray,
        p0: np.ndarray,
        dim_z: int,
        config: FilterConfig | None = None,
        perturbers: PerturberFn | None = None,
    ) -> None:
        from filterpy.kalman import ExtendedKalmanFilter

        self.model = model
        self.config = config or FilterConfig()
        self.perturbers = perturbers
        ekf = ExtendedKalmanFilter(dim_x=6, dim_z=dim_z)
        ekf.x = np.array(x0, dtype=float).reshape(6, 1)
        ekf.P = np.array(p0, dtype=float)
        self._t = 0.0
        self._dt = 1.0
        adapter = self

        def predict_x(u: object = 0) -> None:
            x_new, _ = rk4_step_stm(
                adapter.model, ekf.x.reshape(1, 6), adapter._t, adapter._dt, adapter.perturbers
            )
            ekf.x = x_new.reshape(6, 1)

        ekf.predict_x = predict_x
        self.ekf = ekf

    @property
    def x(self) -> np.ndarray:
        return self.ekf.x.ravel()

    @property
    def P(self) -> np.ndarray:
        return self.ekf.P

    def predict(self, t: float, dt: float) -> None:
        _, phi = rk4_step_stm(self.model, self.ekf.x.reshape(1, 6), t, dt, self.perturbers)
        self.ekf.F = phi[0]
        self.ekf.Q = process_noise(dt, self.config.accel_psd)
        self._t, self._dt = t, dt
        self.ekf.predict()

    def update(
        self, z: np.ndarray, hx, jacobian, r: np.ndarray, angle_mask: np.ndarray | None = None
    ) -> None:
        """``hx(x) -> (m,)`` and ``jacobian(x) -> (m, 6)`` take the flat state."""

        def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            y = np.subtract(a, b)
            if angle_mask is not None and np.any(angle_mask):
                y[angle_mask] = wrap_angle(y[angle_mask])
            return y

        self.ekf.update(
            np.asarray(z, float).reshape(-1, 1),
            lambda x: jacobian(x.ravel()),
            lambda x: np.asarray(hx(x.ravel())).reshape(-1, 1),
            R=np.asarray(r, float),
            residual=lambda a, b: residual(a.ravel(), b.ravel()).reshape(-1, 1),
        )
