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


def test_image_log_rows_follow_the_relative_order() -> None:
    """On a task with the image log (RandomCruise-Target-v2) both of its per-planet rows are reordered with
    the target blocks, so the per-target scorer reads each target's own success rate."""
    from planetnav_train.policies import per_target_columns

    ext, lay = _extractor("planetnav/RandomCruise-Target-v2")
    T = lay.n_targets
    obs = np.arange(lay.size, dtype=np.float32)
    obs[lay.target_start : lay.elapsed_index] = 0.0
    obs[lay.target_start + 2] = 1.0  # current target 2
    out = ext(torch.as_tensor(obs[None]))[0].numpy()
    for k in range(T):
        src = relative_to_absolute(k, 2, T)
        for row in (0, 1):
            assert out[lay.image_log_start + row * T + k] == obs[lay.image_log_start + row * T + src]
    own, _ = per_target_columns(lay, lay.size)
    for k in range(T):
        assert {lay.image_log_start + k, lay.image_log_start + T + k} <= set(own[k])


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
    # The env's relative targets over the v0 physics decode actions as v1 does: accepted.
    v0 = EnvConfig.from_dict({**id_options("planetnav/RandomCruise-Target-v0"), "target_actions": "relative"})
    assert extractor_kwargs("relative_order", v0)["features_extractor_kwargs"]["n_planets"] == 3
    with pytest.raises(ConfigError, match="4 appended columns"):
        relative_order_index(L.ObservationLayout.for_config(cruise), tail=4)
    with pytest.raises(ConfigError, match="shape"):
        _extractor("planetnav/RandomCruise-Target-v1", tail=-2)


@pytest.mark.parametrize(
    ("extra", "policy"),
    [({}, "ActorCriticPolicy"), ({"action_head": "per_target", "contrast": True}, "PerTargetPolicy")],
)
def test_ppo_with_the_extractor_trains_saves_and_evaluates(tmp_path: Path, extra: dict, policy: str) -> None:
    """The config keys reach SB3 (the saved policy holds the extractor, and the per-target head where
    named), and the saved model reloads and evaluates through train.py like any other."""
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
            "policy_kwargs": {"features_extractor": "relative_order", **extra},
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
    assert type(model.policy).__name__ == policy
    assert yaml.safe_load((run / "config.yaml").read_text())["hyperparams"]["policy_kwargs"] == {
        "features_extractor": "relative_order",
        **extra,
    }
    data = json.loads((run / "eval.json").read_text())
    assert all(np.isfinite(m["mean_pos_err_km"]) for m in data["agents"].values())


# ------------------------------------------------------------------------------------------------
# The per-target action head (policy_kwargs.action_head: per_target)
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("env_id", ["planetnav/RandomCruise-Target-v1", "planetnav/MarsApproach-Tasking-v1"])
def test_per_target_columns_split_every_column_once(env_id: str) -> None:
    """Every observation column is read either as one target's own value or as a shared one, never both
    and never twice; target k's own columns are its block, its one-hot and since-measured entries and its
    value of each appended chunk."""
    from planetnav_train.policies import per_target_columns

    lay = L.ObservationLayout.for_config(EnvConfig.from_dict(id_options(env_id)))
    T, F = lay.n_targets, L.TARGET_FEATURES
    width = lay.size + 2 * T
    own, shared = per_target_columns(lay, width)
    assert own.shape[0] == T
    assert sorted([*own.reshape(-1), *shared]) == list(range(width))
    for k in range(T):
        block = set(range(lay.planets_start + F * k, lay.planets_start + F * (k + 1)))
        extra = {lay.target_start + k, lay.since_measured_start + k, lay.size + k, lay.size + T + k}
        assert set(own[k]) == block | extra


def _per_target_policy(
    env_id: str = "planetnav/RandomCruise-Target-v1", contrast: bool = False, **extra: float
):  # fmt: skip
    from stable_baselines3 import PPO

    from planetnav_train.policies import PerTargetPolicy

    cfg = EnvConfig.from_dict(id_options(env_id))
    env = gym.make(env_id)
    pk = {**extractor_kwargs("relative_order", cfg), "scorer_arch": [16], "contrast": contrast, **extra}
    return PPO(PerTargetPolicy, env, n_steps=16, batch_size=16, device="cpu", policy_kwargs=pk), env


