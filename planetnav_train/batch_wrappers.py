"""The training recipe's options, written once over a batch of N rows (as Brax's wrappers are).

Every option ``train.py``'s recipe adds to the environment is a layer over :class:`Rows`, a batch of N
planetnav environment rows stepped together; a single environment is the batch with N = 1.

====================================== ===================================================================
class                                  what it does to the rows
====================================== ===================================================================
:class:`VectorRows`                    the native vector env (:class:`~planetnav_env.envs.vector_env.
                                       PlanetNavVectorEnv`) as rows: one compiled step for all of them
:class:`SingleEnvRows`                 any (wrapped) single planetnav env as one row (N = 1)
:class:`PointingShapingRows`           adds the potential-based pointing term to the reward
                                       (:class:`planetnav_train.shaping.PointingPotential`)
:class:`PointingBonusRows`             adds the per-step pointing bonus ``Phi(s')`` (not potential-based)
:class:`FeatureRows`                   appends the observation features (:class:`planetnav_train.
                                       features.FeatureBatch`: ``gain``, ``pd_torque``)
====================================== ===================================================================

The decision interface is the environment's, under these layers: one step of a row is one decision of
the env (``EnvConfig.decision_steps`` physics steps, rewards summed), in the env's target actions
(``target_actions``), with its observation (``observe_since_measured``); ``docs/environment.md``. So
the pointing shaping, a difference of potentials between steps, is taken between decisions, whose
discount ``gamma`` is, and the pointing bonus is added once a decision.

:func:`training_rows` stacks the layers in the recipe's order (the pointing bonus innermost: it reads the
raw observation). Two adapters expose a stack: :class:`planetnav_train.vec_training.NavTrainingVecEnv` as
an SB3 ``VecEnv`` over N rows (training), and :class:`RowsEnv` as a Gymnasium env over one row
(:func:`single_training_env`). Both run the same code, so a row of the batch equals the single env seeded
alike, bit for bit (``tests/train/test_vec_training.py``).

Conventions of a :class:`Rows` (why: the adapters reset finished rows themselves, and a row that has
ended must not be stepped again before its reset):

* ``step_rows(actions, active)`` advances only the ``active`` rows (bool (N,)) by one decision and
  returns ``(reward (N,) float64, terminated (N,) bool, truncated (N,) bool)``, zero / False for the
  others; it never resets a row. ``actions`` holds N actions (an array, or a sequence for N = 1).
* ``reset_rows(mask, seed, options)`` resets the rows of ``mask``.
* ``observations()`` and ``filter_state()`` read the rows as they are now.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planetnav_agents.base import unwrapped_config
from planetnav_env.config import EnvConfig
from planetnav_train.features import FeatureBatch, filter_columns
from planetnav_train.moved_options import MOVED_OPTIONS, moved_option_error
from planetnav_train.shaping import PointingPotential, check_shaping


class Rows:
    """N planetnav environment rows stepped together (interface; module docstring for the conventions).

    ``config``: the rows' shared :class:`EnvConfig`; ``core_params``: their compiled parameter record;
    ``observation_space`` / ``action_space``: one row's spaces.
    """

    num_rows: int
    config: EnvConfig
    core_params: Any
    observation_space: spaces.Space
    action_space: spaces.Space

    def __init__(
        self,
        num_rows: int,
        config: EnvConfig,
        core_params: Any,
        observation_space: spaces.Space,
        action_space: spaces.Space,
    ) -> None:
        self.num_rows = num_rows
        self.config = config
        self.core_params = core_params
        self.observation_space = observation_space
        self.action_space = action_space

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        raise NotImplementedError

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def observations(self) -> Any:
        """(N, D) observations as the layer returns them."""
        raise NotImplementedError

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Each row's filter estimate (N, 6) [km, km/s] and covariance (N, 6, 6) [km^2, km^2/s, km^2/s^2]."""
        raise NotImplementedError

    def row_info(self, row: int) -> dict[str, Any]:
        """Row ``row``'s info after its last reset / step (the single env's form, plus the layers' keys)."""
        raise NotImplementedError


class RowsWrapper(Rows):
    """A layer over ``inner``: delegates everything it does not change."""

    def __init__(self, inner: Rows) -> None:
        super().__init__(
            inner.num_rows, inner.config, inner.core_params, inner.observation_space, inner.action_space
        )
        self.inner = inner

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        self.inner.reset_rows(mask, seed, options)

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.inner.step_rows(actions, active)

    def observations(self) -> Any:
        return self.inner.observations()

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.inner.filter_state()

    def row_info(self, row: int) -> dict[str, Any]:
        return self.inner.row_info(row)


