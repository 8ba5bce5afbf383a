"""Extra observation features for learned policies, computed from what the spacecraft knows.

One implementation serves training and evaluation: :class:`FeatureBatch` appends the features to N rows
of box observations; :class:`planetnav_train.batch_wrappers.FeatureRows` drives it over the rows of the
training env (config key ``features``; N rows of the vector env, or one single env), and
:class:`planetnav_train.sb3.SB3Agent` rebuilds the same features (N = 1) from the run's ``config.yaml``
so that a saved policy sees identical inputs when it is evaluated.

The decision interface is the environment's, not a feature: the hold (``EnvConfig.decision_steps``),
relative targets (``target_actions``) and the steps since each target was last measured
(``observe_since_measured``, the ``since_measured`` observation block); ``docs/environment.md``.

========================== ===========================================================================
feature                    values appended (``P`` planets), each in [0, 1] unless stated
========================== ===========================================================================
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

Both are functions of the current observation and filter state: the features hold no per-episode state.
These are inputs, not rewards: the reward stays the environment's navigation error.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planetnav_agents.base import unwrapped_config
from planetnav_agents.gain import DEFAULT_HORIZON, SlewModel, planet_gains
from planetnav_env.attitude import quaternion as qt
from planetnav_env.core import layout as L
from planetnav_train.moved_options import moved_option_error

_DEG = math.pi / 180.0  # the observation's rates are in deg/s

FEATURES = ("gain", "pd_torque")
#: Values per planet of each feature.
_WIDTH = {"gain": 1, "pd_torque": 3}


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
    """The feature names, validated (``ValueError`` naming an unknown or repeated one;
    :class:`~planetnav_env.errors.ConfigError`, a ``ValueError``, naming the env option for
    ``since_measured``, the environment's ``observe_since_measured`` block)."""
    out = tuple(str(f) for f in features)
    for f in out:
        if f == "since_measured":
            raise moved_option_error("since_measured")
        if f not in FEATURES:
            raise ValueError(f"unknown observation feature {f!r}; choose from {list(FEATURES)}")
    if len(set(out)) != len(out):
        raise ValueError(f"observation features repeat: {list(out)}")
    return out


def filter_columns(info: dict[str, Any]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """One step's ``info`` (single env) as the filter state of one row: the estimate (1, 6) [km, km/s] and
    covariance (1, 6, 6) [km^2, km^2/s, km^2/s^2] (None where the info has no ``filter``)."""
    filt = info.get("filter") or {}
    x = np.reshape(filt["x"], (1, 6)) if "x" in filt else None
    p = np.reshape(filt["P"], (1, 6, 6)) if "P" in filt else None
    return x, p


class FeatureBatch:
    """The observation features of N rows of a configuration: their values from the rows' observations and
    filter states (the features hold no per-episode state).

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
        self.layout = L.ObservationLayout.for_config(cfg)
        self._gain = GainFeature(cfg, params) if "gain" in self.features else None
        self._pointing = PointingLaw(cfg) if "pd_torque" in self.features else None
        #: True when :meth:`augment` needs the filter's state (``gain``, ``pd_torque``).
        self.needs_filter = self._gain is not None or self._pointing is not None
        self.n_extra = self.n_planets * sum(_WIDTH[f] for f in self.features)

    @classmethod
    def for_env(cls, env: gym.Env, features: Sequence[str], num_rows: int = 1) -> FeatureBatch:
        """The features of ``env`` (a planetnav environment, wrapped or not)."""
        return cls(unwrapped_config(env), env.unwrapped.core_params, features, num_rows)

    def observation_space(self, base: spaces.Box) -> spaces.Box:
        """``base`` with :attr:`n_extra` more entries."""
        return spaces.Box(-np.inf, np.inf, (base.shape[0] + self.n_extra,), dtype=np.float32)

    def augment(self, observations: np.ndarray, x: np.ndarray | None, p: np.ndarray | None) -> np.ndarray:
        """Observations (N, D) with the features appended in the configured order, float32 (N, D + extra).

        x (N, 6) [km, km/s], p (N, 6, 6): the filter's state at the observations (needed when
        :attr:`needs_filter`)."""
        obs = np.asarray(observations, dtype=np.float32)
        if not self.features:
            return obs
        n = obs.shape[0]
        parts = [obs]
        for f in self.features:
            if f == "gain":
                parts.append(self._gain(obs, x, p))
            else:  # pd_torque: planet-major, 3 torque components per planet
                q, rates, wheel, planets = observation_columns(obs, self.layout)
                directions = qt.rotate_body_to_inertial(q[:, None, :], planets[:, :, L.TF_DIR : L.TF_DIR + 3])
                torques = self._pointing.torque_actions(q, rates, wheel, directions, np.asarray(x)[:, :3])
                parts.append(torques.reshape(n, -1))
        return np.concatenate(parts, axis=1)

    def augment_info(self, observation: Any, info: dict[str, Any]) -> np.ndarray:
        """N = 1: the observation (D,) with the features appended (D + extra,), the filter state read
        from the step's ``info``."""
        if self.num_rows != 1:
            raise ValueError(f"augment_info is the one-row form; this batch has {self.num_rows} rows")
        x, p = filter_columns(info)
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
