"""``import agents`` from a source checkout: a deprecated alias of ``planetnav_agents``.

The folder ``agents/`` installs as ``planetnav_agents``; no top-level ``agents`` is installed, because
other distributions (OpenAI's Agents SDK, ``openai-agents``) install one. In a checkout the folder is
still on ``sys.path`` under its own name. Importing it that way warns and hands back the installed
package and its submodules (one copy of every class), unless another distribution provides
``agents``: then the name is theirs and the import fails, naming it.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
import sys
import warnings


def other_agents_distributions() -> list[str]:
    """Installed distributions other than planetnav that provide a top-level ``agents``."""
    dists = importlib.metadata.packages_distributions().get("agents", [])
    return sorted(d for d in dists if d.lower() != "planetnav")


def alias_checkout_import() -> None:
    """Make ``sys.modules["agents"]`` (and ``agents.<sub>``) the ``planetnav_agents`` modules."""
    others = other_agents_distributions()
    if others:
        raise ImportError(
            f"'agents' here is planetnav's source folder, but {', '.join(others)} also provides a "
            "top-level 'agents' package; import planetnav_agents instead"
        )
    warnings.warn(
        "importing planetnav's agents as 'agents' is deprecated (the name collides with other "
        "distributions): import planetnav_agents",
        DeprecationWarning,
        stacklevel=3,
    )
    package = importlib.import_module("planetnav_agents")
    sys.modules["agents"] = package
    for info in pkgutil.iter_modules(package.__path__):
        if not info.name.startswith("_"):
            sys.modules[f"agents.{info.name}"] = importlib.import_module(f"planetnav_agents.{info.name}")
