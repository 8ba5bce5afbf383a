"""The relative-order features extractor (planetnav_train.policies): block k of its output is the target that
relative action k selects, checked against the environment's own action decoding; named errors; a PPO run
with it trains, saves, reloads and evaluates through the config key."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import relative_to_absolute
from planetnav_env.envs.registration import id_options
from planetnav_env.errors import ConfigError
from planetnav_train.cli import main
from planetnav_train.policies import extractor_kwargs, relative_order_index

torch = pytest.importorskip("torch")


def _extractor(env_id: str, tail: int = 0):
    cfg = EnvConfig.from_dict(id_options(env_id))
    kw = extractor_kwargs("relative_order", cfg)
    lay = L.ObservationLayout.for_config(cfg)
    space = gym.spaces.Box(-np.inf, np.inf, (lay.size + tail,), np.float32)
    return kw["features_extractor_class"](space, **kw["features_extractor_kwargs"]), lay


@pytest.mark.parametrize("env_id", ["planetnav/RandomCruise-Target-v1", "planetnav/MarsApproach-Tasking-v1"])
def test_block_k_is_the_target_that_action_k_selects(env_id: str) -> None:
    """On real observations with every target current in turn (planets and pulsars), the extractor's
    per-target block k, one-hot k and since-measured k are those of the target that the environment's
    relative-action decoding maps action k to; the spacecraft block and elapsed time are untouched."""
    ext, lay = _extractor(env_id)
    T, F = lay.n_targets, L.TARGET_FEATURES
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    seen = set()
    for step in range(3 * T):
        obs, *_ = env.step(1 if step % 3 == 0 else 0)  # move one target on, then dwell
        current = int(np.argmax(obs[lay.target_start : lay.elapsed_index]))
        seen.add(current)
        out = ext(torch.as_tensor(obs[None], dtype=torch.float32))[0].numpy()
        for k in range(T):
            src = relative_to_absolute(k, current, T)
            a, b = lay.planets_start + F * k, lay.planets_start + F * (k + 1)
            np.testing.assert_array_equal(
                out[a:b], obs[lay.planets_start + F * src : lay.planets_start + F * (src + 1)]
            )
            assert out[lay.target_start + k] == obs[lay.target_start + src]
            assert out[lay.since_measured_start + k] == obs[lay.since_measured_start + src]
        assert out[lay.target_start] == 1.0  # the current target is block 0
        np.testing.assert_array_equal(out[: lay.planets_start], obs[: lay.planets_start])
        assert out[lay.elapsed_index] == obs[lay.elapsed_index]
    assert seen == set(range(T))  # every target was current at least once


def test_index_rows_are_permutations_and_row_zero_is_the_identity() -> None:
    lay = L.ObservationLayout(3, 2, None, False, True)
    idx = relative_order_index(lay, tail=5)
    assert idx.shape == (5, lay.size + 5)
    np.testing.assert_array_equal(idx[0], np.arange(lay.size + 5))
    for row in idx:
        assert sorted(row) == list(range(lay.size + 5))
    # an appended per-target feature (one value per target) follows its target
    assert list(idx[2, lay.size :]) == [lay.size + (2 + k) % 5 for k in range(5)]


def test_named_errors() -> None:
    cruise = EnvConfig.from_dict(id_options("planetnav/RandomCruise-Target-v1"))
    with pytest.raises(ConfigError, match="'stack'"):
        extractor_kwargs("stack", cruise)
    with pytest.raises(ConfigError, match="target_actions='absolute'"):
        extractor_kwargs(
            "relative_order", EnvConfig.from_dict(id_options("planetnav/RandomCruise-Target-v0"))
        )
    with pytest.raises(ConfigError, match="4 appended columns"):
        relative_order_index(L.ObservationLayout.for_config(cruise), tail=4)
    with pytest.raises(ConfigError, match="shape"):
        _extractor("planetnav/RandomCruise-Target-v1", tail=-2)


def test_ppo_with_the_extractor_trains_saves_and_evaluates(tmp_path: Path) -> None:
    """The config key reaches SB3 (the saved policy holds the extractor), and the saved model reloads and
    evaluates through train.py like any other."""
    cfg = {
        "name": "rorder",
        "algo": "ppo",
        "env_id": "planetnav/RandomCruise-Target-v1",
        "n_envs": 2,
        "n_timesteps": 64,
        "env": {"episode_steps": 40},
        "hyperparams": {
            "n_steps": 16,
            "batch_size": 16,
            "policy_kwargs": {"features_extractor": "relative_order"},
        },
        "eval": {"episodes": 1, "agents": []},
    }
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    run = tmp_path / "run"
    assert main(["train", "--config", str(path), "--run-dir", str(run), "--no-progress"]) == 0
    from stable_baselines3 import PPO

    model = PPO.load(run / "model.zip", device="cpu")
    assert type(model.policy.features_extractor).__name__ == "RelativeTargetOrder"
    assert yaml.safe_load((run / "config.yaml").read_text())["hyperparams"]["policy_kwargs"] == {
        "features_extractor": "relative_order"
    }
    data = json.loads((run / "eval.json").read_text())
    assert all(np.isfinite(m["mean_pos_err_km"]) for m in data["agents"].values())
