"""Wheel torques at the attitude's timescale (issue 18): ``Cruise-TorqueControl-v0`` and ``Cruise-Hybrid-v0``.

Both run the thesis cruise at a 1-s step for one hour. Checked here: the spaces pass Gymnasium's and SB3's
checkers; the vector env's rows equal single envs; the ``in_field`` block is the camera's own visibility
rule at the star-tracker attitude and the estimated position; the hybrid action's decoding (which option,
which torque) and its named errors; the greedy + PD reference; the training config's smoke run.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_agents.base import PointingLaw, hybrid_action
from planetnav_env.astro.bodies import body
from planetnav_env.core import layout as L
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.envs.spaces import decode_hybrid
from planetnav_env.errors import InvalidParameterError, NonFiniteError
from planetnav_env.sensors.camera import visibility

ROOT = Path(__file__).resolve().parents[2]
TORQUE = "planetnav/Cruise-TorqueControl-v0"
HYBRID = "planetnav/Cruise-Hybrid-v0"
IDS = (TORQUE, HYBRID)
P = 3  # venus, mars, earth
LIMIT_N_M = 0.01  # the default wheel torque limit: one unit of action at torque_action_scale 1


@pytest.mark.parametrize("env_id", IDS)
def test_ids_are_one_hour_at_one_second_with_the_in_field_block(env_id: str) -> None:
    env = gym.make(env_id)
    cfg = env.unwrapped.config
    assert (cfg.step_s, cfg.attitude_substep_s, cfg.episode_steps) == (1.0, 1.0, 3600)
    assert cfg.torque_action_scale == 1.0 and cfg.observe_in_field
    names = [b[0] for b in env.unwrapped.layout.blocks]
    assert names[-1] == "in_field"
    assert env.observation_space.shape == (L.ObservationLayout(P, 0).size + P,)
    want = (3,) if env_id == TORQUE else (P + 1 + 3,)
    assert env.action_space.shape == want


def test_other_ids_have_no_in_field_block() -> None:
    """Existing ids keep their observation (tests/env/test_golden.py pins the numbers)."""
    for env_id in ENV_IDS:
        if env_id.replace("-v1", "-v0") in IDS:  # the 1-s ids, both versions
            continue
        layout = gym.make(env_id).unwrapped.layout
        assert not layout.in_field and "in_field" not in [b[0] for b in layout.blocks], env_id


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_and_sb3_checkers(env_id: str) -> None:
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    gym_check(gym.make(env_id).unwrapped, skip_render_check=True)
    sb3_check(gym.make(env_id, episode_steps=20).unwrapped, warn=True)


@pytest.mark.parametrize("env_id", IDS)
def test_vector_rows_equal_single_envs(env_id: str) -> None:
    """Row r of the vector env equals the single env seeded seed + r, bit for bit, over random actions."""
    n, steps, seed = 3, 40, 11
    rng = np.random.default_rng(0)
    venv = gym.make_vec(env_id, num_envs=n, episode_steps=60)
    singles = [gym.make(env_id, episode_steps=60) for _ in range(n)]
    obs_v, _ = venv.reset(seed=seed)
    np.testing.assert_array_equal(obs_v, np.stack([e.reset(seed=seed + r)[0] for r, e in enumerate(singles)]))
    for _ in range(steps):
        a = rng.uniform(-1, 1, (n, *venv.single_action_space.shape)).astype(np.float32)
        obs_v, rew_v, _, _, info_v = venv.step(a)
        for r, e in enumerate(singles):
            o, rew, _, _, info = e.step(a[r])
            np.testing.assert_array_equal(obs_v[r], o)
            assert rew_v[r] == rew and info_v["measured"][r] == info["measured"]


def _camera_would_measure(env: gym.Env, info: dict) -> np.ndarray:
    """(P,) bool: the camera's own visibility rule (sensors.camera.visibility) for each planet at the
    star-tracker attitude and the estimated heliocentric position, disk no wider than the field."""
    u = env.unwrapped
    cfg = u.config
    bodies = u.body_positions()
    r_est = np.asarray(info["filter"]["x"][:3]) + bodies["central"]
    q_est = u.core.f[0, L.F_QE : L.F_QE + 4]
    planets = np.asarray(bodies["planets"])
    radii = np.array([body(p).radius for p in cfg.planets])
    alpha_max = 2.0 * min(cfg.camera.half_fov_rad)
    out = np.zeros(len(radii), dtype=bool)
    for a in range(len(radii)):
        others = np.delete(np.arange(len(radii)), a)
        v = visibility(r_est, q_est, planets[a], planets[others], radii[others], radii[a], cfg.camera)
        out[a] = bool(v.visible) and float(v.apparent_diameter_rad) <= alpha_max
    return out


def test_in_field_is_the_cameras_visibility_rule_now() -> None:
    """Greedy + PD slews between the planets: every step the block equals the camera's own rule, and
    both values (and a switch of planet) occur."""
    env = gym.make(TORQUE, episode_steps=900, noise_streams="per_step")
    agent = make_agent("greedy-pd", env)
    obs, info = env.reset(seed=3)
    agent.reset(3)
    seen = np.zeros((2, P), dtype=int)
    start = env.unwrapped.layout.in_field_start
    for _ in range(900):
        obs, _, term, trunc, info = env.step(agent.act(obs, info))
        flags = obs[start : start + P]
        want = _camera_would_measure(env, info)
        np.testing.assert_array_equal(flags, want.astype(np.float32))
        np.testing.assert_array_equal(env.unwrapped.decode_observation(obs)["in_field"], want)
        seen[want.astype(int), np.arange(P)] += 1
        if term or trunc:
            break
    assert seen[1].sum() > 0 and seen[0].sum() > 0
    assert (seen[1] > 0).sum() >= 2, f"greedy + PD should have had two planets in the field: {seen}"


def test_hybrid_decoding_picks_the_option_and_the_torque() -> None:
    a = np.array(
        [
            [0.9, 0.1, -1.0, 0.0, 0.5, 0.5, 0.5],  # planet 0 by the PD law: torque ignored
            [-1.0, 0.2, 0.3, 0.1, 0.5, -0.5, 1.0],  # planet 2
            [0.0, 0.0, 0.0, 0.4, -0.25, 0.75, 1.0],  # direct torque
            [0.5, 0.5, 0.5, 0.5, 0.1, 0.1, 0.1],  # a tie: the first maximum (planet 0)
        ]
    )
    targets, torques = decode_hybrid(a, P)
    assert targets.tolist() == [0, 2, -1, 0]
    np.testing.assert_array_equal(torques, [[0, 0, 0], [0, 0, 0], [-0.25, 0.75, 1.0], [0, 0, 0]])
    np.testing.assert_array_equal(hybrid_action(1, P), [-1, 1, -1, -1, 0, 0, 0])
    np.testing.assert_array_equal(hybrid_action(P, P, [0.5, 2.0, -0.25]), [-1, -1, -1, 1, 0.5, 1.0, -0.25])
    with pytest.raises(ValueError, match=r"hybrid option must be in \[0, 3\]"):
        hybrid_action(4, P)
    with pytest.raises(ValueError, match="hybrid torque must be 3 finite numbers"):
        hybrid_action(P, P, [np.nan, 0.0, 0.0])


def test_hybrid_env_applies_the_chosen_option() -> None:
    env = gym.make(HYBRID, episode_steps=400)
    env.reset(seed=0)
    u = env.unwrapped
    env.step(hybrid_action(P, P, [0.5, -0.25, 0.0]))
    # Direct torque at rest: the applied wheel torque is the action x 0.01 N m (far from the momentum cap).
    np.testing.assert_allclose(u.core.f[0, L.F_U : L.F_U + 3], [0.005, -0.0025, 0.0], rtol=0, atol=1e-15)
    # The PD option: the env's law toward Mars; the torque entries do not matter.
    a1, a2 = hybrid_action(1, P), hybrid_action(1, P)
    a2[P + 1 :] = [1.0, -1.0, 1.0]
    e1, e2 = gym.make(HYBRID, episode_steps=400), gym.make(HYBRID, episode_steps=400)
    e1.reset(seed=5)
    e2.reset(seed=5)
    for _ in range(300):  # a slew and its settling (~100-200 s)
        o1, _, _, _, i1 = e1.step(a1)
        o2, _, _, _, i2 = e2.step(a2)
        np.testing.assert_array_equal(o1, o2)
    # The camera measures what it points at: Mars, once the PD law has brought it into the field.
    assert i1["target"] == i2["target"] == "mars" and i1["target_index"] == 1 and i1["measured"]


@pytest.mark.parametrize(
    ("action", "error", "text"),
    [
        (np.zeros(6, np.float32), InvalidParameterError, r"action must have shape \(7,\)"),
        (np.array([0, 0, 0, 1, np.nan, 0, 0], np.float32), NonFiniteError, "NaN or infinite"),
        ("1,0,0,0,0,0,0", InvalidParameterError, "action must be numbers of shape"),
    ],
)
def test_hybrid_bad_actions_raise_named_errors(action: object, error: type, text: str) -> None:
    env = gym.make(HYBRID, episode_steps=5)
    env.reset(seed=0)
    with pytest.raises(error, match=text):
        env.step(action)


def test_greedy_pd_is_greedy_executed_by_the_env_pd_law() -> None:
    """At a 1-s step the agent's law is the env's own (gains of the config), greedy's horizon is 180 s,
    and in torque mode it keeps a planet in the field for most steps of a slewing hour's first 15 min."""
    env = gym.make(TORQUE, episode_steps=900, noise_streams="per_step")
    law = PointingLaw(env.unwrapped.config)
    assert (law.k_a, law.k_w) == (0.02, 1.0)
    agent = make_agent("greedy-pd", env)
    assert agent.name == "greedy-pd" and agent.horizon == 180
    obs, info = env.reset(seed=1)
    measured, targets = 0, set()
    for _ in range(900):
        obs, _, term, trunc, info = env.step(agent.act(obs, info))
        measured += info["measured"]
        targets.add(info["target"])
        if term or trunc:
            break
    assert measured / 900 > 0.7
    assert len(targets - {None}) >= 2
    hybrid = gym.make(HYBRID)
    assert make_agent("greedy-pd", hybrid).encode(None, {}, 2).tolist() == hybrid_action(2, P).tolist()


def test_torque_control_config_smoke(tmp_path: Path) -> None:
    """CI smoke run of configs/torque_control.yaml: a tiny budget, evaluation against greedy + PD included."""
    from planetnav_train.cli import main

    data = yaml.safe_load((ROOT / "configs" / "torque_control.yaml").read_text())
    assert "pretrain" not in data and not data.get("features")
    data.update(n_timesteps=128, n_envs=2)
    data["hyperparams"].update(n_steps=64, batch_size=64, n_epochs=1)
    data["env"] = {**data.get("env", {}), "episode_steps": 30}
    data["eval"] = {**data["eval"], "episodes": 2}
    cfg = tmp_path / "torque_control.yaml"
    cfg.write_text(yaml.safe_dump(data))
    run_dir = tmp_path / "run"
    assert main(["train", "--config", str(cfg), "--run-dir", str(run_dir), "--no-progress"]) == 0
    result = json.loads((run_dir / "eval.json").read_text())
    assert "greedy-pd" in result["agents"]
    for name, m in result["agents"].items():
        assert m["episodes"] == 2, name
        assert m["vs_reference"]["reference"] == "greedy-pd", name
