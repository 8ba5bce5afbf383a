"""Compiled star-camera kernels (the hot path): the visibility rules and the measurement model of one row,
and the batch kernels that loop them over a batch.

:func:`visibility_row_kernel` and :func:`measure_row_kernel` are the one implementation of the camera's
visibility rules and of its noise model; the batch kernels here (behind
:func:`planetnav_env.sensors.camera.visibility` and :func:`planetnav_env.sensors.camera.measure`) and the
simulation core (:mod:`planetnav_env.core`) both call them.

Inputs are flat ``(n, k)`` float64 arrays: positions [km] ICRF heliocentric, attitudes scalar first
(``v_I = R(q) v_B``), radii [km]. The camera enters as ``CameraConfig._c2b`` (``v_B = C v_C``, camera +Z the
boresight) and ``CameraConfig._params`` (slots ``_P_*`` of :mod:`planetnav_env.sensors.camera_config`).
The kernels mirror :func:`planetnav_env.attitude.quaternion.dcm_body_to_inertial` and the projection of
:mod:`planetnav_env.sensors.camera_geometry` because numba cannot call numpy-level code. They return status
codes (:class:`planetnav_env.codes.CameraStatus`), which the API turns into named exceptions.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.codes import CameraStatus, VisibilityReason
from planetnav_env.numerics.jit import row_kernel
from planetnav_env.sensors.camera_config import (
    P_CX,
    P_CY,
    P_EXCL,
    P_FMM,
    P_FPX,
    P_H,
    P_MINPX,
    P_RSUN,
    P_SALPHA,
    P_SDIR,
    P_W,
)

__all__ = [
    "N_VIS_SLOTS",
    "V_ALPHA",
    "V_ANG_B",
    "V_ANG_T",
    "V_IN_FOV",
    "V_OCCULTED",
    "V_OCCULTER",
    "V_PIX_X",
    "V_PIX_Y",
    "V_REASON",
    "V_SMALL",
    "V_SUN_EX",
    "CameraFix",
    "CameraModel",
    "CameraScratch",
    "Occulters",
    "measure_into_kernel",
    "measure_row_kernel",
    "measure_sigmas_row_kernel",
    "rotate_in_camera",
    "shift_toward",
    "visibility_codes_kernel",
    "visibility_row_kernel",
]

# The camera reports VisibilityReason 0-4 (defined in planetnav_env.codes); as ints for the kernels.
_VISIBLE = int(VisibilityReason.VISIBLE)
_OUT_OF_FOV = int(VisibilityReason.OUT_OF_FOV)
_OCCULTED = int(VisibilityReason.OCCULTED)
_SUN_EXCLUSION = int(VisibilityReason.SUN_EXCLUSION)
_TOO_SMALL = int(VisibilityReason.TOO_SMALL)

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


@row_kernel
def _target_los(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    i: int,
    rt: float,
    c2b: np.ndarray,
    m: np.ndarray,
    u: np.ndarray,
) -> tuple[float, int]:
    """:func:`_camera_los` to target ``t[i]`` of radius ``rt`` [km], then the target's own checks (finite,
    positive radius, spacecraft outside it): the one entry of both row kernels. Returns (L [km], status)."""
    dist, st = _camera_los(r, q, t, i, c2b, m, u)
    if st != _OK:
        return dist, st
    if not math.isfinite(rt):
        return dist, _ERR_NONFINITE
    if rt <= 0.0:
        return dist, _ERR_RADIUS
    if dist <= rt:
        return dist, _ERR_INSIDE_TARGET
    return dist, _OK


#: Slots of the per-element visibility record written by :func:`visibility_row_kernel`.
V_REASON, V_IN_FOV, V_SUN_EX, V_OCCULTED, V_SMALL, V_OCCULTER, V_ALPHA, V_ANG_B, V_ANG_T, V_PIX_X, V_PIX_Y = (
    range(11)
)
N_VIS_SLOTS = 11


class CameraModel(NamedTuple):
    """The camera a visibility check reads: its mounting and its parameters."""

    c2b: np.ndarray  # (3, 3) camera -> body rotation
    params: np.ndarray  # (11,) CameraConfig._params (slots _P_*: focal length [px], sensor [px], ...)


class Occulters(NamedTuple):
    """The bodies that can hide a target: ``K`` spheres, and the Sun if ``sun``."""

    pos: np.ndarray  # (K, 3) heliocentric positions [km]
    radii: np.ndarray  # (K,) radii [km]
    sun: bool  # the Sun occults too


class CameraScratch(NamedTuple):
    """Work arrays of the camera's row kernels (no allocation per row)."""

    m: np.ndarray  # (3, 3) inertial -> camera
    u: np.ndarray  # (6,) the line of sight, inertial (0:3) and camera (3:6) components


