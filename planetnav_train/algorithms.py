"""Which algorithms train, and their constructor arguments: the RLlib names (:data:`RLLIB_ALGOS`; the SB3
ones are :data:`planetnav_agents.sb3.ALGORITHMS`) and :func:`algo_kwargs`, the SB3 keyword arguments from a
configuration's ``hyperparams`` (activation names, RL-Zoo ``lin_`` schedules).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from planetnav_env.errors import ConfigError

if TYPE_CHECKING:  # config.py imports this module at run time (is_rllib_algo): only the type from there
    from planetnav_train.config import TrainConfig

#: ``algo`` values of a training configuration that train with RLlib instead of Stable-Baselines3.
RLLIB_ALGOS = ("rllib_ppo",)


def is_rllib_algo(algo: str) -> bool:
    """Whether ``algo`` (any case) names an RLlib algorithm (see :data:`RLLIB_ALGOS`)."""
    return str(algo).lower() in RLLIB_ALGOS


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
    if pk:
        kw["policy_kwargs"] = pk
    return kw
