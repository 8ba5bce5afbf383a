"""Star-camera configuration: :class:`CameraConfig` (validated parameters and the quantities derived from
them) and the default camera.

The model and its frames are described in :mod:`planetnav_env.sensors.camera` and ``docs/camera.md``.
Units: mm for the focal length, um for the pixel pitch, px for sensor coordinates, arcsec and deg in the
fields, rad in the derived properties. The camera frame C has +Z along the boresight; ``v_B = C v_C`` with
``C = CameraConfig.camera_to_body``.

:attr:`CameraConfig._params` packs the scalars the compiled kernels read
(:mod:`planetnav_env.sensors.camera_kernels`), at the ``P_*`` slots defined here next to the code that
fills them, so that the layout has one owner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.errors import OptionError
from planetnav_env.options import check_options, option

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
P_FPX, P_CX, P_CY, P_W, P_H, P_EXCL, P_MINPX, P_SDIR, P_SALPHA, P_FMM, P_RSUN = range(11)


@dataclass(frozen=True)
class CameraConfig:
    """Star-camera parameters (each declared with its unit and range by :func:`~planetnav_env.options.option`;
    validated on construction; errors name the field ``camera.<name>`` and the value).
    """

    focal_length_mm: float = option(20.0, gt=0, unit="mm", doc="focal length f. Thesis 3.1.3: 20 mm")
    pixel_pitch_um: float = option(
        5.5, gt=0, unit="um", doc="pixel size, square pixels. The thesis gives none; 5.5 um is a typical "
        "CMOS star-tracker pixel"
    )  # fmt: skip
    resolution_px: tuple[int, int] = option(
        (1024, 1024), kind="ints", length=2, gt=0, unit="px", doc="sensor size (W, H): W along camera X, H "
        "along camera Y"
    )  # fmt: skip
    principal_point_px: tuple[float, float] | None = option(
        None,
        kind="floats",
        length=2,
        unit="px",
        doc="(c_x, c_y), where the optical axis pierces the sensor; must lie on it. None: the centre "
        "(W/2, H/2), resolved in ``principal_point`` (the field keeps None)",
    )
    direction_noise_arcsec: float = option(
        3.5, ge=0, unit="arcsec", doc="1-sigma of the line-of-sight error per axis perpendicular to the LOS. "
        "Thesis: 3-4\""
    )  # fmt: skip
    diameter_noise_px: float = option(
        2.5,
        ge=0,
        unit="px",
        doc="1-sigma of the measured disk diameter. Thesis: 2-3 px. The angular-diameter noise is "
        "diameter_noise_px / f_px [rad], constant with distance (ERRATA 10)",
    )
    sun_exclusion_deg: float = option(
        30.0,
        ge=0,
        lt=180,
        unit="deg",
        doc="half-angle of the Sun-exclusion cone; 30 deg is a typical star-tracker baffle (not from the "
        "thesis). 0 disables the test",
    )
    min_diameter_px: float = option(
        0.02,
        ge=0,
        unit="px",
        doc="detection threshold on the apparent diameter. Planets are detected by brightness even when "
        "sub-pixel; for one planet the flux is proportional to the solid angle, so the apparent size is a "
        'brightness proxy. 0.02 px (1.1") puts Saturn, the faintest-surface target in ``bodies``, near '
        "V = 6.7 (docs/camera.md)",
    )
    camera_to_body: tuple[tuple[float, float, float], ...] = option(
        DEFAULT_CAMERA_TO_BODY,
        kind="matrix",
        length=(3, 3),
        doc="rotation C with v_B = C v_C (rows: body axes, columns: camera axes; proper, det +1). Default: "
        "camera Z (boresight) -> body +x, camera X -> body +y, camera Y -> body +z",
    )
    # Kernel inputs derived once (not part of equality/hash/repr).
    _pp: tuple[float, float] = field(init=False, repr=False, compare=False)
    _c2b: np.ndarray = field(init=False, repr=False, compare=False)
    _params: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__  # frozen: normalise fields once, here only
        check_options(self, "camera.", coerce=True)
        f_mm = self.focal_length_mm
        width, height = self.resolution_px
        # None stays None in the field (so dataclasses.replace with a new resolution re-centres it); the
        # resolved point is the ``principal_point`` property.
        cx, cy = (0.5 * width, 0.5 * height) if self.principal_point_px is None else self.principal_point_px
        if not (0.0 <= cx <= width and 0.0 <= cy <= height):
            on_sensor = f"a point on the sensor [0, {width}] x [0, {height}] px"
            raise OptionError("camera.principal_point_px", on_sensor, (cx, cy))
        set_(self, "_pp", (cx, cy))
        c = np.array(self.camera_to_body)
        if not np.allclose(c.T @ c, np.eye(3), rtol=0.0, atol=1e-9) or np.linalg.det(c) < 0.0:
            raise OptionError("camera.camera_to_body", "a proper rotation (C^T C = I, det +1)", c.tolist())
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
