"""Measurement models of a planet seen from the spacecraft, with analytic Jacobians.

Geometry: ``d = R - r`` is the line of sight from the spacecraft (``r``) to the planet
centre (``R``), heliocentric ICRF [km]; ``rho = |d|``. This is the direction the camera
measures (ERRATA 000 item 5: the thesis writes ``r - R``; with ``R - r`` the angles are
those of the measured direction to the planet).

Models (``h(x)`` depends on position only, so the velocity columns of ``H`` are zero):

``direction`` (thesis model 1, corrected per ERRATA 1-4)
    theta = asin(d_z / rho)   (declination-like elevation above the equator, [-pi/2, pi/2])
    phi   = atan2(d_y, d_x)   (right-ascension-like azimuth, innovation wrapped to (-pi, pi])
``direction+size`` (thesis model 2)
    the two angles plus the angular diameter alpha = 2 atan(D / (2 rho)) [rad], with the
    exact derivative ``d alpha/d rho = -D / (rho^2 + D^2/4)`` (ERRATA 6).
``los`` / ``los+size`` (singularity-free)
    the measured unit vector projected on two unit vectors ``e1, e2`` orthogonal to the
    *predicted* line of sight: ``z = [e1 . u, e2 . u]`` (+ alpha). With the basis held fixed
    during an update the model is smooth everywhere: no pole at theta = +-90 deg and no
    azimuth wrap. Its noise is the camera's isotropic angular noise.

Shapes: ``r`` (N, 3), ``R`` (N, 3) or (3,), results (N, m) and Jacobians (N, m, 6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planetnav_env.codes import MeasurementKind
from planetnav_env.errors import InvalidParameterError

#: The measurement models' names (:class:`~planetnav_env.codes.MeasurementKind` labels, in code order).
MODELS = tuple(k.label for k in MeasurementKind)


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles [rad] to (-pi, pi]."""
    return np.pi - np.remainder(np.pi - np.asarray(a, dtype=float), 2.0 * np.pi)


