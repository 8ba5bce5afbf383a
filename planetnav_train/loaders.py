"""The agent loaders of the training package, registered into :mod:`planetnav_agents.loaders`.

:func:`register` is the ``planetnav.agent_loaders`` entry point of ``planetnav_train`` (``pyproject.toml``):
``make_agent`` calls it the first time a spec is not a rule agent. It adds two loaders, tried in this
order: the shipped suite baselines (``suite:<task>``, :mod:`planetnav_train.shipped`) and saved SB3 models
(a ``.zip``, a path without ``.zip`` or a run directory, :mod:`planetnav_train.sb3`). Their predicates
test the name or the file system only; SB3 and torch are imported when a model is loaded.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planetnav_agents.loaders import register_loader
from planetnav_train.shipped import is_shipped_spec

#: Loader priorities: the shipped baselines' names first; SB3 after RLlib checkpoints (planetnav_rl), since
#: a run directory of either holds a ``config.yaml`` and the RLlib one is recognised by its checkpoint.
SHIPPED_PRIORITY = 10
SB3_PRIORITY = 50


def _is_sb3_path(spec: str) -> bool:
    path = Path(spec)
    return path.exists() or path.with_suffix(".zip").exists()


def _load_sb3(spec: str, env: Any = None, **kwargs: Any) -> Any:
    from planetnav_train.sb3 import SB3Agent

    return SB3Agent(spec, env, **kwargs)


def _sb3_config(spec: str) -> Path | None:
    from planetnav_train.sb3 import resolve_model_path

    try:
        return resolve_model_path(spec).parent / "config.yaml"
    except FileNotFoundError:
        return None


def _load_shipped(spec: str, env: Any = None, **kwargs: Any) -> Any:
    from planetnav_train.shipped import make_shipped_agent

    return make_shipped_agent(spec, env, **kwargs)


def register() -> None:
    """Register the shipped-baseline and SB3 loaders (the package's ``planetnav.agent_loaders`` entry)."""
    register_loader("shipped", is_shipped_spec, _load_shipped, priority=SHIPPED_PRIORITY)
    register_loader("sb3", _is_sb3_path, _load_sb3, config_path=_sb3_config, priority=SB3_PRIORITY)


__all__ = ["register"]
