"""Image-plane coordinates (p, l) of a planet's centre, with the analytic Jacobian (patent 003, eq. (2)).

The patent's optical observable is the planet centre's image point on the camera's focal plane, in mm:

    [X, Y, Z]^T = R_ci^T (R - r),      p = f X / Z,      l = f Y / Z,

``r`` the spacecraft and ``R`` the planet centre (same origin and ICRF axes: on approach both relative to
Mars, so ``R = 0``), ``f`` the focal length [mm] and ``R_ci`` the camera-to-inertial rotation
(``v_I = R_ci v_C``), built as the patent says from the camera-to-body matrix and the star tracker's
body-to-inertial attitude:

    R_ci = R_bi(q) C_cb,          v_I = R_bi v_B  (q scalar first, planetnav convention),  v_B = C_cb v_C.

Sign convention: the virtual image plane in front of the lens, ``+Z`` the boresight, as in
:mod:`planetnav_env.sensors.camera` (``camera_to_image_mm``), which this module reuses for the projection
(the patent's sign of p and l is lost with its equations; any fixed convention gives the same filter).

Jacobian (position columns; h does not depend on velocity), with ``v = R_ci^T (R - r)``:

    d(p, l)/d v = f [[1/Z, 0, -X/Z^2], [0, 1/Z, -Y/Z^2]],     d v / d r = -R_ci^T.

Noise: a centroid error of ``sigma_c`` [rad] per axis and a star-tracker attitude error of ``sigma_st`` [rad]
per axis both move the image point by ``f sigma / cos^2(off-axis angle)`` [mm]; near the boresight
``sigma_pl = f sqrt(sigma_c^2 + sigma_st^2)`` (:func:`image_plane_sigma_mm`).

Shapes: batches with a leading axis; ``r`` (N, 3), ``R`` (N, 3) or (3,), ``R_ci`` (N, 3, 3) or (3, 3).
"""

from __future__ import annotations

import numpy as np

from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import InvalidParameterError, NotVisibleError, require_finite, require_positive
from planetnav_env.sensors.camera import DEFAULT_CAMERA, CameraConfig, camera_to_image_mm

__all__ = [
    "boresight_attitude",
    "boresight_camera_to_inertial",
    "camera_to_inertial_matrix",
    "image_plane_coordinates",
    "image_plane_jacobian",
    "image_plane_sigma_mm",
]


def camera_to_inertial_matrix(
    q_body_to_inertial: np.ndarray, camera_to_body: np.ndarray | None = None
) -> np.ndarray:
    """``R_ci = R_bi(q) C_cb`` (..., 3, 3): camera-frame components to inertial (ICRF) ones.

    ``q_body_to_inertial`` (..., 4) scalar first (the star tracker's attitude, normalised here);
    ``camera_to_body`` (3, 3) ``C_cb`` with ``v_B = C_cb v_C`` (default: the camera module's default mount).
    """
    q = qt.normalize(require_finite("q_body_to_inertial", q_body_to_inertial))
    c = DEFAULT_CAMERA.camera_to_body_matrix if camera_to_body is None else np.asarray(camera_to_body, float)
    if c.shape != (3, 3):
        raise InvalidParameterError(f"camera_to_body must be 3x3, got shape {c.shape}")
    return qt.dcm_body_to_inertial(q) @ c


def _camera_vector(r: np.ndarray, target: np.ndarray, r_ci: np.ndarray) -> np.ndarray:
    r = require_finite("r_sc", np.atleast_2d(r))
    t = require_finite("target_pos", target)
    m = require_finite("r_ci", r_ci)
    if m.shape[-2:] != (3, 3):
        raise InvalidParameterError(f"r_ci must have shape (..., 3, 3), got {m.shape}")
    d = t - r
    # v_C = R_ci^T d, batched.
    return np.einsum("...ji,...j->...i", m, d)


def _check_in_front(v: np.ndarray, what: str = "target") -> None:
    if np.any(v[..., 2] <= 0.0):
        bad = np.flatnonzero(v.reshape(-1, 3)[:, 2] <= 0.0)
        raise NotVisibleError(
            f"{what} is behind the camera (Z <= 0) in {bad.size} element(s), first at index {int(bad[0])}"
        )


def image_plane_coordinates(
    r_sc: np.ndarray,
    target_pos: np.ndarray,
    r_ci: np.ndarray,
    config: CameraConfig = DEFAULT_CAMERA,
) -> np.ndarray:
    """``(p, l)`` [mm] of the target centre on the image plane, relative to the principal point: (N, 2).

    ``r_sc``, ``target_pos`` [km] in the same frame (ICRF axes, any common origin). Raises
    :class:`NotVisibleError` if the target is behind the camera and :class:`NonFiniteError` on NaN input.
    The field-of-view test (whether (p, l) lies on the sensor) is the caller's: the model is smooth beyond it.
    """
    v = _camera_vector(r_sc, target_pos, r_ci)
    _check_in_front(v)
    return camera_to_image_mm(v, config)


