"""What a Sun-only onboard force model leaves out on the cruises, and the process noise that stands for it.

Question: the cruise truth today is the filter's own two-body model. In the flight world the truth adds
every planet as a point mass and solar radiation pressure. How large is each omitted acceleration along
the scenarios' cruises, what position error does it build over an episode, and which process-noise PSD
represents it?

Command: ``python research/flight_world/unmodelled_accelerations.py [--episodes 200]``

For the ``cruise`` scenario's day and for ``--episodes`` random cruises (the RandomCruise draw: epoch
2018-2032, transfer arcs between the orbits of Venus, Earth and Mars), it evaluates along each episode's
Sun-only trajectory (DOP853, 1-day episodes sampled every hour):

* each planet's perturbing acceleration in the heliocentric frame (direct minus indirect term),
  GM_j ((r_j - r) / |r_j - r|^3 - r_j / |r_j|^3), DE421;
* cannonball SRP, P_1AU (1 AU / r)^2 C_R A/m, for A/m = 0.01 m^2/kg and C_R = 1.3 (a small probe with
  modest solar arrays), and 5 % of it (what an onboard SRP model with a 5 % reflectivity error leaves);

and prints their median and largest magnitudes [m/s^2], the displacement a constant acceleration of that
size builds over the 1-day episode (a t^2 / 2), and the white-acceleration PSD q = a^2 T [km^2/s^3] that
gives a comparable position spread over the episode T (the tuning rule: for an omitted acceleration of
size a that stays nearly constant over the episode, the random walk of velocity with PSD q has position
variance q T^3 / 3 after T, against (a T^2 / 2)^2 for the bias, so q = 3 a^2 T / 4; we quote a^2 T).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.integrate import solve_ivp

from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.dynamics.srp import solar_pressure
from planetnav_env.scenarios.episodes import CRUISE_EPOCH, cruise_state, draw_episode

PLANETS = ("mercury", "venus", "earth", "mars", "jupiter", "saturn")
AREA_TO_MASS = 0.01  # m^2/kg
REFLECTIVITY = 1.3
DAY = 86400.0


def trajectory(x0: np.ndarray, hours: int = 24) -> np.ndarray:
    mu = body("sun").gm

    def rhs(_t, x):
        r = x[:3]
        return np.concatenate([x[3:], -mu * r / np.linalg.norm(r) ** 3])

    t = np.linspace(0.0, hours * 3600.0, hours + 1)
    return solve_ivp(rhs, (0.0, t[-1]), x0, method="DOP853", t_eval=t, rtol=1e-12, atol=1e-6).y.T


def accelerations(eph: DEEphemeris, epoch: float, x0: np.ndarray) -> dict[str, np.ndarray]:
    """Magnitudes [m/s^2] along one episode, per effect."""
    path = trajectory(x0)
    times = epoch + np.arange(path.shape[0]) * 3600.0
    r = path[:, :3]
    out = {}
    for name in PLANETS:
        rj = eph.position(name, times)
        d = rj - r
        direct = d / np.linalg.norm(d, axis=1, keepdims=True) ** 3
        a = body(name).gm * (direct - rj / np.linalg.norm(rj, axis=1, keepdims=True) ** 3)
        out[name] = np.linalg.norm(a, axis=1) * 1e3
    srp = REFLECTIVITY * AREA_TO_MASS * np.array([solar_pressure(x) for x in np.linalg.norm(r, axis=1)])
    out["SRP"] = srp
    out["5 % of SRP"] = 0.05 * srp
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=200)
    args = ap.parse_args()
    eph = DEEphemeris()
    runs = [accelerations(eph, CRUISE_EPOCH, cruise_state())]
    rng = np.random.default_rng(2026)
    for _ in range(args.episodes):
        ep = draw_episode("random-cruise", rng, eph, ("venus", "mars", "earth"), 30.0)
        runs.append(accelerations(eph, ep.epoch, ep.x0))
    print(f"cruise day + {args.episodes} random cruises (1 day each, hourly samples)")
    print(
        "| effect | cruise median [m/s^2] | random cruises median | random cruises max "
        "| a T^2/2 over 1 day at the max [km] | q = a^2 T [km^2/s^3] at the max |"
    )
    print("|---|---|---|---|---|---|")
    for key in runs[0]:
        rand = np.concatenate([run[key] for run in runs[1:]])
        amax = rand.max() * 1e-3  # km/s^2
        print(
            f"| {key} | {np.median(runs[0][key]):.2e} | {np.median(rand):.2e} | {rand.max():.2e} | "
            f"{0.5 * amax * DAY**2:.3f} | {amax**2 * DAY:.1e} |"
        )


if __name__ == "__main__":
    main()
