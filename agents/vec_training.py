"""The training VecEnv of ``train.py``: the native vector environment with the training options on arrays.

:class:`NavTrainingVecEnv` is :class:`planetnav_env.sb3_vec.PlanetNavSB3VecEnv` (the compiled vector
environment as a Stable-Baselines3 ``VecEnv``) plus the three options of the default recipe
(``docs/training.md``), computed for all rows at once with the formulas of :mod:`planetnav_agents.features`:

* ``since_measured`` appended to the observation (:func:`planetnav_agents.features.advance_since_measured`,
  :func:`planetnav_agents.features.since_measured_values`);
* ``action_repeat``: one decision held for that many environment steps, rewards summed; a row whose
  episode ends inside the hold stops there (:meth:`PlanetNavVectorEnv.step_rows` steps only the rows
  still running) and is reset at the end of the decision;
* ``relative_actions``: "stay" / "move k places" (:func:`planetnav_agents.features.relative_actions_batch`).

It is the same MDP as ``n_envs`` single environments wrapped in
:class:`planetnav_agents.features.NavFeatures`,
:class:`~planetnav_agents.features.ActionRepeat` and :class:`~planetnav_agents.features.RelativeTargets`
in SB3's
``DummyVecEnv`` (``tests/test_vec_training.py`` holds the two to equal observations, rewards and
dones), at the vector environment's speed. The ``gain`` feature is computed for all rows by the same
compiled function as the single-env feature (:func:`planetnav_agents.gain.planet_gains`), once per
decision. The
``pd_torque`` feature (a per-environment agent) and reward shaping stay on the ``DummyVecEnv`` path
(:data:`NATIVE_FEATURES`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from planetnav_agents.features import (
    GainFeature,
    advance_since_measured,
    check_features,
    check_relative_config,
    relative_actions_batch,
    since_measured_values,
)
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.sb3_vec import INFO_KEYS, PlanetNavSB3VecEnv

#: Observation features the vector training env computes on arrays.
NATIVE_FEATURES = ("since_measured", "gain")


class NavTrainingVecEnv(PlanetNavSB3VecEnv):
    """``num_envs`` rows of the compiled vector env with ``features``, ``action_repeat`` and
    ``relative_actions`` (see the module docstring). Wrap it in SB3's ``VecMonitor``: episode lengths
    and returns are then counted in decisions, as ``Monitor`` counts them on the wrapped single envs."""

    def __init__(
        self,
        num_envs: int,
        config: EnvConfig | dict | None = None,
        seed: int | None = None,
        features: Sequence[str] = (),
        action_repeat: int = 1,
        relative_actions: bool = False,
    ) -> None:
        super().__init__(num_envs, config, seed=seed)
        cfg = self.config
        self.features = check_features(features)
        other = [f for f in self.features if f not in NATIVE_FEATURES]
        if other:
            raise ValueError(
                f"features {other} need a per-environment agent; the vector training env computes only "
                f"{list(NATIVE_FEATURES)} (use vec_env: dummy)"
            )
        if self.features and cfg.observation != "box":
            raise ValueError("observation features need observation='box'")
        if isinstance(action_repeat, bool) or not isinstance(action_repeat, int) or action_repeat < 1:
            raise ValueError(f"action_repeat must be an integer >= 1, got {action_repeat!r}")
        if relative_actions:
            check_relative_config(cfg)
        self.action_repeat = action_repeat
        self.relative_actions = bool(relative_actions)
        self.n_planets = cfg.n_planets
        n = self.num_envs
        self._since = np.full((n, self.n_planets), np.inf)
        self._current = np.full(n, -1, dtype=np.int64)
        self._gain = GainFeature(cfg, self.venv.core.params) if "gain" in self.features else None
        if self.features:
            base = self.observation_space
            self.observation_space = spaces.Box(
                -np.inf, np.inf, (base.shape[0] + len(self.features) * self.n_planets,), dtype=np.float32
            )

    def _augment(self, obs: np.ndarray) -> np.ndarray:
        """``obs`` with the features appended, in the configured order (as :class:`FeatureState`); the
        ``gain`` feature reads the filter state of the rows as they are now."""
        if not self.features:
            return obs
        parts = [np.asarray(obs, dtype=np.float32)]
        for f in self.features:
            if f == "since_measured":
                parts.append(since_measured_values(self._since))
            else:
                parts.append(self._gain(obs, *self.venv.core.filter_state()))
        return np.concatenate(parts, axis=1)

    def _advance_features(self, stepped: np.ndarray) -> None:
        if not self.features:
            return
        # The two columns the feature reads, not info_batch(): that copies every info array, and this
        # runs once per environment step of a held decision.
        core = self.venv.core
        since = self._since[stepped]
        measured = core.i[stepped, L.I_MEASURED] != 0
        advance_since_measured(since, measured, core.i[stepped, L.I_TARGET])
        self._since[stepped] = since

    def reset(self) -> Any:
        obs = super().reset()
        self._since[:] = np.inf
        self._current[:] = -1
        self._advance_features(np.ones(self.num_envs, dtype=bool))  # as FeatureState.augment on reset
        return self._augment(obs)

    def step_wait(self) -> Any:
        if self._actions is None:
            raise RuntimeError("step_async() must be called before step_wait()")
        actions, self._actions = self._actions, None
        n = self.num_envs
        if self.relative_actions:
            actions, self._current = relative_actions_batch(actions, self._current, self.n_planets)
        total = np.zeros(n)
        running = np.ones(n, dtype=bool)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        for _ in range(self.action_repeat):
            reward, term, trunc = self.venv.step_rows(actions, running)
            total += reward
            self._advance_features(running)
            terminated |= term
            truncated |= trunc
            running &= ~(term | trunc)
            if not running.any():
                break
        done = terminated | truncated
        obs = self._augment(self.venv.observations())
        info = self.venv.core.info_batch()
        infos: list[dict[str, Any]] = [{k: info[k][r] for k in INFO_KEYS} for r in range(n)]
        if done.any():
            for r in np.flatnonzero(done):
                infos[r]["terminal_observation"] = obs[r]
                infos[r]["TimeLimit.truncated"] = bool(truncated[r] and not terminated[r])
            new_obs, _ = self.venv.reset(options={"reset_mask": done})
            self._since[done] = np.inf
            self._current[done] = -1
            self._advance_features(done)
            obs = self._augment(new_obs)
        return obs, total.astype(np.float32), done, infos