class VectorRows(RowsWrapper):
    """The native vector env's rows (its public accessors; it must not autoreset: the layers and the
    adapters reset finished rows themselves). The vector env has ``step_rows``, ``observations`` and
    ``filter_state`` with the meaning :class:`Rows` gives them, so they pass through to it as to any inner
    layer; the other accessors have other names there."""

    def __init__(self, venv: Any) -> None:
        Rows.__init__(
            self,
            venv.num_envs,
            venv.config,
            venv.core_params,
            venv.single_observation_space,
            venv.single_action_space,
        )
        self.inner = self.venv = venv

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        mask = np.asarray(mask, dtype=bool)
        if mask.all():
            self.venv.reset(seed=seed, options=options)
        else:
            self.venv.reset(seed=seed, options={**(options or {}), "reset_mask": mask})

    def row_info(self, row: int) -> dict[str, Any]:
        return self.venv.info_row(row)


class SingleEnvRows(Rows):
    """A single planetnav env (wrapped or not) as one row: the N = 1 end of every layer. Reads what it
    needs from the env's step results (``info``), so any Gymnasium wrapper may sit in between."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(
            1, unwrapped_config(env), env.unwrapped.core_params, env.observation_space, env.action_space
        )
        self.env = env
        self._obs: Any = None
        self._info: dict[str, Any] = {}

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        if np.asarray(mask, dtype=bool).reshape(-1)[0]:
            self._obs, self._info = self.env.reset(seed=seed, options=options)

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not np.asarray(active, dtype=bool).reshape(-1)[0]:
            return np.zeros(1), np.zeros(1, dtype=bool), np.zeros(1, dtype=bool)
        self._obs, reward, terminated, truncated, self._info = self.env.step(actions[0])
        return np.array([float(reward)]), np.array([bool(terminated)]), np.array([bool(truncated)])

    def observations(self) -> Any:
        return [self._obs]  # a list: a dict observation passes through unchanged

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        return filter_columns(self._info)

    def row_info(self, row: int) -> dict[str, Any]:
        return self._info


class PointingShapingRows(RowsWrapper):
    """Adds ``F = gamma * Phi(s') - Phi(s)`` (:class:`planetnav_train.shaping.PointingPotential`) to
    each stepped row's reward; ``Phi`` = 0 in a terminal state. ``row_info`` gains ``"shaping"``, the term
    added at the row's last step."""

    def __init__(self, inner: Rows, weight: float, gamma: float) -> None:
        super().__init__(inner)
        self.potential = PointingPotential(self.config, weight)
        self.gamma = check_shaping(weight, gamma)[1]
        self._phi = np.zeros(self.num_rows)
        self._shaping = np.full(self.num_rows, np.nan)  # NaN: no step since the row's reset

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        self.inner.reset_rows(mask, seed, options)
        mask = np.asarray(mask, dtype=bool)
        self._phi[mask] = self.potential(self.inner.observations())[mask]
        self._shaping[mask] = np.nan

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        reward, terminated, truncated = self.inner.step_rows(actions, active)
        active = np.asarray(active, dtype=bool)
        # Terminal states have potential 0 (the standard convention that keeps the invariance).
        phi = np.where(terminated, 0.0, self.potential(self.inner.observations()))
        shaping = self.gamma * phi - self._phi
        reward = np.where(active, reward + shaping, reward)
        self._phi[active] = phi[active]
        self._shaping[active] = shaping[active]
        return reward, terminated, truncated

    def row_info(self, row: int) -> dict[str, Any]:
        info = self.inner.row_info(row)
        return info if np.isnan(self._shaping[row]) else {**info, "shaping": float(self._shaping[row])}


class PointingBonusRows(RowsWrapper):
    """Adds ``Phi(s')`` (:class:`planetnav_train.shaping.PointingPotential` with weight ``weight``
    [reward units]) of each stepped row's new observation to its reward: a per-step pointing bonus, not
    potential-based (:mod:`planetnav_train.shaping`: reported as shaping). ``row_info`` gains
    ``"pointing_bonus"``, the term added at the row's last step."""

    def __init__(self, inner: Rows, weight: float) -> None:
        super().__init__(inner)
        self.potential = PointingPotential(self.config, weight)
        self._bonus = np.full(self.num_rows, np.nan)  # NaN: no step since the row's reset

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        self.inner.reset_rows(mask, seed, options)
        self._bonus[np.asarray(mask, dtype=bool)] = np.nan

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        reward, terminated, truncated = self.inner.step_rows(actions, active)
        active = np.asarray(active, dtype=bool)
        bonus = self.potential(self.inner.observations())
        self._bonus[active] = bonus[active]
        return np.where(active, reward + bonus, reward), terminated, truncated

    def row_info(self, row: int) -> dict[str, Any]:
        info = self.inner.row_info(row)
        return info if np.isnan(self._bonus[row]) else {**info, "pointing_bonus": float(self._bonus[row])}


class FeatureRows(RowsWrapper):
    """Appends :class:`planetnav_train.features.FeatureBatch`'s features to the rows' box observations."""

    def __init__(self, inner: Rows, features: Sequence[str]) -> None:
        super().__init__(inner)
        self.batch = FeatureBatch(self.config, self.core_params, features, self.num_rows)
        self.observation_space = self.batch.observation_space(inner.observation_space)

    def observations(self) -> np.ndarray:
        obs = self.inner.observations()
        x, p = self.inner.filter_state() if self.batch.needs_filter else (None, None)
        return self.batch.augment(np.asarray(obs, dtype=np.float32), x, p)


@dataclass(frozen=True, kw_only=True)
class TrainingOptions:
    """The training recipe's options over the environment: the one list of them, whose fields (by
    keyword) are the options of :func:`training_rows`, :func:`single_training_env` and
    :class:`planetnav_train.vec_training.NavTrainingVecEnv`.

    ``features``: observation features appended (``gain``, ``pd_torque``); ``pointing``: the pointing
    shaping's weight [reward units] (None / 0: none); ``gamma``: its discount (the algorithm's, per
    decision); ``pointing_bonus``: the per-decision pointing bonus's weight [reward units] (None / 0: none;
    not potential-based). The layers validate them. The decision interface is the env's
    (:func:`options`, :mod:`planetnav_train.moved_options`).
    """

    features: Sequence[str] = ()
    pointing: float | None = None
    gamma: float = 0.99
    pointing_bonus: float | None = None

    def stack(self, inner: Rows) -> Rows:
        """``inner`` with these options in the recipe's order: the pointing bonus, the features, the
        pointing shaping (``Phi`` reads only the env's own observation blocks, not the appended
        features)."""
        rows = inner
        if self.pointing_bonus:
            rows = PointingBonusRows(rows, check_shaping(self.pointing_bonus, 1.0)[0])
        if self.features:
            rows = FeatureRows(rows, self.features)
        if self.pointing:
            rows = PointingShapingRows(rows, self.pointing, self.gamma)
        return rows


def options(**kwargs: Any) -> TrainingOptions:
    """:class:`TrainingOptions` of ``kwargs``; a training-side decision option (``action_repeat``,
    ``relative_actions``) raises the :class:`~planetnav_env.errors.ConfigError` that names the env option
    replacing it."""
    for name in MOVED_OPTIONS:
        if name in kwargs:
            raise moved_option_error(name, kwargs[name])
    if "since_measured" in (kwargs.get("features") or ()):
        raise moved_option_error("since_measured")
    return TrainingOptions(**kwargs)


def training_rows(inner: Rows, **kwargs: Any) -> Rows:
    """``inner`` with the recipe's options (:class:`TrainingOptions`' fields) stacked in their order."""
    return options(**kwargs).stack(inner)


class RowsEnv(gym.Wrapper):
    """One row of ``build(SingleEnvRows(env))`` as a Gymnasium env: the single-env form of a layer stack.

    ``reset`` / ``step`` return what the stack's row 0 holds (observation, summed reward, flags, the info
    of the last environment step plus the layers' keys).
    """

    def __init__(self, env: gym.Env, build: Any) -> None:
        super().__init__(env)
        self.rows: Rows = build(SingleEnvRows(env))
        if self.rows.num_rows != 1:
            raise ValueError(f"RowsEnv needs a stack of one row, got {self.rows.num_rows}")
        self.observation_space = self.rows.observation_space
        self.action_space = self.rows.action_space
        self._one = np.ones(1, dtype=bool)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict[str, Any]]:
        self.rows.reset_rows(self._one, seed, options)
        return self.rows.observations()[0], self.rows.row_info(0)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        reward, terminated, truncated = self.rows.step_rows([action], self._one)
        obs = self.rows.observations()[0]
        return obs, float(reward[0]), bool(terminated[0]), bool(truncated[0]), self.rows.row_info(0)


def single_training_env(env: gym.Env, **kwargs: Any) -> RowsEnv:
    """A single planetnav env with the recipe's options (:class:`TrainingOptions`' fields; the stack of
    :func:`training_rows` with N = 1): what each env of SB3's ``DummyVecEnv`` path runs
    (``vec_env: dummy``)."""
    return RowsEnv(env, options(**kwargs).stack)
