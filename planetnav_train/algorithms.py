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
    if "features_extractor" in pk:  # a name of planetnav_train.policies, laid out for this run's env
        from planetnav_train.policies import extractor_kwargs

        pk.update(extractor_kwargs(pk.pop("features_extractor"), tc.env_config()))
    if pk:
        kw["policy_kwargs"] = pk
    return kw
