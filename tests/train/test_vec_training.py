"""The training options written once over a batch (planetnav_train.batch_wrappers): the native training
VecEnv's rows equal single environments running the same layers with N = 1 (in SB3's DummyVecEnv), for
every feature and the shaping, over the env's decision interface (the hold, relative targets,
since_measured), in every action mode; the agent-side formulas equal their one-row forms; a training-side
decision option is refused with the env option's name."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.errors import ConfigError
from planetnav_train.batch_wrappers import single_training_env
from planetnav_train.features import FeatureBatch
from planetnav_train.vec_training import NavTrainingVecEnv


def _dummy(cfg: EnvConfig, n: int, **options) -> DummyVecEnv:
    return DummyVecEnv([lambda: single_training_env(PlanetNavEnv(cfg), **options) for _ in range(n)])


#: The env's decision options of a case: (decision_steps, relative targets, since_measured).
def _decision(steps: int, relative: bool, since: bool) -> dict:
    return {"decision_steps": steps, "target_actions": "relative" if relative else "absolute",
            "observe_since_measured": since}  # fmt: skip


CASES = [
    # mode, features, env decision options, pointing weight, gamma
    ("target", [], _decision(3, True, True), None, 0.99),  # the default recipe; 3 does not divide 20
    ("target", [], _decision(1, False, False), None, 0.99),
    ("target+torque", ["pd_torque"], _decision(2, False, True), None, 0.99),
    (
        "torque",
        ["pd_torque"],
        _decision(1, False, False),
        1.0,
        0.99,
    ),  # the torque recipe (configs/torque.yaml)
    ("torque", ["gain", "pd_torque"], _decision(4, False, True), 0.5, 0.9),
    ("target", ["gain"], _decision(3, True, True), None, 0.99),  # the random-cruise recipe
    ("target", ["gain"], _decision(1, False, False), 2.0, 1.0),
]


@pytest.mark.parametrize(("mode", "features", "decision", "pointing", "gamma"), CASES)
@pytest.mark.parametrize("scenario", ["cruise", "random-cruise"])
def test_native_training_env_rows_equal_single_env_adapters(
    mode, features, decision, pointing, gamma, scenario
):
    if scenario == "random-cruise" and "gain" not in features and "pd_torque" not in features:
        pytest.skip("the recipes without gain or pd_torque are covered on the fixed cruise")
    n, seed, decisions = 3, 11, 40
    cfg = EnvConfig(action_mode=mode, episode_steps=20, scenario=scenario, **decision)
    options = {"features": features, "pointing": pointing, "gamma": gamma}
    native = NavTrainingVecEnv(n, cfg, seed=seed, **options)
    dummy = _dummy(cfg, n, **options)
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


def test_pd_torque_feature_is_the_agents_pd_law_per_planet():
    """The feature's row-batched PD torques equal TargetAgent.torque_toward (the agent's one-row form) per
    planet, and that equals the PD law called on the single row's arrays (the formula before batching)."""
    from planetnav_agents.base import TargetAgent, parse_observation
    from planetnav_env.attitude.pointing import pd_torque

    env = PlanetNavEnv(episode_steps=10, action_mode="torque", torque_action_scale=0.05)
    agent = TargetAgent(env)
    batch = FeatureBatch.for_env(env, ["pd_torque"])
    obs, info = env.reset(seed=4)
    law = agent.pointing
    for _ in range(10):
        parsed = parse_observation(obs, env)
        feature = batch.augment_info(obs, info)[obs.shape[0] :].reshape(-1, 3)
        for i in range(env.config.n_planets):
            got = agent.torque_toward(parsed, info, i)
            np.testing.assert_array_equal(feature[i], got)
            u = pd_torque(
                parsed.q, parsed.rates_rad_s, parsed.planet_los_inertial[i], law._att_config,
                h_w=parsed.wheel_fraction * law._h_max, roll_ref_inertial=info["filter"]["x"][:3],
                k_a=law.k_a, k_w=law.k_w,
            )  # fmt: skip
            ref = np.clip(u / (law._tau_max * law._torque_scale), -1.0, 1.0).astype(np.float32)
            np.testing.assert_array_equal(got, ref)
        obs, _, _, _, info = env.step(feature[1])  # point at the second planet with the feature's torque


def test_native_training_env_rejects_bad_options():
    with pytest.raises(ValueError, match="unknown observation feature 'clock'"):
        NavTrainingVecEnv(2, EnvConfig(), features=["clock"])
    with pytest.raises(ValueError, match=r"shaping weight must be > 0, got -1\.0"):
        NavTrainingVecEnv(2, EnvConfig(), pointing=-1.0)
    with pytest.raises(ValueError, match=r"shaping gamma must be in \(0, 1\], got 1.5"):
        NavTrainingVecEnv(2, EnvConfig(), pointing=1.0, gamma=1.5)
    with pytest.raises(ValueError, match="observation features need observation='box', got 'dict'"):
        NavTrainingVecEnv(2, EnvConfig(observation="dict"), features=["gain"])


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"action_repeat": 3}, "action_repeat is no longer a training option: set env option "
         "decision_steps=3"),
        ({"relative_actions": True}, "set env option target_actions='relative'"),
        ({"features": ["since_measured"]}, "since_measured is no longer a training feature: set env option "
         "observe_since_measured=true"),
    ],
)  # fmt: skip
def test_training_side_decision_options_name_the_env_option(options, named):
    """The hold, relative targets and since_measured are the env's: the training layers refuse their old
    names with the env option to set, on both adapters."""
    with pytest.raises(ConfigError, match=named):
        NavTrainingVecEnv(2, EnvConfig(), **options)
    with pytest.raises(ConfigError, match=named):
        single_training_env(PlanetNavEnv(episode_steps=4), **options)


def test_relative_actions_name_the_bad_row():
    env = NavTrainingVecEnv(2, EnvConfig(episode_steps=5, target_actions="relative"))
    env.reset()
    with pytest.raises(ValueError, match=r"row 0 must be an integer in \[0, 3\), got -1"):
        env.step(np.array([-1, 0]))


def test_single_env_adapter_adds_no_warning_and_keeps_dict_observations():
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        env = single_training_env(PlanetNavEnv(episode_steps=4, observation="dict", decision_steps=2))
    obs, _ = env.reset(seed=0)
    assert isinstance(obs, dict) and obs["planets"].shape == (3, 7)
    obs, reward, terminated, truncated, _ = env.step(0)
    assert isinstance(obs, dict) and isinstance(reward, float) and not (terminated or truncated)


@pytest.mark.parametrize("config", ["configs/cruise_ppo.yaml", "configs/torque.yaml"])
def test_train_uses_the_native_training_env_for_every_recipe(tmp_path, config):
    from stable_baselines3.common.vec_env import VecMonitor

    from planetnav_train.config import load_config
    from planetnav_train.envs import make_training_env

    tc = load_config(config)
    venv = make_training_env(tc, tmp_path)
    assert isinstance(venv, VecMonitor) and isinstance(venv.venv, NavTrainingVecEnv)
    assert venv.venv.features == tuple(tc.features) and venv.venv.pointing == tc.shaping.get("pointing")
    tc.vec_env = "dummy"
    assert isinstance(make_training_env(tc, tmp_path), DummyVecEnv)
