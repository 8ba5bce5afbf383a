"""Named scenarios: the spacecraft's initial state and epoch for an episode.

``cruise``
    The thesis reproduction's trajectory (``docs/angular_size.md``): a Venus-to-Mars Hohmann-type
    transfer ellipse (perihelion 0.7233 AU, aphelion 1.5237 AU), inclination 2 deg to the J2000
    ecliptic, node 0, argument of perihelion 270 deg, mean anomaly 30 deg at 2020-08-01 00:00 TDB.
    Venus is 0.23 AU away, Mars 0.55 AU and Earth 0.40 AU, all well clear of the Sun.
``random-cruise``
    Drawn from the reset seed: epoch uniform in 2018-2032, a transfer ellipse between the orbits of
    Venus and Mars (perihelion 0.70-0.75 AU, aphelion 1.45-1.60 AU, inclination 0-3 deg) with uniform
    node, perihelion and mean anomaly; kept only if at least two of the configured planets are
    within 1.5 AU and more than 10 deg outside the camera's Sun-exclusion cone (redrawn otherwise).
``mars-approach``
    The patent reproduction's approach (``docs/optical_pulsar.md``, :mod:`planetnav_env.scenarios.approach`):
    hyperbolic arrival at 2.65 km/s, periapsis 400 km, closest approach 2021-02-10 12:00 TDB;
    Mars-centred ICRF state. The episode starts ``episode_steps * step_s`` before its end, which
    is ``end_before_ca_h`` before closest approach.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from planetnav_env.astro.bodies import AU_KM, ECLIPTIC_TO_EQUATORIAL, GM_SUN
from planetnav_env.astro.ephemeris import Ephemeris, elements_to_state
from planetnav_env.astro.timescale import tdb_seconds
from planetnav_env.errors import ConfigError
from planetnav_env.numerics.portable_math import arccos, dot3, matvec3, norm3

CRUISE_EPOCH = tdb_seconds(2020, 8, 1)
RANDOM_EPOCHS = (tdb_seconds(2018, 1, 1), tdb_seconds(2032, 1, 1))


def transfer_state(
    perihelion_au: float,
    aphelion_au: float,
    inc_deg: float,
    node_deg: float,
    argp_deg: float,
    mean_anom_deg: float,
) -> np.ndarray:
    """Heliocentric ICRF state [km, km/s] on an ellipse given in J2000-ecliptic elements."""
    rp, ra = perihelion_au * AU_KM, aphelion_au * AU_KM
    a, e = 0.5 * (rp + ra), (ra - rp) / (ra + rp)
    r, v = elements_to_state(
        a,
        e,
        np.deg2rad(inc_deg),
        np.deg2rad(node_deg),
        np.deg2rad(argp_deg),
        np.deg2rad(mean_anom_deg),
        GM_SUN,
    )
    return np.concatenate([matvec3(ECLIPTIC_TO_EQUATORIAL, r), matvec3(ECLIPTIC_TO_EQUATORIAL, v)])


def cruise_state() -> np.ndarray:
    """The ``cruise`` scenario's initial state at :data:`CRUISE_EPOCH`."""
    return transfer_state(0.7233, 1.5237, 2.0, 0.0, 270.0, 30.0)


@dataclass(frozen=True)
class Episode:
    """Initial truth of one episode: epoch [TDB s since J2000], state [km, km/s] relative to the
    ``central`` body, and the point masses the dynamics include besides it."""

    epoch: float
    x0: np.ndarray
    central: str = "sun"
    perturbers: tuple[str, ...] = ()


@functools.lru_cache(maxsize=8)
def _approach_start(duration_s: float, end_before_ca_h: float) -> tuple[float, tuple[float, ...]]:
    from planetnav_env.scenarios.approach import ApproachConfig, MarsApproach

    hours = duration_s / 3600.0 + end_before_ca_h
    app = MarsApproach(ApproachConfig(duration_h=hours, end_before_ca_h=end_before_ca_h, dt_s=duration_s))
    return float(app.t0), tuple(float(v) for v in app.x_true[0])


def approach_episode(duration_s: float, end_before_ca_h: float) -> Episode:
    """The mars-approach truth at the start of an episode of ``duration_s`` (DOP853 from periapsis)."""
    from planetnav_env.scenarios.approach import PERTURBERS

    t0, x0 = _approach_start(float(duration_s), float(end_before_ca_h))
    return Episode(t0, np.array(x0), "mars", tuple(PERTURBERS))


def _sun_angle_deg(r_sc: np.ndarray, r_body: np.ndarray) -> float:
    d = r_body - r_sc
    return float(np.degrees(arccos(np.clip(dot3(d, -r_sc) / (norm3(d) * norm3(r_sc)), -1.0, 1.0))))


def draw_episode(
    scenario: str,
    rng: np.random.Generator,
    ephemeris: Ephemeris,
    planets: tuple[str, ...],
    sun_exclusion_deg: float,
) -> Episode:
    """The initial truth for ``scenario`` (random scenarios draw from ``rng``); see
    :func:`approach_episode` for ``mars-approach``."""
    if scenario == "cruise":
        return Episode(CRUISE_EPOCH, cruise_state())
    if scenario == "random-cruise":
        for _ in range(1000):
            epoch = float(rng.uniform(*RANDOM_EPOCHS))
            x0 = transfer_state(
                rng.uniform(0.70, 0.75), rng.uniform(1.45, 1.60), rng.uniform(0.0, 3.0),
                rng.uniform(0, 360), rng.uniform(0, 360), rng.uniform(0, 360),
            )  # fmt: skip
            good = 0
            for p in planets:
                rb = ephemeris.position(p, epoch)
                if norm3(rb - x0[:3]) < 1.5 * AU_KM and _sun_angle_deg(x0[:3], rb) > sun_exclusion_deg + 10.0:
                    good += 1
            if good >= min(2, len(planets)):
                return Episode(epoch, x0)
        raise ConfigError(f"random-cruise: no geometry with two usable planets among {planets} in 1000 draws")
    raise ConfigError(f"unknown scenario {scenario!r}")
