"""Training configuration: :class:`TrainConfig` (one run, RL-Zoo style) with its ``eval:`` section
:class:`EvalSettings`, read from YAML by :func:`load_config` and validated by :func:`parse_config`.

Every key is checked (``configs/README.md`` lists them); an unknown or ill-typed value raises
:class:`~planetnav_env.errors.ConfigError` naming it, before anything is trained.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from planetnav_env.config import NOISE_STREAMS, EnvConfig
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError, with_prefix
from planetnav_train.features import check_features
from planetnav_train.moved_options import NO_OP_VALUES, moved_option_error, moved_options_in
from planetnav_train.sb3 import ALGORITHMS, algorithm_class
from planetnav_train.shaping import SHAPINGS

#: The repository checkout this package sits in: ``configs/`` and the default ``runs/`` live here.
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CONFIG = ROOT / "configs" / "cruise_ppo.yaml"
#: ``algo`` values of a training configuration that train with RLlib (:mod:`planetnav_rl.rllib`) instead of
#: Stable-Baselines3 (:data:`planetnav_train.sb3.ALGORITHMS`).
RLLIB_ALGOS = ("rllib_ppo",)
DEFAULT_AGENTS = ("planner", "greedy", "periodic", "baseline", "random", "idle")
EVAL_SEED = 10_000
EVAL_EPISODES = 20
REFERENCE = "greedy"


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
    # "native": n_envs rows of the compiled vector env (planetnav_train.vec_training); "dummy": n_envs single
    # environments in SB3's DummyVecEnv (the path for the gain / pd_torque features and shaping).
    vec_env: str = "native"
    hyperparams: dict[str, Any] = field(default_factory=dict)
    env: dict[str, Any] = field(default_factory=dict)
    eval: EvalSettings = field(default_factory=EvalSettings)
    # Extra observation features (planetnav_train.features). The decision interface (the hold, relative
    # targets, since_measured) is the env's: options of the ``env`` section (planetnav_train.moved_options).
    features: list[str] = field(default_factory=list)
    shaping: dict[str, float] = field(default_factory=dict)  # potential-based, training only (agents/shaping)
    # Decisions between checkpoints in RUN_DIR/resume/ (train.py train --resume RUN_DIR continues a killed run
    # from the last one; planetnav_train.checkpoint); 0: none.
    checkpoint_every: int = 50_000
    pretrain: dict[str, Any] = field(
        default_factory=dict
    )  # behaviour-cloning warm start (planetnav_train/pretrain.py)

    def env_config(self) -> EnvConfig:
        """The environment configuration: the ``env_id``'s defaults overridden by ``env`` (a section given
        there, ``filter: {accel_psd: ...}``, updates the id's section key by key)."""
        base: dict[str, Any] = {}
        if self.env_id is not None:
            if self.env_id not in ENV_IDS:
                raise ConfigError(f"env_id {self.env_id!r} is not one of {sorted(ENV_IDS)}")
            base = dict(ENV_IDS[self.env_id])
        return EnvConfig.from_dict(base, **self.env)

    def to_dict(self) -> dict[str, Any]:
        """The configuration as plain YAML-able data (what ``config.yaml`` of a run holds)."""
        out = dataclasses.asdict(self)
        out["eval"]["agents"] = list(self.eval.agents)
        return out


_TOP_KEYS = {f.name for f in dataclasses.fields(TrainConfig)}
_EVAL_KEYS = {f.name for f in dataclasses.fields(EvalSettings)}


def is_rllib_algo(algo: str) -> bool:
    """Whether ``algo`` (any case) names an RLlib algorithm (see :data:`RLLIB_ALGOS`)."""
    return str(algo).lower() in RLLIB_ALGOS


def _check_keys(data: Mapping[str, Any], known: set[str], where: str) -> None:
    """Raise :class:`ConfigError` naming the keys of ``data`` that ``known`` lacks."""
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; known keys: {sorted(known)}")


