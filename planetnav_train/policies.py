"""Policy front ends for the learners: :class:`RelativeTargetOrder`, a features extractor that reads the
per-target blocks of the box observation in the order of *relative* target actions, and
:class:`PerTargetPolicy`, whose action head scores every target with one shared MLP.

With ``EnvConfig.target_actions = "relative"`` action ``k`` selects the target ``k`` places after the
current one (``(current + k) mod T``; :func:`planetnav_env.core.decisions.relative_targets`), while the
observation lists the targets in their fixed order. A policy then has to find the current target in the
one-hot ``target`` block and shift every per-target feature by it before it can judge "next": a
multiplicative selection that a small MLP learns slowly from a policy gradient's weak per-decision
signal. :class:`RelativeTargetOrder` does that permutation in front of the MLP, so input block ``k`` is
the target that action ``k`` would select. It is a pure function of the raw observation (the one-hot
block says which target is current), so it adds no information: it is part of the policy's architecture,
like a convolution's weight sharing.

The per-target head (:class:`PerTargetScorer`) goes one step further: the logit of action ``k`` is one
MLP, shared by every target, applied to target ``k``'s own values (its block, one-hot, since-measured,
appended features), the values that belong to no target (spacecraft, elapsed time) and a one-hot of ``k``.
A rule such as greedy has that form, one score per candidate. With ``contrast`` each target also reads its
values standardized across the targets. What decides between targets is often a small difference of one
feature (on RandomCruise the per-target ``log_sigma`` columns have a standard deviation under 0.1); Adam
moves each weight by about the learning rate per step, so a flat MLP needs many updates before such a
difference reaches the logits, and the standardized copy puts it at unit scale from the start. Both are
pure functions of the observation.

The same scorer serves DQN as its Q-network (:class:`PerTargetQPolicy`: ``Q(s, k)`` per target).

Config keys: ``hyperparams.policy_kwargs.features_extractor: relative_order``, and for the head
``action_head: per_target`` (PPO or DQN) with ``contrast: true`` and ``scorer_arch: [64, 64]`` (hidden
widths; PPO's value function keeps ``net_arch``); for PPO ``keep_bias: b``, a learned offset that starts
action 0 (keep the current target) ``b`` logits ahead. :func:`planetnav_train.algorithms.algo_kwargs`
fills in the layout from the run's environment and :func:`planetnav_train.algorithms.policy_class` picks
the policy class; both import this module, which needs torch, only then.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.dqn.policies import DQNPolicy, QNetwork
from torch import nn

from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import relative_targets
from planetnav_env.errors import ConfigError

#: Names of ``policy_kwargs.features_extractor`` and what they select.
FEATURES_EXTRACTORS = ("relative_order",)


def _per_target_vectors(lay: L.ObservationLayout, width: int) -> list[int]:
    """Start columns of the blocks of one value per target (T wide) in a flat observation ``width`` wide:
    the one-hot ``target``, each appended chunk, ``since_measured``, ``residual_log`` and the per-planet
    blocks (``in_field``, the two rows of ``image_log``; T wide only without pulsars) where present."""
    T = lay.n_targets
    vectors = [lay.target_start] + [lay.size + j * T for j in range((width - lay.size) // T)]
    vectors += [lay.since_measured_start] if lay.since_measured else []
    vectors += [lay.in_field_start] if lay.in_field else []
    vectors += [lay.image_log_start, lay.image_log_start + T] if lay.image_log else []
    vectors += [lay.residual_log_start] if lay.residual_log else []
    return vectors


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
    if (lay.in_field or lay.image_log) and lay.n_pulsars:
        raise ConfigError(
            "relative_order: the in_field and image_log blocks (planets only) have no relative order with "
            "pulsars"
        )
    vectors = _per_target_vectors(lay, size + tail)
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

    ``n_planets``, ``n_pulsars``, ``n_deadlines``, ``in_field``, ``since_measured``, ``image_log``,
    ``residual_log``: the environment's
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
        image_log: bool = False,
        residual_log: bool = False,
    ) -> None:
        width = int(np.prod(observation_space.shape))
        super().__init__(observation_space, features_dim=width)
        lay = L.ObservationLayout(
            n_planets, n_pulsars, n_deadlines, in_field, since_measured, image_log, residual_log
        )
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


def per_target_columns(lay: L.ObservationLayout, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Columns of a relative-order observation (:class:`RelativeTargetOrder`'s output, ``width`` wide) for
    a per-target scorer: ``(T, m)`` indices of target ``k``'s own values (its 7-column block, then one
    value of each per-target vector: ``target``, ``since_measured``, ``in_field``, each appended chunk)
    and the ``(g,)`` indices of every other column (the spacecraft, the elapsed time, operations), which
    every target's scorer reads too."""
    T = lay.n_targets
    F = L.TARGET_FEATURES
    vectors = _per_target_vectors(lay, width)
    k = np.arange(T)[:, None]
    own = np.hstack([lay.planets_start + F * k + np.arange(F)] + [start + k for start in vectors])
    shared = np.setdiff1d(np.arange(width), own.reshape(-1))
    return own, shared


