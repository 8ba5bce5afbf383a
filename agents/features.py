"""Extra observation features for learned policies, computed from what the spacecraft knows.

One implementation serves training and evaluation: :class:`FeatureState` appends the features to the
environment's box observation; :class:`NavFeatures` is the Gymnasium wrapper ``train.py`` puts around each
training environment (config key ``features``), and :class:`planetnav_agents.sb3.SB3Agent` rebuilds the
same state
from the run's ``config.yaml`` so that a saved policy sees identical inputs when it is evaluated.

========================== ===========================================================================
feature                    values appended (``P`` planets), each in [0, 1] unless stated
========================== ===========================================================================
``since_measured``         per planet: ``log1p(steps since it was last measured) / log1p(1440)``, capped
                           at 1 (1 when never measured this episode), from ``info["measured"]`` and
                           ``info["target"]``. Lets a feed-forward policy time its switches, which the
                           base observation (a snapshot of the filter) cannot express.
``gain``                   per planet: the greedy agent's predicted reduction of trace(P_rr) per step
                           over its horizon (3 steps), slew time counted, relative to the best
                           planet's (1 = greedy's choice), -1 if not observable
                           (:func:`planetnav_agents.gain.planet_gains`). Compiled, a few microseconds per row;
                           the vector training env computes it on arrays.
``pd_torque``              per planet, 3 values in [-1, 1]: the wheel torque (fraction of the limit) of
                           the agent-side PD law toward that planet's estimated direction
                           (:meth:`planetnav_agents.base.TargetAgent.torque_toward`, what ``baseline``
                           commands in
                           torque mode). For torque modes: the policy chooses and blends pointing
                           commands instead of rediscovering attitude control.
========================== ===========================================================================

These are inputs, not rewards: the reward stays the environment's navigation error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planetnav_agents.base import parse_observation, unwrapped_config, with_planet_choice
from planetnav_agents.gain import DEFAULT_HORIZON, SlewModel, planet_gains

FEATURES = ("since_measured", "gain", "pd_torque")
#: Scale of ``since_measured`` [steps]: a constant (one cruise day of 60-s steps), not the episode length,
#: so that a policy evaluated on shorter episodes than it was trained on sees the same values.
SINCE_SCALE_STEPS = 1440
_SINCE_LOG_SCALE = math.log1p(SINCE_SCALE_STEPS)
#: Values per planet of each feature.
_WIDTH = {"since_measured": 1, "gain": 1, "pd_torque": 3}


class GainFeature:
    """The ``gain`` feature of a configuration: :func:`planetnav_agents.gain.planet_gains` with greedy's
    horizon and
    slew model, for rows of box observations and the filter states that go with them."""

    def __init__(self, cfg: Any, params: Any) -> None:
        self.params = params
        self.slew = SlewModel.from_config(cfg)
        self.n_planets = cfg.n_planets

    def __call__(self, observations: np.ndarray, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """(N, P) float32 for observations (N, D), estimates (N, 6) and covariances (N, 6, 6)."""
        return planet_gains(self.params, self.slew, DEFAULT_HORIZON, observations, x, p, self.n_planets)


def check_features(features: Sequence[str]) -> tuple[str, ...]:
    """The feature names, validated (``ValueError`` naming an unknown or repeated one)."""
    out = tuple(str(f) for f in features)
    for f in out:
        if f not in FEATURES:
            raise ValueError(f"unknown observation feature {f!r}; choose from {list(FEATURES)}")
    if len(set(out)) != len(out):
        raise ValueError(f"observation features repeat: {list(out)}")
    return out


def advance_since_measured(since: np.ndarray, measured: np.ndarray, target_index: np.ndarray) -> None:
    """Advance the steps since each planet was last measured by one environment step, in place.

    since: (N, P) float counts (``inf``: not measured this episode). measured: (N,) bool, the step's
    ``info["measured"]``. target_index: (N,) int, the index in ``config.planets`` of what was measured
    (anything outside ``0 .. P - 1``, e.g. -1 or a pulsar, resets nothing). The one formula for the
    single-env wrapper (:class:`FeatureState`, N = 1) and the vector training env
    (``planetnav_agents.vec_training``).
    """
    since += 1.0
    n_planets = since.shape[1]
    target_index = np.asarray(target_index)
    rows = np.flatnonzero(np.asarray(measured, dtype=bool) & (target_index >= 0) & (target_index < n_planets))
    since[rows, target_index[rows]] = 0.0


def since_measured_values(since: np.ndarray) -> np.ndarray:
    """The ``since_measured`` feature (float32, same shape as ``since``): ``log1p(steps) /
    log1p(SINCE_SCALE_STEPS)`` capped at 1, and 1 for a planet not measured this episode."""
    scaled = np.log1p(np.where(np.isfinite(since), since, 0.0)) / _SINCE_LOG_SCALE
    return np.where(np.isfinite(since), np.minimum(scaled, 1.0), 1.0).astype(np.float32)


class FeatureState:
    """Per-episode state of the features of ``env`` (a planetnav environment, box observation).

    Call :meth:`reset` at the start of each episode, then :meth:`augment` with every observation and the
    ``info`` returned with it (including the first one, from ``env.reset``).
    """

    def __init__(self, env: gym.Env, features: Sequence[str]) -> None:
        cfg = unwrapped_config(env)
        if cfg.observation != "box":
            raise ValueError("observation features need observation='box'")
        self.env = env
        self.features = check_features(features)
        self.planets = cfg.planets
        self.n_planets = cfg.n_planets
        self._gain = GainFeature(cfg, env.unwrapped.core.params) if "gain" in self.features else None
        self._pointer = None
        if "pd_torque" in self.features:
            from planetnav_agents.base import TargetAgent

            self._pointer = TargetAgent(env)
        self.n_extra = self.n_planets * sum(_WIDTH[f] for f in self.features)
        self.reset()

    def reset(self) -> None:
        self._since = np.full((1, self.n_planets), np.inf)  # steps since last measured

    def observation_space(self, base: spaces.Box) -> spaces.Box:
        """``base`` with :attr:`n_extra` more entries."""
        return spaces.Box(-np.inf, np.inf, (base.shape[0] + self.n_extra,), dtype=np.float32)

    def augment(self, observation: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        """The observation with the features appended (float32); advances the per-episode state."""
        target = info.get("target")
        index = self.planets.index(target) if target in self.planets else -1
        advance_since_measured(self._since, np.array([bool(info.get("measured"))]), np.array([index]))
        parts = [np.asarray(observation, dtype=np.float32).reshape(-1)]
        for f in self.features:
            if f == "since_measured":
                parts.append(since_measured_values(self._since)[0])
            elif f == "gain":
                filt = info["filter"]
                parts.append(
                    self._gain(np.reshape(observation, (1, -1)), np.reshape(filt["x"], (1, 6)),
                               np.reshape(filt["P"], (1, 6, 6)))[0]
                )
            elif f == "pd_torque":
                parsed = parse_observation(observation, self.env)
                for i in range(self.n_planets):
                    parts.append(self._pointer.torque_toward(parsed, info, i).astype(np.float32))
        return np.concatenate(parts)


class NavFeatures(gym.Wrapper):
    """Appends :class:`FeatureState`'s features to a planetnav environment's box observation."""

    def __init__(self, env: gym.Env, features: Sequence[str]) -> None:
        super().__init__(env)
        self.state = FeatureState(env, features)
        self.observation_space = self.state.observation_space(env.observation_space)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self.state.reset()
        return self.state.augment(obs, info), info

    def step(self, action: Any):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.state.augment(obs, info), reward, terminated, truncated, info


class ActionRepeat(gym.Wrapper):
    """Holds each action for ``repeat`` environment steps (rewards summed): one decision per ``repeat``
    steps. The reward is still the navigation error, summed over the held steps; an episode that ends
    inside a hold ends the decision there.

    Why: the payoff of a target switch builds up over tens of steps, and a policy that decides every step
    has to express "dwell ~10 steps" through its own timing; with one decision per dwell the best fixed
    schedules (``periodic:period=10``) become a two-state rule the one-hot current target already
    carries, and the credit-assignment horizon shrinks ``repeat`` times.
    """

    def __init__(self, env: gym.Env, repeat: int) -> None:
        super().__init__(env)
        if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
            raise ValueError(f"action_repeat must be an integer >= 1, got {repeat!r}")
        self.repeat = repeat

    def step(self, action: Any):
        total = 0.0
        for _ in range(self.repeat):
            obs, reward, terminated, truncated, info = self.env.step(action)
            total += float(reward)
            if terminated or truncated:
                break
        return obs, total, terminated, truncated, info


def relative_targets(actions: np.ndarray, current: np.ndarray, n_targets: int) -> np.ndarray:
    """Target indices (N,) of *relative* actions (N,): 0 keeps the current target, ``k`` moves ``k``
    places along the planet order (``(current + k) mod n``). With no current target (``-1``, the first
    step) the count starts from target 0, so action ``k`` picks target ``k``. ``ValueError`` naming the
    row and the value for an action outside ``0 .. n_targets - 1``."""
    a = np.asarray(actions).reshape(-1)
    ok = np.isfinite(a) & (a == np.round(a)) & (a >= 0) & (a < n_targets)
    if not ok.all():
        r = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"relative action of row {r} must be in [0, {n_targets}), got {a[r].item()!r}")
    return (np.maximum(np.asarray(current, dtype=np.int64), 0) + a.astype(np.int64)) % n_targets


def relative_to_absolute(action: int, current: int, n_targets: int) -> int:
    """:func:`relative_targets` for one action."""
    return int(relative_targets(np.array([action]), np.array([current]), n_targets)[0])


def relative_actions_batch(
    actions: np.ndarray, current: np.ndarray, n_planets: int
) -> tuple[np.ndarray, np.ndarray]:
    """(the environment's actions, their target indices) for relative ``actions`` of N rows: integers
    (N,) in ``target`` mode; in ``target+torque`` mode Box actions (N, D) whose argmax over the first
    ``n_planets`` entries is the relative choice (rewritten as +1 on the absolute target, -1 elsewhere;
    the residual torque kept)."""
    a = np.asarray(actions)
    if a.ndim <= 1:
        targets = relative_targets(a, current, n_planets)
        return targets, targets
    targets = relative_targets(np.argmax(a[:, :n_planets], axis=1), current, n_planets)
    return with_planet_choice(a, targets, n_planets), targets


def relative_action(action: Any, current: int, n_planets: int) -> tuple[Any, int]:
    """:func:`relative_actions_batch` for one action: an integer, or a Box action (D,)."""
    a = np.asarray(action)
    if a.ndim == 0 or a.size == 1:
        target = relative_to_absolute(int(a.reshape(())), current, n_planets)
        return target, target
    out, targets = relative_actions_batch(a.reshape(1, -1), np.array([current]), n_planets)
    return out[0], int(targets[0])


def chosen_planet(action: Any, n_planets: int) -> int:
    """The planet an absolute target-choice action picks: the integer itself, or (``target+torque`` Box
    action of ``n_planets + 3`` entries) the argmax of its planet entries; -1 when it picks none (idle, a
    pulsar, a torque-mode action)."""
    a = np.asarray(action)
    if a.size == 1:
        idx = int(a.reshape(()))
    elif a.size == n_planets + 3:
        idx = int(np.argmax(a.reshape(-1)[:n_planets]))
    else:
        return -1
    return idx if 0 <= idx < n_planets else -1


def absolute_to_relative(action: Any, current: int, n_planets: int) -> tuple[Any, int]:
    """The relative action that makes :func:`relative_action` pick the target of the absolute ``action``
    (an integer, or a ``target+torque`` Box action whose argmax over the planet entries is the target),
    and that target. Its inverse: ``relative_action(absolute_to_relative(a, c, n)[0], c, n)`` chooses
    the target of ``a``. For teachers that act in absolute targets (``planetnav_agents.pretrain``)."""
    a = np.asarray(action)
    target = chosen_planet(a, n_planets)
    if target < 0:
        raise ValueError(f"absolute target must be in [0, {n_planets}), got {action!r}")
    k = (target - max(int(current), 0)) % n_planets
    if a.size == 1:
        return k, target
    return with_planet_choice(a.reshape(1, -1), np.array([k]), n_planets)[0], target


def check_relative_config(cfg: Any) -> None:
    """``ValueError`` unless relative target actions apply to the configuration ``cfg``."""
    if cfg.action_mode == "torque" or cfg.idle_action or cfg.n_pulsars:
        raise ValueError(
            "relative target actions need action_mode 'target' or 'target+torque', planets only, "
            "without idle_action"
        )


class RelativeTargets(gym.Wrapper):
    """Target choice with relative actions (:func:`relative_action`): "stay" or "move k places".

    Why: a policy that finds switching worthwhile but cannot yet tell *when* spreads its probability
    over the planets, and its argmax then stares at one (``docs/training.md``); in relative form the
    same indifference has the argmax "switch", a periodic schedule. The environment, its reward and what
    the camera can do are unchanged; only the encoding of the choice differs.
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        cfg = unwrapped_config(env)
        check_relative_config(cfg)
        self.n_planets = cfg.n_planets
        self._current = -1

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._current = -1
        return obs, info

    def step(self, action: Any):
        env_action, self._current = relative_action(action, self._current, self.n_planets)
        obs, reward, terminated, truncated, info = self.env.step(env_action)
        return obs, reward, terminated, truncated, info
