"""Star camera: pinhole projection, apparent size of a planet, visibility, noisy measurements.

The model is the thesis's (section 2.3, "Модель звездной камеры"; parameters in 3.1.3) with the corrections of
``/work/shared/papers/ERRATA.md`` items 10 and 11. ``docs/camera.md`` gives the reasons behind every default.

Frames and conventions
----------------------
* Inertial frame I: ICRF/J2000 equatorial, heliocentric (the Sun is at the origin). Units km, s, rad.
* Body frame B and the attitude ``q`` (scalar first): ``v_I = R(q) v_B``
  (see :mod:`planetnav_env.quaternion`).
* Camera frame C: the thesis's OXYZ of the CCD. ``+Z`` is the boresight (optical axis, pointing out of the
  lens towards the scene); ``X`` and ``Y`` are parallel to the sides of the sensor. ``v_B = C_cb v_C`` with
  ``C_cb = CameraConfig.camera_to_body``. Default: camera Z -> body +x (the thesis's O'X is the optical axis),
  camera X -> body +y, camera Y -> body +z (a cyclic permutation, so right-handed).
* Pinhole projection (virtual image plane in front of the lens, i.e. not inverted):
  image plane ``x_mm = f X/Z, y_mm = f Y/Z`` (relative to the principal point),
  pixels ``x_px = f_px X/Z + c_x, y_px = f_px Y/Z + c_y`` (thesis: ``x_i = f_x X_i/Z_i + c_x``), with
  ``f_px = f / pitch`` (square pixels, ``f_x = f_y``).
* Pixel coordinates are continuous with their origin at a corner of the sensor (the thesis's Kxy): pixel
  ``(i, j)`` covers ``[i, i+1) x [j, j+1)``; the sensor is the closed rectangle ``[0, W] x [0, H]``;
  the default principal point ``(W/2, H/2)`` is the sensor's centre.

Implementation
--------------
The hot paths (:func:`visibility`, :func:`measure`) are numba kernels looping over the batch; the kernels
mirror :func:`planetnav_env.quaternion.dcm_body_to_inertial` and the projection helpers of this module because
numba cannot call numpy-level code. ``tests/test_camera.py`` pins the kernels to the numpy helpers. Inputs
carry a leading batch shape ``(...)``; a single spacecraft is a batch of shape ``()``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from planetnav_env import quaternion as qt
from planetnav_env.bodies import body
from planetnav_env.codes import CameraStatus, VisibilityReason
from planetnav_env.dynamics.attitude import dcm_body_to_inertial_kernel
from planetnav_env.errors import (
    InvalidParameterError,
    NonFiniteError,
    NotVisibleError,
    require_finite,
)
from planetnav_env.jit import row_kernel

__all__ = [
    "ARCSEC_RAD",
    "DEFAULT_CAMERA",
    "DEFAULT_CAMERA_TO_BODY",
    "NO_OCCULTER",
    "SUN_OCCULTER",
    "CameraConfig",
    "CameraMeasurement",
    "VisibilityReason",
    "VisibilityResult",
    "apparent_diameter",
    "apparent_diameter_model",
    "body_to_camera",
    "camera_to_body",
    "camera_to_image_mm",
    "camera_to_pixel",
    "inertial_to_camera",
    "measure",
    "on_sensor",
    "pixel_to_camera",
    "sun_angle",
    "visibility",
]

ARCSEC_RAD = math.pi / 648_000.0
SUN_RADIUS_KM = body("sun").radius

#: Camera -> body rotation (``v_B = C v_C``): columns are the camera X, Y, Z axes in body components.
#: Z (boresight) -> body +x, X -> body +y, Y -> body +z.
DEFAULT_CAMERA_TO_BODY: tuple[tuple[float, float, float], ...] = (
    (0.0, 0.0, 1.0),
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
)

#: ``VisibilityResult.occulter`` when nothing hides the target / when the Sun does.
NO_OCCULTER = -1
SUN_OCCULTER = -2


# The camera reports VisibilityReason 0-4 (defined in planetnav_env.codes); as ints for the kernels.
_VISIBLE = int(VisibilityReason.VISIBLE)
_OUT_OF_FOV = int(VisibilityReason.OUT_OF_FOV)
_OCCULTED = int(VisibilityReason.OCCULTED)
_SUN_EXCLUSION = int(VisibilityReason.SUN_EXCLUSION)
_TOO_SMALL = int(VisibilityReason.TOO_SMALL)


# ---------------------------------------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------------------------------------


def _real(name: str, value: object) -> float:
    """``float(value)`` for a finite real number (not a bool), else InvalidParameterError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidParameterError(f"CameraConfig.{name} must be a real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise InvalidParameterError(f"CameraConfig.{name} must be finite, got {value!r}")
    return v


@dataclass(frozen=True)
class CameraConfig:
    """Star-camera parameters (validated on construction; errors name the field and the value).

    Attributes
    ----------
    focal_length_mm
        Focal length f [mm]. Thesis 3.1.3: 20 mm.
    pixel_pitch_um
        Pixel size [um], square pixels. The thesis gives none; 5.5 um is a typical CMOS star-tracker pixel.
    resolution_px
        Sensor size ``(W, H)`` in pixels: W along camera X, H along camera Y.
    principal_point_px
        ``(c_x, c_y)`` [px], where the optical axis pierces the sensor; ``None`` -> the centre ``(W/2, H/2)``
        (resolved in :attr:`principal_point`; the field keeps ``None``). Must lie on the sensor.
    direction_noise_arcsec
        1-sigma of the line-of-sight error per axis perpendicular to the LOS [arcsec]. Thesis: 3-4".
    diameter_noise_px
        1-sigma of the measured disk diameter [px]. Thesis: 2-3 px. The angular-diameter noise is
        ``diameter_noise_px / f_px`` [rad], constant with distance (ERRATA 10).
    sun_exclusion_deg
        Half-angle of the Sun-exclusion cone [deg], in [0, 180). 30 deg is a typical star-tracker baffle
        (not from the thesis). 0 disables the test.
    min_diameter_px
        Detection threshold on the apparent diameter [px], >= 0. Planets are detected by brightness even when
        sub-pixel; for one planet the flux is proportional to the solid angle, so the apparent size is a
        brightness proxy. 0.02 px (1.1") puts Saturn, the faintest-surface target in ``bodies``, near V = 6.7;
        see ``docs/camera.md``.
    camera_to_body
        3x3 rotation ``C`` with ``v_B = C v_C`` (rows = body axes, columns = camera axes). Default: camera Z
        (boresight) -> body +x, camera X -> body +y, camera Y -> body +z.
    """

    focal_length_mm: float = 20.0
    pixel_pitch_um: float = 5.5
    resolution_px: tuple[int, int] = (1024, 1024)
    principal_point_px: tuple[float, float] | None = None
    direction_noise_arcsec: float = 3.5
    diameter_noise_px: float = 2.5
    sun_exclusion_deg: float = 30.0
    min_diameter_px: float = 0.02
    camera_to_body: tuple[tuple[float, float, float], ...] = DEFAULT_CAMERA_TO_BODY
    # Kernel inputs derived once (not part of equality/hash/repr).
    _pp: tuple[float, float] = field(init=False, repr=False, compare=False)
    _c2b: np.ndarray = field(init=False, repr=False, compare=False)
    _params: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__  # frozen: normalise fields once, here only
        f_mm = _real("focal_length_mm", self.focal_length_mm)
        pitch = _real("pixel_pitch_um", self.pixel_pitch_um)
        for name, v in (("focal_length_mm", f_mm), ("pixel_pitch_um", pitch)):
            if v <= 0.0:
                raise InvalidParameterError(f"CameraConfig.{name} must be positive, got {v!r}")
        set_(self, "focal_length_mm", f_mm)
        set_(self, "pixel_pitch_um", pitch)

        res = self.resolution_px
        if isinstance(res, (str, bytes)) or not isinstance(res, Sequence | np.ndarray) or len(res) != 2:
            raise InvalidParameterError(f"CameraConfig.resolution_px must be (width, height), got {res!r}")
        wh = []
        for v in res:
            x = _real("resolution_px", v)
            if x <= 0.0 or x != int(x):
                raise InvalidParameterError(
                    f"CameraConfig.resolution_px must be positive integers, got {res!r}"
                )
            wh.append(int(x))
        width, height = wh
        set_(self, "resolution_px", (width, height))

        # None stays None in the field (so dataclasses.replace with a new resolution re-centres it); the
        # resolved point is the ``principal_point`` property.
        pp = (0.5 * width, 0.5 * height) if self.principal_point_px is None else self.principal_point_px
        if isinstance(pp, (str, bytes)) or not isinstance(pp, Sequence | np.ndarray) or len(pp) != 2:
            raise InvalidParameterError(f"CameraConfig.principal_point_px must be (c_x, c_y), got {pp!r}")
        cx, cy = _real("principal_point_px", pp[0]), _real("principal_point_px", pp[1])
        if not (0.0 <= cx <= width and 0.0 <= cy <= height):
            raise InvalidParameterError(
                f"CameraConfig.principal_point_px must lie on the sensor [0, {width}] x [0, {height}], "
                f"got {pp!r}"
            )
        if self.principal_point_px is not None:
            set_(self, "principal_point_px", (cx, cy))
        set_(self, "_pp", (cx, cy))

        for name in ("direction_noise_arcsec", "diameter_noise_px", "min_diameter_px"):
            v = _real(name, getattr(self, name))
            if v < 0.0:
                raise InvalidParameterError(f"CameraConfig.{name} must be >= 0, got {v!r}")
            set_(self, name, v)
        excl = _real("sun_exclusion_deg", self.sun_exclusion_deg)
        if not 0.0 <= excl < 180.0:
            raise InvalidParameterError(f"CameraConfig.sun_exclusion_deg must be in [0, 180), got {excl!r}")
        set_(self, "sun_exclusion_deg", excl)

        try:
            c = np.array(self.camera_to_body, dtype=float)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"CameraConfig.camera_to_body must be a 3x3 rotation matrix, got {self.camera_to_body!r}"
            ) from None
        if c.shape != (3, 3) or not np.all(np.isfinite(c)):
            raise InvalidParameterError(
                f"CameraConfig.camera_to_body must be a finite 3x3 matrix, got {self.camera_to_body!r}"
            )
        if not np.allclose(c.T @ c, np.eye(3), rtol=0.0, atol=1e-9) or np.linalg.det(c) < 0.0:
            raise InvalidParameterError(
                "CameraConfig.camera_to_body must be a proper rotation (C^T C = I, det +1), "
                f"got {c.tolist()!r}"
            )
        set_(self, "camera_to_body", tuple(tuple(float(x) for x in row) for row in c))
        # Kept writable (the public view is read-only): numba types read-only arrays separately, and a pickled
        # copy (vector envs) comes back writable; one array type means one compiled kernel.
        set_(self, "_c2b", c)

        params = np.array(
            [
                self.f_px,
                cx,
                cy,
                float(width),
                float(height),
                self.sun_exclusion_rad,
                self.min_diameter_px,
                self.sigma_direction_rad,
                self.sigma_alpha_rad,
                f_mm,
                SUN_RADIUS_KM,
            ]
        )
        set_(self, "_params", params)

    # --- derived quantities ------------------------------------------------------------------------------
    @property
    def f_px(self) -> float:
        """Focal length in pixels, ``f / pitch`` (the thesis's f_x = f_y)."""
        return self.focal_length_mm * 1000.0 / self.pixel_pitch_um

    @property
    def principal_point(self) -> tuple[float, float]:
        """Resolved ``(c_x, c_y)`` [px]: the sensor centre when ``principal_point_px`` is None."""
        return self._pp

    @property
    def ifov_rad(self) -> float:
        """Instantaneous field of view of one pixel at the principal point [rad/px], ``1 / f_px``."""
        return 1.0 / self.f_px

    @property
    def sensor_size_mm(self) -> tuple[float, float]:
        """Physical size of the sensor (width along X, height along Y) [mm]."""
        return (
            self.resolution_px[0] * self.pixel_pitch_um * 1e-3,
            self.resolution_px[1] * self.pixel_pitch_um * 1e-3,
        )

    @property
    def half_fov_rad(self) -> tuple[float, float]:
        """Largest angle from the boresight to a sensor edge along X and along Y [rad].

        With the default (centred) principal point these are the half-widths of the rectangular field of view.
        The field-of-view test itself is the exact rectangle (:func:`on_sensor`), not a cone.
        """
        (w, h), (cx, cy), f = self.resolution_px, self._pp, self.f_px
        return (math.atan(max(cx, w - cx) / f), math.atan(max(cy, h - cy) / f))

    @property
    def half_fov_diagonal_rad(self) -> float:
        """Half-angle of the cone circumscribing the sensor rectangle [rad] (the farthest corner)."""
        (w, h), (cx, cy), f = self.resolution_px, self._pp, self.f_px
        return math.atan(math.hypot(max(cx, w - cx), max(cy, h - cy)) / f)

    @property
    def sigma_direction_rad(self) -> float:
        """1-sigma line-of-sight error per perpendicular axis [rad]."""
        return self.direction_noise_arcsec * ARCSEC_RAD

    @property
    def sigma_alpha_rad(self) -> float:
        """1-sigma of the measured angular diameter [rad]: ``diameter_noise_px / f_px``, constant with range
        (ERRATA 10: the thesis's ``dQ = Z dq / f_x`` is the error of the physical diameter, not of alpha)."""
        return self.diameter_noise_px / self.f_px

    @property
    def sun_exclusion_rad(self) -> float:
        """Half-angle of the Sun-exclusion cone [rad]."""
        return math.radians(self.sun_exclusion_deg)

    @property
    def min_diameter_rad(self) -> float:
        """Detection threshold as an angular diameter [rad], ``min_diameter_px / f_px``."""
        return self.min_diameter_px / self.f_px

    @property
    def camera_to_body_matrix(self) -> np.ndarray:
        """``C`` as a read-only (3, 3) array, ``v_B = C @ v_C``."""
        view = self._c2b.view()
        view.flags.writeable = False
        return view

    @property
    def boresight_body(self) -> np.ndarray:
        """Unit boresight (camera +Z) in body components, shape (3,)."""
        return self._c2b[:, 2].copy()


