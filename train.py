#!/usr/bin/env python
"""Train Stable-Baselines3 agents on planetnav and compare them with the rule-based agents.

Usage::

    python train.py                                   # = train --config configs/cruise_ppo.yaml (~10 min)
    python train.py train --config configs/X.yaml [--run-dir DIR] [--timesteps N] [--no-eval]
    python train.py evaluate --agent NAME|PATH --episodes N --seed S --json out.json [--config X.yaml]
    python train.py compare --agents planner greedy periodic baseline random idle [PATH ...] --episodes N \\
        [--json J] [--report DIR] [--reference greedy]
    python train.py sweep-periodic [--periods 10 30 60 ...] [--cycles 0-1 0-1-2 ...] [--episodes N] [--seed S]
    python train.py train --config configs/rllib_ppo.yaml [--address HOST:PORT]   # RLlib, needs [ray]
    python train.py tune --config configs/sweep.yaml [--address HOST:PORT] [--resume]  # Ray Tune sweep

A training run writes ``runs/<name>/``: ``model.zip``, ``config.yaml`` (the resolved configuration; the SB3
loader reads ``algo`` from it), ``tb/`` (TensorBoard), ``monitor/`` (episode CSVs), then, unless
``--no-eval``, ``eval.json``, ``report.md`` and the plots ``pos_err.png``, ``pos_sigma.png``,
``training.png``. Configuration keys: ``configs/README.md``. Agents evaluate on 20 held-out seeds (default
10_000 onwards; training environments use the config's ``seed`` onwards, far below), every agent on the
same seeds; each mean comes with a 95 % t-interval and the paired difference from a reference agent
(``greedy``) on the same seeds (:mod:`planetnav_agents.stats`). Agents that cannot act in the environment's
action mode (``idle`` outside ``target`` mode, a model trained for other spaces) are skipped with a note.
``algo: rllib_ppo`` trains with RLlib instead (``planetnav_rl/rllib.py``; the run directory then holds
``checkpoint/`` in place of ``model.zip``, and ``evaluate``/``compare`` take it as an agent like a model
path). Sweeps: ``planetnav_rl/tune.py``, docs/scaling.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import json
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planetnav_agents import (
    NotApplicableError,
    make_agent,
    not_applicable,
    requires_idle_action,
    strip_sampled,
)
from planetnav_agents.features import ActionRepeat, NavFeatures, RelativeTargets, check_features
from planetnav_agents.rllib import config_sidecar as rllib_config_sidecar
from planetnav_agents.sb3 import ALGORITHMS, algorithm_class, resolve_model_path
from planetnav_agents.shaping import SHAPINGS, PointingShaping
from planetnav_agents.stats import MeanCI, mean_ci, paired_difference
from planetnav_env.config import NOISE_STREAMS, EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_env.registration import ENV_IDS
from planetnav_rl import RLLIB_ALGOS, is_rllib_algo

ROOT = Path(__file__).resolve().parent
DEFAULT_CONFIG = ROOT / "configs" / "cruise_ppo.yaml"
DEFAULT_AGENTS = ("planner", "greedy", "periodic", "baseline", "random", "idle")
EVAL_SEED = 10_000
EVAL_EPISODES = 20
REFERENCE = "greedy"
#: Seeds of the periodic sweep: disjoint from the evaluation seeds (the chosen setting is not tuned on them).
SWEEP_SEED = 20_000

# ---------------------------------------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------------------------------------


@dataclass
class EvalSettings:
    """``eval:`` section: held-out episodes run after training (the trained model is added to ``agents``)."""

    episodes: int = EVAL_EPISODES
    seed: int = EVAL_SEED
    agents: tuple[str, ...] = DEFAULT_AGENTS
    episode_steps: int | None = None  # None: the env's own episode length
    # None: the env's own; "per_step": common random numbers across the agents (EnvConfig.noise_streams)
    noise_streams: str | None = None
    reference: str = REFERENCE  # paired differences are taken against this agent (if it ran)


@dataclass
class TrainConfig:
    """A training run, RL-Zoo style (see ``configs/README.md``)."""

    name: str = "run"
    algo: str = "ppo"
    env_id: str | None = None
    n_timesteps: int = 100_000
    policy: str = "MlpPolicy"
    n_envs: int = 4
    seed: int = 0
    torch_threads: int = 1
    # "native": n_envs rows of the compiled vector env (planetnav_agents.vec_training); "dummy": n_envs single
    # environments in SB3's DummyVecEnv (the path for the gain / pd_torque features and shaping).
    vec_env: str = "native"
    hyperparams: dict[str, Any] = field(default_factory=dict)
    env: dict[str, Any] = field(default_factory=dict)
    eval: EvalSettings = field(default_factory=EvalSettings)
    features: list[str] = field(default_factory=list)  # extra observation features (agents/features.py)
    shaping: dict[str, float] = field(default_factory=dict)  # potential-based, training only (agents/shaping)
    action_repeat: int = 1  # environment steps per policy decision (planetnav_agents.features.ActionRepeat)
    # target mode: "stay" / "move k places" (planetnav_agents.features.RelativeTargets)
    relative_actions: bool = False
    pretrain: dict[str, Any] = field(
        default_factory=dict
    )  # behaviour-cloning warm start (agents/pretrain.py)

    def env_config(self) -> EnvConfig:
        """The environment configuration: the ``env_id``'s defaults overridden by ``env``."""
        base: dict[str, Any] = {}
        if self.env_id is not None:
            if self.env_id not in ENV_IDS:
                raise ConfigError(f"env_id {self.env_id!r} is not one of {sorted(ENV_IDS)}")
            base = dict(ENV_IDS[self.env_id])
        return EnvConfig.from_dict({**base, **self.env})

    def to_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["eval"]["agents"] = list(self.eval.agents)
        return out


