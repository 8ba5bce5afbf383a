"""planetnav_train.pretrain ``clone(..., balance=True)``: each discrete action weighs the same in the fit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium import spaces


class _OneState(gym.Env):
    """A one-observation env with four actions: only the cloning fit is exercised."""

    observation_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
    action_space = spaces.Discrete(4)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple:
        return np.zeros(2, np.float32), {}

    def step(self, action: int) -> tuple:
        return np.zeros(2, np.float32), 0.0, True, False, {}


def _probs_after_clone(balance: bool) -> np.ndarray:
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import clone

    torch.manual_seed(0)
    model = PPO("MlpPolicy", _OneState(), n_steps=8, batch_size=8, seed=0, device="cpu")
    # One state, a teacher that picks action 1 at 5 % of the decisions and action 3 ("stay") otherwise.
    obs = np.zeros((400, 2), np.float32)
    actions = np.full(400, 3)
    actions[:20] = 1
    clone(model, obs, actions, epochs=60, balance=balance)
    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs[:1]))
    return dist.distribution.probs.numpy()[0]


def test_balance_weighs_each_action_the_same() -> None:
    # Maximum likelihood on one state gives p_c = (weighted count of c) / (weighted total): 20/400 = 0.05
    # unweighted; with the weights N / (C n_c) every present action has the same weighted count N / C,
    # so p_1 = p_3 = 1/2.
    plain = _probs_after_clone(balance=False)
    balanced = _probs_after_clone(balance=True)
    assert plain[1] == pytest.approx(0.05, abs=0.02) and np.argmax(plain) == 3
    assert balanced[1] == pytest.approx(0.5, abs=0.05) and balanced[3] == pytest.approx(0.5, abs=0.05)


def test_balance_needs_discrete_actions() -> None:
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import clone

    env = _OneState()
    env.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
    model = PPO("MlpPolicy", env, n_steps=8, batch_size=8, seed=0, device="cpu")
    with pytest.raises(ValueError, match="balance needs discrete actions"):
        clone(model, np.zeros((4, 2), np.float32), np.zeros((4, 2), np.float32), epochs=1, balance=True)