DEFAULT_CAMERA = CameraConfig()


# ---------------------------------------------------------------------------------------------------------
# Geometry helpers (numpy; not on the per-step hot path)
# ---------------------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------------------
# Numba kernels (hot path)
# ---------------------------------------------------------------------------------------------------------

# Indices into CameraConfig._params.
_P_FPX, _P_CX, _P_CY, _P_W, _P_H, _P_EXCL, _P_MINPX, _P_SDIR, _P_SALPHA, _P_FMM, _P_RSUN = range(11)

# Kernel status codes (0 = fine); the Python side turns them into named exceptions.
_OK, _ERR_NONFINITE, _ERR_ZERO_Q, _ERR_RADIUS, _ERR_INSIDE_TARGET, _ERR_INSIDE_OCC, _ERR_OCC_RADIUS = (
    int(c) for c in CameraStatus
)


@row_kernel
def _angle(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> float:
    """Angle between two vectors [rad], atan2(|a x b|, a.b): accurate for small and near-pi angles alike."""
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz)


@row_kernel
def _camera_los(
    r: np.ndarray, q: np.ndarray, t: np.ndarray, i: int, c2b: np.ndarray, m: np.ndarray, u: np.ndarray
) -> tuple[float, int]:
    """Line of sight from spacecraft i to its target.

    Fills ``m`` (3, 3) = camera <- inertial rotation ``C^T R(q)^T`` (its row 2 is the boresight in inertial
    components) and ``u`` (6,) = unit LOS in inertial (0:3) and camera (3:6) components. Returns the distance
    L [km] and a status code. R(q) is ``dcm_body_to_inertial_kernel`` divided by |q|^2 (every entry is
    quadratic in q), i.e. the rotation of the normalised q.
    """
    q0, q1, q2, q3 = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    dx, dy, dz = t[i, 0] - r[i, 0], t[i, 1] - r[i, 1], t[i, 2] - r[i, 2]
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    if not (math.isfinite(n2) and math.isfinite(dx) and math.isfinite(dy) and math.isfinite(dz)):
        return 0.0, _ERR_NONFINITE
    if not (math.isfinite(r[i, 0]) and math.isfinite(r[i, 1]) and math.isfinite(r[i, 2])):
        return 0.0, _ERR_NONFINITE
    if n2 == 0.0:
        return 0.0, _ERR_ZERO_Q
    s = 1.0 / n2
    dcm_body_to_inertial_kernel(q0, q1, q2, q3, m)  # R(q) into m for a moment; m is rewritten below
    r00, r01, r02 = m[0, 0] * s, m[0, 1] * s, m[0, 2] * s
    r10, r11, r12 = m[1, 0] * s, m[1, 1] * s, m[1, 2] * s
    r20, r21, r22 = m[2, 0] * s, m[2, 1] * s, m[2, 2] * s
    # m[j, k] = sum_l C[l, j] R[k, l]: camera axis j expressed in inertial components.
    for j in range(3):
        c0, c1, c2 = c2b[0, j], c2b[1, j], c2b[2, j]
        m[j, 0] = r00 * c0 + r01 * c1 + r02 * c2
        m[j, 1] = r10 * c0 + r11 * c1 + r12 * c2
        m[j, 2] = r20 * c0 + r21 * c1 + r22 * c2
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dist == 0.0:
        return 0.0, _ERR_INSIDE_TARGET
    inv = 1.0 / dist
    u[0], u[1], u[2] = dx * inv, dy * inv, dz * inv
    for j in range(3):
        u[3 + j] = m[j, 0] * u[0] + m[j, 1] * u[1] + m[j, 2] * u[2]
    return dist, _OK


