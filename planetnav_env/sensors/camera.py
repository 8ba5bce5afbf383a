"""Star camera: pinhole projection, apparent size of a planet, visibility, noisy measurements.

The model is the thesis's (section 2.3, "Модель звездной камеры"; parameters in 3.1.3) with the corrections of
``/work/shared/papers/ERRATA.md`` items 10 and 11. ``docs/camera.md`` gives the reasons behind every default.

Frames and conventions
----------------------
* Inertial frame I: ICRF/J2000 equatorial, heliocentric (the Sun is at the origin). Units km, s, rad.
* Body frame B and the attitude ``q`` (scalar first): ``v_I = R(q) v_B``
  (see :mod:`planetnav_env.attitude.quaternion`).
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

Modules
-------
This module is the public API: :func:`visibility`, :func:`measure`, their result records, and re-exports of
the configuration (:mod:`~planetnav_env.sensors.camera_config`: :class:`CameraConfig`, ``DEFAULT_CAMERA``) and
of the geometry helpers (:mod:`~planetnav_env.sensors.camera_geometry`: projection, field of view, apparent
size, Sun angle). The compiled row and batch kernels live in :mod:`~planetnav_env.sensors.camera_kernels`.

Implementation
--------------
The hot paths (:func:`visibility`, :func:`measure`) are numba kernels looping over the batch; the kernels
mirror :func:`planetnav_env.attitude.quaternion.dcm_body_to_inertial` and the projection helpers of
:mod:`~planetnav_env.sensors.camera_geometry` because numba cannot call numpy-level code.
``tests/env/test_camera.py`` pins the kernels to the numpy helpers. Inputs carry a leading batch shape
``(...)``; a single spacecraft is a batch of shape ``()``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.codes import CameraStatus, VisibilityReason
from planetnav_env.errors import (
    InvalidParameterError,
    NonFiniteError,
    NotVisibleError,
    require_finite,
)
from planetnav_env.sensors import camera_geometry
from planetnav_env.sensors.camera_config import (
    ARCSEC_RAD,
    DEFAULT_CAMERA,
    DEFAULT_CAMERA_TO_BODY,
    CameraConfig,
)
from planetnav_env.sensors.camera_geometry import *  # noqa: F403 - the geometry is part of this API
from planetnav_env.sensors.camera_kernels import measure_batch_kernel, visibility_batch_kernel

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
    "measure",
    "visibility",
]
#: The geometry helpers, re-exported as they are listed at their home (one list, in camera_geometry).
__all__ += camera_geometry.__all__

#: ``VisibilityResult.occulter`` when nothing hides the target / when the Sun does.
NO_OCCULTER = -1
SUN_OCCULTER = -2


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
    if status == CameraStatus.NONFINITE:
        for name, a in originals.items():
            if a is not None:
                require_finite(name, a)
        raise NonFiniteError(f"non-finite input{where}")  # pragma: no cover - require_finite raised above
    if status == CameraStatus.ZERO_Q:
        raise InvalidParameterError(f"q_body_to_inertial has zero norm{where}")
    if status == CameraStatus.RADIUS:
        raise InvalidParameterError(
            f"target_radius must be positive{where}, got {originals['target_radius']!r}"
        )
    if status == CameraStatus.INSIDE_TARGET:
        raise InvalidParameterError(f"spacecraft is inside the target (distance <= target_radius){where}")
    if status == CameraStatus.INSIDE_OCC:
        raise InvalidParameterError(
            f"spacecraft is inside an occulting body (the Sun or other_body_pos){where}"
        )
    if status == CameraStatus.OCC_RADIUS:
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
    st, idx, res = visibility_batch_kernel(
        r, q, t, trad, occ, occ_rad, per_elem, bool(include_sun), config._c2b, config._params
    )
    reason, fov, sun_ex, occd, small, who, alpha, ang_b, ang_t, pix = res
    if st != CameraStatus.OK:
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
    st, idx, los, alpha, mm, pix, los_true, alpha_true = measure_batch_kernel(
        r, q, t, trad, z, config._c2b, config._params
    )
    if st != CameraStatus.OK:
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
