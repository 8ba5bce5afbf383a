"""The light path of one row (the ``world`` option's light time and stellar aberration): the apparent
target point of a planet, in truth from the true state and on board from the estimated one, and the
velocities they need from the row's ephemeris table.

The formulas are :mod:`planetnav_env.astro.apparent`'s (held to SPICE's ``spkcvo`` 'CN+S'); this module
only feeds them the row's states. Velocities are heliocentric, not barycentric: the Sun's ~13 m/s about
the Solar-system barycentre is omitted on both sides, which moves a direction by at most ~0.01" of
aberration (13 m/s / c) and ~0.02" of light time (13 m/s times the light time, at the range), three
orders of magnitude below the camera's 3.5" (``docs/flight_world.md``).

The range stays geometric: an apparent target point is ``r_obs + |r_tgt - r_obs| u`` with ``u`` the
apparent direction, so the angular size is the geometric one (the light time changes the range by the
target's radial speed times the light time, a few parts in 1e5 of it, a few 1e-9 rad of a disk's size).

Work rows of ``sc.light`` (:data:`LIGHT_ROWS`): the observer's true velocity, the target's velocity, a
direction, the estimated velocity, the estimated position.
"""

from __future__ import annotations

import math

from planetnav_env.astro.apparent import aberrate, light_time
from planetnav_env.astro.bodies import GM_SUN
from planetnav_env.core.ephemeris_table import velocity_kernel
from planetnav_env.core.layout import F_T0
from planetnav_env.numerics.jit import row_kernel

#: Rows of the scratch ``sc.light`` (5, 3).
LIGHT_ROWS = ("v_true", "v_target", "direction", "v_est", "r_est")
V_TRUE, V_TARGET, DIRECTION, V_EST, R_EST = range(5)


@row_kernel
def channel_velocity(prm, eph, f, n, t, channel, out) -> bool:  # pragma: no cover - compiled
    """Velocity [km/s] of ephemeris ``channel`` of row ``n`` at ``t`` [TDB s] into ``out``; zero for -1
    (the Sun, the heliocentric origin). The derivative of the table's series (``velocity_kernel``)."""
    if channel < 0:
        out[0] = out[1] = out[2] = 0.0
        return True
    return velocity_kernel(eph[n], f[n, F_T0], prm.scalars[0].segment_s, t, channel, out)


@row_kernel
def heliocentric_velocity(prm, eph, f, n, t, x, central, out) -> None:  # pragma: no cover - compiled
    """Heliocentric velocity [km/s] of the state ``x`` (6,) of row ``n`` (relative to the central body)
    at ``t``: ``x[3:6]`` plus the central body's velocity from its channel ``central`` (the truth's or the
    onboard model's; -1, the Sun: zero on a cruise, Mars's on the approach)."""
    channel_velocity(prm, eph, f, n, t, central, out)
    for j in range(3):
        out[j] += x[3 + j]


@row_kernel
def apparent_point(
    r_obs, v_obs, r_tgt, v_tgt, with_light_time, with_aberration, work, out
) -> None:  # pragma: no cover - compiled
    """The point ``out`` = ``r_obs + |r_tgt - r_obs| u`` [km, heliocentric], ``u`` the direction in which an
    observer at ``r_obs`` moving at ``v_obs`` sees the target at ``r_tgt`` moving at ``v_tgt`` (heliocentric,
    km and km/s) with light time (``with_light_time``, the target's position a light time earlier,
    :func:`~planetnav_env.astro.apparent.light_time`) and stellar aberration (``with_aberration``,
    :func:`~planetnav_env.astro.apparent.aberrate`): both on is ``apparent_direction``. ``work`` (3,)."""
    d0, d1, d2 = r_tgt[0] - r_obs[0], r_tgt[1] - r_obs[1], r_tgt[2] - r_obs[2]
    rho = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if with_light_time:
        light_time(r_obs, r_tgt, v_tgt, GM_SUN, work)
    else:
        work[0], work[1], work[2] = d0, d1, d2
    wn = math.sqrt(work[0] * work[0] + work[1] * work[1] + work[2] * work[2])
    work[0] /= wn
    work[1] /= wn
    work[2] /= wn
    if with_aberration:
        aberrate(work, v_obs, work)
    for j in range(3):
        out[j] = r_obs[j] + rho * work[j]
