"""A saved Stable-Baselines3 model behind the :class:`~planetnav_agents.base.Agent` interface
(deterministic actions).

``path`` is a model ``.zip`` or a run directory written by ``train.py`` (``runs/<name>/``, which holds
``model.zip`` and ``config.yaml``). The algorithm comes from, in order: the ``algo`` argument, the
``algo`` key of a ``config.yaml`` next to the model, or trying each known SB3 algorithm until one loads.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import Agent, NotApplicableError, target_torque_action
from planetnav_env.core.decisions import relative_to_absolute
from planetnav_train.features import FeatureBatch
from planetnav_train.moved_options import moved_option_error, moved_options_in

#: Lower-case names -> SB3 classes (imported lazily: SB3 and torch take seconds to import).
ALGORITHMS = ("ppo", "a2c", "dqn", "sac", "td3", "ddpg", "recurrent_ppo", "maskable_ppo", "tqc")
#: The names of :data:`ALGORITHMS` that sb3-contrib provides (the ``bench`` extra) -> its class names;
#: ``maskable_ppo`` masks the unobservable targets (:mod:`planetnav_train.masking`).
CONTRIB_ALGORITHMS = {"recurrent_ppo": "RecurrentPPO", "maskable_ppo": "MaskablePPO", "tqc": "TQC"}


def algorithm_class(name: str) -> type:
    """The SB3 or sb3-contrib algorithm class for a lower-case name in :data:`ALGORITHMS`; a
    :class:`~planetnav_env.errors.ConfigError` naming the ``bench`` extra when sb3-contrib is missing."""
    key = str(name).lower()
    if key not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}; choose from {list(ALGORITHMS)}")
    if key in CONTRIB_ALGORITHMS:
        try:
            import sb3_contrib
        except ImportError:
            from planetnav_env.errors import ConfigError

            raise ConfigError(
                f'algorithm {key!r} needs sb3-contrib, which is not installed: pip install -e ".[bench]"'
            ) from None
        if key == "maskable_ppo":
            from planetnav_train.masking import masked_ppo_class

            return masked_ppo_class()
        return getattr(sb3_contrib, CONTRIB_ALGORITHMS[key])
    import stable_baselines3 as sb3

    return getattr(sb3, key.upper())


def resolve_model_path(path: str | Path) -> Path:
    """The model ``.zip`` for a run directory, a ``.zip`` path, or a path given without ``.zip``."""
    p = Path(path)
    if p.is_dir():
        p = p / "model.zip"
    elif not p.exists() and p.with_suffix(".zip").exists():
        p = p.with_suffix(".zip")
    if not p.is_file():
        raise FileNotFoundError(f"no SB3 model at {path} (expected a .zip or a run directory with model.zip)")
    return p


def _sidecar(model_path: Path) -> dict[str, Any]:
    """The run's ``config.yaml`` next to the model (empty when there is none)."""
    cfg = model_path.parent / "config.yaml"
    if not cfg.is_file():
        return {}
    import yaml

    with open(cfg) as fh:
        data = yaml.safe_load(fh) or {}
    return data if isinstance(data, dict) else {}


def _check_sidecar(model_path: Path, sidecar: dict[str, Any]) -> None:
    """A :class:`~planetnav_env.errors.ConfigError` naming the env option when the run's ``config.yaml``
    uses a training-side decision option (a run trained before the decision interface moved to the env);
    the no-op values an older ``config.yaml`` always holds pass
    (:func:`planetnav_train.moved_options.moved_options_in`)."""
    moved = moved_options_in(sidecar)
    if moved:
        err = moved_option_error(*moved[0])
        raise type(err)(f"{model_path.parent / 'config.yaml'}: {err}")


def _trained_relative(sidecar: dict[str, Any]) -> bool:
    """Whether the run's ``config.yaml`` trained on relative target actions (``env.target_actions``, or
    its ``env_id``'s)."""
    from planetnav_env.envs.registration import ENV_IDS

    env = sidecar.get("env") or {}
    base = ENV_IDS.get(sidecar.get("env_id"), {})
    return env.get("target_actions", base.get("target_actions", "absolute")) == "relative"


def _algo_from_sidecar(model_path: Path) -> str | None:
    algo = _sidecar(model_path).get("algo")
    return str(algo).lower() if algo else None


def load_model(path: str | Path, algo: str | None = None) -> Any:
    """Load an SB3 model on the CPU; see the module docstring for how the algorithm is found."""
    model_path = resolve_model_path(path)
    algo = algo or _algo_from_sidecar(model_path)
    if algo is not None:
        return algorithm_class(algo).load(model_path, device="cpu")
    errors = []
    for name in ALGORITHMS:
        try:
            return algorithm_class(name).load(model_path, device="cpu")
        except Exception as exc:
            errors.append(f"{name}: {type(exc).__name__}: {exc}")
    raise ValueError(f"could not load {model_path} with any of {list(ALGORITHMS)}:\n" + "\n".join(errors))


