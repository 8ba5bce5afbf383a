"""The training environments: :func:`make_training_env` builds the VecEnv a configuration trains on (the
native vector env with every option of the recipe on arrays; ``vec_env: dummy`` runs the same options on
single environments in SB3's ``DummyVecEnv``, for comparison)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planetnav_train.config import TrainConfig


def make_training_env(tc: TrainConfig, monitor_dir: Path | None) -> Any:
    """The training VecEnv: ``n_envs`` rows of the native vector env (one compiled step for all rows)
    under SB3's ``VecMonitor``, with the recipe's options on arrays
    (:class:`planetnav_train.vec_training.NavTrainingVecEnv`): the pointing shaping and bonus and the
    features (``gain``, ``pd_torque``), in every action mode. The decision interface (the hold, relative
    targets, ``since_measured``) is the env's, in ``tc.env_config()``.

    ``vec_env: dummy`` builds ``n_envs`` single environments, each running the same option layers with one
    row (:func:`planetnav_train.batch_wrappers.single_training_env`), in SB3's ``DummyVecEnv``: the same
    MDP (``tests/train/test_vec_training.py``), slower; kept to compare the two
    (``benchmarks/bench_train.py``)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_train.batch_wrappers import single_training_env
    from planetnav_train.vec_training import NavTrainingVecEnv

    env_cfg = tc.env_config()
    options = {
        "features": tuple(tc.features),
        "pointing": tc.shaping.get("pointing"),
        "gamma": float(tc.hyperparams.get("gamma", 0.99)),  # the shaping's discount is the algorithm's
        "pointing_bonus": tc.shaping.get("pointing_bonus"),  # per-step, not potential-based
    }
    if tc.vec_env == "native":
        if monitor_dir is not None:
            monitor_dir.mkdir(parents=True, exist_ok=True)
        venv = NavTrainingVecEnv(tc.n_envs, env_cfg, seed=tc.seed, **options)
        return VecMonitor(venv, filename=str(monitor_dir / "vec") if monitor_dir is not None else None)
    return make_vec_env(
        lambda: single_training_env(PlanetNavEnv(env_cfg), **options),
        n_envs=tc.n_envs,
        seed=tc.seed,
        monitor_dir=str(monitor_dir) if monitor_dir is not None else None,
        vec_env_cls=DummyVecEnv,
    )
