"""Rule agents on a ``-v1`` id: refused with the remedy named (they act at the physics step with absolute
targets; a v1 id holds decisions and takes relative ones, so their actions would mean something else)."""

from __future__ import annotations

import gymnasium as gym
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import NotApplicableError, make_agent


@pytest.mark.parametrize("name", ["greedy", "baseline", "periodic", "planner"])
def test_rule_agents_refuse_a_v1_interface(name: str) -> None:
    env = gym.make("planetnav/Cruise-Target-v1")
    with pytest.raises(NotApplicableError, match="at_physics_step"):
        make_agent(name, env)
    physics = gym.make("planetnav/Cruise-Target-v1", decision_steps=1, target_actions="absolute",
                       observe_since_measured=False)  # fmt: skip
    assert make_agent(name, physics) is not None
    assert make_agent("random", env) is not None  # samples whatever space it is given
