"""RLlib PPO (new API stack) on any ``planetnav/*`` environment, driven by a training configuration
(:class:`planetnav_train.config.TrainConfig`).

A training configuration with ``algo: rllib_ppo`` (``configs/rllib_ppo.yaml``) maps onto RLlib as:

================== =====================================================================================
config key         RLlib
================== =====================================================================================
env_id, env        the environment (``env`` overrides the id's defaults, exactly as for SB3)
n_timesteps        train until at least this many env steps are sampled (whole iterations)
n_envs             ``num_envs_per_env_runner``: environments per env runner, vectorised
seed               ``debugging(seed=...)``: RLlib seeds each runner's environments from it
torch_threads      torch threads of the learner (in the driver process)
hyperparams        keyword arguments of ``PPOConfig.training`` (``lr``, ``gamma``, ``lambda_``,
                   ``train_batch_size_per_learner``, ``minibatch_size``, ``num_epochs``, ...), plus
                   ``num_env_runners``, ``rollout_fragment_length``, ``num_cpus_per_env_runner``,
                   ``sample_timeout_s`` (``env_runners``), ``num_learners`` (``learners``) and
                   ``model_config`` (``rl_module``: ``fcnet_hiddens``, ``fcnet_activation``, ...)
================== =====================================================================================

Env runners build their environments with ``gymnasium.make_vec(id, vectorization_mode=
"vector_entry_point")``: the id's registered vector entry point, so the native vector environment is used
wherever ``planetnav_env.envs.registration`` provides one, and Gymnasium's ``SyncVectorEnv`` until then.
Ray is imported only inside functions.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from planetnav_rl import require_ray
from planetnav_rl.hyperparams import ENV_RUNNER_KEYS, LEARNER_KEYS, check_hyperparams
from planetnav_train.checkpoint import TrainingState, checkpoint_dir, load_state, write_state
from planetnav_train.config import TrainConfig

#: Name under which the environment creator is registered with Ray (``tune.register_env``).
ENV_NAME = "planetnav"

#: Environment id used when a configuration has none (its ``env`` section then defines the scenario; the
#: full resolved environment configuration is passed as keywords, so the id's own defaults never leak in).
FALLBACK_ENV_ID = "planetnav/Cruise-Target-v0"

#: Subdirectory of a run directory that holds the RLlib checkpoint (``Algorithm.save_to_path``).
CHECKPOINT_DIR = "checkpoint"


def make_env(ctx: dict[str, Any]) -> Any:
    """RLlib's environment creator: ``ctx`` is ``{"env_id", "env"}`` (+ ``"num_envs"`` for a vector env).

    Runs inside each env runner; registers the planetnav ids there first.
    """
    import gymnasium as gym

    import planetnav_env  # noqa: F401  (registers the ids in this worker process)

    env_id, env_kwargs = ctx["env_id"], dict(ctx["env"])
    if "num_envs" in ctx:
        return gym.make_vec(
            env_id, num_envs=int(ctx["num_envs"]), vectorization_mode="vector_entry_point", **env_kwargs
        )
    return gym.make(env_id, **env_kwargs)


def _callbacks_class() -> type:
    from ray.rllib.callbacks.callbacks import RLlibCallback

    class NavMetricsCallback(RLlibCallback):
        """Logs each finished episode's final true position error [km] (``final_pos_err_km`` in the
        ``env_runners`` results). Truth is only *logged* for the training plot, never seen by the policy."""

        def on_episode_end(self, *, episode: Any, metrics_logger: Any = None, **kwargs: Any) -> None:
            info = episode.get_infos(-1)
            if metrics_logger is not None and isinstance(info, dict) and "pos_err_km" in info:
                metrics_logger.log_value("final_pos_err_km", float(info["pos_err_km"]), reduce="mean")

    return NavMetricsCallback


def build_config(tc: TrainConfig, num_env_runners: int | None = None) -> Any:
    """The ``PPOConfig`` of training configuration ``tc`` (see the module docstring for the mapping).

    ``num_env_runners`` overrides the configuration's (Tune trials sample in their own process: 0).
    """
    require_ray("algo: rllib_ppo")
    from ray.rllib.algorithms.ppo import PPOConfig

    check_hyperparams(tc.hyperparams)
    hp = dict(tc.hyperparams)
    runners = {k: hp.pop(k) for k in ENV_RUNNER_KEYS if k in hp}
    learners = {k: hp.pop(k) for k in LEARNER_KEYS if k in hp}
    model_config = hp.pop("model_config", None)
    if num_env_runners is not None:
        runners["num_env_runners"] = num_env_runners
    runners.setdefault("num_env_runners", 1)
    env_ctx = {"env_id": tc.env_id or FALLBACK_ENV_ID, "env": tc.env_config().to_dict()}
    config = (
        PPOConfig()
        .environment(ENV_NAME, env_config=env_ctx, clip_actions=True)
        .env_runners(
            num_envs_per_env_runner=tc.n_envs, gym_env_vectorize_mode="vector_entry_point", **runners
        )
        .learners(**learners)
        .training(**hp)
        .callbacks(_callbacks_class())
        .debugging(seed=tc.seed, log_level="ERROR")
    )
    if model_config is not None:
        config = config.rl_module(model_config=dict(model_config))
    return config


def register() -> None:
    """Register :func:`make_env` with Ray under :data:`ENV_NAME` (needs ``ray.init`` first)."""
    from ray.tune.registry import register_env

    register_env(ENV_NAME, make_env)


def iteration_summary(result: dict[str, Any]) -> dict[str, float]:
    """Env steps sampled so far, mean episode return and mean final position error [km] (NaN when no
    episode finished yet) from one ``Algorithm.train()`` result."""
    er = result.get("env_runners", {}) or {}
    return {
        "timesteps": float(
            er.get("num_env_steps_sampled_lifetime", result.get("num_env_steps_sampled_lifetime", 0))
        ),
        "return": float(er.get("episode_return_mean", math.nan)),
        "final_pos_err_km": float(er.get("final_pos_err_km", math.nan)),
    }


def build_algorithm(tc: TrainConfig, num_env_runners: int | None = None) -> Any:
    """Register the environment and build the PPO algorithm (Ray must be initialised)."""
    import torch

    # The learner lives in this process; a 64x64 MLP gains nothing from intra-op threads.
    torch.set_num_threads(tc.torch_threads)
    register()
    return build_config(tc, num_env_runners).build_algo()


def train(
    tc: TrainConfig, run_dir: Path, address: str | None = None, progress: bool = True, resume: bool = False
) -> tuple[Path, dict[str, Any]]:
    """Train ``tc`` with RLlib into ``run_dir``; return the checkpoint directory and training statistics
    (the keys :func:`planetnav_train.training.train` returns: timesteps, seconds, steps_per_s, episodes).

    Without ``address`` a local Ray is started on 127.0.0.1 (and shut down at the end); with one, the env
    runners run on that cluster while the learner stays in this process. Every ``tc.checkpoint_every``
    env steps (whole iterations) the algorithm is saved into ``run_dir/resume/``
    (:mod:`planetnav_train.checkpoint`); with ``resume`` a killed run continues from there.
    """
    import yaml

    from planetnav_rl.cluster import init_ray, shutdown_ray

    run_dir = Path(run_dir).resolve()
    run_dir.mkdir(parents=True, exist_ok=True)
    state = load_state(run_dir) if resume else None
    if state is not None and state.done:
        print(f"{run_dir}: its training finished earlier ({state.timesteps} env steps)")
        return run_dir / CHECKPOINT_DIR, state.stats
    if state is None:
        with open(run_dir / "config.yaml", "w") as fh:
            yaml.safe_dump(tc.to_dict(), fh, sort_keys=False)
    build_config(tc)  # validate before starting Ray
    ray_info = init_ray(address)
    try:
        from torch.utils.tensorboard import SummaryWriter

        algo = build_algorithm(tc)
        offset = 0
        episodes: list[tuple[int, float, float]] = []
        seconds_before = 0.0
        if state is not None:
            algo.restore_from_path(str(checkpoint_dir(run_dir) / state.model))
            offset, seconds_before = state.timesteps, state.seconds
            episodes = [tuple(e) for e in state.episodes]
            print(f"resuming {run_dir} at env step {offset} of {tc.n_timesteps}")
        writer = SummaryWriter(str(run_dir / "tb" / f"{tc.algo}_1"))
        t0, steps, last = time.perf_counter(), offset, offset
        while steps < tc.n_timesteps:
            result = algo.train()
            s = iteration_summary(result)
            # The lifetime counter comes back with the restored state in recent RLlib versions; where it
            # restarts at 0, the steps before the checkpoint are added.
            steps = int(s["timesteps"]) if int(s["timesteps"]) > offset else offset + int(s["timesteps"])
            if not math.isnan(s["return"]):
                episodes.append((steps, s["return"], s["final_pos_err_km"]))
                writer.add_scalar("rollout/ep_rew_mean", s["return"], steps)
            if not math.isnan(s["final_pos_err_km"]):
                writer.add_scalar("nav/final_pos_err_km", s["final_pos_err_km"], steps)
            writer.add_scalar("time/fps", (steps - offset) / max(time.perf_counter() - t0, 1e-9), steps)
            if progress:
                print(
                    f"  iteration {result['training_iteration']}: {steps} env steps, "
                    f"return {s['return']:.2f}, final pos err {s['final_pos_err_km']:.0f} km"
                )
            if tc.checkpoint_every and steps - last >= tc.checkpoint_every and steps < tc.n_timesteps:
                name = f"algo_{steps}"
                algo.save_to_path(str(checkpoint_dir(run_dir) / name))
                write_state(run_dir, TrainingState(
                    timesteps=steps, seconds=seconds_before + time.perf_counter() - t0, model=name,
                    episodes=[list(e) for e in episodes],
                ))  # fmt: skip
                last = steps
        elapsed = seconds_before + time.perf_counter() - t0
        writer.close()
        checkpoint = run_dir / CHECKPOINT_DIR
        algo.save_to_path(str(checkpoint))
        algo.stop()
    finally:
        shutdown_ray(ray_info)
    stats = {
        "timesteps": steps,
        "env_steps": steps,  # RLlib acts every environment step (no action repeat)
        "seconds": elapsed,
        "steps_per_s": steps / max(elapsed, 1e-9),
        "episodes": episodes,
        "resumed_at": offset or None,
    }
    done = TrainingState(timesteps=steps, seconds=elapsed, model="", episodes=[list(e) for e in episodes])
    done.done, done.stats = True, stats
    write_state(run_dir, done)
    return checkpoint, stats
