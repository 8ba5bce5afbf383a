"""Provenance of a result record: what produced it (the planetnav source's git commit and whether the
working tree differed from it, the versions of the packages the figures depend on) and where and when
(the CPU, the CPUs the process could use, torch's threads, the time in UTC).

Every JSON result the training package writes carries :func:`provenance` as its ``provenance`` object,
with ``wall_s`` (the writer's wall seconds, None where it does not know them). A record written before
this existed, restored from a published JSON, has ``provenance: null``: nothing is invented for it.

Nothing here imports a package to read its version (``importlib.metadata`` reads it), and nothing uses
the network; git runs locally, and a source tree that is not a git checkout gives ``None``.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import os
import platform
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

#: The packages whose versions a record names, by their distribution names.
PACKAGES = ("numpy", "numba", "torch", "gymnasium", "stable-baselines3")
#: The planetnav source tree whose commit a record names: the repository holding this package.
SOURCE_DIR = Path(__file__).resolve().parent
#: At most this many ``git status --porcelain`` lines are kept in ``git_changes``.
MAX_CHANGES = 20
_GIT_TIMEOUT_S = 10.0


def _git(source_dir: Path, args: Sequence[str]) -> str | None:
    """The stdout of ``git ARGS`` run in ``source_dir``; None if git is missing, fails or hangs. Without
    optional locks: ``git status`` then never writes the index, which a concurrent git command may hold."""
    try:
        done = subprocess.run(
            ["git", "--no-optional-locks", *args],
            cwd=source_dir,
            capture_output=True,
            text=True,
            timeout=_GIT_TIMEOUT_S,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout if done.returncode == 0 else None


def git_state(source_dir: str | Path | None = None) -> dict[str, Any]:
    """``git_commit`` (HEAD), ``git_dirty`` and ``git_changes`` of the checkout holding ``source_dir``
    (default: this package's folder). ``git_dirty``: ``git status --porcelain`` lists something (a tracked
    file changed, staged or not, or an untracked file that no ``.gitignore`` covers; ignored paths such as
    ``runs/`` are not listed). ``git_changes``: its first :data:`MAX_CHANGES` lines. All three are None
    when ``source_dir`` holds no file tracked by a git repository (an installed copy, a source archive, a
    virtual environment inside some other checkout) or git is not available."""
    src = Path(source_dir) if source_dir is not None else SOURCE_DIR
    none: dict[str, Any] = {"git_commit": None, "git_dirty": None, "git_changes": None}
    if not src.is_dir():
        return none
    tracked = _git(src, ["ls-files", "--", "."])
    commit = _git(src, ["rev-parse", "--verify", "HEAD"])
    status = _git(src, ["status", "--porcelain"])
    if not tracked or commit is None or status is None:
        return none
    lines = [ln for ln in status.splitlines() if ln.strip()]
    changes = lines[:MAX_CHANGES]
    if len(lines) > MAX_CHANGES:
        changes.append(f"... and {len(lines) - MAX_CHANGES} more")
    return {"git_commit": commit.strip(), "git_dirty": bool(lines), "git_changes": changes}


def package_versions(packages: Sequence[str] = PACKAGES) -> dict[str, str | None]:
    """``python`` and each of ``packages`` (distribution names) with its installed version, None for one
    that is not installed. Read from the installed metadata: nothing is imported."""
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in packages:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def cpu_model() -> str | None:
    """The CPU's model name: ``model name`` of ``/proc/cpuinfo`` on Linux (the first CPU's), else
    :func:`platform.processor`; None when neither says."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                key, sep, value = line.partition(":")
                if sep and key.strip() == "model name" and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or None


def cpus_available() -> int | None:
    """The CPUs this process may run on (its affinity mask where the OS has one, else all of them)."""
    if hasattr(os, "sched_getaffinity"):
        try:
            return len(os.sched_getaffinity(0))
        except OSError:
            pass
    return os.cpu_count()


def torch_threads() -> int | None:
    """``torch.get_num_threads()`` if torch is already imported; None otherwise (it is not imported for
    this)."""
    torch = sys.modules.get("torch")
    get = getattr(torch, "get_num_threads", None)
    return int(get()) if callable(get) else None


def utc_now() -> str:
    """The current time in UTC, ISO 8601 to the second (``2025-01-31T12:00:00+00:00``)."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def provenance(source_dir: str | Path | None = None, wall_s: float | None = None) -> dict[str, Any]:
    """What produced a result and where, as a JSON-ready dict:

    - ``git_commit``, ``git_dirty``, ``git_changes``: :func:`git_state` of ``source_dir`` (default: the
      planetnav source tree this package was loaded from);
    - ``versions``: python, numpy, numba, torch, gymnasium, stable-baselines3 (:func:`package_versions`);
    - ``platform``: :func:`platform.platform`; ``cpu_model`` (:func:`cpu_model`), ``cpus`` (those the
      process may use, :func:`cpus_available`), ``torch_threads`` (None unless torch is imported);
    - ``utc``: now, ISO 8601;
    - ``wall_s``: the caller's wall seconds of the work the record reports (None: not known).

    No network, no imports of the packages named; git runs at most three short local commands."""
    return {
        **git_state(source_dir),
        "versions": package_versions(),
        "platform": platform.platform(),
        "cpu_model": cpu_model(),
        "cpus": cpus_available(),
        "torch_threads": torch_threads(),
        "utc": utc_now(),
        "wall_s": None if wall_s is None else float(wall_s),
    }


__all__ = [
    "PACKAGES",
    "cpu_model",
    "cpus_available",
    "git_state",
    "package_versions",
    "provenance",
    "torch_threads",
    "utc_now",
]
