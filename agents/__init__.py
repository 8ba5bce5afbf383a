"""Agents for the planetnav environments, behind one interface (:class:`agents.base.Agent`).

``make_agent(name_or_path, env)`` builds one by name or loads a saved Stable-Baselines3 model:

============== ==========================================================================================
name           agent
============== ==========================================================================================
baseline       the thesis's rule: the nearest planet by the filter's estimate (:mod:`agents.baseline`)
baseline-size  the same rule ranking by estimated apparent diameter
greedy         the planet whose measurements shrink the position covariance most, slew time counted
random         a uniformly random action each step
idle           never measures (needs ``idle_action=True``)
PATH           a saved SB3 model (``.zip`` or a ``runs/<name>/`` directory), deterministic actions
PATH           an RLlib checkpoint (a ``runs/<name>/`` directory of ``algo: rllib_ppo``, or the checkpoint
               directory itself; needs the ``[ray]`` extra), the policy's mode (:mod:`agents.rllib`)
PATH@sampled   the same model, actions sampled from the policy (seeded by ``reset(seed)``)
============== ==========================================================================================
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from agents.base import Agent, ParsedObservation, TargetAgent, parse_observation
from agents.baseline import BaselineAgent
from agents.greedy import GreedyAgent
from agents.rllib import RLlibAgent
from agents.rllib import find_checkpoint as find_rllib_checkpoint
from agents.sb3 import SB3Agent
from agents.simple import IdleAgent, RandomAgent

AGENTS: dict[str, Callable[..., Agent]] = {
    "baseline": lambda env, **kw: BaselineAgent(env, criterion="distance", **kw),
    "baseline-size": lambda env, **kw: BaselineAgent(env, criterion="size", **kw),
    "greedy": GreedyAgent,
    "random": RandomAgent,
    "idle": IdleAgent,
}

#: Agents that need the environment's "camera off" action (the harness builds their env with it).
NEEDS_IDLE_ACTION = frozenset({"idle"})


#: Suffix of a model path that evaluates the policy's sampled actions instead of its argmax.
SAMPLED_SUFFIX = "@sampled"


def strip_sampled(spec: str) -> str:
    """The model path of a ``PATH@sampled`` agent spec (other specs unchanged)."""
    s = str(spec)
    return s[: -len(SAMPLED_SUFFIX)] if s.endswith(SAMPLED_SUFFIX) else s


def requires_idle_action(name_or_path: str) -> bool:
    """Whether the agent ``name_or_path`` needs an environment with ``idle_action=True``."""
    return str(name_or_path) in NEEDS_IDLE_ACTION


def make_agent(name_or_path: str | Path, env: gym.Env, **kwargs: Any) -> Agent:
    """An agent by registered name (see the module docstring) or from a saved SB3 model path.

    ``kwargs`` go to the agent's constructor (e.g. ``horizon=60`` for ``greedy``, ``algo="ppo"`` for a
    model). Raises ``ValueError`` naming the known agents when the name is neither registered nor a path.
    """
    key = str(name_or_path)
    if key.endswith(SAMPLED_SUFFIX):
        # "PATH@sampled": the saved policy's actions are sampled, not its argmax (seeded by reset(seed)).
        key = key[: -len(SAMPLED_SUFFIX)]
        kwargs.setdefault("deterministic", False)
    if key in AGENTS:
        return AGENTS[key](env, **kwargs)
    path = Path(key)
    if find_rllib_checkpoint(path) is not None:
        kwargs.pop("algo", None)  # an RLlib checkpoint names its own algorithm
        return RLlibAgent(path, env, **kwargs)
    if path.exists() or path.with_suffix(".zip").exists():
        return SB3Agent(path, env, **kwargs)
    raise ValueError(f"unknown agent {key!r}: not one of {sorted(AGENTS)} and no model file at that path")


__all__ = [
    "AGENTS",
    "Agent",
    "BaselineAgent",
    "GreedyAgent",
    "IdleAgent",
    "ParsedObservation",
    "RLlibAgent",
    "RandomAgent",
    "SB3Agent",
    "TargetAgent",
    "make_agent",
    "parse_observation",
    "requires_idle_action",
    "strip_sampled",
]
