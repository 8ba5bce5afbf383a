"""Extra observation features for learned policies, computed from what the spacecraft knows.

One implementation serves training and evaluation: :class:`FeatureBatch` appends the features to N rows
of box observations; :class:`planetnav_train.batch_wrappers.FeatureRows` drives it over the rows of the
training env (config key ``features``; N rows of the vector env, or one single env), and
:class:`planetnav_train.sb3.SB3Agent` rebuilds the same state (N = 1) from the run's ``config.yaml`` so
that a saved policy sees identical inputs when it is evaluated. The relative-action and action-repeat
formulas here are likewise the ones :mod:`planetnav_train.batch_wrappers` runs.

Deprecated names (a ``DeprecationWarning`` on construction, same behaviour): ``FeatureState`` (use
``FeatureBatch.for_env``), ``NavFeatures``, ``ActionRepeat``, ``RelativeTargets`` (the N = 1 stacks of
:mod:`planetnav_train.batch_wrappers`; use ``single_training_env``).

========================== ===========================================================================
feature                    values appended (``P`` planets), each in [0, 1] unless stated
========================== ===========================================================================
``since_measured``         per planet: ``log1p(steps since it was last measured) / log1p(1440)``, capped
                           at 1 (1 when never measured this episode), from ``info["measured"]`` and
                           ``info["target"]``. Lets a feed-forward policy time its switches, which the
                           base observation (a snapshot of the filter) cannot express.
``gain``                   per planet: the greedy agent's predicted reduction of trace(P_rr) per step
                           over its horizon (3 steps, and at least ``greedy-pd``'s 180 s when the
                           step is shorter than 60 s: :func:`gain_horizon`), slew time counted,
                           relative to the best
                           planet's (1 = greedy's choice), -1 if not observable
                           (:func:`planetnav_agents.gain.planet_gains`). Compiled, a few microseconds per
                           row.
``pd_torque``              per planet, 3 values in [-1, 1]: the wheel torque (fraction of the limit) of
                           the agent-side PD law toward that planet's estimated direction
                           (:class:`planetnav_agents.base.PointingLaw`, what ``baseline`` commands in
                           torque mode). For torque modes: the policy chooses and blends pointing
                           commands instead of rediscovering attitude control.
========================== ===========================================================================

These are inputs, not rewards: the reward stays the environment's navigation error.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planetnav_agents.base import unwrapped_config, with_planet_choice
from planetnav_agents.gain import DEFAULT_HORIZON, SlewModel, planet_gains
from planetnav_env.attitude import quaternion as qt
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import (  # noqa: F401 (re-exported: the recipe's names)
    SINCE_SCALE_STEPS,
    advance_since_measured,
    relative_targets,
    relative_to_absolute,
    since_measured_values,
)

_DEG = math.pi / 180.0  # the observation's rates are in deg/s

FEATURES = ("since_measured", "gain", "pd_torque")
#: Values per planet of each feature.
_WIDTH = {"since_measured": 1, "gain": 1, "pd_torque": 3}


def gain_horizon(step_s: float) -> int:
    """The ``gain`` feature's horizon [steps] at an environment step of ``step_s`` seconds: greedy's
    ``DEFAULT_HORIZON`` (3 steps), or ``greedy-pd``'s horizon kept in time
    (``GREEDY_PD_HORIZON_S`` / ``step_s``) when that is longer. Why: at the 1-s step of the wheel-torque
    tasks 3 steps never outweigh a ~100-s slew, and the feature's argmax should be the choice of the
    reference those tasks clone (``greedy-pd``); at 60 s and above both give 3 steps, as before."""
    from planetnav_agents.greedy import GREEDY_PD_HORIZON_S

    if not (isinstance(step_s, int | float) and math.isfinite(step_s) and step_s > 0):
        raise ValueError(f"step_s must be a positive number of seconds, got {step_s!r}")
    return max(DEFAULT_HORIZON, round(GREEDY_PD_HORIZON_S / step_s))


class GainFeature:
    """The ``gain`` feature of a configuration: :func:`planetnav_agents.gain.planet_gains` with greedy's
    slew model and horizon (:func:`gain_horizon`), for rows of box observations and the filter states
    that go with them."""

    def __init__(self, cfg: Any, params: Any) -> None:
        self.params = params
        self.slew = SlewModel.from_config(cfg)
        self.n_planets = cfg.n_planets
        self.horizon = gain_horizon(float(cfg.step_s))

    def __call__(self, observations: np.ndarray, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """(N, P) float32 for observations (N, D), estimates (N, 6) and covariances (N, 6, 6)."""
        return planet_gains(self.params, self.slew, self.horizon, observations, x, p, self.n_planets)


def check_features(features: Sequence[str]) -> tuple[str, ...]:
    """The feature names, validated (``ValueError`` naming an unknown or repeated one)."""
    out = tuple(str(f) for f in features)
    for f in out:
        if f not in FEATURES:
            raise ValueError(f"unknown observation feature {f!r}; choose from {list(FEATURES)}")
    if len(set(out)) != len(out):
        raise ValueError(f"observation features repeat: {list(out)}")
    return out


def check_action_repeat(repeat: Any) -> int:
    """``repeat`` (environment steps per policy decision), validated: ``ValueError`` naming it unless an
    integer >= 1.

    Why a repeat: the payoff of a target switch builds up over tens of steps, and a policy that decides
    every step has to express "dwell ~10 steps" through its own timing; with one decision per dwell the
    best fixed schedules (``periodic:period=10``) become a two-state rule the one-hot current target
    already carries, and the credit-assignment horizon shrinks ``repeat`` times. The reward is still the
    navigation error, summed over the held steps; an episode that ends inside a hold ends the decision.
    """
    if isinstance(repeat, bool) or not isinstance(repeat, int | np.integer) or repeat < 1:
        raise ValueError(f"action_repeat must be an integer >= 1, got {repeat!r}")
    return int(repeat)


def step_columns(
    info: dict[str, Any], planets: Sequence[str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One step's ``info`` (single env) as the columns of one row that the features read: measured (1,)
    bool, target index (1,) in ``planets`` (-1 for none or a pulsar), the filter estimate (1, 6)
    [km, km/s] and covariance (1, 6, 6)."""
    target = info.get("target")
    index = planets.index(target) if target in planets else -1
    filt = info.get("filter") or {}
    x = np.reshape(filt["x"], (1, 6)) if "x" in filt else None
    p = np.reshape(filt["P"], (1, 6, 6)) if "P" in filt else None
    return np.array([bool(info.get("measured"))]), np.array([index]), x, p


