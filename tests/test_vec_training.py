"""The vector training env (planetnav_agents.vec_training) is the same MDP as wrapped single envs in
DummyVecEnv."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from planetnav_agents.features import ActionRepeat, NavFeatures, RelativeTargets, relative_actions_batch
from planetnav_agents.vec_training import NavTrainingVecEnv
from planetnav_env.config import EnvConfig
from planetnav_env.env import PlanetNavEnv


def _dummy(cfg: EnvConfig, n: int, features, repeat: int, relative: bool) -> DummyVecEnv:
    def make():
        env = PlanetNavEnv(cfg)
        if features:
            env = NavFeatures(env, features)
        if repeat > 1:
            env = ActionRepeat(env, repeat)
        return RelativeTargets(env) if relative else env

    return DummyVecEnv([make for _ in range(n)])


@pytest.mark.parametrize(
    ("mode", "features", "repeat", "relative"),
    [
        ("target", ["since_measured"], 3, True),  # the default recipe; 3 does not divide the episode
        ("target", [], 1, False),
        ("target+torque", ["since_measured"], 2, True),
        ("torque", ["since_measured"], 4, False),
        ("target", ["gain", "since_measured"], 3, True),  # the random-cruise recipe
        ("target", ["gain"], 1, False),
    ],
)
@pytest.mark.parametrize("scenario", ["cruise", "random-cruise"])
def test_native_training_env_equals_wrapped_single_envs(mode, features, repeat, relative, scenario):
    if scenario == "random-cruise" and "gain" not in features:
        pytest.skip("the recipes without gain are covered on the fixed cruise")
    n, seed, decisions = 3, 11, 40
    cfg = EnvConfig(action_mode=mode, episode_steps=20, scenario=scenario)
    native = NavTrainingVecEnv(
        n, cfg, seed=seed, features=features, action_repeat=repeat, relative_actions=relative
    )
    dummy = _dummy(cfg, n, features, repeat, relative)
    dummy.seed(seed)
    assert native.observation_space.shape == dummy.observation_space.shape
    assert native.action_space == dummy.action_space
    o_nat, o_dum = native.reset(), dummy.reset()
    np.testing.assert_array_equal(o_nat, o_dum)
    space = native.action_space
    space.seed(3)
    dones_seen = 0
    for _ in range(decisions):
        acts = np.stack([space.sample() for _ in range(n)])
        o_nat, r_nat, d_nat, i_nat = native.step(acts)
        o_dum, r_dum, d_dum, i_dum = dummy.step(acts)
        np.testing.assert_array_equal(d_nat, d_dum)
        np.testing.assert_array_equal(r_nat, r_dum)
        np.testing.assert_array_equal(o_nat, o_dum)
        for a, b in zip(i_nat, i_dum, strict=True):
            assert a["measured"] == b["measured"] and a["pos_err_km"] == b["pos_err_km"]
            if "terminal_observation" in b:
                np.testing.assert_array_equal(a["terminal_observation"], b["terminal_observation"])
                assert a["TimeLimit.truncated"] == b["TimeLimit.truncated"]
            else:
                assert "terminal_observation" not in a
        dones_seen += int(d_nat.sum())
    assert dones_seen >= n  # the comparison went through episode ends inside a held decision


def test_native_training_env_rejects_what_it_cannot_compute():
    with pytest.raises(ValueError, match="pd_torque"):
        NavTrainingVecEnv(2, EnvConfig(action_mode="torque"), features=["pd_torque"])
    with pytest.raises(ValueError, match="unknown observation feature 'clock'"):
        NavTrainingVecEnv(2, EnvConfig(), features=["clock"])
    with pytest.raises(ValueError, match="relative target actions"):
        NavTrainingVecEnv(2, EnvConfig(action_mode="torque"), relative_actions=True)
    with pytest.raises(ValueError, match="action_repeat must be an integer >= 1, got 0"):
        NavTrainingVecEnv(2, EnvConfig(), action_repeat=0)


def test_relative_actions_name_the_bad_row():
    with pytest.raises(ValueError, match=r"row 1 must be in \[0, 3\), got 5"):
        relative_actions_batch(np.array([0, 5]), np.array([0, 0]), 3)
    env = NavTrainingVecEnv(2, EnvConfig(episode_steps=5), relative_actions=True)
    env.reset()
    with pytest.raises(ValueError, match="row 0"):
        env.step(np.array([-1, 0]))


def test_train_uses_the_native_training_env_for_the_default_recipe(tmp_path):
    from stable_baselines3.common.vec_env import VecMonitor

    from planetnav_train.config import load_config
    from planetnav_train.envs import make_training_env

    tc = load_config("configs/cruise_ppo.yaml")
    venv = make_training_env(tc, tmp_path)
    assert isinstance(venv, VecMonitor) and isinstance(venv.venv, NavTrainingVecEnv)
    assert venv.venv.action_repeat == 10 and venv.venv.relative_actions and venv.venv.features
    tc.vec_env = "dummy"
    assert isinstance(make_training_env(tc, tmp_path), DummyVecEnv)