_TOP_KEYS = {f.name for f in dataclasses.fields(TrainConfig)}
_EVAL_KEYS = {f.name for f in dataclasses.fields(EvalSettings)}


def _check_keys(data: Mapping[str, Any], known: set[str], where: str) -> None:
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; known keys: {sorted(known)}")


def parse_config(data: Mapping[str, Any] | None, name: str = "run") -> TrainConfig:
    """Validate a configuration mapping (unknown keys raise :class:`ConfigError` naming them)."""
    data = dict(data or {})
    _check_keys(data, _TOP_KEYS, "config")
    ev = data.pop("eval", None) or {}
    if not isinstance(ev, Mapping):
        raise ConfigError("config: 'eval' must be a mapping")
    _check_keys(ev, _EVAL_KEYS, "config.eval")
    eval_settings = EvalSettings(**{**ev, "agents": tuple(ev.get("agents", DEFAULT_AGENTS))})
    for key in ("hyperparams", "env"):
        if data.get(key) is None:
            data[key] = {}
        if not isinstance(data[key], Mapping):
            raise ConfigError(f"config: {key!r} must be a mapping")
        data[key] = dict(data[key])
    data.setdefault("name", name)
    tc = TrainConfig(**data, eval=eval_settings)
    tc.algo = str(tc.algo).lower()
    if tc.algo not in ALGORITHMS and not is_rllib_algo(tc.algo):
        raise ConfigError(f"config: algo {tc.algo!r} is not one of {[*ALGORITHMS, *RLLIB_ALGOS]}")
    for key in ("n_timesteps", "n_envs", "torch_threads", "action_repeat"):
        value = getattr(tc, key)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ConfigError(f"config: {key} must be a positive integer, got {value!r}")
    if tc.vec_env not in ("native", "dummy"):
        raise ConfigError(f"config: vec_env must be 'native' or 'dummy', got {tc.vec_env!r}")
    if eval_settings.episodes < 1:
        raise ConfigError(f"config.eval: episodes must be >= 1, got {eval_settings.episodes!r}")
    if eval_settings.noise_streams is not None and eval_settings.noise_streams not in NOISE_STREAMS:
        raise ConfigError(
            f"config.eval: noise_streams must be one of {NOISE_STREAMS}, got {eval_settings.noise_streams!r}"
        )
    _check_hyperparams(tc)
    tc.env_config()  # validate the env section now, not after training
    try:
        tc.features = list(check_features(tc.features or []))
    except ValueError as exc:
        raise ConfigError(f"config: features: {exc}") from None
    if not isinstance(tc.relative_actions, bool):
        raise ConfigError(f"config: relative_actions must be true or false, got {tc.relative_actions!r}")
    tc.pretrain = dict(tc.pretrain or {})
    if tc.pretrain:
        _check_keys(
            tc.pretrain,
            {"teacher", "teacher_config", "episodes", "epochs", "keep_std", "dagger_rounds"},
            "config.pretrain",
        )
        if not isinstance(tc.pretrain.setdefault("keep_std", False), bool):
            raise ConfigError(
                f"config.pretrain: keep_std must be true or false, got {tc.pretrain['keep_std']!r}"
            )
        if ("teacher" in tc.pretrain) == ("teacher_config" in tc.pretrain):
            raise ConfigError(
                "config.pretrain: give either 'teacher' (an agent spec) or 'teacher_config' (a training "
                "YAML to train first), not both or neither"
            )
        if "teacher_config" in tc.pretrain:
            given = tc.pretrain["teacher_config"]
            if not _config_path(given).is_file():
                raise ConfigError(f"config.pretrain: teacher_config {given!r} not found")
        for key, default, least in (("episodes", 4, 1), ("epochs", 20, 1), ("dagger_rounds", 0, 0)):
            value = tc.pretrain.setdefault(key, default)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ConfigError(f"config.pretrain: {key} must be an integer >= {least}, got {value!r}")
    tc.shaping = dict(tc.shaping or {})
    _check_keys(tc.shaping, set(SHAPINGS), "config.shaping")
    for key, weight in tc.shaping.items():
        if isinstance(weight, bool) or not isinstance(weight, int | float) or not weight > 0:
            raise ConfigError(f"config.shaping: {key} must be a positive weight, got {weight!r}")
    return tc


def _config_path(path: str | Path) -> Path:
    """A config path as given, or relative to the repository root (``configs/X.yaml`` from anywhere)."""
    p = Path(path)
    return p if p.is_absolute() or p.is_file() else ROOT / p


def load_config(path: str | Path) -> TrainConfig:
    """Read and validate a YAML training configuration; the run name defaults to the file's stem."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"no configuration file {path}")
    with open(path) as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    try:
        return parse_config(data, name=path.stem)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def _check_hyperparams(tc: TrainConfig) -> None:
    if is_rllib_algo(tc.algo):  # RLlib's PPOConfig keywords (needs the [ray] extra)
        from planetnav_rl.rllib import check_hyperparams

        check_hyperparams(tc.hyperparams)
        return
    params = inspect.signature(algorithm_class(tc.algo).__init__).parameters
    # Set by this script from other keys; a user value would be silently overwritten.
    reserved = {"self", "policy", "env", "seed", "tensorboard_log", "verbose", "device", "_init_setup_model"}
    known = set(params) - reserved
    _check_keys(tc.hyperparams, known, f"config.hyperparams ({tc.algo})")


def _activation(name: str) -> Any:
    import torch.nn as nn

    table = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU, "leaky_relu": nn.LeakyReLU, "gelu": nn.GELU}
    if name.lower() not in table:
        raise ConfigError(f"policy_kwargs.activation_fn {name!r} is not one of {sorted(table)}")
    return table[name.lower()]


def _schedule(value: Any) -> Any:
    """``"lin_3e-4"`` (RL-Zoo) -> linear decay to 0; numbers pass through."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


