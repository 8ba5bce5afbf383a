"""Stable-Baselines3 ``VecEnv`` over the native vector environment.

SB3 does not accept a Gymnasium ``VectorEnv``; this adapter gives it one without per-env Python objects:
the rows are stepped by one compiled loop (:class:`~planetnav_env.envs.vector_env.PlanetNavVectorEnv` in
``same_step`` autoreset mode, which is SB3's convention: a finished row is reset at once and its last
observation travels in ``infos[i]["terminal_observation"]``, with ``"TimeLimit.truncated"`` set for
truncations so that SB3 bootstraps them).

``config`` is what :class:`~planetnav_env.envs.env.PlanetNavEnv` takes: an ``EnvConfig``, a mapping of
options, or a registered id (``PlanetNavSB3VecEnv(4, "planetnav/MarsApproach-Tasking-v0")`` has the options
``gym.make`` would pass), with keyword overrides.

Stable-Baselines3 is imported only when this module is, never by ``import planetnav_env``; it comes with
the ``train`` extra (``pip install "planetnav[train]"``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv
except ImportError as exc:  # the environment alone installs without SB3 (training is an extra)
    raise ImportError(
        "planetnav_train.sb3_vec needs Stable-Baselines3, which the environment alone does not install: "
        f'pip install "planetnav[train]" ({exc})'
    ) from exc

from planetnav_env.config import EnvConfig
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import InvalidParameterError

#: Keys of the single environment's info copied into SB3's per-row info dicts (SB3's Monitor-like
#: callbacks read these); the full set is ``vec.info_row(i)``.
INFO_KEYS = ("pos_err_km", "pos_sigma_km", "measured")


class PlanetNavSB3VecEnv(VecEnv):
    """``num_envs`` planetnav rows as an SB3 ``VecEnv`` (one compiled step for all rows).

    Wrap it in SB3's ``VecMonitor`` for episode statistics (``train.py`` does).
    """

    def __init__(
        self,
        num_envs: int,
        config: EnvConfig | Mapping | str | None = None,
        seed: int | None = None,
        **overrides: Any,
    ):
        self.venv = PlanetNavVectorEnv(num_envs, config=config, autoreset_mode="same_step", **overrides)
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._seed = seed
        self._actions: np.ndarray | None = None

    @property
    def config(self) -> EnvConfig:
        return self.venv.config

    def reset(self) -> Any:
        seed = self._seed
        self._seed = None  # SB3 seeds once (VecEnv.seed), later resets continue the streams
        obs, _ = self.venv.reset(seed=seed)
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> Any:
        if self._actions is None:
            raise RuntimeError("step_async() must be called before step_wait()")
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for k in INFO_KEYS:
            vals = info[k]
            for r in range(self.num_envs):
                infos[r][k] = vals[r]
        for r in np.flatnonzero(done):
            infos[r]["terminal_observation"] = info["final_obs"][r]
            infos[r]["TimeLimit.truncated"] = bool(truncated[r] and not terminated[r])
            infos[r].update({k: info["final_info"][r][k] for k in INFO_KEYS})
        return obs, reward.astype(np.float32), done, infos

    def close(self) -> None:
        self.venv.close()

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    # SB3's VecEnv API for attribute access: the rows share one configuration.
    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = getattr(self.venv, attr_name) if attr_name != "render_mode" else None
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        raise InvalidParameterError(
            f"the native vector env's rows share their attributes; cannot set {attr_name!r}"
        )

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list:
        raise InvalidParameterError(
            f"env_method({method_name!r}) is not available on the native vector env (no env objects)"
        )

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]

    def _indices(self, indices: Any) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices
