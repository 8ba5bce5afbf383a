"""Star-camera configuration: :class:`CameraConfig` (validated parameters and the quantities derived from
them) and the default camera.

The model and its frames are described in :mod:`planetnav_env.sensors.camera` and ``docs/camera.md``.
Units: mm for the focal length, um for the pixel pitch, px for sensor coordinates, arcsec and deg in the
fields, rad in the derived properties. The camera frame C has +Z along the boresight; ``v_B = C v_C`` with
``C = CameraConfig.camera_to_body``.

:attr:`CameraConfig._params` packs the scalars the compiled kernels read
(:mod:`planetnav_env.sensors.camera_kernels`), at the ``_P_*`` slots defined here next to the code that
fills them, so that the layout has one owner.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from planetnav_env.bodies import body
from planetnav_env.errors import InvalidParameterError

__all__ = ["ARCSEC_RAD", "DEFAULT_CAMERA", "DEFAULT_CAMERA_TO_BODY", "SUN_RADIUS_KM", "CameraConfig"]

ARCSEC_RAD = math.pi / 648_000.0
SUN_RADIUS_KM = body("sun").radius

#: Camera -> body rotation (``v_B = C v_C``): columns are the camera X, Y, Z axes in body components.
#: Z (boresight) -> body +x, X -> body +y, Y -> body +z.
DEFAULT_CAMERA_TO_BODY: tuple[tuple[float, float, float], ...] = (
    (0.0, 0.0, 1.0),
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
)

# Slots of CameraConfig._params (filled in CameraConfig.__post_init__, read by the camera kernels).
_P_FPX, _P_CX, _P_CY, _P_W, _P_H, _P_EXCL, _P_MINPX, _P_SDIR, _P_SALPHA, _P_FMM, _P_RSUN = range(11)


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
        The field-of-view test itself is the exact rectangle
        (:func:`~planetnav_env.sensors.camera_geometry.on_sensor`), not a cone.
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
