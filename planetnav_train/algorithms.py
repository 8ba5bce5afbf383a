"""The SB3 algorithm's constructor arguments from a configuration's ``hyperparams``: :func:`algo_kwargs`
(activation names, RL-Zoo ``lin_`` schedules, features extractors by name:
:mod:`planetnav_train.policies`). Which algorithms a configuration may name, and which
``hyperparams`` keys each takes, is checked by :mod:`planetnav_train.config`.
"""

from __future__ import annotations

from typing import Any

from planetnav_env.errors import ConfigError
from planetnav_train.config import TrainConfig


def _activation(name: str) -> Any:
    """A torch activation class by its name in ``policy_kwargs.activation_fn``."""
    import torch.nn as nn

    table = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU, "leaky_relu": nn.LeakyReLU, "gelu": nn.GELU}
    if name.lower() not in table:
        raise ConfigError(f"policy_kwargs.activation_fn {name!r} is not one of {sorted(table)}")
    return table[name.lower()]


def _schedule(value: Any) -> Any:
    """``"lin_3e-4"`` (RL-Zoo) -> linear decay to 0; numbers pass through."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


def algo_kwargs(tc: TrainConfig) -> dict[str, Any]:
    """The algorithm's constructor arguments from ``hyperparams`` (activation names, ``lin_`` schedules)."""
    kw = dict(tc.hyperparams)
    for key in ("learning_rate", "clip_range"):
        if key in kw:
            kw[key] = _schedule(kw[key])
    pk = dict(kw.get("policy_kwargs") or {})
    if isinstance(pk.get("activation_fn"), str):
        pk["activation_fn"] = _activation(pk["activation_fn"])
    pk.pop("action_head", None)  # selects the policy class: policy_class()
    for key in ("scorer_arch", "contrast", "keep_bias"):
        if key in pk and "action_head" not in (tc.hyperparams.get("policy_kwargs") or {}):
            raise ConfigError(f"policy_kwargs.{key} needs policy_kwargs.action_head: per_target")
    if "features_extractor" in pk:  # a name of planetnav_train.policies, laid out for this run's env
        from planetnav_train.policies import extractor_kwargs

        pk.update(extractor_kwargs(pk.pop("features_extractor"), tc.env_config()))
    if pk:
        kw["policy_kwargs"] = pk
    return kw


#: Names of ``policy_kwargs.action_head`` (a policy class of :mod:`planetnav_train.policies`).
ACTION_HEADS = ("per_target",)


def policy_class(tc: TrainConfig) -> Any:
    """The algorithm's first argument: ``tc.policy`` (an SB3 alias such as ``"MlpPolicy"``), or the
    class that ``policy_kwargs.action_head`` names. :class:`~planetnav_env.errors.ConfigError` naming the
    value for an unknown head, or one without the ``relative_order`` extractor it reads."""
    pk = tc.hyperparams.get("policy_kwargs") or {}
    head = pk.get("action_head")
    if head is None:
        return tc.policy
    if head not in ACTION_HEADS:
        raise ConfigError(f"policy_kwargs.action_head {head!r} is not one of {list(ACTION_HEADS)}")
    if pk.get("features_extractor") != "relative_order" or tc.policy != "MlpPolicy":
        raise ConfigError(
            f"policy_kwargs.action_head {head!r} reads the relative-order observation: it needs "
            f"features_extractor: relative_order and policy: MlpPolicy, got "
            f"{pk.get('features_extractor')!r} and {tc.policy!r}"
        )
    if tc.algo not in ("ppo", "dqn"):
        raise ConfigError(
            f"policy_kwargs.action_head {head!r} is a head for ppo (actor-critic) or dqn (Q-network), "
            f"not {tc.algo!r}"
        )
    if tc.algo == "dqn" and "keep_bias" in pk:
        raise ConfigError("policy_kwargs.keep_bias is an initial logit offset of ppo's per-target head")
    from planetnav_train.policies import PerTargetPolicy, PerTargetQPolicy

    return PerTargetPolicy if tc.algo == "ppo" else PerTargetQPolicy
