"""Which ``hyperparams`` keys a configuration with ``algo: rllib_ppo`` may hold: the keywords of RLlib's
``PPOConfig.training`` plus the keys routed to other ``AlgorithmConfig`` sections
(:mod:`planetnav_rl.rllib` explains the mapping).

Kept apart from :mod:`planetnav_rl.rllib` so that the configuration check
(:func:`planetnav_train.config.parse_config`, through the trainer :mod:`planetnav_rl.extensions`
registers) imports nothing of the training code. Ray is imported only inside functions.
"""

from __future__ import annotations

import inspect
from typing import Any

from planetnav_env.errors import ConfigError
from planetnav_rl import require_ray

#: ``hyperparams`` keys routed to other ``AlgorithmConfig`` sections than ``training``.
ENV_RUNNER_KEYS = (
    "num_env_runners",
    "rollout_fragment_length",
    "num_cpus_per_env_runner",
    "sample_timeout_s",
)
LEARNER_KEYS = ("num_learners",)
MODULE_KEYS = ("model_config",)

#: ``training`` keywords that are not hyper-parameters or are set from other config keys / deprecated.
_RESERVED = {"self", "kwargs", "model", "learner_class", "learner_connector", "num_sgd_iter",
             "add_default_connectors_to_learner_pipeline", "learner_config_dict", "train_batch_size",
             "max_requests_in_flight_per_sampler_worker", "num_aggregator_actors_per_learner",
             "max_requests_in_flight_per_aggregator_actor"}  # fmt: skip


def hyperparameter_names() -> set[str]:
    """Every key ``hyperparams`` may hold for ``rllib_ppo`` (see the module docstring)."""
    require_ray("algo: rllib_ppo")
    from ray.rllib.algorithms.algorithm_config import AlgorithmConfig
    from ray.rllib.algorithms.ppo import PPOConfig

    # PPOConfig.training takes PPO's own keywords and passes **kwargs on to AlgorithmConfig.training.
    names = set(inspect.signature(PPOConfig.training).parameters)
    names |= set(inspect.signature(AlgorithmConfig.training).parameters)
    return (names - _RESERVED) | set(ENV_RUNNER_KEYS) | set(LEARNER_KEYS) | set(MODULE_KEYS)


def check_hyperparams(hyperparams: dict[str, Any]) -> None:
    """Raise :class:`ConfigError` naming every key of ``hyperparams`` that RLlib's PPO does not take."""
    known = hyperparameter_names()
    unknown = sorted(set(hyperparams) - known)
    if unknown:
        raise ConfigError(
            f"config.hyperparams (rllib_ppo): unknown key(s) {unknown}; known keys: {sorted(known)}"
        )
    mc = hyperparams.get("model_config")
    if mc is not None and not isinstance(mc, dict):
        raise ConfigError(f"config.hyperparams.model_config must be a mapping, got {mc!r}")