def algo_kwargs(tc: TrainConfig) -> dict[str, Any]:
    """The algorithm's constructor arguments from ``hyperparams`` (activation names, ``lin_`` schedules)."""
    kw = dict(tc.hyperparams)
    for key in ("learning_rate", "clip_range"):
        if key in kw:
            kw[key] = _schedule(kw[key])
    pk = dict(kw.get("policy_kwargs") or {})
    if isinstance(pk.get("activation_fn"), str):
        pk["activation_fn"] = _activation(pk["activation_fn"])
    if pk:
        kw["policy_kwargs"] = pk
    return kw


# ---------------------------------------------------------------------------------------------------------
# Training
# ---------------------------------------------------------------------------------------------------------


def _nav_callback_class() -> type:
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
        from planetnav_agents.pretrain import clone, dagger, demonstrations

        teacher = tc.pretrain.get("teacher")
        if "teacher_config" in tc.pretrain:
            # Two stages: the teacher's own config trains first (e.g. the target-mode policy, which is then
            # distilled into the target+torque action space); its time counts in this run's.
            teacher_tc = load_config(_config_path(tc.pretrain["teacher_config"]))
            print(f"training the teacher {teacher_tc.name} ({tc.pretrain['teacher_config']}) first")
            teacher_path, teacher_stats = train(teacher_tc, run_dir / "teacher", progress=progress)
            teacher = str(teacher_path)
            pretrain_stats["teacher"] = {k: teacher_stats[k] for k in ("timesteps", "env_steps", "seconds")}
        obs, actions = demonstrations(
            tc.env_config(), teacher, tc.pretrain["episodes"], tc.features,
            action_repeat=tc.action_repeat, relative_actions=tc.relative_actions,
        )  # fmt: skip
        nll = clone(model, obs, actions, tc.pretrain["epochs"], keep_std=tc.pretrain["keep_std"])
        if tc.pretrain["dagger_rounds"]:
            obs, actions, nll = dagger(
                model, tc.env_config(), teacher, tc.pretrain["dagger_rounds"], tc.pretrain["episodes"],
                tc.pretrain["epochs"], tc.features, (obs, actions), action_repeat=tc.action_repeat,
                relative_actions=tc.relative_actions, keep_std=tc.pretrain["keep_std"],
            )  # fmt: skip
        pretrain_stats.update(samples=len(obs), nll=nll, seconds=time.perf_counter() - t0)
        print(f"pretrained on {len(obs)} decisions of {teacher} (final NLL {nll:.2f})")
    callback = _nav_callback_class()()
    model.learn(total_timesteps=tc.n_timesteps, callback=callback, progress_bar=progress, tb_log_name=tc.algo)
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
    }
    return model_path, stats


# ---------------------------------------------------------------------------------------------------------
# Evaluation
# ---------------------------------------------------------------------------------------------------------


@dataclass
class EvalResult:
    """Metrics of one agent over held-out episodes, the per-episode values the statistics use, and the
    mean curves used by the plots. ``skipped`` holds the reason when the agent could not run here."""

    name: str
    metrics: dict[str, Any]
    pos_err_curve: np.ndarray
    pos_sigma_curve: np.ndarray
    episode_mean_err: np.ndarray = field(default_factory=lambda: np.zeros(0))  # km, one per seed
    seeds: tuple[int, ...] = ()
    skipped: str | None = None

    @property
    def ran(self) -> bool:
        return self.skipped is None


def _skipped(name: str, reason: str) -> EvalResult:
    return EvalResult(name, {"skipped": reason}, np.zeros(0), np.zeros(0), skipped=reason)


def _episode(agent: Any, env: Any, seed: int, on_step: Callable[[], None]) -> dict[str, Any]:
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    err, sig, vel, measured = [], [], [], 0
    slews, ret, diverged = 0, 0.0, False
    t0 = time.perf_counter()
    while True:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        err.append(info["pos_err_km"])
        sig.append(info["pos_sigma_km"])
        vel.append(info["vel_err_km_s"])
        measured += bool(info["measured"])
        slews += bool(info["slewing"])
        ret += float(reward)
        on_step()
        if terminated or truncated:
            diverged = bool(terminated)
            break
    return {
        "pos_err": np.asarray(err),
        "pos_sigma": np.asarray(sig),
        "mean_vel_err_km_s": float(np.mean(vel)),
        "measured_fraction": measured / len(err),
        "slews": slews,
        "return": ret,
        "diverged": diverged,
        "seconds": time.perf_counter() - t0,
    }


def _padded_mean(curves: Sequence[np.ndarray]) -> np.ndarray:
    n = max(len(c) for c in curves)
    out = np.full((len(curves), n), np.nan)
    for i, c in enumerate(curves):
        out[i, : len(c)] = c
    return np.nanmean(out, axis=0)


