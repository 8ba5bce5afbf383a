"""Apparent directions: where a camera sees a planet or a star, with one-way light time and stellar
aberration.

A spacecraft's camera does not see a planet where the planet is at the instant of the image: it sees the
light that left the planet a light time ``tau`` earlier (about 10 to 20 minutes in an interplanetary
cruise), and that light arrives tilted toward the camera's own velocity by stellar aberration (``v / c``,
about 20" at 30 km/s). These are the corrections that SPICE names ``'LT+S'`` (``'CN+S'`` when the light
time is iterated to convergence, as here); ``tests/env/test_apparent.py`` holds the functions below to
SPICE's ``spkcvo`` within 1e-4".

Frames and units: ICRF, km, s, km/s. Positions may be heliocentric or barycentric (only differences of
positions enter); velocities are barycentric, i.e. relative to the Solar-system barycentre, because
aberration is a property of the observer's velocity in the barycentric frame, and the target's
barycentric velocity is what moves it during the light time.

The light-time equation ``|r_t(t - tau) - r_o(t)| = c tau`` is solved with the target's motion expanded
to second order about ``t``: ``r_t(t - tau) = r_t(t) - tau v_t + tau^2 a_t / 2``, with ``a_t`` the
heliocentric two-body acceleration. What it neglects (the third-order term ``|j| tau^3 / 6``, the other
planets' pull on the target, the Sun's barycentric acceleration) moves the corrected vector by a metre or
two over a 20-minute light time, and the Moon's pull on the Earth's centre by up to ~20 m: below 1e-4"
at the ranges of a cruise.

The functions are compiled row kernels (:mod:`planetnav_env.numerics.jit`): scalars and caller-allocated
arrays only, so the same source compiles for the CPU and as CUDA device functions.
"""

from __future__ import annotations

import math

from planetnav_env.numerics.jit import row_kernel

#: Speed of light in vacuum [km/s] (exact, SI).
SPEED_OF_LIGHT_KM_S = 299_792.458

#: Fixed-point iterations of the light-time equation. Each one multiplies the error of ``tau`` by about
#: ``|v_radial| / c`` (~1e-4), so three take it from the geometric guess to far below a nanosecond.
LIGHT_TIME_ITERATIONS = 3


@row_kernel
def aberrate(u, v_obs, out) -> None:  # pragma: no cover - compiled
    """Stellar aberration of the unit direction ``u`` seen by an observer of barycentric velocity
    ``v_obs`` [km/s]: ``out`` = ``u`` turned toward ``v_obs`` by the angle ``asin(|u x v_obs| / c)``,
    in the plane of ``u`` and ``v_obs`` (SPICE's ``stelab``). ``out`` may be ``u`` itself.
    Valid for ``|v_obs| << c``; the formula is first order in ``v / c``."""
    ux, uy, uz = u[0], u[1], u[2]
    vx = v_obs[0] / SPEED_OF_LIGHT_KM_S
    vy = v_obs[1] / SPEED_OF_LIGHT_KM_S
    vz = v_obs[2] / SPEED_OF_LIGHT_KM_S
    along = ux * vx + uy * vy + uz * vz
    px, py, pz = vx - along * ux, vy - along * uy, vz - along * uz  # v/c across the line of sight
    s = math.sqrt(px * px + py * py + pz * pz)  # sin of the aberration angle
    if s == 0.0:
        out[0], out[1], out[2] = ux, uy, uz
        return
    c = math.sqrt(1.0 - s * s)
    out[0] = c * ux + px
    out[1] = c * uy + py
    out[2] = c * uz + pz


@row_kernel
def light_time(r_obs, r_tgt, v_tgt, mu_sun, out) -> float:  # pragma: no cover - compiled
    """One-way light time ``tau`` [s] from a target to an observer at the observer's time ``t``, and in
    ``out`` the light-time-corrected vector from the observer to the target [km], ``r_t(t - tau) - r_o(t)``.

    ``r_obs``, ``r_tgt``: heliocentric positions at ``t`` [km]; ``v_tgt``: the target's barycentric
    velocity at ``t`` [km/s]; ``mu_sun``: the Sun's GM [km^3/s^2] for the target's acceleration (0 drops
    the second-order term)."""
    rx, ry, rz = r_tgt[0], r_tgt[1], r_tgt[2]
    rn = math.sqrt(rx * rx + ry * ry + rz * rz)
    k = -mu_sun / (rn * rn * rn) if rn > 0.0 else 0.0
    ax, ay, az = k * rx, k * ry, k * rz
    dx, dy, dz = rx - r_obs[0], ry - r_obs[1], rz - r_obs[2]
    tau = math.sqrt(dx * dx + dy * dy + dz * dz) / SPEED_OF_LIGHT_KM_S
    for _ in range(LIGHT_TIME_ITERATIONS):
        h = 0.5 * tau * tau
        ex = dx - tau * v_tgt[0] + h * ax
        ey = dy - tau * v_tgt[1] + h * ay
        ez = dz - tau * v_tgt[2] + h * az
        tau = math.sqrt(ex * ex + ey * ey + ez * ez) / SPEED_OF_LIGHT_KM_S
    h = 0.5 * tau * tau
    out[0] = dx - tau * v_tgt[0] + h * ax
    out[1] = dy - tau * v_tgt[1] + h * ay
    out[2] = dz - tau * v_tgt[2] + h * az
    return tau


@row_kernel
def apparent_direction(r_obs, v_obs, r_tgt, v_tgt, mu_sun, out) -> float:  # pragma: no cover - compiled
    """Unit direction [ICRF] in which an observer sees a target, corrected for light time and stellar
    aberration (SPICE ``'CN+S'``), into ``out``; returns the light time [s].

    ``r_obs``, ``r_tgt``: heliocentric positions at the observer's time [km]; ``v_obs``, ``v_tgt``:
    barycentric velocities [km/s]; ``mu_sun`` [km^3/s^2] as in :func:`light_time`."""
    tau = light_time(r_obs, r_tgt, v_tgt, mu_sun, out)
    n = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2])
    out[0] /= n
    out[1] /= n
    out[2] /= n
    aberrate(out, v_obs, out)
    return tau
