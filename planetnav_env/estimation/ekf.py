"""Extended Kalman filter settings and the front end the compiled filter shares.

:class:`FilterConfig` (P0, Q, gating, state transition matrix, each option with its unit),
:func:`process_noise` (the discrete Q of white acceleration noise), :func:`validate_initial` and
:class:`EKFBase` (construction and the Q cache). The environments' filter is compiled
(:mod:`planetnav_env.estimation.ekf_kernels`); its numpy oracle and the filterpy adapter that cross-checks
the oracle are :mod:`planetnav_validation.numpy_ekf`.

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

from planetnav_env.dynamics.orbit import GravityModel, PerturberFn
from planetnav_env.errors import InvalidParameterError, require_finite, require_positive
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
