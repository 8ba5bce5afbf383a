"""SB3 training of one configuration: :func:`train` writes ``config.yaml``, the model, TensorBoard logs and
monitor CSVs into a run directory, after an optional behaviour-cloning warm start (``pretrain``), and
logs navigation metrics of the training episodes (``nav/...``)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planetnav_train.algorithms import algo_kwargs
from planetnav_train.config import TrainConfig, load_config, resolve_config_path
from planetnav_train.envs import make_training_env
from planetnav_train.sb3 import algorithm_class


def _nav_callback_class() -> type:
    """The SB3 callback class (defined here so that SB3 is imported only when training)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class NavMetricsCallback(BaseCallback):
        """Logs navigation metrics of finished training episodes to TensorBoard (``nav/...``).

        The final position error is privileged (truth) but only *logged*, never given to the policy.
        """

        def __init__(self) -> None:
            super().__init__()
            self.episodes: list[tuple[int, float, float]] = []  # (timestep, return, final pos err)
            self._measured: np.ndarray | None = None
            self._steps: np.ndarray | None = None

        def _on_training_start(self) -> None:
            n = self.training_env.num_envs
            self._measured, self._steps = np.zeros(n), np.zeros(n)

        def _on_step(self) -> bool:
            infos, dones = self.locals["infos"], self.locals["dones"]
            for i, info in enumerate(infos):
                self._measured[i] += bool(info.get("measured", False))
                self._steps[i] += 1
                if dones[i]:
                    ep = info.get("episode", {})
                    err = float(info.get("pos_err_km", math.nan))
                    self.logger.record_mean("nav/final_pos_err_km", err)
                    self.logger.record_mean("nav/measured_fraction", self._measured[i] / self._steps[i])
                    self.episodes.append((self.num_timesteps, float(ep.get("r", math.nan)), err))
                    self._measured[i] = self._steps[i] = 0
            return True

    return NavMetricsCallback


def train(tc: TrainConfig, run_dir: Path, progress: bool = True) -> tuple[Path, dict[str, Any]]:
    """Train ``tc`` into ``run_dir``; returns the model path and training statistics."""
    import torch

    # A 64x64 MLP is too small to gain from intra-op threads; one thread leaves a core for the env.
    torch.set_num_threads(tc.torch_threads)
    run_dir.mkdir(parents=True, exist_ok=True)
    with open(run_dir / "config.yaml", "w") as fh:
        yaml.safe_dump(tc.to_dict(), fh, sort_keys=False)
    venv = make_training_env(tc, run_dir / "monitor")
    cls = algorithm_class(tc.algo)
    model = cls(
        tc.policy,
        venv,
        seed=tc.seed,
        tensorboard_log=str(run_dir / "tb"),
        device="cpu",
        verbose=0,
        **algo_kwargs(tc),
    )
    t0 = time.perf_counter()
    pretrain_stats: dict[str, Any] = {}
    if tc.pretrain:
        from planetnav_train.pretrain import clone, dagger, demonstrations

        teacher = tc.pretrain.get("teacher")
        if "teacher_config" in tc.pretrain:
            # Two stages: the teacher's own config trains first (e.g. the target-mode policy, which is then
            # distilled into the target+torque action space); its time counts in this run's.
            teacher_tc = load_config(resolve_config_path(tc.pretrain["teacher_config"]))
            print(f"training the teacher {teacher_tc.name} ({tc.pretrain['teacher_config']}) first")
            teacher_path, teacher_stats = train(teacher_tc, run_dir / "teacher", progress=progress)
            teacher = str(teacher_path)
            pretrain_stats["teacher"] = {k: teacher_stats[k] for k in ("timesteps", "env_steps", "seconds")}
        obs, actions = demonstrations(
            tc.env_config(), teacher, tc.pretrain["episodes"], tc.features,
            action_repeat=tc.action_repeat, relative_actions=tc.relative_actions,
        )  # fmt: skip
        nll = clone(
            model, obs, actions, tc.pretrain["epochs"], keep_std=tc.pretrain["keep_std"],
            balance=tc.pretrain.get("balance", False),
        )  # fmt: skip
        if tc.pretrain["dagger_rounds"]:
            obs, actions, nll = dagger(
                model, tc.env_config(), teacher, tc.pretrain["dagger_rounds"], tc.pretrain["episodes"],
                tc.pretrain["epochs"], tc.features, (obs, actions), action_repeat=tc.action_repeat,
                relative_actions=tc.relative_actions, keep_std=tc.pretrain["keep_std"],
                balance=tc.pretrain.get("balance", False),
            )  # fmt: skip
        pretrain_stats.update(samples=len(obs), nll=nll, seconds=time.perf_counter() - t0)
        print(f"pretrained on {len(obs)} decisions of {teacher} (final NLL {nll:.2f})")
    callback = _nav_callback_class()()
    interrupted = False
    try:
        model.learn(
            total_timesteps=tc.n_timesteps, callback=callback, progress_bar=progress, tb_log_name=tc.algo
        )
    except KeyboardInterrupt:
        # Ctrl-C (SIGINT) ends training early but keeps what it learnt: the model is saved and the run goes
        # on to its evaluation, which then reports the steps actually trained (stats["interrupted"]).
        interrupted = True
        print(f"\ninterrupted at {model.num_timesteps} of {tc.n_timesteps} decisions: saving the model")
    elapsed = time.perf_counter() - t0
    model_path = run_dir / "model.zip"
    model.save(model_path)
    venv.close()
    # With action_repeat, SB3's timesteps are decisions; the environment ran ``action_repeat`` steps each.
    env_steps = int(model.num_timesteps) * tc.action_repeat
    # A teacher trained by this run (pretrain.teacher_config) is part of its time and its steps.
    teacher_steps = int(pretrain_stats.get("teacher", {}).get("env_steps", 0))
    stats = {
        "timesteps": int(model.num_timesteps),
        "env_steps": env_steps,
        "teacher_env_steps": teacher_steps,
        "seconds": elapsed,
        "steps_per_s": (env_steps + teacher_steps) / max(elapsed, 1e-9),
        "episodes": callback.episodes,
        "pretrain": pretrain_stats,
        "interrupted": interrupted,
    }
    return model_path, stats
