"""Extended Kalman filter for the spacecraft's position and velocity.

A batched numpy core (leading axis = independent filters, so one filter is a batch of one)
and an adapter onto filterpy's ``ExtendedKalmanFilter`` used to cross-check it. The numpy core is the
oracle of the compiled kernels (:mod:`planetnav_env.estimation.ekf_kernels`, the environments' filter):
``tests/env/test_fast_ekf.py`` holds them to it, so its equations are written separately on purpose (matrix
algebra here, scalar loops there); what both filters' front ends share that is not an equation (their
construction and the Q cache) is written once, in :class:`EKFBase`.

Cycle (thesis, section 2.1, with the choices below):

* predict: state by RK4; covariance ``P = Phi P Phi^T + Q`` with ``Phi`` from the RK4-integrated
  variational equations (default) or the thesis's ``I + F dt`` (``stm="euler"``);
* update: ``K = P H^T S^-1``; Joseph form ``P = (I-KH) P (I-KH)^T + K R K^T``, symmetrised,
  which stays positive definite under round-off where the thesis's ``(I - KH) P`` need not;
  angle components of the innovation are wrapped to (-pi, pi];
* gating: an innovation whose NIS ``y^T S^-1 y`` exceeds the chi-square quantile
  ``gate_probability`` for ``m`` degrees of freedom is rejected (state and covariance keep
  their predicted values) and counted.

Filter settings have physical units (see :class:`FilterConfig`). The thesis's literal
``Q = 1e-4 I``, ``P0 = 1e3 I`` give no units; ``docs/filter.md`` states and justifies ours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from planetnav_env.dynamics.orbit import GravityModel, PerturberFn, euler_stm, rk4_step_stm
from planetnav_env.errors import InvalidParameterError, require_finite, require_positive
from planetnav_env.estimation.measurements import wrap_angle
from planetnav_env.options import check_options, option


@dataclass(frozen=True)
class FilterConfig:
    """EKF settings, each declared with its unit and range (:func:`~planetnav_env.options.option`)."""

    sigma_pos0: float = option(1000.0, gt=0, unit="km", doc="initial 1-sigma position error per axis (P0)")
    sigma_vel0: float = option(1e-3, gt=0, unit="km/s", doc="initial 1-sigma velocity error per axis (P0)")
    accel_psd: float = option(
        1e-20, ge=0, unit="km^2/s^3", doc="PSD of the white unmodelled acceleration per axis (sets Q)"
    )
    gate_probability: float = option(
        0.9999, gt=0, le=1, doc="chi-square probability of the innovation gate (1 disables gating)"
    )
    stm: str = option(
        "rk4", choices=("rk4", "euler"), doc="``rk4`` (variational equations) or ``euler`` (thesis, I + F dt)"
    )

    def __post_init__(self) -> None:
        check_options(self, "filter.")

    def initial_covariance(self) -> np.ndarray:
        """P0 (6, 6)."""
        return np.diag([self.sigma_pos0**2] * 3 + [self.sigma_vel0**2] * 3)

    def gate_threshold(self, dim: int) -> float:
        """NIS above which an innovation of dimension ``dim`` is rejected (inf when gating is off)."""
        return float("inf") if self.gate_probability >= 1.0 else float(chi2.ppf(self.gate_probability, dim))


def process_noise(dt: float, accel_psd: float) -> np.ndarray:
    """Discrete Q (6, 6) of white acceleration noise of PSD ``accel_psd`` [km^2/s^3] over ``dt`` [s]."""
    dt = require_positive("dt", dt)
    i3 = np.eye(3)
    return accel_psd * np.block([[dt**3 / 3.0 * i3, dt**2 / 2.0 * i3], [dt**2 / 2.0 * i3, dt * i3]])


def validate_initial(x0: np.ndarray, p0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Initial estimate (..., 6) and covariance (6, 6) as float arrays, or the error naming the problem."""
    x = require_finite("initial estimate", np.array(x0, dtype=float))
    if x.shape[-1:] != (6,):
        raise InvalidParameterError(f"state must have 6 components, got shape {x.shape}")
    p = require_finite("initial covariance", np.array(p0, dtype=float))
    if p.shape[-2:] != (6, 6) or np.any(np.linalg.eigvalsh(0.5 * (p + np.swapaxes(p, -1, -2))) <= 0.0):
        raise InvalidParameterError("initial covariance must be a symmetric positive definite 6x6 matrix")
    return x, p


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


class EKFBase:
    """What a filter front end holds: gravity model, settings, perturbers' positions function, Q per step.

    ``x0`` (6,) or (N, 6) [km, km/s] and ``p0`` (6, 6) or (N, 6, 6) [km^2, km^2/s^2, km^2/s] are checked by
    :func:`validate_initial`; the subclass's ``_start(x, p)`` makes its state arrays of them.
    ``perturbers(t) -> (K, 3)`` gives perturbing bodies' positions relative to the central body [km] when
    the gravity model has any.
    """

    def __init__(
        self,
        model: GravityModel,
        x0: np.ndarray,
        p0: np.ndarray,
        config: FilterConfig | None = None,
        perturbers: PerturberFn | None = None,
    ) -> None:
        self.model = model
        self.config = config or FilterConfig()
        self.perturbers = perturbers
        self._q_cache: dict[float, np.ndarray] = {}
        self._start(*validate_initial(x0, p0))

    def _start(self, x: np.ndarray, p: np.ndarray) -> None:
        raise NotImplementedError

    def q(self, dt: float) -> np.ndarray:
        """Process noise Q (6, 6) over ``dt`` [s] (:func:`process_noise`), computed once per ``dt``."""
        if dt not in self._q_cache:
            self._q_cache[dt] = process_noise(dt, self.config.accel_psd)
        return self._q_cache[dt]


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
