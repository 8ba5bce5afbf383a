"""The training environments: :func:`make_training_env` builds the VecEnv a configuration trains on
(the native vector env with the training options on arrays, or wrapped single environments in SB3's
``DummyVecEnv`` where a feature or the shaping needs them)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planetnav_agents.features import ActionRepeat, NavFeatures, RelativeTargets
from planetnav_agents.shaping import PointingShaping
from planetnav_train.config import TrainConfig


def make_training_env(tc: TrainConfig, monitor_dir: Path | None) -> Any:
    """The training VecEnv: ``n_envs`` rows of the native vector env (one compiled step for all rows)
    under SB3's ``VecMonitor``, with ``since_measured``, action repeat and relative actions computed on
    arrays (:class:`planetnav_agents.vec_training.NavTrainingVecEnv`, the ``gain`` feature included). The
    feature that
    needs a per-environment agent (``pd_torque``) and reward shaping are gymnasium wrappers of single
    environments: with any
    of those configured, ``n_envs`` wrapped single environments run in SB3's ``DummyVecEnv`` instead
    (``vec_env: dummy`` forces that path; both paths are the same MDP, ``tests/test_vec_training.py``)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    from planetnav_agents.vec_training import NATIVE_FEATURES, NavTrainingVecEnv
    from planetnav_env.env import PlanetNavEnv

    env_cfg = tc.env_config()
    features = tuple(tc.features)
    pointing = tc.shaping.get("pointing")
    gamma = float(tc.hyperparams.get("gamma", 0.99))

    native = tc.vec_env == "native" and not pointing and set(features) <= set(NATIVE_FEATURES)
    if native:
        if monitor_dir is not None:
            monitor_dir.mkdir(parents=True, exist_ok=True)
        venv = NavTrainingVecEnv(
            tc.n_envs, env_cfg, seed=tc.seed, features=features, action_repeat=tc.action_repeat,
            relative_actions=tc.relative_actions,
        )  # fmt: skip
        return VecMonitor(venv, filename=str(monitor_dir / "vec") if monitor_dir is not None else None)

    def make_env() -> Any:
        env = PlanetNavEnv(env_cfg)
        if pointing:  # the shaping reads the raw observation: inside the feature wrapper
            env = PointingShaping(env, pointing, gamma)
        if features:
            env = NavFeatures(env, features)
        if tc.action_repeat > 1:
            env = ActionRepeat(env, tc.action_repeat)
        # Outside the repeat: a relative choice is made once per decision, then its absolute target held.
        return RelativeTargets(env) if tc.relative_actions else env

    return make_vec_env(
        make_env,
        n_envs=tc.n_envs,
        seed=tc.seed,
        monitor_dir=str(monitor_dir) if monitor_dir is not None else None,
        vec_env_cls=DummyVecEnv,
    )