#: Slots of the per-element visibility record written by :func:`visibility_row_kernel`.
V_REASON, V_IN_FOV, V_SUN_EX, V_OCCULTED, V_SMALL, V_OCCULTER, V_ALPHA, V_ANG_B, V_ANG_T, V_PIX_X, V_PIX_Y = (
    range(11)
)
N_VIS_SLOTS = 11


@row_kernel
def visibility_row_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    i: int,
    rt: float,
    occ: np.ndarray,
    occ_rad: np.ndarray,
    include_sun: bool,
    c2b: np.ndarray,
    p: np.ndarray,
    m: np.ndarray,
    u: np.ndarray,
    vals: np.ndarray,
) -> int:
    """Visibility of target ``t[i]`` (radius ``rt`` [km]) from spacecraft ``r[i]`` at attitude ``q[i]``.

    The one implementation of the camera's visibility rules (field of view, occultation by the Sun and
    the bodies ``occ`` (K, 3) of radii ``occ_rad`` (K,) [km], Sun exclusion, detection threshold): the
    batch kernel and the simulation core both call it. Writes the record ``vals`` (``N_VIS_SLOTS``,
    slots ``V_*``; reason code 0 visible, 1 out of field, 2 occulted, 3 Sun exclusion, 4 too small;
    occulter -2 the Sun, -1 none, else k). ``m`` (3, 3) and ``u`` (6,) are scratch. Returns a status
    (``_OK`` or an ``_ERR_*`` code). Allocates nothing.
    """
    dist, st = _camera_los(r, q, t, i, c2b, m, u)
    if st != _OK:
        return st
    if not math.isfinite(rt):
        return _ERR_NONFINITE
    if rt <= 0.0:
        return _ERR_RADIUS
    if dist <= rt:
        return _ERR_INSIDE_TARGET
    f_px, cx, cy, w, h = p[_P_FPX], p[_P_CX], p[_P_CY], p[_P_W], p[_P_H]
    excl, min_px, r_sun = p[_P_EXCL], p[_P_MINPX], p[_P_RSUN]
    a = 2.0 * math.asin(rt / dist)
    vals[V_ALPHA] = a
    # Field of view: the centre's pixel inside the closed sensor rectangle, in front of the lens.
    zc = u[5]
    fov = False
    if zc > 0.0:
        xp = f_px * u[3] / zc + cx
        yp = f_px * u[4] / zc + cy
        vals[V_PIX_X], vals[V_PIX_Y] = xp, yp
        fov = 0.0 <= xp <= w and 0.0 <= yp <= h
    else:
        vals[V_PIX_X], vals[V_PIX_Y] = np.nan, np.nan
    # Sun (origin) seen from the spacecraft: direction -r.
    rx, ry, rz = r[i, 0], r[i, 1], r[i, 2]
    d_sun = math.sqrt(rx * rx + ry * ry + rz * rz)
    ab = _angle(m[2, 0], m[2, 1], m[2, 2], -rx, -ry, -rz)
    at = _angle(u[0], u[1], u[2], -rx, -ry, -rz)
    vals[V_ANG_B], vals[V_ANG_T] = ab, at
    sun_ex = ab < excl or at < excl
    # Occultation: a body whose centre is nearer than the target's and whose disk overlaps the target's
    # disk at all (sep < rho_occ + rho_target); the nearest such body is reported.
    rho_t = 0.5 * a
    best = math.inf
    who = -1
    if include_sun:
        if d_sun <= r_sun:
            return _ERR_INSIDE_OCC
        if d_sun < dist and at < math.asin(r_sun / d_sun) + rho_t:
            best = d_sun
            who = -2
    for k in range(occ_rad.shape[0]):
        ox, oy, oz = occ[k, 0] - rx, occ[k, 1] - ry, occ[k, 2] - rz
        if not (math.isfinite(ox) and math.isfinite(oy) and math.isfinite(oz)):
            return _ERR_NONFINITE
        dk = math.sqrt(ox * ox + oy * oy + oz * oz)
        if dk <= occ_rad[k]:
            return _ERR_INSIDE_OCC
        if dk < dist and dk < best:
            if _angle(u[0], u[1], u[2], ox, oy, oz) < math.asin(occ_rad[k] / dk) + rho_t:
                best = dk
                who = k
    small = a * f_px < min_px
    reason = _VISIBLE
    if not fov:
        reason = _OUT_OF_FOV
    elif who != -1:
        reason = _OCCULTED
    elif sun_ex:
        reason = _SUN_EXCLUSION
    elif small:
        reason = _TOO_SMALL
    vals[V_REASON] = reason
    vals[V_IN_FOV] = fov
    vals[V_SUN_EX] = sun_ex
    vals[V_OCCULTED] = who != -1
    vals[V_SMALL] = small
    vals[V_OCCULTER] = who
    return _OK


