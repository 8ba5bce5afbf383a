"""The per-step pointing bonus (``shaping: {pointing_bonus: W}``, issue 18): not potential-based, it adds
``W * Phi(s')`` of each new state to the reward, on the native training rows and on a single env alike;
bad weights are named."""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError
from planetnav_train.batch_wrappers import single_training_env
from planetnav_train.config import parse_config
from planetnav_train.shaping import PointingPotential
from planetnav_train.vec_training import NavTrainingVecEnv

TORQUE = "planetnav/Cruise-TorqueControl-v0"


def _cfg(steps: int = 60) -> dict:
    return {**ENV_IDS[TORQUE], "episode_steps": steps, "reward": "covariance"}


def test_bonus_is_the_new_states_potential_on_every_row() -> None:
    """Two training envs on the same seeds and actions differ by exactly ``W * max cos`` of the new
    observation, row by row, every decision; with the env's hold of k physics steps, the potential of the
    state the decision ends in (one physics step at a time, k steps on)."""
    weight, n = 0.05, 4
    rng = np.random.default_rng(3)
    actions = np.clip(rng.normal(0.0, 0.5, (12, n, 3)), -1.0, 1.0)  # 36 steps at most: inside an episode
    for hold in (1, 3):
        held = {**_cfg(), "decision_steps": hold}
        plain = NavTrainingVecEnv(n, held, seed=7)
        bonus = NavTrainingVecEnv(n, held, seed=7, pointing_bonus=weight)
        inner = NavTrainingVecEnv(n, _cfg(), seed=7)  # one physics step at a time
        potential = PointingPotential(inner.venv.config, weight)
        plain.reset(), bonus.reset(), inner.reset()
        seen = 0.0
        for a in actions:
            o1, r1, d1, _ = plain.step(a)
            o2, r2, d2, _ = bonus.step(a)
            for _ in range(hold):
                obs, _, _, _ = inner.step(a)
            np.testing.assert_array_equal(o1, obs)  # the decision is the k physics steps
            expected = potential(obs)
            np.testing.assert_array_equal(o1, o2)
            np.testing.assert_allclose(r2 - r1, expected, rtol=1e-5, atol=1e-6)
            seen = max(seen, float(np.max(expected)))
            assert not (d1.any() or d2.any())
        assert seen > 0.0  # some row pointed somewhere: the bonus was not zero throughout


def test_single_env_bonus_matches_and_is_reported() -> None:
    env = single_training_env(PlanetNavEnv(**_cfg()), pointing_bonus=0.2)
    plain = PlanetNavEnv(**_cfg())
    env.reset(seed=1), plain.reset(seed=1)
    potential = PointingPotential(plain.config, 0.2)
    for _ in range(3):
        obs, reward, *_, info = env.step(np.array([0.3, -0.2, 0.1], dtype=np.float32))
        _, ref, *_ = plain.step(np.array([0.3, -0.2, 0.1], dtype=np.float32))
        assert reward == pytest.approx(ref + float(potential(obs[None])[0]))
        assert info["pointing_bonus"] == pytest.approx(float(potential(obs[None])[0]))


def test_bad_bonus_weights_are_named() -> None:
    with pytest.raises(ValueError, match=r"shaping weight must be > 0, got -0\.5"):
        NavTrainingVecEnv(2, _cfg(), pointing_bonus=-0.5)
    with pytest.raises(ConfigError, match=r"pointing_bonus must be a positive weight, got 0"):
        parse_config({"env_id": TORQUE, "algo": "ppo", "shaping": {"pointing_bonus": 0}})
    with pytest.raises(ConfigError, match=r"unknown key\(s\) \['bonus'\]"):
        parse_config({"env_id": TORQUE, "algo": "ppo", "shaping": {"bonus": 1.0}})
    tc = parse_config({"env_id": TORQUE, "algo": "ppo", "shaping": {"pointing_bonus": 0.05}})
    assert tc.shaping == {"pointing_bonus": 0.05}
