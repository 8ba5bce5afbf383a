"""The training VecEnv: the native vector environment with every option of the training recipe on arrays.

:class:`NavTrainingVecEnv` is :class:`planetnav_train.sb3_vec.PlanetNavSB3VecEnv` (the compiled vector
environment as a Stable-Baselines3 ``VecEnv``) with the recipe's options stacked over its rows by
:meth:`planetnav_train.batch_wrappers.TrainingOptions.stack`: the pointing shaping and bonus and the
observation features (``gain``, ``pd_torque``). Those layers are the only implementation of the options; a
single env runs them with N = 1 (:func:`planetnav_train.batch_wrappers.single_training_env`), so row ``i``
here equals that single env seeded ``seed + i``, bit for bit (``tests/train/test_vec_training.py``). Every
action mode and every option trains on this path: no per-env Python objects, no SB3 ``DummyVecEnv``.

The decision interface is the env's (``config``: ``decision_steps``, ``target_actions``,
``observe_since_measured``): one SB3 step is one decision of the env. A row whose episode ends inside a
held decision stops there and is reset at the end of the decision; its last observation travels in
``infos[i]["terminal_observation"]`` (SB3's convention).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_train.batch_wrappers import VectorRows, options
from planetnav_train.sb3_vec import INFO_KEYS, PlanetNavSB3VecEnv


class NavTrainingVecEnv(PlanetNavSB3VecEnv):
    """``num_envs`` rows of the compiled vector env with the recipe's options (module docstring).

    After ``num_envs``, ``config`` and ``seed``: the recipe's options, the fields of
    :class:`planetnav_train.batch_wrappers.TrainingOptions` by keyword (``features``: as the config key;
    ``pointing``: the pointing shaping's weight [reward units], None: no shaping; ``gamma``: its discount,
    the algorithm's; ``pointing_bonus``); ``options`` holds them.

    Wrap it in SB3's ``VecMonitor``: episode lengths and returns are then counted in decisions, as
    ``Monitor`` counts them on single envs.
    """

    def __init__(
        self,
        num_envs: int,
        config: EnvConfig | dict | None = None,
        seed: int | None = None,
        **kwargs: Any,
    ) -> None:
        self.options = options(**kwargs)
        super().__init__(num_envs, config, seed=seed)
        self.rows = self.options.stack(VectorRows(self.venv))
        self.features = tuple(self.options.features)
        self.pointing = self.options.pointing
        self.observation_space = self.rows.observation_space
        self._all = np.ones(self.num_envs, dtype=bool)
        self._all.flags.writeable = False

    def reset(self) -> Any:
        seed, self._seed = self._seed, None  # SB3 seeds once (VecEnv.seed), later resets continue the streams
        self.rows.reset_rows(self._all, seed)
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self.rows.observations()

    def step_wait(self) -> Any:
        if self._actions is None:
            raise RuntimeError("step_async() must be called before step_wait()")
        actions, self._actions = self._actions, None
        reward, terminated, truncated = self.rows.step_rows(actions, self._all)
        done = terminated | truncated
        obs = self.rows.observations()
        # The keys SB3's callbacks read, from the core's columns (not info_row: that builds dicts per row).
        info = self.venv.info_arrays()
        infos: list[dict[str, Any]] = [{k: info[k][r] for k in INFO_KEYS} for r in range(self.num_envs)]
        if done.any():
            for r in np.flatnonzero(done):
                infos[r]["terminal_observation"] = obs[r]
                infos[r]["TimeLimit.truncated"] = bool(truncated[r] and not terminated[r])
            self.rows.reset_rows(done)
            obs = self.rows.observations()
        return obs, reward.astype(np.float32), done, infos
