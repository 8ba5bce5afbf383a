"""Invalid-action masks for MaskablePPO (sb3-contrib): a target whose ``observable`` column is 0 cannot be
measured now (Sun exclusion, occultation, too small), so choosing it is masked out.

The mask is read from the env's own flat observation (:data:`planetnav_env.core.layout.TF_OBSERVABLE` of
each target block), so it needs no access to the environment: :class:`ObservableMasks` serves it to
MaskablePPO's rollout collection from the last observation of any VecEnv, and
:func:`masked_ppo_class` returns a MaskablePPO whose ``predict`` computes it from the observation it is
given, so a saved model evaluates with the same mask through the ordinary
:class:`~planetnav_agents.sb3.SB3Agent` path. sb3-contrib is imported lazily (the ``bench`` extra).
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np

from planetnav_env.core.layout import TARGET_FEATURES, TF_OBSERVABLE, ObservationLayout


def n_targets_of(obs_size: int) -> int:
    """The number of targets (planets + pulsars) of a flat observation of ``obs_size`` values."""
    # size = spacecraft block + T blocks of TARGET_FEATURES + the T-wide target one-hot + elapsed (1)
    base = ObservationLayout(0, 0).size
    n, rest = divmod(obs_size - base, TARGET_FEATURES + 1)
    if n < 1 or rest:
        raise ValueError(f"an observation of {obs_size} values is not a flat planetnav observation")
    return n


def observable_mask(obs: np.ndarray, n_actions: int) -> np.ndarray:
    """Boolean masks (..., ``n_actions``) of the targets observable in flat observations ``obs`` (..., size).

    Pulsar blocks follow the planet blocks with the same width, so target ``i``'s column sits at
    ``planets_start + i * TARGET_FEATURES + TF_OBSERVABLE``. Actions past the targets (the idle action)
    are always allowed; a row with no observable target allows every action, because the environment
    accepts them all (the policy just measures nothing) and an all-false mask has no distribution.
    """
    obs = np.asarray(obs, dtype=np.float32)
    n = n_targets_of(obs.shape[-1])
    start = ObservationLayout(n, 0).planets_start
    cols = start + TARGET_FEATURES * np.arange(n) + TF_OBSERVABLE
    lead = obs.shape[:-1]
    mask = np.ones((*lead, n_actions), dtype=bool)
    mask[..., :n] = obs[..., cols] > 0.5
    none = ~mask[..., :n].any(axis=-1)
    mask[none] = True
    return mask


def observable_masks_wrapper(venv: Any) -> Any:
    """``venv`` under a VecEnv wrapper that answers ``env_method("action_masks")`` from its last
    observation (what sb3-contrib's ``get_action_masks`` calls during rollouts)."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class ObservableMasks(VecEnvWrapper):
        """Serves :func:`observable_mask` of the last observation to MaskablePPO."""

        def __init__(self, venv: Any) -> None:
            super().__init__(venv)
            self._last: np.ndarray | None = None

        def reset(self) -> Any:
            self._last = self.venv.reset()
            return self._last

        def step_wait(self) -> Any:
            obs, rewards, dones, infos = self.venv.step_wait()
            self._last = obs  # after an auto-reset, the new episode's first observation (SB3's _last_obs)
            return obs, rewards, dones, infos

        def has_attr(self, attr_name: str) -> bool:
            return attr_name == "action_masks" or self.venv.has_attr(attr_name)

        def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
            if method_name != "action_masks":
                return self.venv.env_method(method_name, *args, indices=indices, **kwargs)
            if self._last is None:
                raise RuntimeError("action_masks before the first reset")
            masks = observable_mask(self._last, int(self.action_space.n))
            rows = range(self.num_envs) if indices is None else np.atleast_1d(indices)
            return [masks[i] for i in rows]

    return ObservableMasks(venv)


@cache
def masked_ppo_class() -> type:
    """MaskablePPO masking the unobservable targets, in training (its env is wrapped by
    :func:`observable_masks_wrapper`) and in ``predict`` (masks from the given observations)."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import VecEnv

    class ObservableMaskablePPO(MaskablePPO):
        """MaskablePPO with the mask of unobservable targets (:func:`observable_mask`)."""

        @staticmethod
        def _wrap_env(env: Any, verbose: int = 0, monitor_wrapper: bool = True) -> VecEnv:
            return observable_masks_wrapper(MaskablePPO._wrap_env(env, verbose, monitor_wrapper))

        def predict(  # type: ignore[override]
            self,
            observation: Any,
            state: Any = None,
            episode_start: Any = None,
            deterministic: bool = False,
            action_masks: np.ndarray | None = None,
        ) -> Any:
            if action_masks is None:
                action_masks = observable_mask(observation, int(self.action_space.n))
            return super().predict(observation, state, episode_start, deterministic, action_masks)

    return ObservableMaskablePPO
