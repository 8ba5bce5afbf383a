"""Single-file PPO for Box actions (the torque tasks): baselines/ppo_single_file.py with a Gaussian head.

    python baselines/ppo_continuous.py --env-id planetnav/Cruise-Torque-v3 --total-timesteps 300000

CleanRL keeps its continuous-action PPO in a file of its own; so does this one. The arguments and their
defaults, the rollout, GAE, the clipped update and the evaluation are ppo_single_file's (imported: one
loop in one place); only the agent and its sampled actions differ. The policy is Stable-Baselines3's
``MlpPolicy`` for a Box: the actor's output is the mean of a diagonal Gaussian whose log standard deviation
is a free parameter per action dimension, initialized at 0 (SB3's ``log_std_init``); a sample's
log-probability and entropy are sums over the dimensions. The env clips a sample to the Box ([-1, 1]: SB3
clips too, [environment.md](../docs/environment.md)), and the update uses the unclipped sample's
log-probability, as SB3's does.

Evaluation: ppo_single_file's (suite v2's seeds and stored references, where the task has them); a row's
sampled action is drawn from its own generator as the suite's evaluator draws a one-row
``Normal.rsample`` (``loc + eps * scale``), so a policy scores here what it scores there. Suite v3 scores a
saved agent with ``python -m planetnav_train.suite.v3 agent-rows --task Cruise-Torque-v3 --agent F``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from torch import nn
from torch.distributions import Normal

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ppo_single_file as single  # a sibling script, not a package


class GaussianAgent(single.Agent):
    """ppo_single_file's actor and critic; the actor's ``action_dim`` outputs are a Gaussian's mean."""

    action_dtype = torch.float32

    def __init__(self, obs_dim: int, action_dim: int) -> None:
        super().__init__(obs_dim, action_dim)
        self.action_shape = (action_dim,)
        self.log_std = nn.Parameter(torch.zeros(action_dim))

    def distribution(self, x: torch.Tensor) -> Normal:
        mean = self.actor(x)
        return Normal(mean, self.log_std.exp().expand_as(mean))

    def get_action_and_value(self, x: torch.Tensor, action: torch.Tensor | None = None):
        dist = self.distribution(x)
        action = dist.rsample() if action is None else action  # loc + eps * scale: SB3's draw
        return action, dist.log_prob(action).sum(-1), dist.entropy().sum(-1), self.critic(x)


def box_agent(space: gym.Space, obs_dim: int) -> GaussianAgent:
    """The agent of a one-dimensional Box of actions (ppo_single_file's ``build``)."""
    if not isinstance(space, gym.spaces.Box) or len(space.shape) != 1:
        raise ValueError(f"this PPO takes a 1-D Box of actions, not {space} (Discrete: ppo_single_file.py)")
    return GaussianAgent(obs_dim, int(space.shape[0]))


def agent_from_sb3(policy_state: dict) -> GaussianAgent:
    """A GaussianAgent holding the weights of an SB3 ``MlpPolicy``'s ``state_dict()`` on a Box."""
    agent = GaussianAgent(policy_state["mlp_extractor.policy_net.0.weight"].shape[1],
                          policy_state["action_net.weight"].shape[0])  # fmt: skip
    names = {**single.SB3_NAMES, "log_std": "log_std"}
    agent.load_state_dict({ours: policy_state[theirs] for ours, theirs in names.items()})
    return agent


def load_agent(path: str | Path) -> GaussianAgent:
    """A GaussianAgent holding the ``state_dict`` that ``--save-model`` wrote at ``path``."""
    state = torch.load(path, map_location="cpu")
    if "log_std" not in state:
        raise ValueError(f"{path}: no log_std: not a Gaussian agent (a Discrete one: ppo_single_file's)")
    agent = GaussianAgent(state["actor.0.weight"].shape[1], state["actor.4.weight"].shape[0])
    agent.load_state_dict(state)
    return agent


def sampled_policy(agent: GaussianAgent, seeds: list[int], stream: int = 0):
    """The agent's sampled actions (N, A), row ``r`` drawing ``loc + eps * scale`` from its own generator
    seeded ``stream + seeds[r]``: stream 0 gives the suite's draws (ppo_single_file.sampled_policy)."""
    gens = [torch.Generator().manual_seed(stream + int(s)) for s in seeds]

    def act(o: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            dist = agent.distribution(torch.as_tensor(o))
            eps = torch.cat([torch.empty((1, dist.loc.shape[1])).normal_(generator=g) for g in gens])
            return (dist.loc + eps * dist.scale).numpy()

    return act


def make_parser() -> argparse.ArgumentParser:
    p = single.make_parser("Single-file PPO for Box actions on planetnav's native vector env.")
    p.set_defaults(env_id="planetnav/Cruise-Torque-v2")
    return p


def main(argv: list[str] | None = None) -> dict:
    return single.main(argv, make_parser(), box_agent, sampled_policy)


if __name__ == "__main__":
    main()