class CameraFix(NamedTuple):
    """Where a camera measurement writes its image of the target (each a view the caller owns)."""

    los: np.ndarray  # (3,) noisy line of sight, body frame
    los_true: np.ndarray  # (3,) true line of sight, body frame
    mm: np.ndarray  # (2,) image point [mm]
    pix: np.ndarray  # (2,) image point [px]


@row_kernel
def visibility_row_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    i: int,
    rt: float,
    occulters: Occulters,
    camera: CameraModel,
    ws: CameraScratch,
    vals: np.ndarray,
) -> int:
    """Visibility of target ``t[i]`` (radius ``rt`` [km]) from spacecraft ``r[i]`` at attitude ``q[i]``.

    The one implementation of the camera's visibility rules (field of view, occultation by the Sun (if
    ``occulters.sun``) and the bodies ``occulters``, Sun exclusion, detection threshold): the batch kernel
    and the simulation core both call it. Writes the record ``vals`` (``N_VIS_SLOTS``, slots ``V_*``;
    reason code 0 visible, 1 out of field, 2 occulted, 3 Sun exclusion, 4 too small; occulter -2 the Sun,
    -1 none, else k). Returns a status (``_OK`` or an ``_ERR_*`` code). Allocates nothing.
    """
    occ, occ_rad, include_sun = occulters.pos, occulters.radii, occulters.sun
    c2b, p, m, u = camera.c2b, camera.params, ws.m, ws.u
    dist, st = _target_los(r, q, t, i, rt, c2b, m, u)
    if st != _OK:
        return st
    f_px, cx, cy, w, h = p[P_FPX], p[P_CX], p[P_CY], p[P_W], p[P_H]
    excl, min_px, r_sun = p[P_EXCL], p[P_MINPX], p[P_RSUN]
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
def visibility_batch_kernel(
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
    camera = CameraModel(c2b=c2b, params=p)
    ws = CameraScratch(m=np.empty((3, 3)), u=np.empty(6))
    vals = np.empty(N_VIS_SLOTS)
    for k in range(n_occ):
        if not math.isfinite(occ_rad[k]):
            return _ERR_NONFINITE, -1, res
        if occ_rad[k] <= 0.0:
            return _ERR_OCC_RADIUS, k, res
    for i in range(n):
        occulters = Occulters(pos=occ[i if occ_per_elem else 0], radii=occ_rad, sun=include_sun)
        st = visibility_row_kernel(r, q, t, i, trad[i], occulters, camera, ws, vals)
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
    camera: CameraModel,
    ws: CameraScratch,
    out: CameraFix,
) -> tuple[int, float, float]:
    """One camera measurement of target ``t[i]`` (radius ``rt``) from ``r[i]`` at attitude ``q[i]`` with
    the three standard-normal draws ``z`` (two across the line of sight, one for the diameter).

    The one implementation of the measurement model (the batch kernel and the simulation core call it).
    Writes the noisy and true body-frame lines of sight, the image point [mm] and [px] into ``out``;
    returns (status, noisy angular diameter, true angular diameter) [rad]. Allocates nothing. The sigmas
    are the camera's (``P_SDIR``, ``P_SALPHA``); :func:`measure_sigmas_row_kernel` takes them per image.
    """
    p = camera.params
    return measure_sigmas_row_kernel(r, q, t, i, rt, z, camera, ws, out, p[P_SDIR], p[P_SALPHA])