@njit(cache=True, nogil=True)
def _visibility_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    trad: np.ndarray,
    occ: np.ndarray,
    occ_rad: np.ndarray,
    occ_per_elem: bool,
    include_sun: bool,
    c2b: np.ndarray,
    p: np.ndarray,
):  # -> (status, bad index, (reason, in_fov, sun_ex, occulted, small, occulter, alpha, ang_b, ang_t, pix))
    n = r.shape[0]
    n_occ = occ_rad.shape[0]
    reason = np.zeros(n, np.int8)
    in_fov = np.zeros(n, np.bool_)
    sun_ex = np.zeros(n, np.bool_)
    occd = np.zeros(n, np.bool_)
    small = np.zeros(n, np.bool_)
    occulter = np.full(n, -1, np.int64)
    alpha = np.empty(n)
    ang_b = np.empty(n)
    ang_t = np.empty(n)
    pix = np.empty((n, 2))
    res = (reason, in_fov, sun_ex, occd, small, occulter, alpha, ang_b, ang_t, pix)
    m = np.empty((3, 3))
    u = np.empty(6)
    vals = np.empty(N_VIS_SLOTS)
    for k in range(n_occ):
        if not math.isfinite(occ_rad[k]):
            return _ERR_NONFINITE, -1, res
        if occ_rad[k] <= 0.0:
            return _ERR_OCC_RADIUS, k, res
    for i in range(n):
        st = visibility_row_kernel(
            r, q, t, i, trad[i], occ[i if occ_per_elem else 0], occ_rad, include_sun, c2b, p, m, u, vals
        )
        if st != _OK:
            return st, i, res
        reason[i] = int(vals[V_REASON])
        in_fov[i] = vals[V_IN_FOV] != 0.0
        sun_ex[i] = vals[V_SUN_EX] != 0.0
        occd[i] = vals[V_OCCULTED] != 0.0
        small[i] = vals[V_SMALL] != 0.0
        occulter[i] = int(vals[V_OCCULTER])
        alpha[i] = vals[V_ALPHA]
        ang_b[i] = vals[V_ANG_B]
        ang_t[i] = vals[V_ANG_T]
        pix[i, 0], pix[i, 1] = vals[V_PIX_X], vals[V_PIX_Y]
    return _OK, -1, res


