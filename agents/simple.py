"""Floor agents: ``random`` (a uniformly random action each step), ``idle`` (never measures) and ``zero``
(zero wheel torque: the camera drifts with the body)."""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import Agent, unwrapped_config


class RandomAgent(Agent):
    """Samples the action space each step from its own generator (seeded by :meth:`reset`).

    In ``target`` mode this picks a new planet most steps, so the camera spends much of the episode
    slewing: a floor that measures sometimes, by luck.
    """

    name = "random"
    requires_idle_action = False

    def __init__(self, env: gym.Env) -> None:
        # A private copy: seeding the env's own space would couple agents (and the env's users) sharing it.
        self.action_space = copy.deepcopy(env.action_space)

    def reset(self, seed: int | None = None) -> None:
        # The space's own sampler, re-seeded: identical actions for identical seeds.
        self.action_space.seed(seed)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self.action_space.sample()


class IdleAgent(Agent):
    """Always the environment's "camera off" action: the filter only predicts (the error floor).

    Needs an environment built with ``idle_action=True`` (the last discrete action).
    """

    name = "idle"
    requires_idle_action = True

    def __init__(self, env: gym.Env) -> None:
        cfg = unwrapped_config(env)
        if not cfg.idle_action:
            raise ValueError("the idle agent needs an environment built with idle_action=True")
        self._action = cfg.n_planets

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._action


class ZeroTorqueAgent(Agent):
    """Zero wheel torque every step (``action_mode="torque"``): the camera keeps the attitude it starts in,
    drifting with the body's rates, and measures whatever planet comes into its field. With ``random``
    it is the blind family of the torque tasks (:mod:`planetnav_train.suite.blind`): torques chosen
    without reading the state.
    """

    name = "zero"
    requires_idle_action = False

    def __init__(self, env: gym.Env) -> None:
        cfg = unwrapped_config(env)
        if cfg.action_mode != "torque":
            raise ValueError(
                "the zero agent commands wheel torques: it needs action_mode 'torque', got "
                f"{cfg.action_mode!r}"
            )
        self._action = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._action.copy()
