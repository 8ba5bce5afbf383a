"""Potential-based reward shaping for training in torque modes (reported as shaping wherever used).

The environment's reward (navigation error, truth or covariance) is kept; :class:`PointingShaping` adds
``F = gamma * Phi(s') - Phi(s)`` (Ng, Harada & Russell 1999), which leaves the optimal policies unchanged:
over an episode it sums to ``gamma^T Phi(s_T) - Phi(s_0)`` and only shifts the values. It is there
to make the first measurement discoverable: random wheel torques measure ~1 % of the steps, so the
navigation reward alone gives almost no gradient toward pointing the camera.

``Phi(s) = weight * max_p cos(angle between the boresight and planet p)`` over the planets observable if
pointed at, from the observation only (the per-planet estimated direction in body axes; the camera
boresight is body +x in every shipped configuration, and the wrapper checks it), 0 when none is
observable. ``weight`` is in reward units (the navigation reward is ``-error / reward_scale_km`` per
step, ~-0.1..-1.7 in cruise).

Used only by ``train.py`` during training (config key ``shaping: {pointing: WEIGHT}``); evaluation
reports the unshaped navigation metrics.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import parse_observation, unwrapped_config

SHAPINGS = ("pointing",)


class PointingShaping(gym.Wrapper):
    """Adds the potential-based pointing term of the module docstring to the reward.

    ``info["shaping"]`` holds the term added at each step (so a log can separate it from the reward).
    """

    def __init__(self, env: gym.Env, weight: float, gamma: float) -> None:
        super().__init__(env)
        cfg = unwrapped_config(env)
        if not np.allclose(cfg.camera.boresight_body, (1.0, 0.0, 0.0)):
            raise ValueError(
                f"pointing shaping assumes the camera boresight is body +x, got {cfg.camera.boresight_body}"
            )
        if not (np.isfinite(weight) and weight > 0):
            raise ValueError(f"shaping weight must be > 0, got {weight!r}")
        if not 0.0 < gamma <= 1.0:
            raise ValueError(f"shaping gamma must be in (0, 1], got {gamma!r}")
        self.weight, self.gamma = float(weight), float(gamma)
        self._phi = 0.0

    def potential(self, observation: Any) -> float:
        """``Phi(s)`` of an observation (see the module docstring)."""
        obs = parse_observation(observation, self.env)
        visible = obs.planet_observable
        if not np.any(visible):
            return 0.0
        cos = obs.planets[:, 0]  # x component of the estimated body-frame direction = cos(off-boresight)
        return self.weight * float(np.max(cos[visible]))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._phi = self.potential(obs)
        return obs, info

    def step(self, action: Any):
        obs, reward, terminated, truncated, info = self.env.step(action)
        # Terminal states have potential 0 (the standard convention that keeps the invariance).
        phi = 0.0 if terminated else self.potential(obs)
        shaping = self.gamma * phi - self._phi
        self._phi = phi
        info = {**info, "shaping": shaping}
        return obs, float(reward) + shaping, terminated, truncated, info
