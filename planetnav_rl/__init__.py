"""Scale-out for planetnav on Ray: RLlib training (:mod:`planetnav_rl.rllib`), Tune sweeps
(:mod:`planetnav_rl.tune`) and the Ray connection (:mod:`planetnav_rl.cluster`).

Needs the ``[ray]`` extra (``pip install -e ".[ray]"``). Importing this package does not import Ray:
every Ray import is inside a function, so ``import planetnav_env, agents`` and the SB3 path of
``train.py`` work without it. Commands and cluster set-up: ``docs/scaling.md``.

This package builds on :mod:`planetnav_train` (configuration, training envs, evaluation), never the other
way at import time: ``planetnav_train`` hands a run to Ray only from inside its functions.
"""

from __future__ import annotations

# The algorithm names belong to the training package (its configuration validates them); kept here too,
# where they were first published.
from planetnav_train.algorithms import RLLIB_ALGOS, is_rllib_algo


def require_ray(what: str) -> None:
    """Raise :class:`ConfigError` naming the ``[ray]`` extra when Ray (RLlib + Tune) is not installed."""
    import importlib.util

    from planetnav_env.errors import ConfigError

    if importlib.util.find_spec("ray") is None:
        raise ConfigError(
            f'{what} needs Ray (RLlib and Tune), which is not installed: pip install -e ".[ray]" '
            "(or make test-ray, which builds .venv-ray)"
        )


__all__ = ["RLLIB_ALGOS", "is_rllib_algo", "require_ray"]
