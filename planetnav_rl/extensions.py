"""What planetnav_rl adds to the packages below it, registered through their entry points
(``pyproject.toml``), so that neither ``planetnav_agents`` nor ``planetnav_train`` imports this package.

- :func:`register_agent_loader` (group ``planetnav.agent_loaders``): ``make_agent`` of an RLlib checkpoint
  or run directory builds an :class:`~planetnav_rl.agent.RLlibAgent`;
- :func:`register` (group ``planetnav.train_extensions``): the RLlib trainer of each
  :data:`~planetnav_train.config.RLLIB_ALGOS` name with its ``hyperparams`` check, the ``tune`` command and
  the suite's ``ray`` grid runner (:mod:`planetnav_train.extensions`).

Registering imports no Ray: each function imports its module when it is called.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from planetnav_agents.loaders import register_loader
from planetnav_rl.agent import config_sidecar, find_checkpoint
from planetnav_train import extensions
from planetnav_train.config import RLLIB_ALGOS

#: Tried before the SB3 loader (:data:`planetnav_train.loaders.SB3_PRIORITY`): an RLlib run directory
#: exists as a path too, and is recognised by its checkpoint.
RLLIB_PRIORITY = 20


def _load_rllib(spec: str, env: Any = None, **kwargs: Any) -> Any:
    from planetnav_rl.agent import RLlibAgent

    kwargs.pop("algo", None)  # an RLlib checkpoint names its own algorithm
    return RLlibAgent(spec, env, **kwargs)


def register_agent_loader() -> None:
    """Register the RLlib checkpoint loader with :mod:`planetnav_agents.loaders`."""
    register_loader(
        "rllib",
        lambda spec: find_checkpoint(spec) is not None,
        _load_rllib,
        config_path=config_sidecar,
        priority=RLLIB_PRIORITY,
    )


def _train(
    tc: Any, run_dir: Path, address: str | None = None, progress: bool = True, resume: bool = False
) -> tuple[Path, dict]:
    from planetnav_rl.rllib import train

    return train(tc, run_dir, address=address, progress=progress, resume=resume)


def _check_hyperparams(hyperparams: Mapping[str, Any]) -> None:
    from planetnav_rl.hyperparams import check_hyperparams

    check_hyperparams(hyperparams)


def _tune(args: Any) -> int:
    from planetnav_rl.tune import cmd_tune

    return cmd_tune(args)


def _ray_grid(cells: Any, settings: Any, references: Any, address: str | None) -> list[dict[str, Any]]:
    from planetnav_rl.suite_grid import run_ray_grid

    return run_ray_grid(cells, settings, references, address)


def register() -> None:
    """Register the RLlib trainers, the ``tune`` command and the suite's ``ray`` grid runner."""
    for algo in RLLIB_ALGOS:
        extensions.register_trainer(algo, _train, _check_hyperparams)
    extensions.register_command("tune", _tune)
    extensions.register_grid_runner("ray", _ray_grid)


__all__ = ["register", "register_agent_loader"]