def test_keep_bias_starts_keep_ahead_by_that_logit_and_is_learned(tmp_path: Path) -> None:
    """``keep_bias`` b: at initialization (output layer near zero) P(keep) / P(slew k) = e^b for every
    observation; the offset is a parameter (it trains and saves); at 0 the head has no such parameter, so
    policies saved before it load."""
    from stable_baselines3 import PPO

    model, env = _per_target_policy(contrast=True, keep_bias=2.0)
    obs = torch.as_tensor(np.stack([env.reset(seed=s)[0] for s in range(3)]))
    probs = model.policy.get_distribution(obs).distribution.probs
    ratio = probs[:, 0] / probs[:, 1]
    torch.testing.assert_close(ratio, torch.full((3,), float(np.exp(2.0))), rtol=0.05, atol=0)
    head = model.policy.action_net
    assert any(p is head.slot_bias for p in model.policy.parameters())
    model.save(tmp_path / "m.zip")
    assert PPO.load(tmp_path / "m.zip", device="cpu").policy.action_net.slot_bias[0].item() == 2.0
    plain, _ = _per_target_policy(contrast=True)
    assert plain.policy.action_net.slot_bias is None
    assert "action_net.slot_bias" not in plain.policy.state_dict()


def test_dqn_per_target_q_network_scores_each_target_and_reloads(tmp_path: Path) -> None:
    """The DQN head: Q(s, k) moves only with target k's own columns (and the shared ones), the target
    network has the same form, and the saved model reloads with the same Q-values."""
    from stable_baselines3 import DQN

    from planetnav_train.policies import PerTargetQPolicy, PerTargetScorer, per_target_columns

    env_id = "planetnav/RandomCruise-Target-v1"
    cfg = EnvConfig.from_dict(id_options(env_id))
    env = gym.make(env_id)
    pk = {**extractor_kwargs("relative_order", cfg), "scorer_arch": [16]}
    model = DQN(PerTargetQPolicy, env, learning_starts=0, device="cpu", policy_kwargs=pk)
    assert isinstance(model.q_net.q_net, PerTargetScorer)
    assert isinstance(model.q_net_target.q_net, PerTargetScorer)
    lay = L.ObservationLayout.for_config(cfg)
    own, _ = per_target_columns(lay, lay.size)
    x = torch.randn(4, lay.size)
    head = model.q_net.q_net
    base = head(x)
    y = x.clone()
    y[:, own[2]] += 1.0
    assert ((head(y) - base).abs().amax(dim=0) > 1e-6).tolist() == [False, False, True]
    model.save(tmp_path / "q.zip")
    again = DQN.load(tmp_path / "q.zip", device="cpu")
    assert type(again.policy).__name__ == "PerTargetQPolicy" and again.policy.scorer_arch == [16]
    obs = torch.as_tensor(env.reset(seed=0)[0][None])
    torch.testing.assert_close(model.q_net(obs), again.q_net(obs))


def test_per_target_logit_k_reads_only_target_k_and_the_shared_columns() -> None:
    """Perturbing one target's own columns moves that target's logit and no other; perturbing a shared
    column (the spacecraft's) may move every logit."""
    from planetnav_train.policies import per_target_columns

    model, env = _per_target_policy()
    head = model.policy.action_net
    for p in head.parameters():  # away from the near-zero output init, so changes show
        torch.nn.init.normal_(p, std=0.5)
    lay = L.ObservationLayout.for_config(env.unwrapped.config)
    own, shared = per_target_columns(lay, lay.size)
    x = torch.randn(4, lay.size)
    base = head(x)
    for k in range(lay.n_targets):
        y = x.clone()
        y[:, own[k]] += 1.0
        moved = (head(y) - base).abs().amax(dim=0) > 1e-6
        assert moved.tolist() == [j == k for j in range(lay.n_targets)]
    y = x.clone()
    y[:, shared[0]] += 1.0
    assert ((head(y) - base).abs() > 1e-6).any()


