"""Apparent directions (light time + stellar aberration) against SPICE.

The oracle is NAIF's CSPICE through spiceypy: ``spkcvo`` with ``'CN+S'`` (converged Newtonian light time
and stellar aberration) for an observer given by its heliocentric state, on the DE421 kernel that
``skyfield-data`` ships. The inputs of :mod:`planetnav_env.astro.apparent` come from the same kernel
through jplephem (positions and velocities at the observer's time only).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_env.astro.apparent import SPEED_OF_LIGHT_KM_S, aberrate, apparent_direction, light_time
from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import de421_path
from planetnav_env.astro.timescale import J2000_JD, tdb_seconds

spice = pytest.importorskip("spiceypy")
spk = pytest.importorskip("jplephem.spk")

ARCSEC = math.pi / 180.0 / 3600.0
#: SPICE name and the jplephem segment chain from the barycentre of each target.
TARGETS = {
    "VENUS": ((0, 2), (2, 299)),
    "EARTH": ((0, 3), (3, 399)),
    "MARS": ((0, 4), (4, 499)),
    "JUPITER BARYCENTER": ((0, 5),),
}


@pytest.fixture(scope="module")
def kernels():
    path = de421_path()
    spice.furnsh(path)
    kernel = spk.SPK.open(path)
    yield kernel
    kernel.close()
    spice.unload(path)


def _barycentric_state(kernel, chain, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Position [km] and velocity [km/s] relative to the Solar-system barycentre at ``t`` [TDB s]."""
    pos = np.zeros(3)
    vel = np.zeros(3)
    for pair in chain:
        p, v = kernel[pair].compute_and_differentiate(J2000_JD + t / 86400.0)
        pos += p
        vel += v / 86400.0
    return pos, vel


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b)))


def _observers(n: int, seed: int):
    """Heliocentric spacecraft states of a cruise: 0.6-1.7 AU, near-circular speed in a random direction
    across the radius plus a few km/s of random velocity, at epochs spread over 2018-2032."""
    rng = np.random.default_rng(seed)
    mu = body("sun").gm
    for _ in range(n):
        t = float(rng.uniform(tdb_seconds(2018, 1, 1), tdb_seconds(2032, 1, 1)))
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        r = rng.uniform(0.6, 1.7) * 1.495978707e8 * u
        w = np.cross(u, rng.normal(size=3))
        w /= np.linalg.norm(w)
        v = math.sqrt(mu / np.linalg.norm(r)) * w + rng.normal(scale=3.0, size=3)
        yield t, r, v


def test_apparent_direction_matches_spice_cn_s(kernels):
    mu = body("sun").gm
    worst = 0.0
    for t, r_obs, v_obs in _observers(40, seed=11):
        r_sun, v_sun = _barycentric_state(kernels, ((0, 10),), t)
        for name, chain in TARGETS.items():
            r_t, v_t = _barycentric_state(kernels, chain, t)
            out = np.empty(3)
            tau = apparent_direction(r_obs, v_obs + v_sun, r_t - r_sun, v_t, mu, out)
            state, lt = spice.spkcvo(
                name, t, "J2000", "OBSERVER", "CN+S", np.concatenate([r_obs, v_obs]), t, "SUN", "J2000"
            )
            ref = np.asarray(state[:3]) / np.linalg.norm(state[:3])
            worst = max(worst, _angle(out, ref) / ARCSEC)
            assert tau == pytest.approx(lt, rel=1e-9, abs=1e-6)
            assert np.linalg.norm(out) == pytest.approx(1.0, abs=1e-15)
    assert worst < 1e-4, f"largest difference from SPICE 'CN+S': {worst:.2e} arcsec"


def test_light_time_alone_matches_spice_cn(kernels):
    """Without aberration ('CN'), the corrected vector itself agrees with SPICE's to 3 m (the expansion's
    third-order term and the planets' pull on the target: ~1e-6" at 2 AU), but for the
    Earth: the expansion's acceleration is the Sun's alone, and the Moon's pull on the Earth's centre,
    GM_moon / d^2 ~ 3.3e-8 km/s^2, moves it by up to a tau^2 / 2 ~ 20 m over a 20-minute light time
    (3e-5" at 0.5 AU, far below the camera's resolution)."""
    mu = body("sun").gm
    moon_pull = body("moon").gm / 384_400.0**2
    for t, r_obs, v_obs in _observers(20, seed=12):
        r_sun, _ = _barycentric_state(kernels, ((0, 10),), t)
        for name, chain in TARGETS.items():
            r_t, v_t = _barycentric_state(kernels, chain, t)
            out = np.empty(3)
            tau = light_time(r_obs, r_t - r_sun, v_t, mu, out)
            state, _ = spice.spkcvo(
                name, t, "J2000", "OBSERVER", "CN", np.concatenate([r_obs, v_obs]), t, "SUN", "J2000"
            )
            bound = 3e-3 + (1.1 * 0.5 * moon_pull * tau * tau if name == "EARTH" else 0.0)
            assert np.linalg.norm(out - np.asarray(state[:3])) < bound  # km


def test_aberration_matches_spice_stelab():
    rng = np.random.default_rng(3)
    for _ in range(200):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = rng.normal(scale=30.0, size=3)
        out = np.empty(3)
        aberrate(u, v, out)
        ref = np.asarray(spice.stelab(u, v))
        assert _angle(out, ref / np.linalg.norm(ref)) < 1e-9 * ARCSEC
        assert np.linalg.norm(out) == pytest.approx(1.0, abs=1e-15)


def test_aberration_angle_is_v_over_c_across_the_line_of_sight():
    """Closed form: the direction turns toward the velocity by asin(v sin(theta) / c)."""
    u = np.array([1.0, 0.0, 0.0])
    for theta_deg in (10.0, 45.0, 90.0, 150.0):
        th = math.radians(theta_deg)
        v = 30.0 * np.array([math.cos(th), math.sin(th), 0.0])
        out = np.empty(3)
        aberrate(u, v, out)
        expected = math.asin(30.0 * math.sin(th) / SPEED_OF_LIGHT_KM_S)
        assert math.atan2(out[1], out[0]) == pytest.approx(expected, rel=1e-12)
        assert out[2] == 0.0


def test_aberration_in_place_and_along_the_velocity():
    u = np.array([0.0, 0.6, 0.8])
    aberrate(u, np.array([0.0, 6.0, 8.0]), u)  # along the line of sight: unchanged, also in place
    assert np.array_equal(u, [0.0, 0.6, 0.8])