@row_kernel
def measure_row_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    i: int,
    rt: float,
    z: np.ndarray,
    c2b: np.ndarray,
    p: np.ndarray,
    m: np.ndarray,
    u: np.ndarray,
    los: np.ndarray,
    los_true: np.ndarray,
    mm: np.ndarray,
    pix: np.ndarray,
) -> tuple[int, float, float]:
    """One camera measurement of target ``t[i]`` (radius ``rt``) from ``r[i]`` at attitude ``q[i]`` with
    the three standard-normal draws ``z`` (two across the line of sight, one for the diameter).

    The one implementation of the measurement model (the batch kernel and the simulation core call it).
    Writes the noisy and true body-frame lines of sight ``los``/``los_true`` (3,), the image point ``mm``
    (2,) [mm] and ``pix`` (2,) [px]; returns (status, noisy angular diameter, true angular diameter)
    [rad]. ``m`` (3, 3) and ``u`` (6,) are scratch. Allocates nothing.
    """
    dist, st = _camera_los(r, q, t, i, c2b, m, u)
    if st != _OK:
        return st, 0.0, 0.0
    if not math.isfinite(rt):
        return _ERR_NONFINITE, 0.0, 0.0
    if rt <= 0.0:
        return _ERR_RADIUS, 0.0, 0.0
    if dist <= rt:
        return _ERR_INSIDE_TARGET, 0.0, 0.0
    f_px, cx, cy, f_mm = p[_P_FPX], p[_P_CX], p[_P_CY], p[_P_FMM]
    s_dir, s_alpha = p[_P_SDIR], p[_P_SALPHA]
    a = 2.0 * math.asin(rt / dist)
    ux, uy, uz = u[3], u[4], u[5]
    # Tangent basis at the true LOS: e1 = camera X projected off the LOS (camera Y when the LOS is within
    # ~26 deg of X, to stay well conditioned); e2 = u x e1. Near the boresight e1 ~ X and e2 ~ Y, so the
    # two draws are the errors along the image axes.
    if abs(ux) < 0.9:
        e1x, e1y, e1z = 1.0 - ux * ux, -ux * uy, -ux * uz
    else:
        e1x, e1y, e1z = -uy * ux, 1.0 - uy * uy, -uy * uz
    inv = 1.0 / math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x, e1y, e1z = e1x * inv, e1y * inv, e1z * inv
    e2x, e2y, e2z = uy * e1z - uz * e1y, uz * e1x - ux * e1z, ux * e1y - uy * e1x
    # Rotate u by the angle vector (d1, d2) in the tangent plane (exponential map on the sphere): an exact
    # unit vector, per-axis angular errors d1, d2 ~ N(0, sigma) independent.
    d1 = s_dir * z[0]
    d2 = s_dir * z[1]
    wx, wy, wz = d1 * e1x + d2 * e2x, d1 * e1y + d2 * e2y, d1 * e1z + d2 * e2z
    phi = math.sqrt(d1 * d1 + d2 * d2)
    cphi = math.cos(phi)
    sinc = math.sin(phi) / phi if phi > 0.0 else 1.0
    vx, vy, vz = cphi * ux + sinc * wx, cphi * uy + sinc * wy, cphi * uz + sinc * wz
    for k in range(3):
        los[k] = c2b[k, 0] * vx + c2b[k, 1] * vy + c2b[k, 2] * vz
        los_true[k] = c2b[k, 0] * ux + c2b[k, 1] * uy + c2b[k, 2] * uz
    if vz > 0.0:
        mm[0], mm[1] = f_mm * vx / vz, f_mm * vy / vz
        pix[0], pix[1] = f_px * vx / vz + cx, f_px * vy / vz + cy
    else:
        mm[0], mm[1] = np.nan, np.nan
        pix[0], pix[1] = np.nan, np.nan
    # Unbiased additive noise; may go negative when sigma_alpha >> alpha (kept on purpose).
    return _OK, a + s_alpha * z[2], a


@njit(cache=True, nogil=True)
def _measure_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    trad: np.ndarray,
    z: np.ndarray,
    c2b: np.ndarray,
    p: np.ndarray,
):  # -> (status, bad index, los_b, alpha, image_mm, pix, los_b_true, alpha_true)
    n = r.shape[0]
    los = np.empty((n, 3))
    los_true = np.empty((n, 3))
    alpha = np.empty(n)
    alpha_true = np.empty(n)
    mm = np.empty((n, 2))
    pix = np.empty((n, 2))
    m = np.empty((3, 3))
    u = np.empty(6)
    for i in range(n):
        st, alpha[i], alpha_true[i] = measure_row_kernel(
            r, q, t, i, trad[i], z[i], c2b, p, m, u, los[i], los_true[i], mm[i], pix[i]
        )
        if st != _OK:
            return st, i, los, alpha, mm, pix, los_true, alpha_true
    return _OK, -1, los, alpha, mm, pix, los_true, alpha_true