class PerTargetScorer(nn.Module):
    """Logits ``(B, T)`` of the relative target actions from a relative-order observation: one MLP, shared
    by every target, scores target ``k`` from its own columns, the shared columns and a one-hot of ``k``
    (action 0 keeps the current target, so it may score differently from a slew). Greedy rules are of this
    form (one score per candidate). With ``contrast`` each target also reads its columns standardized
    across the targets (on RandomCruise-Target-v1 the contrast, not the weight sharing alone, brings PPO
    near greedy)."""

    def __init__(
        self, own: np.ndarray, shared: np.ndarray, hidden: list[int], activation: type[nn.Module],
        contrast: bool = False, keep_bias: float = 0.0,
    ) -> None:  # fmt: skip
        super().__init__()
        T = own.shape[0]
        self.contrast = contrast
        self.register_buffer("own", torch.as_tensor(own))
        self.register_buffer("shared", torch.as_tensor(shared))
        self.register_buffer("slot", torch.eye(T))
        layers: list[nn.Module] = []
        width = own.shape[1] * (2 if contrast else 1) + len(shared) + T
        for h in hidden:
            layers += [nn.Linear(width, h), activation()]
            width = h
        self.hidden = nn.Sequential(*layers)
        self.out = nn.Linear(width, 1)
        # A learned per-action offset that starts action 0 (keep the current target) ``keep_bias`` ahead;
        # absent at 0, so that policies saved without it load unchanged.
        self.slot_bias = nn.Parameter(torch.eye(T)[0] * keep_bias) if keep_bias else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        B, T = x.shape[0], self.own.shape[0]
        own = x[:, self.own]  # (B, T, m)
        if self.contrast:
            mean = own.mean(dim=1, keepdim=True)
            own = torch.cat([own, (own - mean) / (own.std(dim=1, keepdim=True, unbiased=False) + 1e-3)], 2)
        shared = x[:, self.shared].unsqueeze(1).expand(B, T, -1)
        slot = self.slot.unsqueeze(0).expand(B, T, T)
        logits = self.out(self.hidden(torch.cat([own, shared, slot], dim=2))).squeeze(2)
        return logits if self.slot_bias is None else logits + self.slot_bias


def _make_scorer(policy: Any, keep_bias: float = 0.0) -> PerTargetScorer:
    """The :class:`PerTargetScorer` of a policy built over :class:`RelativeTargetOrder` (its extractor
    kwargs give the layout) with the policy's ``scorer_arch``, activation and ``contrast``; named errors
    for a non-discrete action space or not one action per target."""
    fx = policy.features_extractor_kwargs
    lay = L.ObservationLayout(
        fx["n_planets"], fx.get("n_pulsars", 0), fx.get("n_deadlines"), fx.get("in_field", False),
        fx.get("since_measured", False), fx.get("image_log", False), fx.get("residual_log", False),
    )  # fmt: skip
    if not isinstance(policy.action_space, gym.spaces.Discrete):
        raise ConfigError(
            f"policy_kwargs.action_head 'per_target' needs discrete target actions, got {policy.action_space}"
        )
    n_actions = int(policy.action_space.n)
    if n_actions != lay.n_targets:
        raise ConfigError(
            f"policy_kwargs.action_head 'per_target': {n_actions} actions for {lay.n_targets} targets"
        )
    own, shared = per_target_columns(lay, int(np.prod(policy.observation_space.shape)))
    return PerTargetScorer(own, shared, policy.scorer_arch, policy.activation_fn, policy.contrast, keep_bias)