def evaluate_agent(
    spec: str, env_cfg: EnvConfig, episodes: int, seed: int, progress: bool = True
) -> EvalResult:
    """Run agent ``spec`` (name, ``name:key=value,...`` or model path) on seeds ``seed, seed+1, ...``.

    Raises :class:`planetnav_agents.NotApplicableError` when the agent cannot act in this environment.
    """
    from tqdm.auto import tqdm

    from planetnav_env.env import PlanetNavEnv

    reason = not_applicable(spec, env_cfg)
    if reason:
        raise NotApplicableError(reason)
    # Only the idle agent gets the extra "camera off" action: the others keep the trained action space.
    overrides = {"idle_action": True} if requires_idle_action(spec) else {}
    env = PlanetNavEnv(env_cfg, **overrides)
    agent = make_agent(spec, env)
    name = getattr(agent, "name", spec)
    bar = tqdm(
        total=episodes * env_cfg.episode_steps,
        desc=f"eval {name}",
        unit="step",
        disable=not progress,
        leave=False,
    )
    runs = [_episode(agent, env, seed + i, lambda: bar.update(1)) for i in range(episodes)]
    bar.close()
    env.close()
    final = np.array([r["pos_err"][-1] for r in runs])
    per_episode = np.array([np.mean(r["pos_err"]) for r in runs])
    # The filter's own 1-sigma varies far less from seed to seed than the error drawn around it, so
    # paired differences of it resolve what the error's cannot (docs/training.md, 100-seed checks).
    per_episode_sigma = [float(np.mean(r["pos_sigma"])) for r in runs]
    ci = mean_ci(per_episode)
    metrics = {
        "episodes": episodes,
        "seed": seed,
        "noise_streams": env_cfg.noise_streams,
        "mean_pos_err_km": ci.mean,
        "mean_pos_err_ci95_km": [ci.low, ci.high],
        "final_pos_err_km": float(np.mean(final)),
        "final_pos_err_std_km": float(np.std(final)),
        "final_pos_err_ci95_km": [mean_ci(final).low, mean_ci(final).high],
        "final_pos_sigma_km": float(np.mean([r["pos_sigma"][-1] for r in runs])),
        "mean_pos_sigma_km": float(np.mean(per_episode_sigma)),
        "mean_vel_err_km_s": float(np.mean([r["mean_vel_err_km_s"] for r in runs])),
        "measured_fraction": float(np.mean([r["measured_fraction"] for r in runs])),
        "slews": float(np.mean([r["slews"] for r in runs])),
        "return": float(np.mean([r["return"] for r in runs])),
        "diverged": int(sum(r["diverged"] for r in runs)),
        "seconds_per_episode": float(np.mean([r["seconds"] for r in runs])),
        "per_episode_mean_pos_err_km": per_episode.tolist(),
        "per_episode_mean_pos_sigma_km": per_episode_sigma,
    }
    return EvalResult(
        name=name,
        metrics=metrics,
        pos_err_curve=_padded_mean([r["pos_err"] for r in runs]),
        pos_sigma_curve=_padded_mean([r["pos_sigma"] for r in runs]),
        episode_mean_err=per_episode,
        seeds=tuple(range(seed, seed + episodes)),
    )


def add_paired(results: Sequence[EvalResult], reference: str) -> EvalResult | None:
    """Adds ``metrics["vs_reference"]`` (mean of the per-seed differences agent - reference of the mean
    position error [km] with its paired 95 % t-interval, and the ratio of the means) to every agent that
    ran on the reference's seeds. The reference is the result whose name is ``reference`` (or starts with
    ``reference:``); returns it, or None when it did not run."""
    ref = next(
        (r for r in results if r.ran and (r.name == reference or r.name.startswith(reference + ":"))), None
    )
    if ref is None:
        return None
    for r in results:
        if not r.ran or r.seeds != ref.seeds:
            continue
        d = paired_difference(r.episode_mean_err, ref.episode_mean_err)
        ds = paired_difference(
            r.metrics["per_episode_mean_pos_sigma_km"], ref.metrics["per_episode_mean_pos_sigma_km"]
        )
        r.metrics["vs_reference"] = {
            "reference": ref.name,
            "mean_diff_km": d.mean,
            "ci95_km": [d.low, d.high],
            "ratio": r.metrics["mean_pos_err_km"] / ref.metrics["mean_pos_err_km"],
            "outside_noise": d.excludes_zero(),
            "mean_sigma_diff_km": ds.mean,
            "sigma_ci95_km": [ds.low, ds.high],
        }
    return ref


def compare_agents(
    specs: Sequence[str],
    env_cfg: EnvConfig,
    episodes: int,
    seed: int,
    progress: bool = True,
    reference: str = REFERENCE,
) -> list[EvalResult]:
    """Evaluate each agent on the same seeds (so the same initial states and estimate errors); agents that
    cannot act in this environment are kept as skipped rows with the reason; paired differences against
    ``reference`` (see :func:`add_paired`)."""
    results = []
    for s in specs:
        try:
            results.append(evaluate_agent(s, env_cfg, episodes, seed, progress))
        except NotApplicableError as exc:
            results.append(_skipped(str(s), str(exc)))
    add_paired(results, reference)
    return results


def results_json(results: Sequence[EvalResult]) -> dict[str, Any]:
    """``{"agents": {name: metrics}, "skipped": {name: reason}}`` (names made unique if two agents share
    one)."""
    out: dict[str, Any] = {}
    skipped: dict[str, str] = {}
    for r in results:
        if not r.ran:
            skipped[r.name] = str(r.skipped)
            continue
        key, k = r.name, 2
        while key in out:
            key, k = f"{r.name}#{k}", k + 1
        out[key] = r.metrics
    return {"agents": out, "skipped": skipped}


def _paired_cell(r: EvalResult, mean_key: str, ci_key: str) -> str:
    """A paired difference from ``metrics["vs_reference"]`` as ``"+d [lo, hi]"`` for the tables."""
    vs = r.metrics.get("vs_reference")
    if vs is None:
        return "-"
    if vs["reference"] == r.name:
        return "(reference)"
    return MeanCI(vs[mean_key], *vs[ci_key], r.metrics["episodes"], math.nan, 0.95).format("{:+.1f}")


def _vs_reference(r: EvalResult) -> tuple[str, str]:
    """(the paired difference of the mean error, the ratio of the means) against the reference."""
    vs = r.metrics.get("vs_reference")
    ratio = "-" if vs is None else ("1.00" if vs["reference"] == r.name else f"{vs['ratio']:.2f}")
    return _paired_cell(r, "mean_diff_km", "ci95_km"), ratio


def _sigma_vs_reference(r: EvalResult) -> str:
    """The paired difference of the filter's mean 1-sigma against the reference."""
    return _paired_cell(r, "mean_sigma_diff_km", "sigma_ci95_km")


TABLE_HEAD = (
    "agent",
    "mean err km [95% CI]",
    "Δ vs ref km [95% CI]",
    "ratio",
    "Δ 1σ vs ref km [95% CI]",
    "final err km",
    "final 1σ km",
    "measured",
    "slews",
    "s/episode",
)


