"""Policy-only exports (planetnav_train/export.py, planetnav_train.policy_only; docs/suite.md "Shipped
baselines"): per algorithm, a model trained a few dozen steps on a 10-step episode is exported, and the
export must act exactly as the full model on real observations of the env (a recurrent policy: over a
sequence with its LSTM state and episode starts), with the same acting outputs (logits, Q-values, Gaussian
means), at a fraction of the full zip's size; a policy built from the same file without its weights must
not act the same (the comparison can fail)."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planetnav_train import policy_only as po
from planetnav_train.export import export_policy

pytest.importorskip("sb3_contrib")

#: (algorithm, task): the discrete algorithms on Cruise-Target-v0, the continuous ones on Cruise-Torque-v0
#: (PPO on both: a categorical and a Gaussian policy).
CASES = [
    ("ppo", "Cruise-Target-v0"),
    ("a2c", "Cruise-Target-v0"),
    ("dqn", "Cruise-Target-v0"),
    ("recurrent_ppo", "Cruise-Target-v0"),
    ("maskable_ppo", "Cruise-Target-v0"),
    ("ppo", "Cruise-Torque-v0"),
    ("sac", "Cruise-Torque-v0"),
    ("td3", "Cruise-Torque-v0"),
    ("tqc", "Cruise-Torque-v0"),
]
STEPS = 10  # episode length: the 30 observations below span three episodes


def _env(task: str) -> Any:
    from planetnav_env.envs.env import PlanetNavEnv

    return PlanetNavEnv(f"planetnav/{task}", episode_steps=STEPS)


def _observations(env: Any, n: int = 3 * STEPS) -> tuple[np.ndarray, np.ndarray]:
    """``n`` real observations of ``env`` under seeded random actions, and whether each starts an episode."""
    env.action_space.seed(7)
    obs, _ = env.reset(seed=11)
    rows, starts, start = [], [], True
    for _ in range(n):
        rows.append(obs)
        starts.append(start)
        obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
        start = terminated or truncated
        if start:
            obs, _ = env.reset()
    assert sum(starts) >= 3  # the sequence crosses episode starts
    return np.stack(rows), np.array(starts)


def _train(algo: str, env: Any, path: Path) -> Path:
    """A model of ``algo`` after a few dozen steps (so its optimizers have state, as after training)."""
    from planetnav_train.sb3 import algorithm_class

    kw: dict[str, Any] = {"seed": 0, "device": "cpu"}
    if algo in ("ppo", "recurrent_ppo", "maskable_ppo"):
        kw.update(n_steps=16, batch_size=16, n_epochs=1)
    elif algo == "a2c":
        kw.update(n_steps=8)
    else:
        kw.update(learning_starts=8, buffer_size=100, batch_size=8)
    policy = "MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy"
    model = algorithm_class(algo)(policy, env, **kw)
    model.learn(32)
    model.save(path)
    return path


@pytest.fixture(scope="module", params=CASES, ids=[f"{a}-{t}" for a, t in CASES])
def exported(request, tmp_path_factory) -> tuple[str, Any, Any, Path, Path, Any]:
    """(algorithm, full model, export, full zip, export file, env) of one algorithm."""
    from planetnav_train.sb3 import load_model

    algo, task = request.param
    env = _env(task)
    tmp = tmp_path_factory.mktemp(algo)
    full = _train(algo, env, tmp / "model.zip")
    out = export_policy(full, tmp / "model.policy.zip", algo)
    return algo, load_model(full, algo), po.load_policy_only(out), full, out, env


def _acting_outputs(policy: Any, obs: np.ndarray) -> np.ndarray:
    """What the deterministic action is computed from: logits (categorical), Gaussian means, Q-values, or
    the actor's (squashed) action."""
    import torch

    with torch.no_grad():
        x = policy.obs_to_tensor(obs)[0]
        if hasattr(policy, "q_net"):
            return policy.q_net(x).numpy()
        if hasattr(policy, "actor"):  # SAC, TD3, TQC: the actor's action before rescaling to the bounds
            return policy._predict(x, deterministic=True).numpy()
        dist = policy.get_distribution(x).distribution
        return (dist.logits if hasattr(dist, "logits") else dist.mean).numpy()


def test_export_acts_as_the_full_model(exported) -> None:
    algo, full, export, _, _, env = exported
    obs, starts = _observations(env)
    assert export.algorithm == algo and export.observation_space == full.observation_space
    assert export.action_space == full.action_space
    if hasattr(full.policy, "lstm_actor"):
        # One row through the sequence, each model carrying its own LSTM state, episode starts as played.
        s_full = s_exp = None
        for o, start in zip(obs, starts, strict=True):
            a, s_full = full.predict(
                o[None], state=s_full, episode_start=np.array([start]), deterministic=True
            )
            b, s_exp = export.predict(
                o[None], state=s_exp, episode_start=np.array([start]), deterministic=True
            )
            np.testing.assert_array_equal(a, b)
            for x, y in zip(s_full, s_exp, strict=True):
                np.testing.assert_array_equal(x, y)
        assert np.abs(s_full[0]).max() > 0  # the state carried something
    else:
        a, _ = full.predict(obs, deterministic=True)
        b, _ = export.predict(obs, deterministic=True)
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(_acting_outputs(full.policy, obs), _acting_outputs(export.policy, obs))
        for o in obs[:3]:  # single observations, as SB3Agent passes them
            assert np.array_equal(
                full.predict(o, deterministic=True)[0], export.predict(o, deterministic=True)[0]
            )


