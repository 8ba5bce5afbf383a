"""Deprecated import paths: a moved name stays importable from its old module, with a warning.

An old module keeps a module-level ``__getattr__`` (PEP 562, as Skyfield does for its renamed paths)
built by :func:`moved_names`: Python calls it only for names the module no longer defines, so the
old path resolves to the very object at the new path and warns once per access.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable, Mapping


def moved_names(old_module: str, new_modules: str | Mapping[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``old_module`` whose names now live in ``new_modules``.

    ``new_modules``: one module that took every name, or ``{name: new module}`` for names that went to
    several. Accessing a moved name emits a :class:`DeprecationWarning` naming the new path.
    """

    def __getattr__(name: str) -> object:
        if isinstance(new_modules, str):
            target = new_modules
        elif name in new_modules:
            target = new_modules[name]
        else:
            raise AttributeError(f"module {old_module!r} has no attribute {name!r}")
        try:
            obj = getattr(importlib.import_module(target), name)
        except AttributeError:
            raise AttributeError(f"module {old_module!r} has no attribute {name!r}") from None
        warnings.warn(
            f"{old_module}.{name} is deprecated: it moved to {target}.{name}",
            DeprecationWarning,
            stacklevel=2,
        )
        return obj

    return __getattr__
