"""Scale-out for planetnav on Ray: RLlib training (:mod:`planetnav_rl.rllib`, its ``hyperparams`` keys in
:mod:`planetnav_rl.hyperparams`), Tune sweeps (:mod:`planetnav_rl.tune`) and the Ray connection
(:mod:`planetnav_rl.cluster`).

Needs the ``[ray]`` extra (``pip install -e ".[ray]"``). Importing this package does not import Ray:
every Ray import is inside a function, so ``import planetnav_env, planetnav_agents`` and the SB3 path of
``train.py`` work without it. Commands and cluster set-up: ``docs/scaling.md``.

This package builds on :mod:`planetnav_train` (configuration, training envs, evaluation), which never
imports it: :mod:`planetnav_rl.extensions` registers the RLlib trainer, the ``tune`` command, the suite's
Ray grid (:mod:`planetnav_rl.suite_grid`) and the RLlib agent loader (:mod:`planetnav_rl.agent`) through
entry points. The ``algo`` names that train with RLlib are :data:`planetnav_train.config.RLLIB_ALGOS`.
"""

from __future__ import annotations


def require_ray(what: str) -> None:
    """Raise :class:`ConfigError` naming the ``[ray]`` extra when Ray (RLlib + Tune) is not installed."""
    import importlib.util

    from planetnav_env.errors import ConfigError

    if importlib.util.find_spec("ray") is None:
        raise ConfigError(
            f'{what} needs Ray (RLlib and Tune), which is not installed: pip install -e ".[ray]" '
            "(or make test-ray, which builds .venv-ray)"
        )


__all__ = ["require_ray"]
