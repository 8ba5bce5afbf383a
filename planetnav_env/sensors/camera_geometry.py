"""Star-camera geometry (numpy, not on the per-step hot path): frame rotations, pinhole projection, field
of view, apparent size of a planet and the Sun angle.

Frames (see :mod:`planetnav_env.sensors.camera`): inertial I (ICRF heliocentric, km), body B with
``v_I = R(q) v_B`` (q scalar first), camera C with +Z the boresight and ``v_B = C v_C``. Image-plane
coordinates are in mm relative to the principal point, pixel coordinates in px from a corner of the sensor.
The compiled kernels (:mod:`planetnav_env.sensors.camera_kernels`) inline the same projection;
``tests/env/test_camera.py`` pins them to these helpers.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import InvalidParameterError, require_finite
from planetnav_env.sensors.camera_config import DEFAULT_CAMERA, CameraConfig

__all__ = [
    "apparent_diameter",
    "apparent_diameter_model",
    "body_to_camera",
    "camera_to_body",
    "camera_to_image_mm",
    "camera_to_pixel",
    "inertial_to_camera",
    "on_sensor",
    "pixel_to_camera",
    "sun_angle",
]


def _vec(name: str, a: object, width: int) -> np.ndarray:
    v = require_finite(name, a)
    if v.ndim == 0 or v.shape[-1] != width:
        raise InvalidParameterError(f"{name} must have shape (..., {width}), got {v.shape}")
    return v


def apparent_diameter(distance_km: np.ndarray | float, radius_km: np.ndarray | float) -> np.ndarray:
    """Exact angular diameter of a sphere [rad]: ``2 asin(R / L)`` (the truth image of the disk).

    ``distance_km`` L: from the observer to the sphere's centre [km]; ``radius_km`` R [km]. Requires
    ``L > R > 0`` (outside the body). Broadcasts.
    """
    dist = require_finite("distance_km", distance_km)
    rad = require_finite("radius_km", radius_km)
    if np.any(rad <= 0.0):
        raise InvalidParameterError(f"radius_km must be positive, got {rad[rad <= 0.0].ravel()[:4]}")
    if np.any(dist <= rad):
        bad = np.broadcast_to(dist, np.broadcast_shapes(dist.shape, rad.shape))[dist <= rad]
        raise InvalidParameterError(
            f"distance_km must exceed radius_km (observer inside the body), got {bad[:4]}"
        )
    return 2.0 * np.arcsin(rad / dist)


def apparent_diameter_model(distance_km: np.ndarray | float, radius_km: np.ndarray | float) -> np.ndarray:
    """The thesis's measurement model of the angular diameter [rad]: ``2 atan(D / 2L) = 2 atan(R / L)``.

    This is what the filter uses as ``h(x)`` (thesis 2.2). It differs from the exact :func:`apparent_diameter`
    by ``2 asin(x) - 2 atan(x) = x^3 + O(x^5)`` with ``x = R/L``. Requires ``L > 0``, ``R > 0``.
    """
    dist = require_finite("distance_km", distance_km)
    rad = require_finite("radius_km", radius_km)
    if np.any(rad <= 0.0) or np.any(dist <= 0.0):
        raise InvalidParameterError(f"distance_km and radius_km must be positive, got {dist!r}, {rad!r}")
    return 2.0 * np.arctan(rad / dist)


def body_to_camera(v_body: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Body-frame vectors ``(..., 3)`` -> camera frame, ``v_C = C^T v_B``."""
    return _vec("v_body", v_body, 3) @ config._c2b


def camera_to_body(v_cam: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Camera-frame vectors ``(..., 3)`` -> body frame, ``v_B = C v_C``."""
    return _vec("v_cam", v_cam, 3) @ config._c2b.T


def inertial_to_camera(
    v_inertial: np.ndarray, q_body_to_inertial: np.ndarray, config: CameraConfig = DEFAULT_CAMERA
) -> np.ndarray:
    """Inertial vectors ``(..., 3)`` -> camera frame for attitude ``q`` ``(..., 4)``: ``C^T R(q)^T v_I``."""
    v = _vec("v_inertial", v_inertial, 3)
    q = qt.normalize(_vec("q_body_to_inertial", q_body_to_inertial, 4))
    return qt.rotate_inertial_to_body(q, v) @ config._c2b


def _project(v_cam: np.ndarray, scale: float, cx: float, cy: float) -> np.ndarray:
    v = _vec("v_cam", v_cam, 3)
    z = v[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.stack([scale * v[..., 0] / z + cx, scale * v[..., 1] / z + cy], axis=-1)
    # Not imaged (behind or in the plane of the lens): NaN rather than a mirrored point.
    out[z <= 0.0] = np.nan
    return out


def camera_to_image_mm(v_cam: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Image-plane coordinates [mm] relative to the principal point, ``(f X/Z, f Y/Z)``; shape ``(..., 2)``.

    NaN where ``Z <= 0`` (the direction is not imaged).
    """
    return _project(v_cam, config.focal_length_mm, 0.0, 0.0)


def camera_to_pixel(v_cam: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Pixel coordinates ``(f_px X/Z + c_x, f_px Y/Z + c_y)`` [px], shape ``(..., 2)``; NaN where ``Z <= 0``
    (not imaged)."""
    cx, cy = config.principal_point
    return _project(v_cam, config.f_px, cx, cy)


def pixel_to_camera(pixel: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Unit line of sight in the camera frame ``(..., 3)`` through pixel coordinates ``(..., 2)`` [px].

    The inverse of :func:`camera_to_pixel` for ``Z > 0``; any pixel coordinates are accepted (also those off
    the sensor).
    """
    p = _vec("pixel", pixel, 2)
    cx, cy = config.principal_point
    v = np.stack(
        [(p[..., 0] - cx) / config.f_px, (p[..., 1] - cy) / config.f_px, np.ones(p.shape[:-1])], axis=-1
    )
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def on_sensor(v_cam: np.ndarray, config: CameraConfig = DEFAULT_CAMERA) -> np.ndarray:
    """Whether camera-frame directions ``(..., 3)`` land on the sensor: ``Z > 0`` and the pixel coordinates in
    the closed rectangle ``[0, W] x [0, H]``. Returns a bool array of shape ``(...)``."""
    px = camera_to_pixel(v_cam, config)
    w, h = config.resolution_px
    with np.errstate(invalid="ignore"):  # NaN (behind the camera) compares False
        return (px[..., 0] >= 0.0) & (px[..., 0] <= w) & (px[..., 1] >= 0.0) & (px[..., 1] <= h)


def sun_angle(r_sc: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Angle [rad] between inertial ``direction`` ``(..., 3)`` seen from the spacecraft at heliocentric
    ``r_sc`` ``(..., 3)`` [km] and the direction to the Sun (at the origin), in [0, pi]."""
    r = _vec("r_sc", r_sc, 3)
    d = _vec("direction", direction, 3)
    s = -r
    cross = np.linalg.norm(np.cross(d, s), axis=-1)
    return np.arctan2(cross, np.sum(d * s, axis=-1))
