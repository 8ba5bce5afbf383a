"""Shared test helpers."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def load_train() -> ModuleType:
    """``train.py`` (a script, not a package module) imported once per session as ``planetnav_train``."""
    if "planetnav_train" in sys.modules:
        return sys.modules["planetnav_train"]
    spec = importlib.util.spec_from_file_location("planetnav_train", ROOT / "train.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve annotations through sys.modules
    spec.loader.exec_module(module)
    return module
