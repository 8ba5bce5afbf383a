"""Scale-out for planetnav on Ray: RLlib training (:mod:`planetnav_rl.rllib`, its ``hyperparams`` keys in
:mod:`planetnav_rl.hyperparams`), Tune sweeps (:mod:`planetnav_rl.tune`) and the Ray connection
(:mod:`planetnav_rl.cluster`).

Needs the ``[ray]`` extra (``pip install -e ".[ray]"``). Importing this package does not import Ray:
every Ray import is inside a function, so ``import planetnav_env, agents`` and the SB3 path of
``train.py`` work without it. Commands and cluster set-up: ``docs/scaling.md``.

This package builds on :mod:`planetnav_train` (configuration, training envs, evaluation). The other way,
only functions of ``planetnav_train`` import from here (its command line hands a run to Ray; its
configuration checks :mod:`planetnav_rl.hyperparams`), and neither this file nor that module imports
``planetnav_train``, so the imports form no circle. The ``algo`` names that train with RLlib are
:data:`planetnav_train.config.RLLIB_ALGOS` (:func:`planetnav_train.config.is_rllib_algo`).
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