def table_rows(results: Sequence[EvalResult]) -> list[list[str]]:
    rows = []
    for r in results:
        if not r.ran:
            rows.append([r.name, "skipped (note below)", *[""] * (len(TABLE_HEAD) - 2)])
            continue
        m = r.metrics
        ci = MeanCI(m["mean_pos_err_km"], *m["mean_pos_err_ci95_km"], m["episodes"], math.nan, 0.95)
        diff, ratio = _vs_reference(r)
        rows.append(
            [
                r.name,
                ci.format("{:.1f}"),
                diff,
                ratio,
                _sigma_vs_reference(r),
                f"{m['final_pos_err_km']:.1f}",
                f"{m['final_pos_sigma_km']:.1f}",
                f"{m['measured_fraction']:.2f}",
                f"{m['slews']:.1f}",
                f"{m['seconds_per_episode']:.2f}",
            ]
        )
    return rows


def _reference_name(results: Sequence[EvalResult]) -> str | None:
    return next(
        (r.metrics["vs_reference"]["reference"] for r in results if "vs_reference" in r.metrics), None
    )


def table_head(results: Sequence[EvalResult]) -> list[str]:
    """:data:`TABLE_HEAD` with the reference agent's name in the paired columns."""
    head = list(TABLE_HEAD)
    ref = _reference_name(results)
    if ref:
        head[2] = f"Δ vs {ref} km [95% CI]"
        head[4] = f"Δ 1σ vs {ref} km [95% CI]"
    return head


def markdown_table(results: Sequence[EvalResult]) -> str:
    head = table_head(results)
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(results)]
    lines += [f"\nSkipped `{n}`: {why}" for n, why in skipped_notes(results)]
    return "\n".join(lines)


def skipped_notes(results: Sequence[EvalResult]) -> list[tuple[str, str]]:
    """(name, reason) of the agents that could not run in this environment."""
    return [(r.name, str(r.skipped)) for r in results if not r.ran]


def print_table(results: Sequence[EvalResult], title: str | None = None) -> None:
    from rich.console import Console
    from rich.table import Table

    rows = table_rows(results)
    ran = [r for r in results if r.ran]
    if title is None:
        n = ran[0].metrics["episodes"] if ran else 0
        first = ran[0].metrics["seed"] if ran else 0
        title = f"planetnav agents: {n} held-out seeds ({first}..{first + n - 1}), paired on the same seeds"
    table = Table(title=title)
    for i, h in enumerate(table_head(results)):
        table.add_column(h, justify="left" if i == 0 else "right", no_wrap=True)
    for row in rows:
        table.add_row(*row)
    console = Console()
    if not console.is_terminal:
        # Logs and pipes: rich would assume 80 columns and truncate the agent names.
        console = Console(width=200)
    console.print(table)
    for name, why in skipped_notes(results):
        console.print(f"skipped {name}: {why}", highlight=False)


def write_plots(results: Sequence[EvalResult], out_dir: Path, step_s: float) -> list[str]:
    """Mean position error and 1-sigma vs time, one line per agent (Agg PNGs); returns the file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    for attr, fname, ylabel in (
        ("pos_err_curve", "pos_err.png", "position error [km] (mean over episodes)"),
        ("pos_sigma_curve", "pos_sigma.png", "filter position 1-sigma, sqrt(tr P_rr) [km]"),
    ):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for r in results:
            if not r.ran:
                continue
            curve = getattr(r, attr)
            hours = (np.arange(len(curve)) + 1) * step_s / 3600.0
            ax.plot(hours, curve, label=r.name, lw=1.2)
        ax.set_yscale("log")
        ax.set_xlabel("time [h]")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out_dir / fname, dpi=110)
        plt.close(fig)
        names.append(fname)
    return names


def write_training_plot(episodes: Sequence[tuple[int, float, float]], out_dir: Path) -> str | None:
    """Training episode return and final position error vs timesteps; None without finished episodes."""
    if not episodes:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps, ret, err = (np.asarray(v, dtype=float) for v in zip(*episodes, strict=True))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a1.plot(steps, ret, ".", ms=3)
    a1.set_ylabel("episode return")
    a2.plot(steps, err, ".", ms=3)
    a2.set_yscale("log")
    a2.set_ylabel("final pos err [km]")
    a2.set_xlabel("timesteps")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_dir / "training.png", dpi=110)
    plt.close(fig)
    return "training.png"


def write_report(
    out_dir: Path,
    results: Sequence[EvalResult],
    env_cfg: EnvConfig,
    title: str,
    train_stats: dict[str, Any] | None = None,
    tc: TrainConfig | None = None,
) -> Path:
    """``report.md`` + plots + ``eval.json`` in ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    plots = write_plots(results, out_dir, env_cfg.step_s)
    training_plot = write_training_plot(train_stats["episodes"], out_dir) if train_stats else None
    with open(out_dir / "eval.json", "w") as fh:
        json.dump(results_json(results), fh, indent=2)
    ran = [r for r in results if r.ran]
    m0 = ran[0].metrics if ran else {"episodes": 0, "seed": 0}
    lines = [
        f"# {title}",
        "",
        f"Scenario `{env_cfg.scenario}`, planets {', '.join(env_cfg.planets)}, action mode "
        f"`{env_cfg.action_mode}`, {env_cfg.episode_steps} steps of {env_cfg.step_s:g} s, "
        f"{m0['episodes']} held-out episodes (seeds {m0['seed']}..{m0['seed'] + m0['episodes'] - 1}), "
        "the same seeds for every agent"
        + (
            "; per-step noise streams (the same sensor noise for every agent wherever it makes the same "
            "measurement at the same step)."
            if env_cfg.noise_streams == "per_step"
            else "."
        ),
        "",
    ]
    if train_stats and tc:
        lines += [
            f"Training: {tc.algo.upper()} `{tc.policy}`, {train_stats['timesteps']} decisions "
            f"({train_stats['env_steps']} environment steps, action_repeat {tc.action_repeat}) on "
            f"{tc.n_envs} envs in {train_stats['seconds']:.0f} s "
            f"({train_stats['steps_per_s']:.0f} env steps/s, environment + learning), seed {tc.seed}; "
            f"features {tc.features or 'none'}; shaping "
            f"{tc.shaping or 'none'}. Evaluation {train_stats.get('eval_seconds', 0):.0f} s.",
            "",
        ]
    lines += [
        markdown_table(results),
        "",
        "Mean err: per-step true position error averaged over the episode, then over episodes, with the "
        "95 % Student-t interval over the episodes. Δ vs ref: mean over seeds of (agent - reference) of the "
        "episode's mean error, with the paired 95 % t-interval (an interval containing 0 means the "
        "difference is inside the seed-to-seed noise); ratio: the agent's mean / the reference's. Δ 1σ vs "
        "ref: the same paired difference for the filter's own position 1-sigma, sqrt(trace P_rr) averaged "
        "over the episode (what the covariance reward measures; it varies far less from seed to seed than "
        "the error drawn around it, so its interval resolves differences the error's cannot). Final: "
        "at the last step (mean over episodes). Final 1σ: sqrt(trace P_rr) of the filter at the last step. "
        "Measured: fraction of steps with a camera measurement. Slews: target changes per episode. "
        "s/episode: wall time per episode including the agent's own computation. eval.json has the "
        "per-episode values, the velocity error and the return.",
        "",
    ]
    lines += [f"![{p}]({p})" for p in plots]
    if training_plot:
        lines += ["", f"![training]({training_plot})"]
    path = out_dir / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