@njit(cache=True, nogil=True)
def visibility_codes_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    trad: np.ndarray,
    occ: np.ndarray,
    occ_rad: np.ndarray,
    include_sun: bool,
    c2b: np.ndarray,
    p: np.ndarray,
    out: np.ndarray,
) -> int:
    """Reason codes only (into ``out``), for callers inside a step loop: returning the full result
    tuple boxes ten arrays, which costs more than the geometry. Same semantics as
    :func:`_visibility_kernel` with occulters shared by the batch; returns its status."""
    st, _, res = _visibility_kernel(r, q, t, trad, occ, occ_rad, False, include_sun, c2b, p)
    if st == _OK:
        for i in range(out.shape[0]):
            out[i] = res[0][i]
    return st


@njit(cache=True, nogil=True)
def measure_into_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    trad: np.ndarray,
    z: np.ndarray,
    c2b: np.ndarray,
    p: np.ndarray,
    los_out: np.ndarray,
    alpha_out: np.ndarray,
    pix_out: np.ndarray,
) -> int:
    """:func:`_measure_kernel` writing the noisy body-frame LOS, angular diameter and pixel of
    element 0..n-1 into caller arrays (no boxing); returns its status."""
    st, _, los, alpha, _, pix, _, _ = _measure_kernel(r, q, t, trad, z, c2b, p)
    if st == _OK:
        for i in range(los.shape[0]):
            alpha_out[i] = alpha[i]
            for k in range(3):
                los_out[i, k] = los[i, k]
            pix_out[i, 0] = pix[i, 0]
            pix_out[i, 1] = pix[i, 1]
    return st


# ---------------------------------------------------------------------------------------------------------
# Public hot-path API
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class VisibilityResult:
    """Per-element visibility of a target (arrays of the batch shape ``(...)``).

    Attributes
    ----------
    visible
        bool: all tests pass (``reason == VISIBLE``).
    reason
        int8 codes of :class:`VisibilityReason`: the first failing test in the order
        OUT_OF_FOV, OCCULTED, SUN_EXCLUSION, TOO_SMALL.
    in_fov
        bool: the target's centre projects onto the sensor rectangle (``Z > 0``).
    sun_excluded
        bool: the boresight or the target's direction is within ``sun_exclusion_deg`` of the Sun.
    occulted
        bool: a nearer body's disk overlaps the target's disk (the Sun included).
    too_small
        bool: ``apparent_diameter_rad * f_px < min_diameter_px``.
    occulter
        int: :data:`NO_OCCULTER` (-1), :data:`SUN_OCCULTER` (-2), or the index into ``other_body_pos`` of the
        nearest occulting body.
    apparent_diameter_rad
        Truth angular diameter ``2 asin(R/L)`` [rad].
    sun_angle_boresight_rad, sun_angle_target_rad
        Angles [rad] from the Sun direction to the boresight and to the target.
    pixel
        Truth pixel coordinates of the target's centre ``(..., 2)`` [px]; NaN where it is behind the camera.
    """

    visible: np.ndarray
    reason: np.ndarray
    in_fov: np.ndarray
    sun_excluded: np.ndarray
    occulted: np.ndarray
    too_small: np.ndarray
    occulter: np.ndarray
    apparent_diameter_rad: np.ndarray
    sun_angle_boresight_rad: np.ndarray
    sun_angle_target_rad: np.ndarray
    pixel: np.ndarray

    @property
    def behind_sun(self) -> np.ndarray:
        """bool: the Sun's disk is in front of the target's."""
        return self.occulter == SUN_OCCULTER

    @property
    def all_visible(self) -> bool:
        """Whether every element of the batch is visible."""
        return bool(np.all(self.visible))

    def reason_at(self, index: int | tuple[int, ...] = ()) -> VisibilityReason:
        """The :class:`VisibilityReason` of one element (``()`` for an unbatched call)."""
        return VisibilityReason(int(self.reason[index]))


@dataclass(frozen=True, slots=True)
class CameraMeasurement:
    """One noisy camera measurement per element (batch shape ``(...)``).

    Attributes
    ----------
    los_body
        Measured unit line of sight to the target's centre, body frame ``(..., 3)``.
    alpha_rad
        Measured angular diameter [rad]; truth + N(0, sigma_alpha). May be negative at long range (unbiased).
    image_mm
        Measured centre on the image plane relative to the principal point ``(..., 2)`` [mm], ``f X/Z``
        of the measured LOS; NaN if the measured LOS is behind the camera.
    pixel
        The same in pixel coordinates ``(..., 2)`` [px].
    los_body_true, alpha_true_rad
        The noise-free values (truth: geometric LOS and ``2 asin(R/L)``), for diagnostics and rewards.
    visibility
        The :class:`VisibilityResult` checked before measuring, or ``None`` when ``require_visible=False``.
    """

    los_body: np.ndarray
    alpha_rad: np.ndarray
    image_mm: np.ndarray
    pixel: np.ndarray
    los_body_true: np.ndarray
    alpha_true_rad: np.ndarray
    visibility: VisibilityResult | None = None


