"""Batched evaluation (``planetnav_train.evaluate``): an SB3 model played on its seeds as rows of the
native vector env gives the same per-episode results as one episode at a time.

Exact equality (``==`` on every metric but the wall time and the path's own flags): row ``i`` of the
vector env is the single env seeded alike, bit for bit, and the recipe's layers are the same code on both
paths. A discrete policy predicts all rows in one call (its batched forward pass rounds its float32
products differently from the 1-row one in the last bits, which an argmax does not see); a continuous one
predicts row by row by default (``exact_actions``). With ``exact_actions=False`` a continuous policy's
batched actions differ in those last bits: its metrics are compared to a relative 1e-6 (measured: about
1e-9 on these 30-step episodes; full episodes amplify it, ``benchmarks/bench_eval.py``) and the counts
(measured steps, slews, divergence) exactly.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.evaluate import batch_reason, evaluate_agent
from planetnav_train.vec_training import NavTrainingVecEnv

SEED = 10_000
EPISODES = 3
#: The wall time differs between the paths by design; the flags say which path ran.
TIMING_KEYS = {"seconds_per_episode", "batched", "batch_fallback", "exact_actions"}


def _cfg(env_id: str, steps: int, env: dict[str, Any] | None = None) -> EnvConfig:
    # per_step: the suite's noise streams (each row's noise depends only on its seed and step); ``env``:
    # the case's env options (its decision interface).
    return EnvConfig.from_dict(ENV_IDS[env_id], episode_steps=steps, noise_streams="per_step", **(env or {}))


def _save_model(tmp_path: Path, algo: str, cfg: EnvConfig, options: dict[str, Any]) -> Path:
    """A randomly initialised policy (no training: equality does not depend on what it learned) saved as
    ``train.py`` saves a run: ``model.zip`` with a ``config.yaml`` naming its recipe options (``env``:
    the env options, in ``cfg`` already)."""
    from planetnav_train.sb3 import algorithm_class

    venv = NavTrainingVecEnv(2, cfg, seed=0, **{k: v for k, v in options.items() if k != "env"})
    kwargs: dict[str, Any] = {"n_steps": 8, "batch_size": 8, "policy_kwargs": {"net_arch": [16]}}
    if algo in ("sac", "dqn"):
        kwargs = {"buffer_size": 100, "policy_kwargs": {"net_arch": [16]}}
    if algo == "recurrent_ppo":
        kwargs["policy_kwargs"] = {"net_arch": [16], "lstm_hidden_size": 8}
    policy = "MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy"
    model = algorithm_class(algo)(policy, venv, seed=0, device="cpu", **kwargs)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": algo, **options}))
    return run


#: Continuous actions: the batched forward pass's float32 rounding (module docstring).
RTOL = 1e-6


def _assert_same(single: Any, batched: Any, exact: bool) -> None:
    assert single.metrics["batched"] is False and batched.metrics["batched"] is True
    a = {k: v for k, v in single.metrics.items() if k not in TIMING_KEYS}
    b = {k: v for k, v in batched.metrics.items() if k not in TIMING_KEYS}
    assert a.keys() == b.keys()
    assert single.seeds == batched.seeds and single.name == batched.name
    if exact:
        assert a == b
        np.testing.assert_array_equal(single.pos_err_curve, batched.pos_err_curve)
        np.testing.assert_array_equal(single.pos_sigma_curve, batched.pos_sigma_curve)
        return
    for k, v in a.items():
        if isinstance(v, (str, bool, int)) and not isinstance(v, float):
            assert v == b[k], k  # names, counts, divergence
        else:
            np.testing.assert_allclose(b[k], v, rtol=RTOL, err_msg=k)
    np.testing.assert_allclose(batched.pos_err_curve, single.pos_err_curve, rtol=RTOL)
    np.testing.assert_allclose(batched.pos_sigma_curve, single.pos_sigma_curve, rtol=RTOL)


CASES = [
    # Discrete target choice with the recipe's feature on the rows, in the env's hold, relative targets and
    # since_measured.
    (
        "planetnav/Cruise-Target-v0",
        "ppo",
        {
            "features": ["gain"],
            "env": {"decision_steps": 3, "target_actions": "relative", "observe_since_measured": True},
        },
        40,
    ),
    # Continuous wheel torques (Box actions): clipped (PPO) and squashed (SAC) actions.
    ("planetnav/Cruise-Torque-v0", "ppo", {}, 30),
    ("planetnav/Cruise-Torque-v0", "sac", {}, 30),
    # An operations scenario: the objective J is info["objective"] at each row's end.
    ("planetnav/ThrustArc-TCM-v0", "ppo", {}, 30),
    # A recurrent policy: one LSTM state per row.
    ("planetnav/Cruise-Target-v0", "recurrent_ppo", {"env": {"decision_steps": 2}}, 30),
    # MaskablePPO: the mask is read from each row's observation in predict.
    ("planetnav/Cruise-Target-v0", "maskable_ppo", {}, 30),
]


@pytest.mark.parametrize(("env_id", "algo", "options", "steps"), CASES)
def test_batched_equals_single_env_evaluation(
    tmp_path: Path, env_id: str, algo: str, options: dict[str, Any], steps: int
) -> None:
    cfg = _cfg(env_id, steps, options.get("env"))
    run = _save_model(tmp_path, algo, cfg, options)
    single = evaluate_agent(str(run), cfg, EPISODES, SEED, progress=False, batched=False)
    # batch_rows=2: the 3 seeds as a batch of 2 rows and one of 1 (the chunking joins them in seed order).
    batched = evaluate_agent(str(run), cfg, EPISODES, SEED, progress=False, batch_rows=2)
    _assert_same(single, batched, exact=True)
    assert len(set(single.metrics["per_episode_objective"])) == EPISODES  # the seeds differ


@pytest.mark.parametrize(("algo", "mode"), [("ppo", ""), ("ppo", "@sampled"), ("sac", "@sampled")])
def test_batched_continuous_predict_equals_to_float_rounding(tmp_path: Path, algo: str, mode: str) -> None:
    """``exact_actions=False``: one forward pass for all rows, argmax or sampled (each row's draw from its
    own generator state on its slice of the batched distribution, clipped or squashed)."""
    cfg = _cfg("planetnav/Cruise-Torque-v0", 30)
    spec = f"{_save_model(tmp_path, algo, cfg, {})}{mode}"
    single = evaluate_agent(spec, cfg, EPISODES, SEED, progress=False, batched=False)
    batched = evaluate_agent(spec, cfg, EPISODES, SEED, progress=False, exact_actions=False)
    assert batched.metrics["exact_actions"] is False
    _assert_same(single, batched, exact=False)


SAMPLED_CASES = [
    # Discrete: one forward pass for the rows, each row's draw from its own generator state.
    CASES[0],
    # Continuous: each row's forward pass and draw is the single path's call (clipped and squashed).
    ("planetnav/Cruise-Torque-v0", "ppo", {}, 30),
    ("planetnav/Cruise-Torque-v0", "sac", {}, 30),
]


@pytest.mark.parametrize(("env_id", "algo", "options", "steps"), SAMPLED_CASES)
def test_batched_sampled_actions_equal_single_env_evaluation(
    tmp_path: Path, env_id: str, algo: str, options: dict[str, Any], steps: int
) -> None:
    """``PATH@sampled``: each row draws from its own copy of the generator state the single path seeds per
    episode, so the episodes are the single path's, and the global generator is left as it leaves it
    (a learning curve scored during training leaves the trainer's draws unchanged)."""
    import torch

    cfg = _cfg(env_id, steps, options.get("env"))
    run = _save_model(tmp_path, algo, cfg, options)
    spec = f"{run}@sampled"
    torch.manual_seed(123)
    single = evaluate_agent(spec, cfg, EPISODES, SEED, progress=False, batched=False)
    after_single = torch.get_rng_state()
    torch.manual_seed(456)  # another state before: the batched path must not depend on it
    batched = evaluate_agent(spec, cfg, EPISODES, SEED, progress=False, batch_rows=2)
    _assert_same(single, batched, exact=True)
    assert torch.equal(torch.get_rng_state(), after_single)
    argmax = evaluate_agent(str(run), cfg, EPISODES, SEED, progress=False)
    assert argmax.metrics["per_episode_objective"] != batched.metrics["per_episode_objective"]  # it sampled


def test_rule_agents_and_recurrent_sampled_models_fall_back(tmp_path: Path) -> None:
    cfg = _cfg("planetnav/Cruise-Target-v0", 20)
    env = PlanetNavEnv(cfg)
    assert "no batched action" in str(batch_reason(make_agent("greedy", env)))
    run = _save_model(tmp_path, "ppo", cfg, {})
    assert batch_reason(make_agent(str(run), env)) is None
    assert batch_reason(make_agent(f"{run}@sampled", env)) is None
    for algo in ("recurrent_ppo", "dqn"):  # the LSTM state; DQN's epsilon-greedy draws from numpy
        folder = tmp_path / algo
        folder.mkdir()
        other = _save_model(folder, algo, cfg, {})
        assert "drawn one episode at a time" in str(batch_reason(make_agent(f"{other}@sampled", env)))
        assert batch_reason(make_agent(str(other), env)) is None
    res = evaluate_agent("greedy", cfg, 2, SEED, progress=False)
    assert res.metrics["batched"] is False and "batch_fallback" not in res.metrics


def test_bad_batch_rows_is_refused(tmp_path: Path) -> None:
    cfg = _cfg("planetnav/Cruise-Target-v0", 20)
    with pytest.raises(ValueError, match="batch_rows must be a positive integer, got 0"):
        evaluate_agent("random", cfg, 1, SEED, progress=False, batch_rows=0)
