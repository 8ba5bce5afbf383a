"""The thesis's rule: point the camera at the nearest planet (by the filter's estimate).

Each step the agent ranks the planets by the *estimated* distance (``criterion="distance"``, the thesis) or
by the estimated apparent diameter (``criterion="size"``: a large far planet can beat a small near one) and
points at the best one; it switches as soon as another planet ranks first. Planets the camera could not
see even if pointed straight at them (Sun exclusion, occultation, below the detection threshold) are
skipped (``skip_invisible``), so the rule never stares at a planet hidden in the Sun's glare; if none is
visible it keeps the current target (or the best-ranked one).

In the default cruise (Venus, Mars, Earth from 2020-08-01) Venus is nearest for the whole day, so the rule
stares at Venus: it only ever measures the two directions across Venus' line of sight, and the range along
it is constrained by the apparent diameter alone (weak at 0.3 AU).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, TargetAgent


class BaselineAgent(TargetAgent):
    """Nearest planet (or largest apparent size) by the filter's estimate; see the module docstring."""

    requires_idle_action = False

    def __init__(
        self,
        env: gym.Env,
        criterion: str = "distance",
        skip_invisible: bool = True,
        pulsar_every_s: float = 7200.0,
    ) -> None:
        super().__init__(env)
        if criterion not in ("distance", "size"):
            raise ValueError(f"criterion must be 'distance' or 'size', got {criterion!r}")
        if not pulsar_every_s > 0:
            raise ValueError(f"pulsar_every_s must be positive, got {pulsar_every_s!r}")
        self.criterion = criterion
        self.skip_invisible = skip_invisible
        self.name = "baseline" if criterion == "distance" else "baseline-size"
        cfg = self.config
        self._every = max(1, round(pulsar_every_s / cfg.step_s))
        self._integration_steps = max(1, math.ceil(cfg.detector.integration_time_s / cfg.step_s - 1e-9))
        self._k = 0

    def reset(self, seed: int | None = None) -> None:
        self._k = 0

    def nearest_planet(self, obs: ParsedObservation) -> int:
        """The thesis's rule on the estimate: nearest (or largest) planet among those observable."""
        # Both criteria come from the estimate: the observation's log10 distance and apparent diameter.
        score = -obs.planets[:, 3] if self.criterion == "distance" else obs.planets[:, 4]
        if self.skip_invisible:
            visible = obs.planet_observable
            if not np.any(visible):
                return obs.target if 0 <= obs.target < self.n_planets else int(np.argmax(score))
            score = np.where(visible, score, -np.inf)
        return int(np.argmax(score))

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        k = self._k
        self._k += 1
        planet = self.nearest_planet(obs)
        if obs.pulsars.shape[0] == 0:
            return planet
        # With a pulsar detector: the patent's fixed hybrid schedule. Every ``pulsar_every_s`` the
        # detector times the first pulsar that is observable and whose cycle count the filter can
        # trust (predicted 3 sigma < half a cycle), for one integration window; the camera images the
        # nearest planet the rest of the time.
        if k % self._every < self._integration_steps + 1:  # +1: the slew's step
            ok = (obs.pulsars[:, 5] > 0.5) & (3.0 * 10.0 ** obs.pulsars[:, 4] < 0.5)
            if np.any(ok):
                return self.n_planets + int(np.argmax(ok))
        return planet
