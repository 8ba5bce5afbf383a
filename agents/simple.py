"""Floor agents: ``random`` (a uniformly random action each step) and ``idle`` (never measures)."""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym

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
