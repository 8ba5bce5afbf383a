"""Physical constants of the Solar-system bodies: the one source of truth.

Units: km, s, rad (angles in the element tables are degrees, as published, and are
converted where used). Frame of the mean elements: J2000 mean ecliptic and equinox;
everything else in planetnav is ICRF/J2000 equatorial (see ``ECLIPTIC_TO_EQUATORIAL``).

Sources
-------
GM
    Park, Folkner, Williams, Boggs (2021), "The JPL Planetary and Lunar Ephemerides
    DE440 and DE441", AJ 161:105, table 8. Planet values are of the planetary *system*
    (planet plus moons) except Earth and Moon, because point masses at the system
    barycentre are what a heliocentric cruise sees. The thesis prints GM_sun =
    132712440018 km^3/s^2 (the DE405 value); the 2e-10 relative difference is far
    below anything this project can resolve.
Radii
    Archinal et al. (2018), "Report of the IAU Working Group on Cartographic
    Coordinates and Rotational Elements: 2015", Celest. Mech. Dyn. Astr. 130:22.
    Equatorial radii: the limb a camera sees. Sun: IAU 2015 Resolution B3 nominal radius.
    Polar radii and the north poles' right ascension and declination at J2000 (ICRF, the
    constant terms; their rates move them by under 0.1 deg over 2018-2032) from the same
    report; Mars's pole from its 2009 edition (Archinal et al. 2011, Celest. Mech. Dyn.
    Astr. 109:101), whose constant terms the 2015 edition's periodic series averages to.
Mean elements
    E. M. Standish, "Keplerian Elements for Approximate Positions of the Major
    Planets", JPL Solar System Dynamics, table 1 (valid 1800 AD - 2050 AD). Stated
    accuracy there, Mars: ~40 arcsec in heliocentric longitude. The "Earth" row is the
    Earth-Moon barycentre.
Obliquity
    IAU 1976 value at J2000, 84381.448 arcsec, the one DE ephemerides are tied to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.errors import UnknownBodyError

AU_KM = 149_597_870.7  # IAU 2012 Resolution B2
OBLIQUITY_J2000_RAD = np.deg2rad(84381.448 / 3600.0)


def _rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


#: Rotates J2000-ecliptic vectors into the ICRF/J2000 equatorial frame: v_eq = M @ v_ecl.
ECLIPTIC_TO_EQUATORIAL = _rot_x(OBLIQUITY_J2000_RAD)


@dataclass(frozen=True)
class Body:
    """A Solar-system body: name, GM [km^3/s^2], equatorial radius [km], NAIF id for the DE kernel, polar
    radius [km] (a body's figure is the spheroid of the two radii) and the north pole's right ascension
    and declination [deg, ICRF, J2000]."""

    name: str
    gm: float
    radius: float
    naif_id: int
    polar_radius: float
    pole_ra_dec_deg: tuple[float, float]

    @property
    def diameter(self) -> float:
        """Equatorial diameter [km]."""
        return 2.0 * self.radius

    @property
    def pole(self) -> np.ndarray:
        """Unit vector of the north pole, ICRF."""
        ra, dec = (math.radians(a) for a in self.pole_ra_dec_deg)
        return np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])


BODIES: dict[str, Body] = {
    b.name: b
    for b in (
        Body("sun", 132_712_440_041.279419, 695_700.0, 10, 695_700.0, (286.13, 63.87)),
        Body("mercury", 22_031.868551, 2_440.53, 199, 2_438.26, (281.0103, 61.4155)),
        Body("venus", 324_858.592000, 6_051.8, 299, 6_051.8, (272.76, 67.16)),
        Body("earth", 398_600.435507, 6_378.1366, 399, 6_356.7519, (0.0, 90.0)),
        Body("moon", 4_902.800118, 1_737.4, 301, 1_737.4, (269.9949, 66.5392)),
        Body("mars", 42_828.375816, 3_396.19, 499, 3_376.20, (317.68143, 52.88650)),
        Body("jupiter", 126_712_764.100000, 71_492.0, 5, 66_854.0, (268.056595, 64.495303)),
        Body("saturn", 37_940_584.841800, 60_268.0, 6, 54_364.0, (40.589, 83.537)),
    )
}

#: Gravitational parameter of the Sun [km^3/s^2].
GM_SUN = BODIES["sun"].gm


def body(name: str) -> Body:
    """Look a body up by name (case-insensitive); :class:`UnknownBodyError` names the bad one."""
    key = str(name).strip().lower()
    try:
        return BODIES[key]
    except KeyError:
        raise UnknownBodyError(f"unknown body {name!r}; known bodies: {sorted(BODIES)}") from None


@dataclass(frozen=True)
class MeanElements:
    """JPL approximate mean elements at J2000 and their rates per Julian century.

    Columns (J2000 ecliptic): a [au], e [-], I [deg], L mean longitude [deg],
    varpi longitude of perihelion [deg], Omega longitude of the ascending node [deg].
    """

    a: float
    e: float
    inc: float
    mean_longitude: float
    long_peri: float
    long_node: float
    a_rate: float
    e_rate: float
    inc_rate: float
    mean_longitude_rate: float
    long_peri_rate: float
    long_node_rate: float


# Standish, table 1 (1800 AD - 2050 AD). "earth" is the Earth-Moon barycentre.
MEAN_ELEMENTS: dict[str, MeanElements] = {
    "mercury": MeanElements(
        0.38709927,
        0.20563593,
        7.00497902,
        252.25032350,
        77.45779628,
        48.33076593,
        0.00000037,
        0.00001906,
        -0.00594749,
        149472.67411175,
        0.16047689,
        -0.12534081,
    ),
    "venus": MeanElements(
        0.72333566,
        0.00677672,
        3.39467605,
        181.97909950,
        131.60246718,
        76.67984255,
        0.00000390,
        -0.00004107,
        -0.00078890,
        58517.81538729,
        0.00268329,
        -0.27769418,
    ),
    "earth": MeanElements(
        1.00000261,
        0.01671123,
        -0.00001531,
        100.46457166,
        102.93768193,
        0.0,
        0.00000562,
        -0.00004392,
        -0.01294668,
        35999.37244981,
        0.32327364,
        0.0,
    ),
    "mars": MeanElements(
        1.52371034,
        0.09339410,
        1.84969142,
        -4.55343205,
        -23.94362959,
        49.55953891,
        0.00001847,
        0.00007882,
        -0.00813131,
        19140.30268499,
        0.44441088,
        -0.29257343,
    ),
    "jupiter": MeanElements(
        5.20288700,
        0.04838624,
        1.30439695,
        34.39644051,
        14.72847983,
        100.47390909,
        -0.00011607,
        -0.00013253,
        -0.00183714,
        3034.74612775,
        0.21252668,
        0.20469106,
    ),
    "saturn": MeanElements(
        9.53667594,
        0.05386179,
        2.48599187,
        49.95424423,
        92.59887831,
        113.66242448,
        -0.00125060,
        -0.00050991,
        0.00193609,
        1222.49362201,
        -0.41897216,
        -0.28867794,
    ),
}

#: Interval of validity of MEAN_ELEMENTS, as TDB seconds since J2000 (1800-01-01 .. 2050-12-31).
MEAN_ELEMENTS_VALID_S = (-6311390400.0, 1609329600.0)
