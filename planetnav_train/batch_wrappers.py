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
                                       features.FeatureBatch`: ``since_measured``, ``gain``, ``pd_torque``)
:class:`ActionRepeatRows`              holds each decision ``repeat`` steps, rewards summed
:class:`RelativeTargetRows`            "stay" / "move k places" target actions
====================================== ===================================================================

:func:`training_rows` stacks them in the recipe's order (shaping innermost: it reads the raw
observation; the relative choice outermost: made once per decision). Two adapters expose a stack:
:class:`planetnav_train.vec_training.NavTrainingVecEnv` as an SB3 ``VecEnv`` over N rows (training), and
:class:`RowsEnv` as a Gymnasium env over one row (:func:`single_training_env`, and the deprecated
single-env wrappers at the end of this module). Both run the same code, so a row
of the batch equals the single env seeded alike, bit for bit (``tests/train/test_vec_training.py``).

Conventions of a :class:`Rows` (why: a held decision steps only the rows still running, and an episode
that ends inside it must not be stepped again before its reset):

* ``step_rows(actions, active)`` advances only the ``active`` rows (bool (N,)) by one step of this layer
  and returns ``(reward (N,) float64, terminated (N,) bool, truncated (N,) bool)``, zero / False for the
  others; it never resets a row. ``actions`` holds N actions (an array, or a sequence for N = 1).
* ``reset_rows(mask, seed, options)`` resets the rows of ``mask``.
* ``observations()``, ``measured()``, ``targets()``, ``filter_state()`` read the rows as they are now.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planetnav_agents.base import unwrapped_config
from planetnav_env.config import EnvConfig
from planetnav_train.features import (
    FeatureBatch,
    check_action_repeat,
    check_relative_config,
    relative_actions_batch,
    step_columns,
)
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

    def measured(self) -> np.ndarray:
        """(N,) bool: the last environment step of each row gave an accepted measurement."""
        raise NotImplementedError

    def targets(self) -> np.ndarray:
        """(N,) int: each row's current target index (planets, then pulsars), -1 for none."""
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

    def measured(self) -> np.ndarray:
        return self.inner.measured()

    def targets(self) -> np.ndarray:
        return self.inner.targets()

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

    def measured(self) -> np.ndarray:
        return self.venv.measured_flags()

    def targets(self) -> np.ndarray:
        return self.venv.current_targets()

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

    def measured(self) -> np.ndarray:
        return step_columns(self._info, self.config.planets)[0]

    def targets(self) -> np.ndarray:
        return step_columns(self._info, self.config.planets)[1]

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        return step_columns(self._info, self.config.planets)[2:]

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
    """Appends :class:`planetnav_train.features.FeatureBatch`'s features to the rows' box observations;
    every environment step of a row advances its feature state (``since_measured`` counts steps)."""

    def __init__(self, inner: Rows, features: Sequence[str]) -> None:
        super().__init__(inner)
        self.batch = FeatureBatch(self.config, self.core_params, features, self.num_rows)
        self.observation_space = self.batch.observation_space(inner.observation_space)

    def _advance(self, rows: np.ndarray) -> None:
        self.batch.advance(self.inner.measured(), self.inner.targets(), rows)

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        self.inner.reset_rows(mask, seed, options)
        self.batch.reset(mask)
        self._advance(np.asarray(mask, dtype=bool))  # the first observation counts as a step seen

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        out = self.inner.step_rows(actions, active)
        self._advance(np.asarray(active, dtype=bool))
        return out

    def observations(self) -> np.ndarray:
        obs = self.inner.observations()
        x, p = self.inner.filter_state() if self.batch.needs_filter else (None, None)
        return self.batch.augment(np.asarray(obs, dtype=np.float32), x, p)


class ActionRepeatRows(RowsWrapper):
    """Holds each action for ``repeat`` environment steps, rewards summed (:func:`planetnav_train.features.
    check_action_repeat` says why); a row whose episode ends inside the hold stops there."""

    def __init__(self, inner: Rows, repeat: int) -> None:
        super().__init__(inner)
        self.repeat = check_action_repeat(repeat)

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = self.num_rows
        total = np.zeros(n)
        running = np.array(active, dtype=bool, copy=True)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        for _ in range(self.repeat):
            reward, term, trunc = self.inner.step_rows(actions, running)
            total += reward
            terminated |= term
            truncated |= trunc
            running &= ~(term | trunc)
            if not running.any():
                break
        return total, terminated, truncated


class RelativeTargetRows(RowsWrapper):
    """Target choice with relative actions (:func:`planetnav_train.features.relative_actions_batch`):
    "stay" or "move k places" from each row's last choice (-1 after a reset)."""

    def __init__(self, inner: Rows) -> None:
        super().__init__(inner)
        check_relative_config(self.config)
        self.n_planets = self.config.n_planets
        self._current = np.full(self.num_rows, -1, dtype=np.int64)

    def reset_rows(self, mask: np.ndarray, seed: Any = None, options: dict | None = None) -> None:
        self.inner.reset_rows(mask, seed, options)
        self._current[np.asarray(mask, dtype=bool)] = -1

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        env_actions, targets = relative_actions_batch(np.asarray(actions), self._current, self.n_planets)
        active = np.asarray(active, dtype=bool)
        self._current[active] = targets[active]
        return self.inner.step_rows(env_actions, active)


@dataclass(frozen=True)
class TrainingOptions:
    """The training recipe's options over the environment (``research/training_log.md``): the one list of
    them, whose fields (positionally in this order, or by keyword) are the options of :func:`training_rows`,
    :func:`single_training_env` and :class:`planetnav_train.vec_training.NavTrainingVecEnv`.

    ``features``: observation features appended (``since_measured``, ``gain``, ``pd_torque``);
    ``action_repeat``: environment steps per decision; ``relative_actions``: "stay" / "move k places"
    target actions; ``pointing``: the pointing shaping's weight [reward units] (None / 0: none);
    ``gamma``: its discount (the algorithm's); ``pointing_bonus``: the per-step pointing bonus's weight
    [reward units] (None / 0: none; not potential-based). The layers validate them.
    """

    features: Sequence[str] = ()
    action_repeat: int = 1
    relative_actions: bool = False
    pointing: float | None = None
    gamma: float = 0.99
    pointing_bonus: float | None = None

    def stack(self, inner: Rows) -> Rows:
        """``inner`` with these options in the recipe's order: the pointing bonus, the features, action
        repeat, the pointing shaping, relative target actions.

        The shaping sits above the repeat so that ``F = gamma * Phi(s') - Phi(s)`` is taken between
        decisions, whose discount ``gamma`` is: below it, the per-step terms summed over a decision of
        ``k`` steps leave ``(gamma - 1) * (Phi(s_1) + ... + Phi(s_{k-1}))``, which is not potential-based
        and penalises pointing (``Phi`` reads only the env's own observation blocks, not the appended
        features)."""
        rows = inner
        if self.pointing_bonus:
            rows = PointingBonusRows(rows, check_shaping(self.pointing_bonus, 1.0)[0])
        if self.features:
            rows = FeatureRows(rows, self.features)
        if check_action_repeat(self.action_repeat) > 1:
            rows = ActionRepeatRows(rows, self.action_repeat)
        if self.pointing:
            rows = PointingShapingRows(rows, self.pointing, self.gamma)
        return RelativeTargetRows(rows) if self.relative_actions else rows


def training_rows(inner: Rows, *args: Any, **kwargs: Any) -> Rows:
    """``inner`` with the recipe's options (:class:`TrainingOptions`' fields) stacked in their order."""
    return TrainingOptions(*args, **kwargs).stack(inner)


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


def single_training_env(env: gym.Env, *args: Any, **kwargs: Any) -> RowsEnv:
    """A single planetnav env with the recipe's options (:class:`TrainingOptions`' fields; the stack of
    :func:`training_rows` with N = 1): what each env of SB3's ``DummyVecEnv`` path runs
    (``vec_env: dummy``)."""
    return RowsEnv(env, TrainingOptions(*args, **kwargs).stack)


# ------------------------------------------------------------------------------------------------
# Deprecated single-env wrappers: each is the N = 1 stack of its layer, with the old constructor and
# attributes.
# ------------------------------------------------------------------------------------------------
def _deprecated(old: str, new: str) -> None:
    warnings.warn(
        f"planetnav_train.batch_wrappers.{old} is deprecated; use planetnav_train.batch_wrappers.{new}",
        DeprecationWarning,
        stacklevel=3,
    )


class NavFeatures(RowsEnv):
    """Deprecated: :class:`FeatureRows` on one env (``single_training_env(env, features=...)``)."""

    def __init__(self, env: gym.Env, features: Sequence[str]) -> None:
        _deprecated("NavFeatures", "single_training_env(env, features=...)")
        super().__init__(env, lambda rows: FeatureRows(rows, features))


class ActionRepeat(RowsEnv):
    """Deprecated: :class:`ActionRepeatRows` on one env (``single_training_env(env, action_repeat=...)``)."""

    def __init__(self, env: gym.Env, repeat: int) -> None:
        _deprecated("ActionRepeat", "single_training_env(env, action_repeat=...)")
        super().__init__(env, lambda rows: ActionRepeatRows(rows, repeat))
        self.repeat = int(repeat)


class RelativeTargets(RowsEnv):
    """Deprecated: :class:`RelativeTargetRows` on one env (``single_training_env(env,
    relative_actions=True)``)."""

    def __init__(self, env: gym.Env) -> None:
        _deprecated("RelativeTargets", "single_training_env(env, relative_actions=True)")
        super().__init__(env, RelativeTargetRows)
        self.n_planets = self.rows.n_planets


class PointingShaping(RowsEnv):
    """Deprecated: :class:`PointingShapingRows` on one env (``single_training_env(env, pointing=weight,
    gamma=gamma)``); ``info["shaping"]`` holds the term added at each step."""

    def __init__(self, env: gym.Env, weight: float, gamma: float) -> None:
        _deprecated("PointingShaping", "single_training_env(env, pointing=..., gamma=...)")
        super().__init__(env, lambda rows: PointingShapingRows(rows, weight, gamma))
        self.weight, self.gamma = float(weight), float(gamma)

    def potential(self, observation: Any) -> float:
        """``Phi(s)`` of one observation (:class:`planetnav_train.shaping.PointingPotential`)."""
        return float(self.rows.potential(np.reshape(observation, (1, -1)))[0])
