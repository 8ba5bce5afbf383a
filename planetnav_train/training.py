"""SB3 training of one configuration: :func:`train` writes ``config.yaml``, the model, TensorBoard logs,
monitor CSVs and checkpoints (``resume/``, :mod:`planetnav_train.checkpoint`) into a run directory, after an
optional behaviour-cloning warm start (``pretrain``), and logs navigation metrics of the training episodes
(``nav/...``); ``train(..., resume=True)`` continues a killed run from its last checkpoint."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planetnav_train.algorithms import algo_kwargs, policy_class
from planetnav_train.checkpoint import (
    TrainingState,
    checkpoint_callback_class,
    checkpoint_dir,
    load_state,
    save_checkpoint,
    write_state,
)
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


def _pretrain(tc: TrainConfig, model: Any, run_dir: Path, progress: bool, resume: bool) -> dict[str, Any]:
    """The warm start of ``tc.pretrain`` (behaviour cloning, then DAgger rounds) applied to ``model``; its
    statistics (a teacher trained first counts its steps and time)."""
    from planetnav_train.pretrain import clone, dagger, demonstrations

    t0 = time.perf_counter()
    stats: dict[str, Any] = {}
    teacher = tc.pretrain.get("teacher")
    if "teacher_config" in tc.pretrain:
        # Two stages: the teacher's own config trains first (e.g. the target-mode policy, which is then
        # distilled into the target+torque action space); its time counts in this run's.
        teacher_tc = load_config(resolve_config_path(tc.pretrain["teacher_config"]))
        print(f"training the teacher {teacher_tc.name} ({tc.pretrain['teacher_config']}) first")
        teacher_path, teacher_stats = train(teacher_tc, run_dir / "teacher", progress=progress, resume=resume)
        teacher = str(teacher_path)
        stats["teacher"] = {k: teacher_stats[k] for k in ("timesteps", "env_steps", "seconds")}
    obs, actions = demonstrations(tc.env_config(), teacher, tc.pretrain["episodes"], tc.features)
    nll = clone(
        model, obs, actions, tc.pretrain["epochs"], keep_std=tc.pretrain["keep_std"],
        balance=tc.pretrain.get("balance", False),
    )  # fmt: skip
    if tc.pretrain["dagger_rounds"]:
        obs, actions, nll = dagger(
            model, tc.env_config(), teacher, tc.pretrain["dagger_rounds"], tc.pretrain["episodes"],
            tc.pretrain["epochs"], tc.features, (obs, actions), keep_std=tc.pretrain["keep_std"],
            balance=tc.pretrain.get("balance", False),
        )  # fmt: skip
    stats.update(samples=len(obs), nll=nll, seconds=time.perf_counter() - t0)
    print(f"pretrained on {len(obs)} decisions of {teacher} (final NLL {nll:.2f})")
    return stats


def train(
    tc: TrainConfig,
    run_dir: Path,
    progress: bool = True,
    resume: bool = False,
    callbacks: Sequence[Any] = (),
) -> tuple[Path, dict[str, Any]]:
    """Train ``tc`` into ``run_dir``; returns the model path and training statistics.

    Checkpoints every ``tc.checkpoint_every`` decisions, and after a warm start, into ``run_dir/resume/``
    (:mod:`planetnav_train.checkpoint`). With ``resume`` a run killed earlier continues from its last
    checkpoint up to ``tc.n_timesteps`` decisions (one without a checkpoint starts afresh; a finished one
    returns its model). ``callbacks``: further SB3 callbacks, called after the project's own.
    """
    import torch

    # A 64x64 MLP is too small to gain from intra-op threads; one thread leaves a core for the env.
    torch.set_num_threads(tc.torch_threads)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    state = load_state(run_dir) if resume else None
    if state is not None and state.done:
        print(f"{run_dir}: its training finished earlier ({state.timesteps} decisions)")
        return run_dir / "model.zip", state.stats
    if state is None:
        with open(run_dir / "config.yaml", "w") as fh:
            yaml.safe_dump(tc.to_dict(), fh, sort_keys=False)
    offset = state.timesteps if state is not None else 0
    if offset:
        # New episodes, from another seed than the first ones (a resumed run does not replay them); the
        # resumed part's monitor CSVs go beside the first part's.
        seeded = dataclasses.replace(tc, seed=tc.seed + offset)
        venv = make_training_env(seeded, run_dir / "monitor" / f"from{offset}")
    else:
        venv = make_training_env(tc, run_dir / "monitor")
    cls = algorithm_class(tc.algo)
    t0 = time.perf_counter()
    seconds_before = state.seconds if state is not None else 0.0
    if state is not None:
        folder = checkpoint_dir(run_dir)
        model = cls.load(folder / state.model, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb"))
        model._last_obs = None  # the environments are new: learn() resets them
        model.set_random_seed(tc.seed + offset)
        if state.replay_buffer:
            model.load_replay_buffer(folder / state.replay_buffer)
        pretrain_stats = dict(state.pretrain)
        print(f"resuming {run_dir} at decision {offset} of {tc.n_timesteps}")
    else:
        model = cls(
            policy_class(tc),
            venv,
            seed=tc.seed,
            tensorboard_log=str(run_dir / "tb"),
            device="cpu",
            verbose=0,
            **algo_kwargs(tc),
        )
        pretrain_stats = _pretrain(tc, model, run_dir, progress, resume) if tc.pretrain else {}
    callback = _nav_callback_class()()
    if state is not None:
        callback.episodes = [tuple(e) for e in state.episodes]

    def current_state() -> TrainingState:
        return TrainingState(
            timesteps=int(model.num_timesteps), seconds=seconds_before + time.perf_counter() - t0, model="",
            episodes=[list(e) for e in callback.episodes], pretrain=pretrain_stats,
        )  # fmt: skip

    if state is None and tc.pretrain and tc.checkpoint_every:
        save_checkpoint(model, run_dir, current_state())  # a kill during PPO does not redo the warm start
    saver = checkpoint_callback_class()(run_dir, tc.checkpoint_every, current_state, last=offset)
    interrupted = False
    try:
        if state is None:
            model.learn(
                total_timesteps=tc.n_timesteps, callback=[callback, saver, *callbacks], progress_bar=progress,
                tb_log_name=tc.algo,
            )  # fmt: skip
        elif tc.n_timesteps > model.num_timesteps:
            model.learn(
                total_timesteps=tc.n_timesteps - model.num_timesteps, callback=[callback, saver, *callbacks],
                progress_bar=progress, tb_log_name=tc.algo, reset_num_timesteps=False,
            )  # fmt: skip
    except KeyboardInterrupt:
        # Ctrl-C (SIGINT) ends training early but keeps what it learnt: the model is saved and the run goes
        # on to its evaluation, which then reports the steps actually trained (stats["interrupted"]); a
        # checkpoint lets --resume finish the run later.
        interrupted = True
        print(f"\ninterrupted at {model.num_timesteps} of {tc.n_timesteps} decisions: saving the model")
        save_checkpoint(model, run_dir, current_state())
    elapsed = seconds_before + time.perf_counter() - t0
    model_path = run_dir / "model.zip"
    model.save(model_path)
    venv.close()
    # SB3's timesteps are decisions; each ran the env's decision_steps physics steps.
    env_steps = int(model.num_timesteps) * tc.env_config().decision_steps
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
        "resumed_at": offset or None,
    }
    if not interrupted:
        final = current_state()
        final.done, final.stats = True, stats
        write_state(run_dir, final)  # the checkpoint's files go: the final model is run_dir/model.zip
    return model_path, stats