@row_kernel
def measure_sigmas_row_kernel(
    r: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    i: int,
    rt: float,
    z: np.ndarray,
    camera: CameraModel,
    ws: CameraScratch,
    out: CameraFix,
    s_dir: float,
    s_alpha: float,
) -> tuple[int, float, float]:
    """:func:`measure_row_kernel` with this image's sigmas: ``s_dir`` [rad] per axis across the line of
    sight and ``s_alpha`` [rad] of the angular diameter (the flight world's image-driven errors,
    :mod:`planetnav_env.sensors.image_noise`)."""
    c2b, p, u = camera.c2b, camera.params, ws.u
    los, los_true, mm, pix = out.los, out.los_true, out.mm, out.pix
    dist, st = _target_los(r, q, t, i, rt, c2b, ws.m, u)
    if st != _OK:
        return st, 0.0, 0.0
    f_px, cx, cy, f_mm = p[P_FPX], p[P_CX], p[P_CY], p[P_FMM]
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


#: Centre-of-brightness offset of a uniformly bright illuminated disk, per radius and per (1 - cos phase):
#: the centroid of the half disk plus (or minus) the half ellipse of the terminator lies 4 / (3 pi) R
#: (1 - cos phase) from the centre of figure, toward the Sun (docs/camera.md, "Centroid bias").
COB_UNIFORM_DISK = 4.0 / (3.0 * math.pi)


@row_kernel
def centroid_offset(scale, alpha, cos_phase) -> float:  # pragma: no cover - compiled
    """The centre-of-brightness offset [rad] of a planet of angular diameter ``alpha`` [rad] at phase angle
    acos(``cos_phase``): ``scale * COB_UNIFORM_DISK * alpha / 2 * (1 - cos_phase)`` (``scale`` 1: the
    uniformly bright disk)."""
    return scale * COB_UNIFORM_DISK * 0.5 * alpha * (1.0 - cos_phase)


@row_kernel
def centroid_bias_kernel(los, sun_dir, cos_phase, alpha, scale) -> float:  # pragma: no cover - compiled
    """Displace the measured unit line of sight ``los`` (3,) in place by the centre-of-brightness offset of
    a planet of true angular diameter ``alpha`` [rad] at phase angle acos(``cos_phase``) (Sun-planet-camera),
    toward ``sun_dir`` (3,), the unit direction from the planet to the Sun in the frame of ``los``:
    ``delta = scale * COB_UNIFORM_DISK * alpha / 2 * (1 - cos_phase)`` [rad], along the component of
    ``sun_dir`` across the line of sight (the sunlit limb's side in the image). ``scale`` 1 is the uniformly
    bright disk; a centroiding algorithm that models part of it leaves a smaller one. Returns ``delta``."""
    delta = centroid_offset(scale, alpha, cos_phase)
    d = sun_dir[0] * los[0] + sun_dir[1] * los[1] + sun_dir[2] * los[2]
    px, py, pz = sun_dir[0] - d * los[0], sun_dir[1] - d * los[1], sun_dir[2] - d * los[2]
    norm = math.sqrt(px * px + py * py + pz * pz)
    if delta <= 0.0 or norm < 1e-12:  # no offset, or the Sun straight behind or ahead: no direction
        return 0.0
    c, s_ = math.cos(delta), math.sin(delta) / norm
    for k in range(3):
        los[k] = c * los[k] + s_ * (sun_dir[k] - d * los[k])
    return delta


@row_kernel
def shift_toward(los, direction, delta) -> None:  # pragma: no cover - compiled
    """Turn the unit line of sight ``los`` (3,) in place by the angle ``delta`` [rad] toward the component
    of the unit ``direction`` (3,) across it (away from it for ``delta`` < 0); unchanged when
    ``direction`` is along ``los``. The centre-of-brightness offset and its onboard correction."""
    d = direction[0] * los[0] + direction[1] * los[1] + direction[2] * los[2]
    px, py, pz = direction[0] - d * los[0], direction[1] - d * los[1], direction[2] - d * los[2]
    norm = math.sqrt(px * px + py * py + pz * pz)
    if norm < 1e-12:
        return
    c, s_ = math.cos(delta), math.sin(delta) / norm
    los[0] = c * los[0] + s_ * px
    los[1] = c * los[1] + s_ * py
    los[2] = c * los[2] + s_ * pz