def _los(r: np.ndarray, planet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.asarray(planet, float) - np.asarray(r, float)
    rho = np.sqrt(np.sum(d * d, axis=-1))
    return d, rho


def angular_diameter_model(rho: np.ndarray, diameter: float) -> np.ndarray:
    """The thesis's ``alpha = 2 atan(D / (2 rho))`` [rad] (filter model)."""
    return 2.0 * np.arctan(0.5 * diameter / rho)


def h_direction(r: np.ndarray, planet: np.ndarray) -> np.ndarray:
    """``[theta, phi]`` [rad] of the line of sight, shape (N, 2)."""
    d, rho = _los(r, planet)
    return np.stack([np.arcsin(d[..., 2] / rho), np.arctan2(d[..., 1], d[..., 0])], axis=-1)


def jac_direction(r: np.ndarray, planet: np.ndarray) -> np.ndarray:
    """``d[theta, phi]/dx`` (N, 2, 6). Singular at theta = +-90 deg (use the ``los`` model there)."""
    d, rho = _los(r, planet)
    dx, dy, dz = d[..., 0], d[..., 1], d[..., 2]
    rxy2 = dx * dx + dy * dy
    rxy = np.sqrt(rxy2)
    rho2 = rho * rho
    h = np.zeros(d.shape[:-1] + (2, 6))
    # Derivatives with respect to d, negated because d = R - r.
    h[..., 0, 0] = dx * dz / (rho2 * rxy)
    h[..., 0, 1] = dy * dz / (rho2 * rxy)
    h[..., 0, 2] = -rxy / rho2
    h[..., 1, 0] = dy / rxy2
    h[..., 1, 1] = -dx / rxy2
    return h


def h_size(r: np.ndarray, planet: np.ndarray, diameter: float) -> np.ndarray:
    """Angular diameter ``2 atan(D / 2 rho)`` [rad], shape (N, 1)."""
    _, rho = _los(r, planet)
    return angular_diameter_model(rho, diameter)[..., None]


def jac_size(r: np.ndarray, planet: np.ndarray, diameter: float) -> np.ndarray:
    """``d alpha / dx = +D d / (rho (rho^2 + D^2/4))`` on the position columns, shape (N, 1, 6)."""
    d, rho = _los(r, planet)
    h = np.zeros(d.shape[:-1] + (1, 6))
    h[..., 0, 0:3] = diameter * d / (rho * (rho * rho + 0.25 * diameter * diameter))[..., None]
    return h


def los_basis(u: np.ndarray) -> np.ndarray:
    """Two unit vectors orthogonal to unit ``u`` (N, 3) and to each other: shape (N, 2, 3).

    ``e1`` is built from the coordinate axis least aligned with ``u`` so that it is never
    degenerate; ``e2 = u x e1``.
    """
    u = np.asarray(u, float)
    axis = np.zeros_like(u)
    idx = np.argmin(np.abs(u), axis=-1)
    np.put_along_axis(axis, idx[..., None], 1.0, axis=-1)
    e1 = np.cross(u, axis)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(u, e1)
    return np.stack([e1, e2], axis=-2)


def h_los(r: np.ndarray, planet: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``[e1 . u, e2 . u]`` with ``u = d / rho`` and a fixed ``basis`` (N, 2, 3); shape (N, 2)."""
    d, rho = _los(r, planet)
    return np.einsum("...ij,...j->...i", basis, d / rho[..., None])


def jac_los(r: np.ndarray, planet: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``d h_los / dx = -basis (I - u u^T) / rho`` on the position columns, shape (N, 2, 6)."""
    d, rho = _los(r, planet)
    u = d / rho[..., None]
    proj = np.eye(3) - u[..., :, None] * u[..., None, :]
    h = np.zeros(d.shape[:-1] + (2, 6))
    h[..., :, 0:3] = -np.einsum("...ij,...jk->...ik", basis, proj) / rho[..., None, None]
    return h


@dataclass(frozen=True)
class MeasurementModel:
    """One of :data:`MODELS` with its noise: ``sigma_dir`` [rad] per axis, ``sigma_size`` [rad].

    ``evaluate`` returns ``(h, H, R, angle_mask)`` for a batch; ``angle_mask`` flags components
    whose innovation must be wrapped. ``basis`` is required by the ``los`` models (use
    :func:`los_basis` of the predicted line of sight).
    """

    kind: str = "direction+size"
    sigma_dir: float = np.deg2rad(3.5 / 3600.0)
    sigma_size: float = 1e-4

    def __post_init__(self) -> None:
        if self.kind not in MODELS:
            raise InvalidParameterError(f"unknown measurement model {self.kind!r}; choose from {MODELS}")
        for name in ("sigma_dir", "sigma_size"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0.0:
                raise InvalidParameterError(f"{name} must be a positive finite number, got {v!r}")

    @property
    def uses_size(self) -> bool:
        return self.kind.endswith("+size")

    @property
    def dim(self) -> int:
        return 3 if self.uses_size else 2

    @property
    def angle_mask(self) -> np.ndarray:
        m = np.zeros(self.dim, dtype=bool)
        if self.kind.startswith("direction"):
            m[1] = True
        return m

    def evaluate(
        self, r: np.ndarray, planet: np.ndarray, diameter: float, basis: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted measurement (N, m), Jacobian (N, m, 6) and noise covariance (N, m, m)."""
        r = np.atleast_2d(np.asarray(r, float))
        n = r.shape[0]
        cov = np.zeros((n, self.dim, self.dim))
        if self.kind.startswith("direction"):
            h, jac = h_direction(r, planet), jac_direction(r, planet)
            # The camera's isotropic angular noise maps onto azimuth as sigma / cos(theta).
            cov[:, 0, 0] = self.sigma_dir**2
            cov[:, 1, 1] = self.sigma_dir**2 / np.cos(h[:, 0]) ** 2
        else:
            if basis is None:
                raise InvalidParameterError(f"model {self.kind!r} needs the line-of-sight basis")
            h, jac = h_los(r, planet, basis), jac_los(r, planet, basis)
            cov[:, 0, 0] = cov[:, 1, 1] = self.sigma_dir**2
        if self.uses_size:
            h = np.concatenate([h, h_size(r, planet, diameter)], axis=-1)
            jac = np.concatenate([jac, jac_size(r, planet, diameter)], axis=-2)
            cov[:, 2, 2] = self.sigma_size**2
        return h, jac, cov

    def from_unit_vector(
        self, u: np.ndarray, alpha: np.ndarray | None = None, basis: np.ndarray | None = None
    ) -> np.ndarray:
        """Turn a measured inertial unit line of sight (N, 3) (+ angular diameter) into ``z`` (N, m)."""
        u = np.atleast_2d(np.asarray(u, float))
        if self.kind.startswith("direction"):
            z = np.stack([np.arcsin(np.clip(u[:, 2], -1.0, 1.0)), np.arctan2(u[:, 1], u[:, 0])], axis=-1)
        else:
            if basis is None:
                raise InvalidParameterError(f"model {self.kind!r} needs the line-of-sight basis")
            z = np.einsum("nij,nj->ni", basis, u)
        if self.uses_size:
            if alpha is None:
                raise InvalidParameterError(f"model {self.kind!r} needs the measured angular diameter")
            z = np.concatenate([z, np.reshape(alpha, (-1, 1))], axis=-1)
        return z