def test_export_is_small_and_holds_only_acting_float32_tensors(exported) -> None:
    _, full, _, full_zip, out, _ = exported
    assert out.stat().st_size * 4 < full_zip.stat().st_size, (out.stat().st_size, full_zip.stat().st_size)
    meta, arrays = po.read_archive(out)
    params = {k[len("params/") :]: v for k, v in arrays.items() if k.startswith("params/")}
    assert set(params) == set(meta["parameters"]) and meta["dropped_parameters"] > 0
    assert all(v.dtype == np.float32 for v in params.values())
    kept, _ = po.split_acting(full.policy, list(full.policy.state_dict()))
    assert sorted(params) == sorted(kept)
    for name in ("critic", "value_net", "q_net_target", "lstm_critic", "actor_target"):
        assert not any(k == name or k.startswith(name + ".") for k in params)
    state = full.policy.state_dict()
    for k, v in params.items():  # the weights as trained, bit for bit
        np.testing.assert_array_equal(v, state[k].numpy())
    with zipfile.ZipFile(out) as zf:  # nothing pickled, no optimizer state
        assert all(n == po.META_NAME or n.endswith(".npy") for n in zf.namelist())
    assert meta["source"]["bytes"] == full_zip.stat().st_size


def test_the_comparison_fails_without_the_weights(exported) -> None:
    """The same policy class and arguments with freshly initialized weights acts otherwise on these
    observations: equal actions above come from the exported weights, not from the architecture."""
    import torch

    _, full, _, _, out, env = exported
    meta, _ = po.read_archive(out)
    torch.manual_seed(123)
    fresh = po.PolicyOnlyModel(
        po.decode_value({"__class__": meta["policy_class"]})(
            full.observation_space, full.action_space, lambda _: 0.0, **po.decode_value(meta["policy_kwargs"])
        ),
        meta,
    )
    obs, _ = _observations(env)
    if hasattr(full.policy, "lstm_actor"):
        _, s = full.predict(obs, episode_start=np.ones(len(obs), dtype=bool), deterministic=True)
        _, t = fresh.predict(obs, episode_start=np.ones(len(obs), dtype=bool), deterministic=True)
        assert not np.array_equal(s[0], t[0])
    else:
        assert not np.array_equal(_acting_outputs(full.policy, obs), _acting_outputs(fresh.policy, obs))


def test_export_bytes_are_reproducible(exported, tmp_path) -> None:
    algo, _, _, full_zip, out, _ = exported
    again = export_policy(full_zip, tmp_path / "again.zip", algo)
    assert again.read_bytes() == out.read_bytes()


def test_maskable_export_keeps_the_mask(tmp_path) -> None:
    """The export records the training env's layout and masks from the observation as the model does: with
    the chosen target made unobservable, both choose the same other target."""
    from planetnav_env.core.layout import TARGET_FEATURES, TF_OBSERVABLE
    from planetnav_train.masking import layout_of
    from planetnav_train.sb3 import load_model

    env = _env("Cruise-Target-v0")
    full_zip = _train("maskable_ppo", env, tmp_path / "m.zip")
    export = po.load_policy_only(export_policy(full_zip, tmp_path / "m.policy.zip", "maskable_ppo"))
    full = load_model(full_zip, "maskable_ppo")
    assert export.observation_layout == json.loads(json.dumps(full.observation_layout))
    layout = layout_of(env)
    obs, _ = _observations(env)
    chosen, _ = full.predict(obs, deterministic=True)
    blocked = obs.copy()
    cols = layout.planets_start + TARGET_FEATURES * chosen + TF_OBSERVABLE
    blocked[np.arange(len(obs)), cols] = 0.0
    a, _ = full.predict(blocked, deterministic=True)
    b, _ = export.predict(blocked, deterministic=True)
    np.testing.assert_array_equal(a, b)
    assert not np.any(a == chosen)


def test_bad_input_is_named(tmp_path) -> None:
    not_export = tmp_path / "x.zip"
    with zipfile.ZipFile(not_export, "w") as zf:
        zf.writestr("data", "{}")
    assert not po.is_policy_only(not_export)
    with pytest.raises(ValueError, match=r"x\.zip: not a policy-only export"):
        po.load_policy_only(not_export)
    with pytest.raises(ValueError, match=r"class 'os:system': expected 'module:qualname' under one of"):
        po.resolve_class("os:system")
    with pytest.raises(ValueError, match=r"policy_kwargs\.f = <function"):
        po.encode_value({"f": lambda: 0}, "policy_kwargs")