# ---------------------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------------------


def _eval_env_config(args: argparse.Namespace, specs: Sequence[str]) -> tuple[EnvConfig, EvalSettings]:
    """The env of ``--config``, else of the first model run directory's ``config.yaml``, else defaults."""
    if args.config:
        tc = load_config(args.config)
    else:
        tc = parse_config({})
        for s in specs:
            try:
                sidecar = resolve_model_path(strip_sampled(s)).parent / "config.yaml"
            except FileNotFoundError:
                sidecar = rllib_config_sidecar(strip_sampled(s))  # an RLlib run or checkpoint directory
                if sidecar is None:
                    continue
            if sidecar.is_file():
                tc = load_config(sidecar)
                break
    steps = args.episode_steps or tc.eval.episode_steps
    noise = args.noise_streams or tc.eval.noise_streams
    return evaluation_env(tc.env_config(), steps, noise), tc.eval


def evaluation_env(env_cfg: EnvConfig, episode_steps: int | None, noise_streams: str | None) -> EnvConfig:
    """``env_cfg`` with the evaluation's overrides of the episode length and the noise streams (None:
    keep the env's own)."""
    overrides: dict[str, Any] = {}
    if episode_steps:
        overrides["episode_steps"] = episode_steps
    if noise_streams:
        overrides["noise_streams"] = noise_streams
    return EnvConfig.from_dict(env_cfg.to_dict(), **overrides) if overrides else env_cfg


def cmd_train(args: argparse.Namespace) -> int:
    tc = load_config(args.config)
    if args.timesteps:
        tc.n_timesteps = args.timesteps
    if args.seed is not None:
        if args.seed < 0:
            raise ConfigError(f"--seed must be >= 0, got {args.seed}")
        tc.seed = args.seed
    run_dir = Path(args.run_dir) if args.run_dir else ROOT / "runs" / tc.name
    progress = not args.no_progress
    print(f"training {tc.algo.upper()} for {tc.n_timesteps} steps on {tc.n_envs} envs -> {run_dir}")
    if is_rllib_algo(tc.algo):
        from planetnav_rl.rllib import train as train_rllib

        model_path, stats = train_rllib(tc, run_dir, address=args.address, progress=progress)
    elif args.address:
        raise ConfigError(f"--address {args.address!r}: only RLlib configs (algo: rllib_ppo) train on Ray")
    else:
        model_path, stats = train(tc, run_dir, progress=progress)
    print(
        f"trained {stats['timesteps']} decisions = {stats.get('env_steps', stats['timesteps'])} env steps"
        + (f" + the teacher's {stats['teacher_env_steps']}" if stats.get("teacher_env_steps") else "")
        + f" in {stats['seconds']:.0f} s ({stats['steps_per_s']:.0f} env steps/s)"
    )
    if args.no_eval:
        return 0
    env_cfg = evaluation_env(tc.env_config(), tc.eval.episode_steps, tc.eval.noise_streams)
    # The trained policy twice: its argmax (the usual deterministic evaluation) and its sampled actions,
    # which on this problem can differ a lot (docs/training.md).
    specs = [str(model_path), f"{model_path}@sampled", *tc.eval.agents]
    t0 = time.perf_counter()
    results = compare_agents(specs, env_cfg, tc.eval.episodes, tc.eval.seed, progress, tc.eval.reference)
    stats["eval_seconds"] = time.perf_counter() - t0
    print_table(results)
    print(
        f"wall time: training {stats['seconds']:.0f} s + evaluation {stats['eval_seconds']:.0f} s = "
        f"{(stats['seconds'] + stats['eval_seconds']) / 60:.1f} min"
    )
    report = write_report(run_dir, results, env_cfg, f"Run `{tc.name}`", stats, tc)
    print(f"report: {report}")
    return 0


