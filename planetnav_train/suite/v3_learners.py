"""Learner rows of suite version 3: off-the-shelf PPO, an untrained network and uniform random, each with
its policy's entropy, scored against the published constants (docs/tasks_v3_normalization.json).

- **PPO**: Stable-Baselines3's ``PPO("MlpPolicy", env)`` with every default, ``env =
  make_vec_env("planetnav/<id>")`` (SB3's own helper, its default of one env), trained for ``budget``
  decisions (SB3 timesteps) from ``seed``. Nothing is tuned per task.
- **untrained**: the same network before training (SB3's initialization from the same seed).
- **uniform**: uniform random actions in the task's interface.

Each is evaluated with sampled actions on the evaluation seeds (:data:`planetnav_train.suite.v3.EVAL_SEED`..,
per-step noise streams) by :func:`planetnav_train.suite.v3.roll_out`; its entropy [nats] is the mean of
the action distribution's entropy over the observations it meets there (uniform: ``log A``; for a torque
task the Gaussian's differential entropy, SB3's own ``entropy()``). With a published normalization the
row has its blind-zero score and interval (:func:`planetnav_train.suite.v3.run_score`).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_train.suite import v3


def _policy_fn(model: Any, entropies: list[float]):
    """(decision, observations) -> sampled actions of an SB3 model, recording each batch's mean entropy."""
    import torch

    def act(d: int, obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            t, _ = model.policy.obs_to_tensor(obs)
            dist = model.policy.get_distribution(t)
            entropies.append(float(dist.entropy().mean()))
            a = dist.get_actions(deterministic=False).cpu().numpy()
        if model.action_space.shape:
            a = np.clip(a, model.action_space.low, model.action_space.high)
        return a

    return act


def _row(name: str, j: np.ndarray, entropy: float, task: str, extra: dict[str, Any]) -> dict[str, Any]:
    row = {"policy": name, "J": v3.mean_interval(j), "entropy_nats": entropy, **extra}
    try:
        norm = v3.normalization(task)
    except Exception:  # no published constants yet: the row carries J only
        row["score"] = None
    else:
        row["score"] = v3.run_score(j, norm["J_zero"]["mean"], norm["J_best"]["mean"])
    return row


def learner_rows(
    task: str,
    budget: int,
    seed: int = 0,
    episodes: int = 100,
    episode_steps: int | None = None,
    ppo_overrides: dict[str, Any] | None = None,
    target_actions: str | None = None,
) -> dict[str, Any]:
    """PPO (SB3 defaults via ``make_vec_env``), the untrained network and uniform random on v3 ``task``
    (``Cruise-Target-v3``): J on ``episodes`` evaluation seeds, entropy, score. ``episode_steps`` shortens
    the episodes and ``ppo_overrides`` changes PPO's arguments: smoke runs only (the command passes
    neither, and a row made with them is not the task's). ``target_actions``: ``relative`` to measure
    relative target actions against the task's absolute ones (same seeds, same budget)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    env_id = f"planetnav/{task}"
    over: dict[str, Any] = {"episode_steps": episode_steps} if episode_steps else {}
    if target_actions:  # the absolute-versus-relative measurement (docs/tasks_v3.md)
        over["target_actions"] = target_actions
    cfg: EnvConfig = v3.eval_config(env_id, **over)
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + episodes)
    venv = make_vec_env(env_id, seed=seed, env_kwargs=over)
    model = PPO("MlpPolicy", venv, seed=seed, verbose=0, **(ppo_overrides or {}))
    rows: dict[str, Any] = {"task": task, "target_actions": cfg.target_actions, "budget_decisions": budget,
                            "seed": seed, "episodes": episodes, "episode_steps": cfg.episode_steps,
                            "rows": []}  # fmt: skip
    ent: list[float] = []
    j = v3.roll_out(cfg, _policy_fn(model, ent), seeds).objective
    rows["rows"].append(_row("untrained network", j, float(np.mean(ent)), task, {}))
    if cfg.action_mode == "torque":
        uniform = v3.BlindTorques("uniform", np.zeros((cfg.episode_decisions, 3)), 1.0)
        h_uniform = 3 * math.log(2.0)  # differential entropy of U(-1, 1)^3
    else:
        n_a = cfg.n_targets + (1 if cfg.idle_action else 0)
        uniform = v3.BlindTargets("uniform", np.full((cfg.episode_decisions, n_a), 1.0 / n_a))
        h_uniform = math.log(n_a)
    j = v3.roll_out(cfg, uniform, seeds).objective
    rows["rows"].append(_row("uniform random", j, h_uniform, task, {}))
    t0 = time.time()
    model.learn(total_timesteps=budget)
    train_s = time.time() - t0
    ent = []
    j = v3.roll_out(cfg, _policy_fn(model, ent), seeds).objective
    rows["rows"].append(_row("SB3 PPO (defaults, make_vec_env)", j, float(np.mean(ent)), task,
                             {"train_seconds": train_s}))  # fmt: skip
    venv.close()
    rows["provenance"] = v3.provenance()
    return rows


__all__ = ["learner_rows"]