def parse_config(data: Mapping[str, Any] | None, name: str = "run") -> TrainConfig:
    """Validate a configuration mapping (unknown keys raise :class:`ConfigError` naming them)."""
    data = dict(data or {})
    _check_moved_options(data)
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
    for key in ("n_timesteps", "n_envs", "torch_threads"):
        value = getattr(tc, key)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ConfigError(f"config: {key} must be a positive integer, got {value!r}")
    if (
        isinstance(tc.checkpoint_every, bool)
        or not isinstance(tc.checkpoint_every, int)
        or tc.checkpoint_every < 0
    ):
        raise ConfigError(f"config: checkpoint_every must be an integer >= 0, got {tc.checkpoint_every!r}")
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
    tc.pretrain = dict(tc.pretrain or {})
    if tc.pretrain:
        _check_keys(
            tc.pretrain,
            {"teacher", "teacher_config", "episodes", "epochs", "keep_std", "dagger_rounds", "balance"},
            "config.pretrain",
        )
        if not isinstance(tc.pretrain.setdefault("keep_std", False), bool):
            raise ConfigError(
                f"config.pretrain: keep_std must be true or false, got {tc.pretrain['keep_std']!r}"
            )
        if not isinstance(tc.pretrain.setdefault("balance", False), bool):
            raise ConfigError(
                f"config.pretrain: balance must be true or false, got {tc.pretrain['balance']!r}"
            )
        if ("teacher" in tc.pretrain) == ("teacher_config" in tc.pretrain):
            raise ConfigError(
                "config.pretrain: give either 'teacher' (an agent spec) or 'teacher_config' (a training "
                "YAML to train first), not both or neither"
            )
        if "teacher_config" in tc.pretrain:
            given = tc.pretrain["teacher_config"]
            if not resolve_config_path(given).is_file():
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


def _check_moved_options(data: dict[str, Any]) -> None:
    """A :class:`ConfigError` naming the env option for a training-side decision option of ``data``
    (``action_repeat``, ``relative_actions``, ``features: [since_measured]``), before anything else; their
    no-op values (``action_repeat: 1``, ``relative_actions: false``, in every older run's ``config.yaml``)
    are dropped from ``data``."""
    moved = moved_options_in(data)
    if moved:
        name, value = moved[0]
        if name == "since_measured":
            raise with_prefix(moved_option_error(name), "config: features")
        base = 1
        env_id, env = data.get("env_id"), data.get("env")
        if isinstance(env, Mapping) and isinstance(env.get("decision_steps"), int):
            base = env["decision_steps"]
        elif env_id in ENV_IDS:
            base = int(ENV_IDS[env_id].get("decision_steps", 1))
        raise with_prefix(moved_option_error(name, value, base), "config")
    for name in NO_OP_VALUES:
        data.pop(name, None)


def resolve_config_path(path: str | Path) -> Path:
    """A config path as given, or relative to the repository root (``configs/X.yaml`` from anywhere)."""
    p = Path(path)
    return p if p.is_absolute() or p.is_file() else ROOT / p


def read_yaml_mapping(path: Path, what: str) -> Mapping[str, Any]:
    """The top-level mapping of the YAML file ``path`` (an empty file reads as ``{}``), or a ConfigError:
    ``no {what} {path}`` when the file is missing, or naming the file when its top level is not a mapping.
    The one reader of the training and sweep configuration files."""
    if not path.is_file():
        raise ConfigError(f"no {what} {path}")
    with open(path) as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    return data


def load_config(path: str | Path) -> TrainConfig:
    """Read and validate a YAML training configuration; the run name defaults to the file's stem."""
    path = Path(path)
    data = read_yaml_mapping(path, "configuration file")
    try:
        return parse_config(data, name=path.stem)
    except ConfigError as exc:
        raise with_prefix(exc, str(path)) from None


def _init_parameters(cls: type) -> dict[str, inspect.Parameter]:
    """The named constructor parameters of ``cls``: a subclass whose ``__init__`` passes ``*args,
    **kwargs`` through (``agents.masking``'s MaskablePPO) takes its base class's."""
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    params: dict[str, inspect.Parameter] = {}
    for klass in cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is None:
            continue
        own = inspect.signature(init).parameters
        params = {**{k: v for k, v in own.items() if v.kind not in variadic}, **params}
        if not any(v.kind == inspect.Parameter.VAR_KEYWORD for v in own.values()):
            break
    return params


def _check_hyperparams(tc: TrainConfig) -> None:
    """Reject ``hyperparams`` keys the algorithm's constructor does not take (or that are set from other
    keys)."""
    if is_rllib_algo(tc.algo):  # RLlib's PPOConfig keywords (needs the [ray] extra), checked by its trainer
        from planetnav_train import extensions

        check = extensions.trainer(tc.algo).check_hyperparams
        if check is not None:
            check(tc.hyperparams)
        return
    params = _init_parameters(algorithm_class(tc.algo))
    # Set by the training code from other keys; a user value would be silently overwritten.
    reserved = {"self", "policy", "env", "seed", "tensorboard_log", "verbose", "device", "_init_setup_model"}
    known = set(params) - reserved
    _check_keys(tc.hyperparams, known, f"config.hyperparams ({tc.algo})")