def image_plane_jacobian(
    r_sc: np.ndarray,
    target_pos: np.ndarray,
    r_ci: np.ndarray,
    config: CameraConfig = DEFAULT_CAMERA,
) -> np.ndarray:
    """``d(p, l)/dx`` (N, 2, 6) [mm/km on the position columns, 0 on the velocity columns]."""
    v = _camera_vector(r_sc, target_pos, r_ci)
    _check_in_front(v)
    f = config.focal_length_mm
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    dv = np.zeros(v.shape[:-1] + (2, 3))
    dv[..., 0, 0] = f / z
    dv[..., 0, 2] = -f * x / z**2
    dv[..., 1, 1] = f / z
    dv[..., 1, 2] = -f * y / z**2
    m = np.broadcast_to(np.asarray(r_ci, float), v.shape[:-1] + (3, 3))
    h = np.zeros(v.shape[:-1] + (2, 6))
    # dv/dr = -R_ci^T, so d(p,l)/dr = -dv @ R_ci^T.
    h[..., 0:3] = -dv @ np.swapaxes(m, -1, -2)
    return h


def image_plane_sigma_mm(config: CameraConfig = DEFAULT_CAMERA, star_tracker_arcsec: float = 0.0) -> float:
    """1-sigma of p and l [mm] near the boresight: ``f sqrt(sigma_c^2 + sigma_st^2)``.

    ``sigma_c`` is the camera's ``direction_noise_arcsec`` (centroiding), ``sigma_st`` the star tracker's
    per-axis attitude error [arcsec]; both angles converted to rad.
    """
    st = float(star_tracker_arcsec)
    if not np.isfinite(st) or st < 0.0:
        raise InvalidParameterError(f"star_tracker_arcsec must be >= 0, got {star_tracker_arcsec!r}")
    sig = np.hypot(config.sigma_direction_rad, np.deg2rad(st / 3600.0))
    return float(config.focal_length_mm * sig)


def boresight_camera_to_inertial(
    los_inertial: np.ndarray, up_inertial: np.ndarray | None = None
) -> np.ndarray:
    """Camera-to-inertial matrices ``R_ci`` (N, 3, 3) whose boresight (camera +Z) is along ``los_inertial``.

    The camera X axis is taken orthogonal to the line of sight and to ``up_inertial`` (default ICRF +Z;
    ICRF +X where the line of sight is within ~1e-3 rad of it); Y completes a right-handed frame.
    """
    u = require_finite("los_inertial", np.atleast_2d(los_inertial))
    nrm = np.linalg.norm(u, axis=-1, keepdims=True)
    if np.any(nrm == 0.0):
        raise InvalidParameterError("los_inertial has a zero vector")
    u = u / nrm
    up = np.array([0.0, 0.0, 1.0]) if up_inertial is None else require_finite("up_inertial", up_inertial)
    ex = np.cross(np.broadcast_to(up, u.shape), u)
    small = np.linalg.norm(ex, axis=-1) < 1e-3
    if np.any(small):
        ex = np.where(small[:, None], np.cross(np.array([1.0, 0.0, 0.0]), u), ex)
    ex /= np.linalg.norm(ex, axis=-1, keepdims=True)
    ey = np.cross(u, ex)
    return np.stack([ex, ey, u], axis=-1)  # columns: camera X, Y, Z in inertial components


def boresight_attitude(
    los_inertial: np.ndarray, camera_to_body: np.ndarray | None = None, up_inertial: np.ndarray | None = None
) -> np.ndarray:
    """Body-to-inertial quaternions (N, 4) that put the camera boresight along ``los_inertial`` (N, 3)
    (see :func:`boresight_camera_to_inertial`): ``R_bi = R_ci C_cb^T``."""
    r_ci = boresight_camera_to_inertial(los_inertial, up_inertial)
    c = DEFAULT_CAMERA.camera_to_body_matrix if camera_to_body is None else np.asarray(camera_to_body, float)
    return qt.from_dcm_body_to_inertial(r_ci @ c.T)


def focal_length_mm(config: CameraConfig = DEFAULT_CAMERA) -> float:
    """The focal length used by the model [mm] (validated positive by :class:`CameraConfig`)."""
    return require_positive("focal_length_mm", config.focal_length_mm)