class FeatureBatch:
    """The observation features of N rows of a configuration: their per-episode state and values.

    The one implementation: :class:`planetnav_train.batch_wrappers.FeatureRows` drives it over the
    rows of a training env (N rows of the vector env, or one single env), and agents that rebuild a
    policy's inputs (``planetnav_train.sb3``, ``planetnav_train.pretrain``) use it with N = 1 through
    :meth:`augment_info`.

    cfg: the rows' :class:`EnvConfig` (``observation="box"``); params: their compiled parameter record
    (``env.core_params``), for ``gain``'s what-if updates.
    """

    def __init__(self, cfg: Any, params: Any, features: Sequence[str], num_rows: int = 1) -> None:
        from planetnav_agents.base import PointingLaw

        if cfg.observation != "box":
            raise ValueError(f"observation features need observation='box', got {cfg.observation!r}")
        self.features = check_features(features)
        self.planets = cfg.planets
        self.n_planets = cfg.n_planets
        self.num_rows = int(num_rows)
        self.layout = L.ObservationLayout(cfg.n_planets, cfg.n_pulsars)
        self._gain = GainFeature(cfg, params) if "gain" in self.features else None
        self._pointing = PointingLaw(cfg) if "pd_torque" in self.features else None
        #: True when :meth:`augment` needs the filter's state (``gain``, ``pd_torque``).
        self.needs_filter = self._gain is not None or self._pointing is not None
        self.n_extra = self.n_planets * sum(_WIDTH[f] for f in self.features)
        self._since = np.full((self.num_rows, self.n_planets), np.inf)  # steps since last measured
        self._all = np.ones(self.num_rows, dtype=bool)

    @classmethod
    def for_env(cls, env: gym.Env, features: Sequence[str], num_rows: int = 1) -> FeatureBatch:
        """The features of ``env`` (a planetnav environment, wrapped or not)."""
        return cls(unwrapped_config(env), env.unwrapped.core_params, features, num_rows)

    def reset(self, mask: np.ndarray | None = None) -> None:
        """Start a new episode in the rows of ``mask`` (all rows when None)."""
        self._since[self._all if mask is None else np.asarray(mask, dtype=bool)] = np.inf

    def advance(self, measured: np.ndarray, targets: np.ndarray, rows: np.ndarray) -> None:
        """One environment step (or a reset's first observation) seen by the ``rows`` (bool (N,)):
        ``measured`` (N,) bool and ``targets`` (N,) target indices are every row's, as the step left them."""
        if "since_measured" not in self.features:
            return  # the only feature with per-episode state
        rows = np.asarray(rows, dtype=bool)
        since = self._since[rows]
        advance_since_measured(since, np.asarray(measured)[rows], np.asarray(targets)[rows])
        self._since[rows] = since

    def observation_space(self, base: spaces.Box) -> spaces.Box:
        """``base`` with :attr:`n_extra` more entries."""
        return spaces.Box(-np.inf, np.inf, (base.shape[0] + self.n_extra,), dtype=np.float32)

    def augment(self, observations: np.ndarray, x: np.ndarray | None, p: np.ndarray | None) -> np.ndarray:
        """Observations (N, D) with the features appended in the configured order, float32 (N, D + extra).

        x (N, 6) [km, km/s], p (N, 6, 6): the filter's state at the observations (needed when
        :attr:`needs_filter`). Reads the per-episode state; :meth:`advance` moves it."""
        obs = np.asarray(observations, dtype=np.float32)
        if not self.features:
            return obs
        n = obs.shape[0]
        parts = [obs]
        for f in self.features:
            if f == "since_measured":
                parts.append(since_measured_values(self._since))
            elif f == "gain":
                parts.append(self._gain(obs, x, p))
            else:  # pd_torque: planet-major, 3 torque components per planet
                q, rates, wheel, planets = observation_columns(obs, self.layout)
                directions = qt.rotate_body_to_inertial(q[:, None, :], planets[:, :, L.TF_DIR : L.TF_DIR + 3])
                torques = self._pointing.torque_actions(q, rates, wheel, directions, np.asarray(x)[:, :3])
                parts.append(torques.reshape(n, -1))
        return np.concatenate(parts, axis=1)

    def augment_info(self, observation: Any, info: dict[str, Any]) -> np.ndarray:
        """N = 1: the observation (D,) with the features appended (D + extra,), advancing the state with
        the step's ``info`` (call it with every observation, the reset's included)."""
        if self.num_rows != 1:
            raise ValueError(f"augment_info is the one-row form; this batch has {self.num_rows} rows")
        measured, target, x, p = step_columns(info, self.planets)
        self.advance(measured, target, self._all)
        return self.augment(np.reshape(observation, (1, -1)), x, p)[0]


