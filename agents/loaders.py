"""Loaders of learned policies for :func:`planetnav_agents.make_agent`: a registry that other packages fill.

This package holds the rule agents only and imports no training code. A saved model (an SB3 ``.zip`` or
run directory, an RLlib checkpoint, a shipped ``suite:<task>`` baseline) is built by a loader that the
package owning the format registers with :func:`register_loader`:

- ``planetnav_train`` registers the shipped baselines (``suite:<task>``) and saved SB3 models (full or
  policy-only);
- ``planetnav_rl`` registers RLlib checkpoints.

They register through the entry point group :data:`ENTRY_POINT_GROUP` (``pyproject.toml``): the first
time a spec is not a rule agent, :func:`find_loader` calls every registration function installed in that
group, so ``make_agent("runs/x", env)`` works without the caller importing the training package, and no
module here imports it. A predicate is cheap (a prefix, a file test) and imports nothing heavy; the
factory imports torch, SB3 or Ray when it builds the agent.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Entry point group whose objects are functions of no argument that call :func:`register_loader`.
ENTRY_POINT_GROUP = "planetnav.agent_loaders"


@dataclass(frozen=True)
class Loader:
    """How to build the agent of a saved policy.

    ``matches(spec)``: whether ``spec`` (a model path or name, ``@sampled`` already stripped) is this
    loader's; ``load(spec, env, **kwargs)``: the agent; ``config_path(spec)``: the training run's
    ``config.yaml`` beside the saved policy, or None (what ``train.py evaluate`` builds the environment
    from). Loaders are tried by ``priority``, lowest first (a directory can hold several formats).
    """

    name: str
    matches: Callable[[str], bool]
    load: Callable[..., Any]
    config_path: Callable[[str], Path | None] | None = None
    priority: int = 100


_LOADERS: dict[str, Loader] = {}
_discovered = False


def register_loader(
    name: str,
    matches: Callable[[str], bool],
    load: Callable[..., Any],
    config_path: Callable[[str], Path | None] | None = None,
    priority: int = 100,
) -> Loader:
    """Register (or replace, by ``name``) a loader of saved policies; returns it."""
    loader = Loader(name, matches, load, config_path, priority)
    _LOADERS[name] = loader
    return loader


def run_entry_points(group: str) -> None:
    """Call the registration function (no argument) of every installed entry point of ``group``: how the
    packages above this one register what they provide without an import edge from here."""
    for ep in importlib.metadata.entry_points(group=group):
        ep.load()()


def discover_loaders() -> None:
    """Call the registration functions of the :data:`ENTRY_POINT_GROUP` entry points (once)."""
    global _discovered
    if _discovered:
        return
    _discovered = True
    run_entry_points(ENTRY_POINT_GROUP)


def loaders() -> list[Loader]:
    """The registered loaders (installed ones discovered), in the order they are tried."""
    discover_loaders()
    return sorted(_LOADERS.values(), key=lambda loader: (loader.priority, loader.name))


def find_loader(spec: str | Path) -> Loader | None:
    """The first loader whose predicate accepts ``spec``, or None."""
    return next((loader for loader in loaders() if loader.matches(str(spec))), None)


def config_path(spec: str | Path) -> Path | None:
    """The training ``config.yaml`` of the saved policy ``spec`` (its loader's answer), or None."""
    loader = find_loader(spec)
    if loader is None or loader.config_path is None:
        return None
    return loader.config_path(str(spec))


#: What :func:`planetnav_agents.make_agent` says when no loader takes a spec.
MISSING_LOADERS_HINT = (
    "model paths and suite:<task> load through the loaders that planetnav_train (SB3 models, shipped "
    "baselines) and planetnav_rl (RLlib checkpoints) register; if none is registered, reinstall planetnav "
    '(pip install -e ".[train]") so that its entry points are installed'
)


__all__ = [
    "ENTRY_POINT_GROUP",
    "Loader",
    "config_path",
    "discover_loaders",
    "find_loader",
    "loaders",
    "register_loader",
]
