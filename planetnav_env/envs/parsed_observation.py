"""The observation an agent reads, as one typed record in physical units: :class:`ParsedObservation`.

The public contract between the environments and any agent that reads the observation by meaning rather
than as a flat vector: :meth:`ParsedObservation.from_observation` turns a ``box`` or ``dict`` observation
of an environment into named arrays through the environment's own decoder
(``PlanetNavEnv.decode_observation``, :func:`planetnav_env.envs.spaces.decode_observation`, which reads
the environment's :class:`~planetnav_env.core.layout.ObservationLayout`), so the record and the
observation cannot drift apart. Units and
frames are given per field; the per-target blocks keep the layout's columns (``planetnav_env.core.layout``
``TF_*``), which the properties read.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.attitude import quaternion as qt
from planetnav_env.core import layout as L

__all__ = ["ParsedObservation"]

_OPTIONAL = frozenset(b.name for b in L.OBSERVATION_BLOCKS)


@dataclass(frozen=True)
class ParsedObservation:
    """One observation as named float64 arrays in physical units.

    * position_km (3,), velocity_km_s (3,): the filter's estimate relative to the scenario's central body,
      ICRF axes [km, km/s]; log_sigma (6,): log10 of the filter's position, then velocity, 1-sigma per axis;
    * q (4,): star-tracker attitude, body -> inertial, scalar first, unit norm; rates_rad_s (3,): reported
      body rates [rad/s, body axes]; wheel_fraction (3,): wheel momentum / capacity per axis;
    * planets (P, 7), pulsars (Q, 7): the per-target blocks, columns ``layout.TF_*`` (unit direction in body
      axes; per kind log10 distance [AU] or integration progress, size or log10 phase 1-sigma; observable;
      log10 position 1-sigma);
    * target: index of the current target (planets first, then pulsars) or -1; elapsed: fraction of the
      episode;
    * blocks: the optional blocks the environment observes (:meth:`block`), and on an operations
      scenario: deadline_time_d (D,) the time to each deadline [d] (0 once
      reached), dv_lost_m_s the delta-v lost so far [m/s], thrusting whether the engine fires.
    """

    position_km: np.ndarray
    velocity_km_s: np.ndarray
    q: np.ndarray
    rates_rad_s: np.ndarray
    wheel_fraction: np.ndarray
    planets: np.ndarray
    pulsars: np.ndarray
    target: int
    elapsed: float
    log_sigma: np.ndarray | None = None
    #: The optional blocks the environment observes (each on with its ``EnvConfig.observe_<name>`` option),
    #: by name, as :data:`planetnav_env.core.layout.OBSERVATION_BLOCKS` declares them (their shapes and
    #: meanings are in that declaration and in docs/environment.md); read one with :meth:`block`.
    blocks: Mapping[str, np.ndarray] = field(default_factory=dict)
    deadline_time_d: np.ndarray | None = None
    dv_lost_m_s: float | None = None
    thrusting: bool | None = None

    @classmethod
    def from_decoded(cls, decoded: dict[str, Any]) -> ParsedObservation:
        """The record of a decoder's dict (:func:`planetnav_env.envs.spaces.decode_observation`): its
        optional blocks go to :attr:`blocks`."""
        fields = {k: v for k, v in decoded.items() if k not in _OPTIONAL}
        blocks = {k: v for k, v in decoded.items() if k in _OPTIONAL and v is not None}
        return cls(**fields, blocks=blocks)

    def block(self, name: str) -> np.ndarray | None:
        """The optional block ``name`` (``"image_log"``, ...), or None when the environment does not observe
        it; an unknown name raises a ``KeyError`` naming the known ones."""
        if name not in _OPTIONAL:
            raise KeyError(f"unknown observation block {name!r}; the optional blocks are {sorted(_OPTIONAL)}")
        return self.blocks.get(name)

    @classmethod
    def from_observation(cls, observation: Any, env: gym.Env) -> ParsedObservation:
        """The record of one ``box`` or ``dict`` observation of ``env`` (a planetnav environment, wrapped or
        not; a vector env's row); a mismatched observation raises the decoder's named error."""
        return cls.from_decoded(env.unwrapped.decode_observation(observation))

    @property
    def planet_distance_km(self) -> np.ndarray:
        """Estimated distance to each planet [km], (P,)."""
        return AU_KM * 10.0 ** self.planets[:, L.TF_LOG_DISTANCE]

    @property
    def planet_los_inertial(self) -> np.ndarray:
        """Estimated unit line of sight to each planet, inertial axes (P, 3) (body block rotated by q)."""
        return qt.rotate_body_to_inertial(self.q, self.planets[:, L.TF_DIR : L.TF_DIR + 3])

    @property
    def planet_observable(self) -> np.ndarray:
        """(P,) bool: measurable if pointed at (Sun exclusion, occultation, size), per the env."""
        return self.planets[:, L.TF_OBSERVABLE] > 0.5

    @property
    def pulsar_los_inertial(self) -> np.ndarray:
        """Unit direction of each pulsar, inertial axes (Q, 3)."""
        return qt.rotate_body_to_inertial(self.q, self.pulsars[:, L.TF_DIR : L.TF_DIR + 3])

    @property
    def boresight_inertial(self) -> np.ndarray:
        """Current camera boresight (body +x) in inertial axes, from the star-tracker attitude."""
        return qt.rotate_body_to_inertial(self.q, np.array([1.0, 0.0, 0.0]))

    def planet_positions(self, x_est: np.ndarray) -> np.ndarray:
        """Planet positions (P, 3) [km] in the estimate's frame: ``x_est + distance * line of sight``."""
        x = np.asarray(x_est, dtype=float)[:3]
        return x + self.planet_los_inertial * self.planet_distance_km[:, None]