def _write_json(path: str, data: Any) -> None:
    """``data`` as indented JSON at ``path`` (the ``--json`` option of the commands), folders created."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(data, indent=2))


def cmd_evaluate(args: argparse.Namespace) -> int:
    env_cfg, ev = _eval_env_config(args, [args.agent])
    episodes = args.episodes or ev.episodes
    seed = ev.seed if args.seed is None else args.seed
    result = evaluate_agent(args.agent, env_cfg, episodes, seed, progress=not args.no_progress)
    print_table([result])
    if args.json:
        _write_json(args.json, results_json([result]))
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    env_cfg, ev = _eval_env_config(args, args.agents)
    episodes = args.episodes or ev.episodes
    seed = ev.seed if args.seed is None else args.seed
    reference = args.reference or ev.reference
    results = compare_agents(args.agents, env_cfg, episodes, seed, not args.no_progress, reference)
    print_table(results)
    if args.json:
        _write_json(args.json, results_json(results))
    if args.report:
        print(f"report: {write_report(Path(args.report), results, env_cfg, 'Agent comparison')}")
    return 0


def _evaluation_entry(given: str) -> tuple[str, dict[str, Any]]:
    """``FILE:AGENT`` (an ``eval.json`` or a ``--json`` output and one of its agents) -> (agent, metrics)."""
    # Agent names hold colons (ppo:run, periodic:period=10): the file is the shortest prefix that exists.
    cuts = [i for i, ch in enumerate(given) if ch == ":" and Path(given[:i]).is_file()]
    if not cuts or cuts[0] == len(given) - 1:
        raise ConfigError(f"paired: expected FILE:AGENT with an existing evaluation file, got {given!r}")
    path, agent = given[: cuts[0]], given[cuts[0] + 1 :]
    try:
        agents = json.loads(Path(path).read_text())["agents"]
    except (ValueError, KeyError, TypeError):
        raise ConfigError(f"paired: {path!r} is not an evaluation JSON (no 'agents')") from None
    if agent not in agents:
        raise ConfigError(f"paired: no agent {agent!r} in {path}; it has {sorted(agents)}")
    return agent, agents[agent]


def cmd_paired(args: argparse.Namespace) -> int:
    """Paired difference of two evaluations on the same seeds, which may come from two environments (the
    same policy in target and target+torque mode) or two runs of ``compare``."""
    (name_a, a), (name_b, b) = _evaluation_entry(args.a), _evaluation_entry(args.b)
    if (a["seed"], a["episodes"]) != (b["seed"], b["episodes"]):
        raise ConfigError(
            f"paired: the evaluations ran on different seeds: {args.a} on {a['episodes']} from {a['seed']}, "
            f"{args.b} on {b['episodes']} from {b['seed']}"
        )
    diff = paired_difference(a["per_episode_mean_pos_err_km"], b["per_episode_mean_pos_err_km"])
    print(
        f"{name_a}: {a['mean_pos_err_km']:.1f} km, {name_b}: {b['mean_pos_err_km']:.1f} km; paired "
        f"difference (first - second) {diff.format('{:+.1f}')} km on {a['episodes']} seeds from {a['seed']}"
    )
    # Files written before the key existed used the sequential stream.
    streams = (a.get("noise_streams", "sequential"), b.get("noise_streams", "sequential"))
    if streams[0] != streams[1]:
        print(
            f"note: {args.a} drew {streams[0]} noise, {args.b} {streams[1]}: the two share no sensor noise, "
            "so the pairing is by seed only (docs/training.md, common random numbers)"
        )
    per_seed = np.subtract(a["per_episode_mean_pos_err_km"], b["per_episode_mean_pos_err_km"])
    q05, q50, q95 = np.percentile(per_seed, [5, 50, 95])
    print(f"per seed: 5 % quantile {q05:+.1f} km, median {q50:+.1f} km, 95 % quantile {q95:+.1f} km")
    key = "per_episode_mean_pos_sigma_km"
    if key in a and key in b:  # evaluation files written before this key have the error only
        sig = paired_difference(a[key], b[key])
        print(
            f"filter 1-sigma (mean over the day): {a['mean_pos_sigma_km']:.1f} km vs "
            f"{b['mean_pos_sigma_km']:.1f} km; paired difference {sig.format('{:+.1f}')} km"
        )
    return 0


def cmd_agreement(args: argparse.Namespace) -> int:
    """How often a trained policy picks another planet than a teacher on the policy's own states."""
    from planetnav_agents.pretrain import agreement

    env_cfg, ev = _eval_env_config(args, [args.student])
    episodes = args.episodes or 5
    seed = ev.seed if args.seed is None else args.seed
    try:
        got = agreement(args.student, env_cfg, args.teacher, episodes, seed)
    except ValueError as exc:
        raise ConfigError(f"agreement: {exc}") from None
    residual = got["mean_abs_residual"]
    print(
        f"{args.student} vs {args.teacher} on {episodes} episodes from seed {seed}: another planet at "
        f"{100 * got['different']:.1f} % of {got['decisions']} decisions"
        + (f"; mean |residual torque| {residual:.4f} of the action range" if math.isfinite(residual) else "")
    )
    if args.json:
        if not math.isfinite(residual):
            got["mean_abs_residual"] = None  # target mode: no residual torque (JSON has no NaN)
        _write_json(args.json, {"student": args.student, "teacher": args.teacher, "episodes": episodes,
                                "seed": seed, **got})  # fmt: skip
    return 0


DEFAULT_SWEEP_PERIODS = (10, 20, 30, 60, 120, 240)
DEFAULT_SWEEP_CYCLES = ("0-1", "0-2", "1-2", "0-1-2", "0-2-1")


def sweep_periodic(
    env_cfg: EnvConfig,
    periods: Sequence[int],
    cycles: Sequence[str],
    episodes: int,
    seed: int,
    progress: bool = True,
) -> list[EvalResult]:
    """Every ``periodic:period=P,cycle=C`` on the same seeds, best (lowest mean error) first, with paired
    differences against the best."""
    specs = [f"periodic:period={p},cycle={c}" for c in cycles for p in periods]
    results = [evaluate_agent(s, env_cfg, episodes, seed, progress) for s in specs]
    results.sort(key=lambda r: r.metrics["mean_pos_err_km"])
    add_paired(results, results[0].name)
    return results


