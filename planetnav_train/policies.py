"""Policy front ends for the learners: :class:`RelativeTargetOrder`, a features extractor that reads the
per-target blocks of the box observation in the order of *relative* target actions.

With ``EnvConfig.target_actions = "relative"`` action ``k`` selects the target ``k`` places after the
current one (``(current + k) mod T``; :func:`planetnav_env.core.decisions.relative_targets`), while the
observation lists the targets in their fixed order. A policy then has to find the current target in the
one-hot ``target`` block and shift every per-target feature by it before it can judge "next": a
multiplicative selection that a small MLP learns slowly from a policy gradient's weak per-decision
signal. :class:`RelativeTargetOrder` does that permutation in front of the MLP, so input block ``k`` is
the target that action ``k`` would select. It is a pure function of the raw observation (the one-hot
block says which target is current), so it adds no information: it is part of the policy's architecture,
like a convolution's weight sharing.

Config key: ``hyperparams.policy_kwargs.features_extractor: relative_order``
(:func:`planetnav_train.algorithms.algo_kwargs` fills in the layout from the run's environment, and
imports this module, which needs torch, only then).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import relative_targets
from planetnav_env.errors import ConfigError

#: Names of ``policy_kwargs.features_extractor`` and what they select.
FEATURES_EXTRACTORS = ("relative_order",)


def relative_order_index(lay: L.ObservationLayout, tail: int = 0) -> np.ndarray:
    """Gather indices (T, size + tail): row ``c`` reorders a flat observation of layout ``lay`` so that
    every per-target quantity of block ``k`` is that of target ``(c + k) mod T``: the target blocks
    (planets, then pulsars, 7 columns each), the one-hot ``target`` block, ``since_measured`` and, where
    the layout has no pulsars, ``in_field``. ``tail`` appended columns (features such as ``gain``, one
    value per target each) are reordered per chunk of T. Row 0 is the identity.

    Raises :class:`~planetnav_env.errors.ConfigError` when ``tail`` is not a whole number of per-target
    chunks, or the layout has ``in_field`` and pulsars (a block over planets only has no relative order).
    """
    T, size = lay.n_targets, lay.size
    if tail < 0 or tail % T:
        raise ConfigError(
            f"relative_order: {tail} appended columns are not chunks of one value per target ({T})"
        )
    if lay.in_field and lay.n_pulsars:
        raise ConfigError(
            "relative_order: the in_field block (planets only) has no relative order with pulsars"
        )
    # Blocks of one value per target (T wide), each reordered like the targets themselves.
    vectors = [lay.target_start] + [size + j * T for j in range(tail // T)]
    vectors += [lay.since_measured_start] if lay.since_measured else []
    vectors += [lay.in_field_start] if lay.in_field else []
    F = L.TARGET_FEATURES
    out = np.tile(np.arange(size + tail), (T, 1))
    for c in range(T):
        src = relative_targets(np.arange(T), np.full(T, c), T)  # the target action k selects, per k
        feature = lay.planets_start + F * src[:, None] + np.arange(F)  # (T, F) columns of those blocks
        out[c, lay.planets_start : lay.planets_start + F * T] = feature.reshape(-1)
        for start in vectors:
            out[c, start : start + T] = start + src
    return out


class RelativeTargetOrder(BaseFeaturesExtractor):
    """SB3 features extractor: the flat observation with its per-target blocks in relative-action order
    (module docstring). Output width = input width; no parameters.

    ``n_planets``, ``n_pulsars``, ``n_deadlines``, ``in_field``, ``since_measured``: the environment's
    :class:`~planetnav_env.core.layout.ObservationLayout` (plain values, so a saved policy rebuilds it).
    """

    def __init__(
        self,
        observation_space: Any,
        n_planets: int,
        n_pulsars: int = 0,
        n_deadlines: int | None = None,
        in_field: bool = False,
        since_measured: bool = False,
    ) -> None:
        width = int(np.prod(observation_space.shape))
        super().__init__(observation_space, features_dim=width)
        lay = L.ObservationLayout(n_planets, n_pulsars, n_deadlines, in_field, since_measured)
        if len(observation_space.shape) != 1 or width < lay.size:
            raise ConfigError(
                f"relative_order: observation of shape {observation_space.shape} is not the flat layout "
                f"of {lay} ({lay.size} values, plus appended features)"
            )
        self.target_start, self.target_stop = lay.target_start, lay.elapsed_index
        self.register_buffer("index", torch.as_tensor(relative_order_index(lay, width - lay.size)))

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        # No current target (the first step: all zeros) counts from target 0, as the actions do.
        current = torch.argmax(observations[:, self.target_start : self.target_stop], dim=1)
        return torch.gather(observations, 1, self.index[current])


def extractor_kwargs(name: str, cfg: EnvConfig) -> dict[str, Any]:
    """``features_extractor_class`` and ``features_extractor_kwargs`` of the extractor ``name`` for an
    environment of configuration ``cfg``. :class:`~planetnav_env.errors.ConfigError` naming the value for
    an unknown name, relative actions off, or a dict observation."""
    if name not in FEATURES_EXTRACTORS:
        raise ConfigError(
            f"policy_kwargs.features_extractor {name!r} is not one of {list(FEATURES_EXTRACTORS)}"
        )
    if cfg.target_actions != "relative":
        raise ConfigError(
            f"policy_kwargs.features_extractor {name!r} needs relative target actions, "
            f"got target_actions={cfg.target_actions!r}"
        )
    if cfg.observation != "box":
        raise ConfigError(
            f"policy_kwargs.features_extractor {name!r} reads box observations, got {cfg.observation!r}"
        )
    lay = L.ObservationLayout.for_config(cfg)
    return {
        "features_extractor_class": RelativeTargetOrder,
        "features_extractor_kwargs": {
            "n_planets": lay.n_planets,
            "n_pulsars": lay.n_pulsars,
            "n_deadlines": lay.n_deadlines,
            "in_field": lay.in_field,
            "since_measured": lay.since_measured,
        },
    }


__all__ = ["FEATURES_EXTRACTORS", "RelativeTargetOrder", "extractor_kwargs", "relative_order_index"]
