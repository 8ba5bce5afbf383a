"""Scale-out for planetnav on Ray: RLlib training (:mod:`planetnav_rl.rllib`), Tune sweeps
(:mod:`planetnav_rl.tune`) and the Ray connection (:mod:`planetnav_rl.cluster`).

Needs the ``[ray]`` extra (``pip install -e ".[ray]"``). Importing this package does not import Ray:
every Ray import is inside a function, so ``import planetnav_env, agents`` and the SB3 path of
``train.py`` work without it. Commands and cluster set-up: ``docs/scaling.md``.
"""

from __future__ import annotations

#: ``algo`` values of a training configuration that train with RLlib instead of Stable-Baselines3.
RLLIB_ALGOS = ("rllib_ppo",)


def is_rllib_algo(algo: str) -> bool:
    """Whether ``algo`` (any case) names an RLlib algorithm (see :data:`RLLIB_ALGOS`)."""
    return str(algo).lower() in RLLIB_ALGOS


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
