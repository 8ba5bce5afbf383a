"""A saved RLlib policy (new API stack checkpoint) behind the :class:`~planetnav_agents.base.Agent` interface.

``path`` is a run directory written by ``train.py`` for ``algo: rllib_ppo`` (``runs/<name>/``, which holds
``checkpoint/`` and ``config.yaml``) or an ``Algorithm.save_to_path`` directory itself. Only the policy's
RLModule is loaded (no Ray cluster is started). Observations go to the module unchanged: the training
configurations here add no observation connectors (filters), so this is what the env runners fed it.
Needs the ``[ray]`` extra; this module imports Ray only when an agent is built.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import Agent

#: File that marks an RLlib checkpoint directory.
CHECKPOINT_MARKER = "rllib_checkpoint.json"
#: Where the default policy's module lives inside an algorithm checkpoint (ray 2.x new API stack).
MODULE_SUBDIR = Path("learner_group") / "learner" / "rl_module" / "default_policy"


def find_checkpoint(path: str | Path) -> Path | None:
    """The RLlib checkpoint directory for a checkpoint or run directory, else None (not an RLlib model)."""
    p = Path(path)
    for candidate in (p, p / "checkpoint"):
        if (candidate / CHECKPOINT_MARKER).is_file():
            return candidate
    return None


def config_sidecar(path: str | Path) -> Path | None:
    """The run's ``config.yaml`` beside an RLlib checkpoint (None if there is none or no checkpoint)."""
    ckpt = find_checkpoint(path)
    if ckpt is None:
        return None
    for candidate in (ckpt / "config.yaml", ckpt.parent / "config.yaml"):
        if candidate.is_file():
            return candidate
    return None


class RLlibAgent(Agent):
    """Actions of a saved RLlib PPO policy: the distribution's mode by default, sampled with
    ``deterministic=False`` (seeded through torch by ``reset(seed)``). Continuous actions are clipped to
    the action space, as the env runners did during training (``clip_actions=True``)."""

    requires_idle_action = False

    def __init__(self, path: str | Path, env: gym.Env | None = None, deterministic: bool = True) -> None:
        from planetnav_rl import require_ray

        require_ray("an RLlib checkpoint agent")
        from ray.rllib.core.rl_module import RLModule

        ckpt = find_checkpoint(path)
        if ckpt is None:
            raise FileNotFoundError(f"no RLlib checkpoint at {path} (expected {CHECKPOINT_MARKER})")
        self.path = ckpt
        self.deterministic = bool(deterministic)
        self.module = RLModule.from_checkpoint(ckpt / MODULE_SUBDIR)
        self.module.eval()
        self._dist_cls = self.module.get_inference_action_dist_cls()
        self.action_space = self.module.action_space
        self.observation_space = self.module.observation_space
        stem = ckpt.parent.name if ckpt.name == "checkpoint" else ckpt.name
        self.name = f"rllib_ppo:{stem}" + ("" if self.deterministic else ":stochastic")
        if env is not None:
            for what in ("observation_space", "action_space"):
                mine, theirs = getattr(self, what), getattr(env, what)
                if (
                    mine.shape != theirs.shape
                    or type(mine) is not type(theirs)
                    or (getattr(mine, "n", None) != getattr(theirs, "n", None))
                ):
                    raise ValueError(
                        f"{ckpt}: the policy's {what} {mine} does not match the environment's {theirs}"
                    )

    def reset(self, seed: int | None = None) -> None:
        if not self.deterministic and seed is not None:
            import torch

            torch.manual_seed(seed)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        import torch

        obs = torch.as_tensor(np.asarray(observation, dtype=np.float32)[None])
        with torch.no_grad():
            out = self.module.forward_inference({"obs": obs})
        dist = self._dist_cls.from_logits(out["action_dist_inputs"])
        if self.deterministic:
            dist = dist.to_deterministic()
        action = dist.sample().numpy()[0]
        if isinstance(self.action_space, gym.spaces.Discrete):
            return int(action)
        return np.clip(action, self.action_space.low, self.action_space.high).astype(np.float32)