def test_contrast_reads_each_feature_against_the_other_targets() -> None:
    """With ``contrast`` every target also reads its features standardized across the targets: moving one
    target's feature moves every logit, and shifting a feature by the same amount for every target leaves
    the contrast (not the raw value) unchanged, checked on the head's input."""
    from planetnav_train.policies import per_target_columns

    model, env = _per_target_policy(contrast=True)
    head = model.policy.action_net
    for p in head.parameters():
        torch.nn.init.normal_(p, std=0.5)
    lay = L.ObservationLayout.for_config(env.unwrapped.config)
    own, _ = per_target_columns(lay, lay.size)
    x = torch.randn(4, lay.size)
    y = x.clone()
    y[:, own[1, 0]] += 1.0
    assert ((head(y) - head(x)).abs().amin(dim=0) > 1e-6).all()
    seen = []
    head.hidden.register_forward_hook(lambda m, inp, out: seen.append(inp[0]))
    z = x.clone()
    z[:, own[:, 0]] += 0.7  # the same column of every target
    head(x), head(z)
    m = own.shape[1]
    torch.testing.assert_close(seen[0][:, :, m : 2 * m], seen[1][:, :, m : 2 * m])
    assert not torch.allclose(seen[0][:, :, :m], seen[1][:, :, :m])


def test_per_target_policy_saves_and_reloads_its_head(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    model, env = _per_target_policy(contrast=True)
    model.save(tmp_path / "m.zip")
    again = PPO.load(tmp_path / "m.zip", device="cpu")
    assert type(again.policy).__name__ == "PerTargetPolicy" and again.policy.scorer_arch == [16]
    assert again.policy.contrast and again.policy.action_net.contrast
    obs, _ = env.reset(seed=1)
    t = torch.as_tensor(obs[None])
    a = model.policy.get_distribution(t).distribution.probs
    b = again.policy.get_distribution(t).distribution.probs
    torch.testing.assert_close(a, b)


def test_per_target_head_named_errors() -> None:
    from planetnav_train.algorithms import algo_kwargs, policy_class
    from planetnav_train.config import TrainConfig

    def tc(pk: dict, algo: str = "ppo") -> TrainConfig:
        env_id = "planetnav/RandomCruise-Target-v1"
        return TrainConfig(algo=algo, env_id=env_id, hyperparams={"policy_kwargs": pk})

    assert policy_class(tc({})) == "MlpPolicy"
    with pytest.raises(ConfigError, match="'pointer'"):
        policy_class(tc({"action_head": "pointer", "features_extractor": "relative_order"}))
    with pytest.raises(ConfigError, match="features_extractor: relative_order"):
        policy_class(tc({"action_head": "per_target"}))
    head = {"action_head": "per_target", "features_extractor": "relative_order"}
    with pytest.raises(ConfigError, match="not 'recurrent_ppo'"):
        policy_class(tc(head, "recurrent_ppo"))
    assert policy_class(tc(head, "dqn")).__name__ == "PerTargetQPolicy"
    with pytest.raises(ConfigError, match="keep_bias is an initial logit offset of ppo"):
        policy_class(tc({**head, "keep_bias": 2.0}, "dqn"))
    with pytest.raises(ConfigError, match="keep_bias needs"):
        algo_kwargs(tc({"keep_bias": 2.0}))
    with pytest.raises(ConfigError, match="scorer_arch needs"):
        algo_kwargs(tc({"scorer_arch": [8]}))
    with pytest.raises(ConfigError, match="contrast needs"):
        algo_kwargs(tc({"contrast": True}))
    # A continuous action space has no target per action.
    from planetnav_train.policies import PerTargetPolicy

    cfg = EnvConfig.from_dict(id_options("planetnav/RandomCruise-Target-v1"))
    box = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    with pytest.raises(ConfigError, match="needs discrete target actions"):
        PerTargetPolicy(
            gym.spaces.Box(-np.inf, np.inf, (50,), np.float32), box, lambda _: 3e-4,
            **extractor_kwargs("relative_order", cfg),
        )  # fmt: skip