def _c_array(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """C-contiguous, writable float64 array of ``shape`` (a view when possible). Writable because numba
    compiles read-only arrays as a separate type; one type per kernel argument keeps a single compiled
    specialisation (and its cache)."""
    a = a.reshape(shape)
    if not (a.flags.c_contiguous and a.flags.writeable):
        a = np.array(a, dtype=np.float64, order="C")
    return a


def _prepare(
    r_sc: np.ndarray, q: np.ndarray, target_pos: np.ndarray, target_radius: np.ndarray | float
) -> tuple[tuple[int, ...], dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Batch shape, the original inputs (for error messages) and flat (n, k) kernel arrays."""
    r = np.asarray(r_sc, dtype=np.float64)
    qa = np.asarray(q, dtype=np.float64)
    t = np.asarray(target_pos, dtype=np.float64)
    rad = np.asarray(target_radius, dtype=np.float64)
    for name, a, k in (("r_sc", r, 3), ("q_body_to_inertial", qa, 4), ("target_pos", t, 3)):
        if a.ndim == 0 or a.shape[-1] != k:
            raise InvalidParameterError(f"{name} must have shape (..., {k}), got {a.shape}")
    batch = r.shape[:-1]
    if qa.shape[:-1] != batch or t.shape[:-1] != batch or (rad.ndim and rad.shape != batch):
        try:
            batch = np.broadcast_shapes(batch, qa.shape[:-1], t.shape[:-1], rad.shape)
        except ValueError:
            raise InvalidParameterError(
                f"batch shapes do not broadcast: r_sc {r.shape}, q_body_to_inertial {qa.shape}, "
                f"target_pos {t.shape}, target_radius {rad.shape}"
            ) from None
        r = np.broadcast_to(r, (*batch, 3))
        qa = np.broadcast_to(qa, (*batch, 4))
        t = np.broadcast_to(t, (*batch, 3))
    n = math.prod(batch)
    originals = {"r_sc": r, "q_body_to_inertial": qa, "target_pos": t, "target_radius": rad}
    rad_flat = np.full(n, float(rad)) if rad.ndim == 0 else _c_array(np.broadcast_to(rad, batch), (n,))
    return batch, originals, _c_array(r, (n, 3)), _c_array(qa, (n, 4)), _c_array(t, (n, 3)), rad_flat


_NO_OCC_POS = np.zeros((1, 0, 3))
_NO_OCC_RAD = np.zeros(0)


def _prepare_occulters(
    batch: tuple[int, ...], n: int, other_body_pos: np.ndarray | None, other_body_radius: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, bool]:
    if other_body_pos is None and other_body_radius is None:
        return _NO_OCC_POS, _NO_OCC_RAD, False
    if other_body_pos is None or other_body_radius is None:
        raise InvalidParameterError("other_body_pos and other_body_radius must be given together")
    pos = np.asarray(other_body_pos, dtype=np.float64)
    rad = np.atleast_1d(np.asarray(other_body_radius, dtype=np.float64))
    if pos.ndim == 1:
        pos = pos[None, :]
    m = rad.shape[0]
    if rad.ndim != 1 or pos.shape[-1:] != (3,) or pos.shape[-2] != m:
        raise InvalidParameterError(
            f"other_body_pos must be (M, 3) or (..., M, 3) with M = len(other_body_radius) = {m}, "
            f"got {pos.shape}"
        )
    if pos.ndim == 2:
        return _c_array(pos, (1, m, 3)), _c_array(rad, (m,)), False
    if pos.shape[:-2] != batch:
        try:
            pos = np.broadcast_to(pos, (*batch, m, 3))
        except ValueError:
            raise InvalidParameterError(
                f"other_body_pos batch shape {pos.shape[:-2]} does not match the batch {batch}"
            ) from None
    return _c_array(pos, (n, m, 3)), _c_array(rad, (m,)), True


def _index(flat: int, batch: tuple[int, ...]) -> tuple[int, ...]:
    """Multi-index (plain ints) of flat element ``flat`` of a batch of shape ``batch``."""
    return tuple(int(k) for k in np.unravel_index(flat, batch)) if batch else ()


def _raise_kernel_error(
    status: int, index: int, batch: tuple[int, ...], originals: dict[str, np.ndarray | None]
) -> None:
    """Turn a kernel status into the specific exception, naming the input and the element."""
    where = f" at batch index {_index(index, batch)}" if index >= 0 else ""
    if status == _ERR_NONFINITE:
        for name, a in originals.items():
            if a is not None:
                require_finite(name, a)
        raise NonFiniteError(f"non-finite input{where}")  # pragma: no cover - require_finite raised above
    if status == _ERR_ZERO_Q:
        raise InvalidParameterError(f"q_body_to_inertial has zero norm{where}")
    if status == _ERR_RADIUS:
        raise InvalidParameterError(
            f"target_radius must be positive{where}, got {originals['target_radius']!r}"
        )
    if status == _ERR_INSIDE_TARGET:
        raise InvalidParameterError(f"spacecraft is inside the target (distance <= target_radius){where}")
    if status == _ERR_INSIDE_OCC:
        raise InvalidParameterError(
            f"spacecraft is inside an occulting body (the Sun or other_body_pos){where}"
        )
    if status == _ERR_OCC_RADIUS:
        raise InvalidParameterError(
            f"other_body_radius must be positive and finite, got {originals.get('other_body_radius')!r}"
        )
    raise AssertionError(f"unknown camera kernel status {status}")  # pragma: no cover


def _visibility_flat(
    batch: tuple[int, ...],
    originals: dict[str, np.ndarray | None],
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    trad: np.ndarray,
    other_body_pos: np.ndarray | None,
    other_body_radius: np.ndarray | None,
    config: CameraConfig,
    include_sun: bool,
) -> VisibilityResult:
    occ, occ_rad, per_elem = _prepare_occulters(batch, r.shape[0], other_body_pos, other_body_radius)
    st, idx, res = _visibility_kernel(
        r, q, t, trad, occ, occ_rad, per_elem, bool(include_sun), config._c2b, config._params
    )
    reason, fov, sun_ex, occd, small, who, alpha, ang_b, ang_t, pix = res
    if st != _OK:
        originals = {**originals, "other_body_pos": other_body_pos, "other_body_radius": other_body_radius}
        _raise_kernel_error(st, idx, batch, originals)
    return VisibilityResult(
        visible=(reason == 0).reshape(batch),
        reason=reason.reshape(batch),
        in_fov=fov.reshape(batch),
        sun_excluded=sun_ex.reshape(batch),
        occulted=occd.reshape(batch),
        too_small=small.reshape(batch),
        occulter=who.reshape(batch),
        apparent_diameter_rad=alpha.reshape(batch),
        sun_angle_boresight_rad=ang_b.reshape(batch),
        sun_angle_target_rad=ang_t.reshape(batch),
        pixel=pix.reshape((*batch, 2)),
    )


def visibility(
    r_sc: np.ndarray,
    q_body_to_inertial: np.ndarray,
    target_pos: np.ndarray,
    other_body_pos: np.ndarray | None,
    other_body_radius: np.ndarray | None,
    target_radius: np.ndarray | float,
    config: CameraConfig = DEFAULT_CAMERA,
    *,
    include_sun: bool = True,
) -> VisibilityResult:
    """Can the camera measure the target? Rules, per element:

    1. OUT_OF_FOV: the target's centre (the geometric direction, no light time or aberration) projects
       outside the sensor rectangle ``[0, W] x [0, H]`` or lies behind the lens.
    2. OCCULTED: a body whose centre is nearer than the target's centre and whose disk overlaps the target's
       disk at all (angular separation < rho_occ + rho_target, rho = asin(R/L)); a partly hidden disk biases
       both the centroid and the diameter, so partial occultation counts. With ``include_sun`` the Sun
       (origin, IAU radius) is always an occulter: a planet behind the Sun is OCCULTED.
    3. SUN_EXCLUSION: the boresight, or the target's direction, is within ``sun_exclusion_deg`` of the Sun.
    4. TOO_SMALL: truth angular diameter ``2 asin(R/L)`` below ``min_diameter_px`` pixels.

    Parameters
    ----------
    r_sc
        Spacecraft heliocentric position ``(..., 3)`` [km], ICRF.
    q_body_to_inertial
        Attitude ``(..., 4)``, scalar first, ``v_I = R(q) v_B`` (normalised internally; zero -> error).
    target_pos
        Target centre ``(..., 3)`` [km], ICRF heliocentric.
    other_body_pos, other_body_radius
        Possible occulters other than the Sun: positions ``(M, 3)`` shared by the batch or ``(..., M, 3)``,
        radii ``(M,)`` [km]; ``None`` for none. Do not list the target itself (it is ignored anyway: a body is
        only an occulter when strictly nearer than the target).
    target_radius
        Target radius [km], scalar or ``(...)``.
    config
        The camera.
    include_sun
        Treat the Sun as an occulter (default True).

    Raises
    ------
    NonFiniteError
        NaN/inf in any input (named).
    InvalidParameterError
        Bad shapes, zero quaternion, non-positive radius, spacecraft inside the target or an occulter.
    """
    batch, originals, r, q, t, trad = _prepare(r_sc, q_body_to_inertial, target_pos, target_radius)
    return _visibility_flat(
        batch, originals, r, q, t, trad, other_body_pos, other_body_radius, config, include_sun
    )


def measure(
    rng: np.random.Generator,
    r_sc: np.ndarray,
    q_body_to_inertial: np.ndarray,
    target_pos: np.ndarray,
    target_radius: np.ndarray | float,
    config: CameraConfig = DEFAULT_CAMERA,
    *,
    require_visible: bool = True,
    other_body_pos: np.ndarray | None = None,
    other_body_radius: np.ndarray | None = None,
    include_sun: bool = True,
    target_name: str = "target",
) -> CameraMeasurement:
    """Noisy camera measurement of a target: body-frame line of sight and angular diameter.

    Noise model (independent per element and per draw):

    * direction: the truth unit LOS ``u`` is rotated by an angle vector ``d1 e1 + d2 e2`` in the plane
      perpendicular to ``u`` (e1 ~ camera X, e2 = u x e1 ~ camera Y near the boresight), with
      ``d1, d2 ~ N(0, sigma_direction_rad)``; the result is an exact unit vector.
    * angular diameter: ``alpha = 2 asin(R/L) + N(0, sigma_alpha_rad)``, ``sigma_alpha = diameter_noise_px /
      f_px`` (constant with range, ERRATA 10). Not clipped: a negative alpha at long range is a legitimate,
      unbiased draw.

    Random numbers: exactly one ``rng.standard_normal((n, 3))`` per call (columns d1, d2, alpha noise; n the
    batch size), also when a sigma is zero, so the stream does not depend on the configuration; the same seed
    gives the same numbers bit for bit. With ``require_visible=True`` (default) :func:`visibility` is checked
    first (with the given occulters) and :class:`NotVisibleError` is raised, naming ``target_name`` and the
    reason, before anything is drawn. With ``require_visible=False`` the caller has checked visibility (saves
    one kernel call per step); any geometry is then measured, and on an input error the generator may already
    have advanced.

    Parameters are as for :func:`visibility`; ``rng`` is the episode's generator.

    Raises
    ------
    NotVisibleError
        ``require_visible`` and some element is not visible.
    NonFiniteError, InvalidParameterError
        As :func:`visibility`.
    """
    if not isinstance(rng, np.random.Generator):
        raise InvalidParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    batch, originals, r, q, t, trad = _prepare(r_sc, q_body_to_inertial, target_pos, target_radius)
    vis = None
    if require_visible:
        vis = _visibility_flat(
            batch, originals, r, q, t, trad, other_body_pos, other_body_radius, config, include_sun
        )
        if not vis.all_visible:
            bad = np.flatnonzero(vis.reason.ravel() != 0)
            codes = vis.reason.ravel()
            items = ", ".join(
                f"{_index(int(i), batch)}: {VisibilityReason(int(codes[i])).name}" for i in bad[:4]
            )
            raise NotVisibleError(
                f"cannot measure {target_name}: not visible in {bad.size} of {r.shape[0]} element(s) ({items}"
                f"{', ...' if bad.size > 4 else ''})"
            )
    z = rng.standard_normal((r.shape[0], 3))
    st, idx, los, alpha, mm, pix, los_true, alpha_true = _measure_kernel(
        r, q, t, trad, z, config._c2b, config._params
    )
    if st != _OK:
        _raise_kernel_error(st, idx, batch, originals)
    return CameraMeasurement(
        los_body=los.reshape((*batch, 3)),
        alpha_rad=alpha.reshape(batch),
        image_mm=mm.reshape((*batch, 2)),
        pixel=pix.reshape((*batch, 2)),
        los_body_true=los_true.reshape((*batch, 3)),
        alpha_true_rad=alpha_true.reshape(batch),
        visibility=vis,
    )
