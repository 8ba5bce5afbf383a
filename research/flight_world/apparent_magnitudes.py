"""How far light time and stellar aberration move each planet's direction on the cruise, against the
camera's 3.5" direction noise.

Command: ``python research/flight_world/apparent_magnitudes.py``

Prints, for Venus, Earth and Mars seen from the ``cruise`` scenario's spacecraft (the thesis's Venus-Mars
transfer at 2020-08-01, DE421) at the episode's start and end, the light time, the angle between the
geometric and the light-time-corrected direction, and the aberration angle, all from
:mod:`planetnav_env.astro.apparent` (held to SPICE by ``tests/env/test_apparent.py``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from planetnav_env.astro.apparent import aberrate, light_time
from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.scenarios.episodes import CRUISE_EPOCH, cruise_state

ARCSEC = math.pi / 180.0 / 3600.0


def angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b)))


def sun_velocity(eph: DEEphemeris, t: float) -> np.ndarray:
    """The Sun's barycentric velocity [km/s] by a central difference over +-10 s (its acceleration,
    ~2e-10 km/s^2, makes the difference's error negligible)."""
    return (eph.sun_barycentric_position(t + 10.0) - eph.sun_barycentric_position(t - 10.0)) / 20.0


def two_body(x0: np.ndarray, dt: float, mu: float) -> np.ndarray:
    """The heliocentric state [km, km/s] after ``dt`` [s] of Sun-only motion (DOP853)."""

    def rhs(_t, x):
        r = x[:3]
        return np.concatenate([x[3:], -mu * r / np.linalg.norm(r) ** 3])

    return solve_ivp(rhs, (0.0, dt), x0, method="DOP853", rtol=1e-12, atol=1e-6).y[:, -1]


def main() -> None:
    eph = DEEphemeris()
    mu = body("sun").gm
    x0 = cruise_state()
    print("| elapsed [h] | planet | light time [s] | light-time shift [arcsec] | aberration [arcsec] |")
    print("|---|---|---|---|---|")
    for hours in (0.0, 24.0):
        t = CRUISE_EPOCH + hours * 3600.0
        x = two_body(x0, hours * 3600.0, mu) if hours else x0
        v_sun = sun_velocity(eph, t)
        for name in ("venus", "earth", "mars"):
            r, v = eph.state(name, t)
            geometric = r - x[:3]
            corrected = np.empty(3)
            tau = light_time(x[:3], r, v + v_sun, mu, corrected)
            u = corrected / np.linalg.norm(corrected)
            apparent = np.empty(3)
            aberrate(u, x[3:] + v_sun, apparent)
            print(
                f"| {hours:.0f} | {name} | {tau:.1f} | {angle(geometric, corrected) / ARCSEC:.2f} | "
                f"{angle(u, apparent) / ARCSEC:.2f} |"
            )


if __name__ == "__main__":
    main()