def cmd_sweep_periodic(args: argparse.Namespace) -> int:
    env_cfg, _ = _eval_env_config(args, [])
    if env_cfg.action_mode != "target":
        raise ConfigError("sweep-periodic runs in action_mode 'target' (use a target-mode --config)")
    episodes = args.episodes or EVAL_EPISODES
    seed = SWEEP_SEED if args.seed is None else args.seed
    t0 = time.perf_counter()
    results = sweep_periodic(env_cfg, args.periods, args.cycles, episodes, seed, not args.no_progress)
    print_table(
        results,
        title=f"periodic schedules: {episodes} seeds ({seed}..{seed + episodes - 1}), paired with the best",
    )
    best = results[0]
    print(f"best: {best.name} (mean err {best.metrics['mean_pos_err_km']:.1f} km); "
          f"{len(results)} settings in {time.perf_counter() - t0:.0f} s")  # fmt: skip
    if args.json:
        _write_json(args.json, {**results_json(results), "best": best.name})
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter
    )
    sub = p.add_subparsers(dest="command")

    t = sub.add_parser("train", help="train an SB3 agent from a YAML config, then evaluate and report")
    t.add_argument("--config", default=str(DEFAULT_CONFIG), help="training YAML (default %(default)s)")
    t.add_argument("--run-dir", help="output directory (default runs/<name>)")
    t.add_argument("--timesteps", type=int, help="override n_timesteps")
    t.add_argument("--seed", type=int, help="override the config's training seed (spread across runs)")
    t.add_argument("--no-eval", action="store_true", help="skip the evaluation and report")
    t.add_argument("--address", help="RLlib only: join the Ray cluster at HOST:PORT (default: a local Ray)")
    t.set_defaults(func=cmd_train)

    def cmd_tune(args: argparse.Namespace) -> int:
        from planetnav_rl.tune import cmd_tune as run_tune

        return run_tune(args)

    tn = sub.add_parser("tune", help="Ray Tune sweep over an SB3 or RLlib config (needs the [ray] extra)")
    tn.add_argument("--config", required=True, help="sweep YAML (e.g. configs/sweep.yaml)")
    tn.add_argument("--address", help="join the Ray cluster at HOST:PORT (default: a local Ray)")
    tn.add_argument("--run-dir", help="output directory (default runs/<sweep name>)")
    tn.add_argument("--resume", action="store_true", help="continue an interrupted sweep in --run-dir")
    tn.add_argument("--num-cpus", type=int, help="CPUs of the local Ray (default: all)")
    tn.set_defaults(func=cmd_tune)

    def common(sp: argparse.ArgumentParser) -> None:
        sp.add_argument(
            "--episodes", type=int, help="episodes per agent (default: the config's eval.episodes)"
        )
        sp.add_argument("--seed", type=int, help=f"first held-out seed (default {EVAL_SEED})")
        sp.add_argument("--config", help="YAML whose env (and eval) sections define the environment")
        sp.add_argument("--episode-steps", type=int, help="override the episode length")
        sp.add_argument(
            "--noise-streams",
            choices=NOISE_STREAMS,
            help="override the env's noise_streams: per_step gives every agent the same sensor noise "
            "wherever it makes the same measurement (common random numbers; docs/training.md)",
        )
        sp.add_argument("--json", help="write the metrics as JSON here")

    e = sub.add_parser("evaluate", help="evaluate one agent (name or SB3 model path)")
    e.add_argument(
        "--agent", required=True, help="planner, greedy, periodic:period=60,cycle=0-1-2, ... or a model path"
    )
    common(e)
    e.set_defaults(func=cmd_evaluate)

    c = sub.add_parser("compare", help="evaluate several agents on the same seeds and print one table")
    c.add_argument("--agents", nargs="+", default=list(DEFAULT_AGENTS), help="names and/or model paths")
    c.add_argument("--report", help="also write report.md, plots and eval.json into this directory")
    c.add_argument("--reference", help=f"paired differences against this agent (default {REFERENCE})")
    common(c)
    c.set_defaults(func=cmd_compare)

    pr = sub.add_parser(
        "paired", help="paired difference of two evaluation JSONs on the same seeds (e.g. two action modes)"
    )
    pr.add_argument("--a", required=True, help="FILE:AGENT, e.g. runs/x/eval.json:ppo:x")
    pr.add_argument("--b", required=True, help="FILE:AGENT, subtracted from --a")
    pr.set_defaults(func=cmd_paired)

    ag = sub.add_parser(
        "agreement", help="how often a trained policy picks another planet than a teacher, on its own states"
    )
    ag.add_argument("--student", required=True, help="a train.py run directory or model .zip")
    ag.add_argument("--teacher", required=True, help="an agent spec or another run (it labels the states)")
    common(ag)
    ag.set_defaults(func=cmd_agreement)

    w = sub.add_parser(
        "sweep-periodic",
        help=f"every periodic schedule of a grid on seeds {SWEEP_SEED}.. (not the evaluation seeds)",
    )
    w.add_argument(
        "--periods", nargs="+", type=int, default=list(DEFAULT_SWEEP_PERIODS), help="steps per planet"
    )
    w.add_argument(
        "--cycles", nargs="+", default=list(DEFAULT_SWEEP_CYCLES), help="planet cycles, e.g. 0-1-2"
    )
    common(w)
    w.set_defaults(func=cmd_sweep_periodic)

    for sp in (t, e, c, w, tn):
        sp.add_argument("--no-progress", action="store_true", help="no progress bars")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        argv = ["train"]  # python train.py: the default training run
    args = build_parser().parse_args(argv)
    if args.command is None:
        build_parser().print_help()
        return 2
    try:
        return args.func(args)
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
