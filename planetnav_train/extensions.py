"""Extension points of the training package, filled in by the packages built on it.

``planetnav_train`` never imports those packages. Each registers here from a function of no argument
installed in the entry point group :data:`ENTRY_POINT_GROUP` (``pyproject.toml``), which the lookups
below call the first time a name is not registered. ``planetnav_rl`` registers:

- a trainer per RLlib ``algo`` (:data:`planetnav_train.config.RLLIB_ALGOS`): its training function and its
  ``hyperparams`` check (``train.py train``, the configuration checks, the suite's RLlib cells);
- the ``tune`` command of ``train.py``;
- the ``ray`` grid runner of the suite (``train.py suite`` on Ray Tune).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from planetnav_agents.loaders import run_entry_points
from planetnav_env.errors import ConfigError

#: Entry point group whose objects are functions of no argument that call the ``register_*`` functions.
ENTRY_POINT_GROUP = "planetnav.train_extensions"


@dataclass(frozen=True)
class Trainer:
    """Training of the ``algo`` names that Stable-Baselines3 does not train.

    ``train(tc, run_dir, *, address=None, progress=True, resume=False)`` -> (model path, statistics), as
    :func:`planetnav_train.training.train`; ``check_hyperparams(hyperparams)`` raises
    :class:`~planetnav_env.errors.ConfigError` on a key the algorithm does not take.
    """

    train: Callable[..., tuple[Any, dict[str, Any]]]
    check_hyperparams: Callable[[Mapping[str, Any]], None] | None = None


_TRAINERS: dict[str, Trainer] = {}
_COMMANDS: dict[str, Callable[[Any], int]] = {}
_GRID_RUNNERS: dict[str, Callable[..., list[dict[str, Any]]]] = {}
_discovered = False


def register_trainer(
    algo: str,
    train: Callable[..., tuple[Any, dict[str, Any]]],
    check_hyperparams: Callable[[Mapping[str, Any]], None] | None = None,
) -> None:
    """Train configurations of ``algo`` (lower case) with ``train``."""
    _TRAINERS[str(algo).lower()] = Trainer(train, check_hyperparams)


def register_command(name: str, run: Callable[[Any], int]) -> None:
    """``run(args)`` carries out the ``train.py`` command ``name`` (its options are the parser's)."""
    _COMMANDS[name] = run


def register_grid_runner(name: str, run: Callable[..., list[dict[str, Any]]]) -> None:
    """``run(cells, settings, references, address)`` runs suite cells and returns their records
    (:func:`planetnav_train.suite.runner.run_suite`)."""
    _GRID_RUNNERS[name] = run


def discover() -> None:
    """Call the registration functions of the :data:`ENTRY_POINT_GROUP` entry points (once)."""
    global _discovered
    if _discovered:
        return
    _discovered = True
    run_entry_points(ENTRY_POINT_GROUP)


def _lookup(table: Mapping[str, Any], name: str, what: str) -> Any:
    if name not in table:
        discover()
    if name not in table:
        raise ConfigError(
            f"{what} {name!r} comes from planetnav_rl, whose entry point is not installed: reinstall "
            'planetnav (pip install -e ".[ray]")'
        )
    return table[name]


def trainer(algo: str) -> Trainer:
    """The registered :class:`Trainer` of ``algo``; ``ConfigError`` when none is."""
    return _lookup(_TRAINERS, str(algo).lower(), "algorithm")


def command(name: str) -> Callable[[Any], int]:
    """The registered handler of the ``train.py`` command ``name``."""
    return _lookup(_COMMANDS, name, "command")


def grid_runner(name: str) -> Callable[..., list[dict[str, Any]]]:
    """The registered suite grid runner ``name``."""
    return _lookup(_GRID_RUNNERS, name, "grid runner")


__all__ = [
    "ENTRY_POINT_GROUP",
    "Trainer",
    "command",
    "discover",
    "grid_runner",
    "register_command",
    "register_grid_runner",
    "register_trainer",
    "trainer",
]