@row_kernel
def rotate_in_camera(los, c2b, ax, ay) -> None:  # pragma: no cover - compiled
    """Rotate the body-frame unit vector ``los`` (3,) in place by the rotation vector ``(ax, ay, 0)``
    [rad] of the camera's axes (``c2b``: camera -> body): ``los <- C R(a) C^T los`` (Rodrigues; exact at
    any angle). The boresight drift's turn of a planet image."""
    vx = c2b[0, 0] * los[0] + c2b[1, 0] * los[1] + c2b[2, 0] * los[2]
    vy = c2b[0, 1] * los[0] + c2b[1, 1] * los[1] + c2b[2, 1] * los[2]
    vz = c2b[0, 2] * los[0] + c2b[1, 2] * los[1] + c2b[2, 2] * los[2]
    phi = math.sqrt(ax * ax + ay * ay)
    if phi == 0.0:
        return
    kx, ky = ax / phi, ay / phi  # unit axis (kz = 0)
    c, s_ = math.cos(phi), math.sin(phi)
    kv = kx * vx + ky * vy
    # k x v with k = (kx, ky, 0)
    cx_, cy_, cz_ = ky * vz, -kx * vz, kx * vy - ky * vx
    wx = vx * c + cx_ * s_ + kx * kv * (1.0 - c)
    wy = vy * c + cy_ * s_ + ky * kv * (1.0 - c)
    wz = vz * c + cz_ * s_
    for k in range(3):
        los[k] = c2b[k, 0] * wx + c2b[k, 1] * wy + c2b[k, 2] * wz


@njit(cache=True, nogil=True)
def measure_batch_kernel(
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
    camera = CameraModel(c2b=c2b, params=p)
    ws = CameraScratch(m=np.empty((3, 3)), u=np.empty(6))
    for i in range(n):
        out = CameraFix(los=los[i], los_true=los_true[i], mm=mm[i], pix=pix[i])
        st, alpha[i], alpha_true[i] = measure_row_kernel(r, q, t, i, trad[i], z[i], camera, ws, out)
        if st != _OK:
            return st, i, los, alpha, mm, pix, los_true, alpha_true
    return _OK, -1, los, alpha, mm, pix, los_true, alpha_true


# The two wrappers below forward their arguments unchanged (names, units and shapes as in the kernel they
# call, so not annotated again here); they exist for callers that want plain arrays back.


@njit(cache=True, nogil=True)
def visibility_codes_kernel(r, q, t, trad, occ, occ_rad, include_sun, c2b, p, out) -> int:
    """Reason codes only (into ``out`` (n,)) of :func:`visibility_batch_kernel` with occulters shared by the
    batch (``occ[0]`` (K, 3) for every element); returns its status. Unboxed: returning the full result
    tuple boxes ten arrays, which costs more than the geometry."""
    st, _, res = visibility_batch_kernel(r, q, t, trad, occ, occ_rad, False, include_sun, c2b, p)
    if st == _OK:
        for i in range(out.shape[0]):
            out[i] = res[0][i]
    return st


@njit(cache=True, nogil=True)
def measure_into_kernel(r, q, t, trad, z, c2b, p, los_out, alpha_out, pix_out) -> int:
    """:func:`measure_batch_kernel` writing the noisy body-frame LOS ``los_out`` (n, 3), angular diameter
    ``alpha_out`` (n,) [rad] and pixel ``pix_out`` (n, 2) of element 0..n-1 into caller arrays (no boxing);
    returns its status."""
    st, _, los, alpha, _, pix, _, _ = measure_batch_kernel(r, q, t, trad, z, c2b, p)
    if st == _OK:
        for i in range(los.shape[0]):
            alpha_out[i] = alpha[i]
            for k in range(3):
                los_out[i, k] = los[i, k]
            pix_out[i, 0] = pix[i, 0]
            pix_out[i, 1] = pix[i, 1]
    return st