@functools.lru_cache(maxsize=16)
def _block_bounds(layout: L.ObservationLayout) -> dict[str, tuple[int, int]]:
    """``{block name: (start, stop)}`` of ``layout`` (computed once per layout: this runs every step)."""
    return {name: (a, b) for name, a, b, _ in layout.blocks}


def observation_columns(
    observations: np.ndarray, layout: L.ObservationLayout
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows of box observations (N, D) in the units of :meth:`PlanetNavEnv.decode_observation` (the same
    operations, per row): unit star-tracker quaternion (N, 4), reported rates (N, 3) [rad/s], wheel
    momentum / capacity (N, 3), planet blocks (N, P, 7) (columns ``layout.TF_*``), float64."""
    obs = np.asarray(observations, dtype=float)
    blocks = _block_bounds(layout)
    a, b = blocks["attitude"]
    attitude = obs[:, a:b]
    q = attitude / np.linalg.norm(attitude, axis=-1, keepdims=True)
    a, b = blocks["rates"]
    rates = obs[:, a:b] * _DEG
    a, b = blocks["wheel_momentum"]
    wheel = obs[:, a:b]
    a, b = blocks["planets"]
    planets = obs[:, a:b].reshape(obs.shape[0], layout.n_planets, L.TARGET_FEATURES)
    return q, rates, wheel, planets


class FeatureState(FeatureBatch):
    """Deprecated: :class:`FeatureBatch` for one environment (``FeatureBatch.for_env(env, features)``,
    :meth:`FeatureBatch.augment_info`). Behaves as before: ``reset()``, ``augment(observation, info)``."""

    def __init__(self, env: gym.Env, features: Sequence[str]) -> None:
        warnings.warn(
            "planetnav_train.features.FeatureState is deprecated; use FeatureBatch.for_env(env, features) "
            "and its augment_info",
            DeprecationWarning,
            stacklevel=2,
        )
        super().__init__(unwrapped_config(env), env.unwrapped.core_params, features, 1)
        self.env = env

    def augment(self, observation: Any, info: Any, p: Any = None) -> np.ndarray:  # type: ignore[override]
        """The observation with the features appended (float32); advances the per-episode state."""
        return self.augment_info(observation, info)

    def augment_info(self, observation: Any, info: dict[str, Any]) -> np.ndarray:
        measured, target, x, p = step_columns(info, self.planets)
        self.advance(measured, target, self._all)
        return FeatureBatch.augment(self, np.reshape(observation, (1, -1)), x, p)[0]


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
    the target of ``a``. For teachers that act in absolute targets (``planetnav_train.pretrain``)."""
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
