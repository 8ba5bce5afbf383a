"""Invalid-action masks for MaskablePPO (sb3-contrib): a target whose ``observable`` column is 0 cannot be
measured now (Sun exclusion, occultation, too small), so choosing it is masked out.

The mask is read from the env's own observation (:data:`planetnav_env.core.layout.TF_OBSERVABLE` of each
target block) at the offsets of the env's :class:`~planetnav_env.core.layout.ObservationLayout`, taken
from the environment (:func:`layout_of`), never guessed from the observation's size: the operations and
in-field blocks make sizes ambiguous. :class:`ObservableMasks` serves the mask to MaskablePPO's rollout
collection from the last observation of its VecEnv, and :func:`masked_ppo_class` returns a MaskablePPO
that records the layout with the model (``observation_layout``, saved in its zip) so that its
``predict`` masks from the observation alone and a saved model evaluates with the same mask through the
ordinary :class:`~planetnav_train.sb3.SB3Agent` path. sb3-contrib is imported lazily (the ``bench``
extra).

Actions past the targets (the ``idle_action`` "camera off" / operations "stay", always the last) are never
masked.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from functools import cache
from typing import Any

import numpy as np

from planetnav_env.core.layout import TARGET_FEATURES, TF_OBSERVABLE, ObservationLayout


def layout_of(env: Any) -> ObservationLayout:
    """The observation layout of ``env``: a planetnav env or vector env (``.layout``), a Gymnasium wrapper
    of one, an SB3 VecEnv over one (``get_attr("layout")``), or an :class:`ObservationLayout` itself.

    Raises ``ValueError`` naming the object when it has no planetnav layout.
    """
    if isinstance(env, ObservationLayout):
        return env
    layout = getattr(env, "layout", None)
    if layout is None and hasattr(env, "get_attr"):  # SB3 VecEnv (and its wrappers): ask the first env
        try:
            layout = env.get_attr("layout", indices=[0])[0]
        except AttributeError:
            layout = None
    if layout is None and hasattr(env, "unwrapped"):
        layout = getattr(env.unwrapped, "layout", None)
    if not isinstance(layout, ObservationLayout):
        raise ValueError(f"{env!r} is not a planetnav environment: it has no ObservationLayout ('layout')")
    return layout


def observable_mask(obs: Any, layout: ObservationLayout, n_actions: int) -> np.ndarray:
    """Boolean masks (..., ``n_actions``) of the targets observable in observations ``obs`` of ``layout``:
    flat (..., ``layout.size``) or the ``dict`` form (its ``planets`` and ``pulsars`` blocks).

    Target ``i`` (planets, then pulsars) is action ``i``; its ``observable`` column sits at
    ``layout.planets_start + i * TARGET_FEATURES + TF_OBSERVABLE`` (pulsar blocks follow the planet blocks
    with the same width). Actions past the targets (the idle / "stay" action) are always allowed. A row
    with no observable target and no such action allows every action: the environment accepts them all
    (the policy just measures nothing) and an all-false mask has no distribution.

    Raises ``ValueError`` naming the sizes when ``obs`` is not an observation of ``layout`` (e.g. one with
    observation features appended) or the action space is smaller than the target count.
    """
    n = layout.n_targets
    if n_actions < n:
        raise ValueError(f"{n_actions} actions cannot index the {n} targets of the layout")
    if isinstance(obs, Mapping):
        blocks = [np.asarray(obs["planets"], dtype=np.float32)]
        if layout.n_pulsars:
            blocks.append(np.asarray(obs["pulsars"], dtype=np.float32))
        observable = np.concatenate([b[..., TF_OBSERVABLE] for b in blocks], axis=-1)
    else:
        flat = np.asarray(obs, dtype=np.float32)
        if flat.shape[-1] != layout.size:
            raise ValueError(
                f"an observation of {flat.shape[-1]} values is not one of this layout ({layout.size} values: "
                f"{layout.n_planets} planets, {layout.n_pulsars} pulsars, deadlines {layout.n_deadlines}, "
                f"in_field {layout.in_field}); masks read the env's own observation, without features"
            )
        cols = layout.planets_start + TARGET_FEATURES * np.arange(n) + TF_OBSERVABLE
        observable = flat[..., cols]
    mask = np.ones((*observable.shape[:-1], n_actions), dtype=bool)
    mask[..., :n] = observable > 0.5
    if n_actions == n:  # no idle action to fall back on
        none = ~mask.any(axis=-1)
        mask[none] = True
    return mask


def layout_dict(layout: ObservationLayout) -> dict[str, Any]:
    """``layout`` as JSON data (how a model records it); :class:`ObservationLayout` ``(**d)`` rebuilds it."""
    return dataclasses.asdict(layout)


def observable_masks_wrapper(venv: Any) -> Any:
    """``venv`` under a VecEnv wrapper that answers ``env_method("action_masks")`` from its last
    observation (what sb3-contrib's ``get_action_masks`` calls during rollouts), at the offsets of
    ``venv``'s own layout."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class ObservableMasks(VecEnvWrapper):
        """Serves :func:`observable_mask` of the last observation to MaskablePPO."""

        def __init__(self, venv: Any) -> None:
            super().__init__(venv)
            self.layout = layout_of(venv)
            self._last: Any = None

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
            masks = observable_mask(self._last, self.layout, int(self.action_space.n))
            rows = range(self.num_envs) if indices is None else np.atleast_1d(indices)
            return [masks[i] for i in rows]

    return ObservableMasks(venv)


@cache
def masked_ppo_class() -> type:
    """MaskablePPO masking the unobservable targets, in training (its env is wrapped by
    :func:`observable_masks_wrapper`) and in ``predict`` (masks from the given observations at the
    layout the model recorded from its training env)."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import VecEnv

    class ObservableMaskablePPO(MaskablePPO):
        """MaskablePPO with the mask of unobservable targets (:func:`observable_mask`).

        ``observation_layout`` (saved with the model): the training env's layout as
        :func:`layout_dict`; None on a model built without an env and not loaded from a file.
        """

        def __init__(self, policy: Any, env: Any, *args: Any, **kwargs: Any) -> None:
            super().__init__(policy, env, *args, **kwargs)
            # On load, SB3 builds the model without an env and then restores the saved attributes.
            self.observation_layout: dict[str, Any] | None = (
                None if self.env is None else layout_dict(layout_of(self.env))
            )

        def set_env(self, env: Any, force_reset: bool = True) -> None:
            super().set_env(env, force_reset)
            self.observation_layout = layout_dict(layout_of(self.env))

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
                if self.observation_layout is None:
                    raise ValueError(
                        "this MaskablePPO has no observation layout (built without an env): pass "
                        "action_masks, or set_env(...) a planetnav environment"
                    )
                layout = ObservationLayout(**self.observation_layout)
                action_masks = observable_mask(observation, layout, int(self.action_space.n))
            return super().predict(observation, state, episode_start, deterministic, action_masks)

    return ObservableMaskablePPO