class _PerTargetHead:
    """The scorer settings that the PPO and DQN per-target policies share and save with the model."""

    #: The constructor keywords saved with the model (SB3 rebuilds the policy from them on load).
    head_keys: tuple[str, ...] = ("scorer_arch", "contrast")

    def _set_head(self, scorer_arch: list[int] | None, contrast: bool) -> None:
        self.scorer_arch = list(scorer_arch) if scorer_arch is not None else [64, 64]
        self.contrast = bool(contrast)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()  # type: ignore[misc]
        data.update({k: getattr(self, k) for k in self.head_keys})
        return data


class PerTargetPolicy(_PerTargetHead, ActorCriticPolicy):
    """SB3 actor-critic whose action head is a :class:`PerTargetScorer` (``scorer_arch`` hidden widths)
    over :class:`RelativeTargetOrder`'s output; the value function is the usual MLP (``net_arch``, a list
    or ``{"vf": [...]}``) on the same features. Discrete relative target actions only."""

    head_keys = ("scorer_arch", "contrast", "keep_bias")

    def __init__(
        self, *args: Any, scorer_arch: list[int] | None = None, contrast: bool = False,
        keep_bias: float = 0.0, **kwargs: Any,
    ) -> None:  # fmt: skip
        self._set_head(scorer_arch, contrast)
        self.keep_bias = float(keep_bias)
        net_arch = kwargs.get("net_arch")
        vf = net_arch.get("vf", [64, 64]) if isinstance(net_arch, dict) else (net_arch or [64, 64])
        kwargs["net_arch"] = {"pi": [], "vf": list(vf)}
        super().__init__(*args, **kwargs)

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        self.action_net = _make_scorer(self, self.keep_bias)
        if self.ortho_init:
            self.action_net.hidden.apply(lambda m: self.init_weights(m, gain=np.sqrt(2)))
            self.init_weights(self.action_net.out, gain=0.01)
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)


class PerTargetQPolicy(_PerTargetHead, DQNPolicy):
    """SB3 DQN policy whose Q-network (and target network) is a :class:`PerTargetScorer` over
    :class:`RelativeTargetOrder`'s output: ``Q(s, k)`` is one MLP, shared by every target, of target
    ``k``'s own columns, the shared columns and a one-hot of ``k``, as greedy scores its candidates.
    ``scorer_arch`` (hidden widths) and ``contrast`` as for :class:`PerTargetPolicy`."""

    def __init__(
        self, *args: Any, scorer_arch: list[int] | None = None, contrast: bool = False, **kwargs: Any
    ) -> None:
        self._set_head(scorer_arch, contrast)
        super().__init__(*args, **kwargs)

    def make_q_net(self) -> QNetwork:
        q = super().make_q_net()
        q.q_net = _make_scorer(self).to(self.device)
        return q


def extractor_kwargs(name: str, cfg: EnvConfig) -> dict[str, Any]:
    """``features_extractor_class`` and ``features_extractor_kwargs`` of the extractor ``name`` for an
    environment of configuration ``cfg``. :class:`~planetnav_env.errors.ConfigError` naming the value for
    an unknown name, absolute target actions (``cfg.target_actions``), or a dict observation."""
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
            # Only when present, so the kwargs saved with a model of an older layout stay as they were.
            **({"image_log": True} if lay.image_log else {}),
            **({"residual_log": True} if lay.residual_log else {}),
        },
    }


__all__ = [
    "FEATURES_EXTRACTORS",
    "PerTargetPolicy",
    "PerTargetQPolicy",
    "PerTargetScorer",
    "RelativeTargetOrder",
    "extractor_kwargs",
    "per_target_columns",
    "relative_order_index",
]