class SB3Agent(Agent):
    """Actions of a saved SB3 model (deterministic by default); checks the spaces match the environment's.

    The model acts once per step of ``env``, in ``env``'s decision interface (the one it was trained in:
    ``decision_steps``, ``observe_since_measured``). One translation: a target-choice model trained on
    relative target actions that acts in an environment of absolute ones (a ``target+torque`` env, a
    distillation's student) has its "stay" / "move k places" applied to the environment's current target
    (``info["target"]``, :func:`planetnav_env.core.decisions.relative_to_absolute`).

    ``deterministic=False`` samples the policy instead (analysis only: with ``reset(seed)`` the sampling
    is seeded through torch's global generator).
    """

    requires_idle_action = False

    def __init__(
        self,
        path: str | Path,
        env: gym.Env | None = None,
        algo: str | None = None,
        deterministic: bool = True,
        features: list[str] | None = None,
        model: Any | None = None,
    ) -> None:
        self.path = resolve_model_path(path)
        self.deterministic = bool(deterministic)
        # ``model``: an already-built model read from ``path`` (the shipped policy-only baselines, which
        # ``load_model`` does not read); the checks below hold for it as for a loaded SB3 model.
        self.model = load_model(self.path, algo) if model is None else model
        stem = self.path.parent.name if self.path.name == "model.zip" else self.path.stem
        self.name = f"{type(self.model).__name__.lower()}:{stem}" + (
            "" if self.deterministic else ":stochastic"
        )
        # Observation features the policy was trained with (config key ``features``), rebuilt here so the
        # policy sees the same inputs; ``features`` overrides the run's config.yaml.
        sidecar = _sidecar(self.path)
        _check_sidecar(self.path, sidecar)
        names = features if features is not None else sidecar.get("features") or []
        self._lstm: Any = None  # a recurrent policy's LSTM state (RecurrentPPO), reset with the episode
        cfg = env.unwrapped.config if env is not None else None
        self._n_planets = cfg.n_planets if cfg is not None else 0
        # Relative choices of the model applied to the env's current target (class docstring).
        self._targets = (*cfg.planets, *cfg.pulsars) if cfg is not None else ()
        self._to_absolute = (
            cfg is not None
            and cfg.target_actions != "relative"
            and _trained_relative(sidecar)
            and getattr(self.model.action_space, "n", None) is not None
        )
        self.features = FeatureBatch.for_env(env, names) if (names and env is not None) else None
        if names and env is None:
            raise ValueError(f"{self.path}: a policy with observation features needs the environment")
        # A target-choice policy (Discrete over the planets) in a target+torque environment picks the planet
        # with zero residual torque (planetnav_agents.base.target_torque_action): the target-mode action
        # is a subset.
        self._as_target_torque = (
            env is not None
            and env.unwrapped.config.action_mode == "target+torque"
            and getattr(self.model.action_space, "n", None) == self._n_planets
        )
        if env is not None:
            for what in ("observation_space", "action_space"):
                if what == "action_space" and self._as_target_torque:
                    continue
                mine, theirs = getattr(self.model, what), getattr(env, what)
                if what == "observation_space" and self.features is not None:
                    theirs = self.features.observation_space(theirs)
                if mine.shape != theirs.shape or type(mine) is not type(theirs):
                    raise NotApplicableError(
                        f"{self.path}: the model's {what} {mine} does not match the environment's {theirs}"
                    )
            n = getattr(env.action_space, "n", None)
            if n is not None and getattr(self.model.action_space, "n", None) != n:
                raise NotApplicableError(
                    f"{self.path}: the model has {self.model.action_space} actions, the environment "
                    f"{env.action_space} (was it trained with other planets or idle_action?)"
                )

    def reset(self, seed: int | None = None) -> None:
        self._lstm = None
        if not self.deterministic and seed is not None:
            import torch

            torch.manual_seed(seed)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        if self.features is not None:
            observation = self.features.augment_info(observation, info)
        action = self._decide(observation)
        if self._to_absolute:
            target = info.get("target")
            current = self._targets.index(target) if target in self._targets else -1
            action = relative_to_absolute(int(action), current, len(self._targets))
        if self._as_target_torque:
            action = target_torque_action(int(action), self._n_planets)
        return action

    def _decide(self, observation: Any) -> Any:
        if hasattr(self.model.policy, "lstm_actor"):  # RecurrentPPO: carry the LSTM state over the episode
            start = np.array([self._lstm is None])
            action, self._lstm = self.model.predict(
                observation, state=self._lstm, episode_start=start, deterministic=self.deterministic
            )
        else:
            action, _ = self.model.predict(observation, deterministic=self.deterministic)
        if np.ndim(action) == 0 or getattr(self.model.action_space, "n", None) is not None:
            return int(np.asarray(action).reshape(-1)[0])
        return np.asarray(action, dtype=np.float32)
