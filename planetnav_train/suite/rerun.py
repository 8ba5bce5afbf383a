"""Re-running published suite cells with the command their record holds, and comparing with the record,
behind ``python train.py suite-rerun`` (docs/suite.md).

The suite's protocol asks that re-running any cell with its recorded command gives its objective within
the cell's spread. For a cell key, :func:`rerun_cell` copies the suite's cached references into the
record's ``--out`` (so only the cell trains and evaluates), runs the record's ``command`` with this
interpreter from the repository root (plus ``--no-progress``, and ``--no-ray`` unless the cell is an
RLlib one), and returns the published and the re-run objective, and whether the per-episode errors are
equal and the re-run lies inside the published 95 % interval.
"""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from planetnav_env.errors import ConfigError
from planetnav_train.config import ROOT, is_rllib_algo


def _record(path: Path, key: str) -> dict[str, Any]:
    if not path.is_file():
        raise ConfigError(f"cell {key!r}: no record at {path}")
    return json.loads(path.read_text())


def rerun_cell(key: str, published: str | Path, root: Path = ROOT) -> dict[str, Any]:
    """Re-run cell ``key`` from the records under ``published`` (the suite's ``--out``) with its recorded
    command, in ``root`` (the repository, where ``train.py`` is); the record's ``--out`` is relative to it
    and must not hold a re-run of the cell yet. Returns ``key``, ``published`` and ``rerun`` (objectives),
    ``half_width`` (of the published 95 % interval), ``per_episode_equal`` and ``inside``. Raises
    :class:`ConfigError` naming the key for a missing record, an unexpected command, an earlier re-run or
    a failed one."""
    published = Path(published)
    rec = _record(published / "runs" / f"{key}.json", key)
    argv = shlex.split(rec["command"])
    if argv[:2] != ["python", "train.py"] or "--out" not in argv[:-1]:
        raise ConfigError(f"cell {key!r}: unexpected recorded command {rec['command']!r}")
    if not (root / "train.py").is_file():
        raise ConfigError(f"cell {key!r}: no train.py in {root} to run the recorded command with")
    out = root / argv[argv.index("--out") + 1]
    if (out / "runs" / f"{key}.json").exists():
        raise ConfigError(f"cell {key!r}: {out} already holds a re-run; remove it first")
    shutil.copytree(published / "references", out / "references", dirs_exist_ok=True)
    extra = ["--no-progress"] + ([] if is_rllib_algo(rec["algorithm"]) else ["--no-ray"])
    done = subprocess.run([sys.executable, *argv[1:], *extra], cwd=root, stdout=subprocess.DEVNULL)
    if done.returncode != 0:  # its own error went to stderr above
        raise ConfigError(f"cell {key!r}: the recorded command exited with status {done.returncode}")
    new = _record(out / "runs" / f"{key}.json", key)
    lo, hi = rec["objective_ci95"]
    return {
        "key": key,
        "published": rec["objective"],
        "rerun": new["objective"],
        "half_width": (hi - lo) / 2,
        # A record restored from the published JSON has no per-seed values to compare: None.
        "per_episode_equal": None
        if rec.get("per_episode") is None
        else new.get("per_episode") == rec.get("per_episode"),
        "inside": lo <= new["objective"] <= hi,
    }


def _equal(flag: bool | None) -> str:
    return "not published" if flag is None else str(flag)


def format_rerun(r: Mapping[str, Any]) -> str:
    """One line of :func:`rerun_cell`'s result."""
    return (f"{r['key']}: published {r['published']!r}, re-run {r['rerun']!r}, "
            f"diff {r['rerun'] - r['published']:+.3g} (95 % half-width {r['half_width']:.1f}), "
            f"per-episode equal: {_equal(r['per_episode_equal'])}, inside: {r['inside']}")  # fmt: skip


__all__ = ["format_rerun", "rerun_cell"]
