"""Restoring a suite's output folder from its published JSON (``docs/benchmark.json``), the inverse of
:func:`planetnav_train.suite.publish.publish_json`.

The records and models of a suite run live in its output folder (``runs/suite``), which the repository
does not hold. A fresh clone that wants to re-run a few cells and publish again would otherwise have to
re-run the whole table. :func:`restore` writes back what the published JSON keeps:

- one record per run (``OUT/runs/<cell>.json``): every figure the page aggregates (objective and its
  interval, scores in both evaluation modes, learning curve, wall seconds, command), without the per-seed
  values and the training config, which the published copy leaves out; such a record carries
  ``"restored_from"``, and the ``provenance`` of the run as published: ``null`` for a run published
  without one (the machine that restores it did not produce it);
- each task's references (``OUT/references/<task>.json``);
- the per-agent reference cache (``OUT/references/agents/``), where the JSON has each agent's per-seed
  values and wall seconds (JSON published before it kept them has not): then a re-run cell does not
  evaluate its task's references again, and the page's wall time counts them; each cached agent keeps
  its published ``provenance``, ``null`` where it has none.

``train.py suite-publish`` over the restored folder re-aggregates to the published page; re-running a cell
(``train.py suite ... --out OUT``) replaces its restored record, and a new publish takes it in. Files that
already exist are never overwritten: a local record holds more than the published one. Models are not in
the JSON, so ``suite-publish --baselines`` can ship only tasks whose best run has been re-run here
(``--baseline-tasks``); for the others the shipped model stays as it is.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planetnav_env.errors import ConfigError
from planetnav_train.suite.cells import Cell
from planetnav_train.suite.runner import (
    Settings,
    agent_cache_path,
    record_path,
    reference_settings,
    write_json_atomic,
)
from planetnav_train.suite.tasks import SUITES, get_task

#: The fields every published run must have for the page to aggregate it.
RUN_FIELDS = ("task", "algorithm", "track", "seed", "objective", "normalized_score", "official")


@dataclass
class Restored:
    """What :func:`restore` wrote (paths) and left (existing paths, agents without per-seed values)."""

    records: list[Path] = field(default_factory=list)
    references: list[Path] = field(default_factory=list)
    agents: list[Path] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)
    #: ``<task>/<agent>`` not cached: the JSON has not its per-seed values and wall seconds, or they are of
    #: other than the task's official evaluation settings.
    uncached: list[str] = field(default_factory=list)


def _write_new(path: Path, data: Any, wrote: list[Path], kept: list[Path]) -> None:
    if path.exists():
        kept.append(path)
    else:
        write_json_atomic(path, data)
        wrote.append(path)


def restore(published: str | Path, out: str | Path) -> Restored:
    """Write the records, references and reference cache of the suite JSON ``published`` into the output
    folder ``out`` (module docstring). :class:`ConfigError` naming the value for a missing or unreadable
    file, another suite version, a run without the fields of :data:`RUN_FIELDS` or of an unknown task."""
    path = Path(published)
    if not path.is_file():
        raise ConfigError(f"no suite JSON at {path} to restore from")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ConfigError(f"{path} is not a suite JSON: {err}") from None
    if not isinstance(data, dict) or "runs" not in data or "references" not in data:
        raise ConfigError(f"{path} is not a suite JSON: it has no 'runs' and 'references'")
    version = data.get("suite_version")
    if version not in SUITES:
        raise ConfigError(f"{path} holds suite version {version!r}; the versions are {sorted(SUITES)}")
    settings = Settings(out=Path(out))
    done = Restored()
    for i, run in enumerate(data["runs"]):
        missing = [k for k in RUN_FIELDS if k not in run]
        if missing:
            raise ConfigError(f"{path}: run {i} has no {missing}")
        task = get_task(run["task"])
        if task.suite_version != version:
            raise ConfigError(f"{path}: run {i} is on {task.id}, a task of suite version "
                              f"{task.suite_version}, in a table of version {version}")  # fmt: skip
        cell = Cell(task.id, run["algorithm"], run["track"], int(run["seed"]))
        # Never this machine's provenance: the published one, or null for a run published without it.
        record = {"provenance": None, **run, "restored_from": str(path)}
        _write_new(record_path(settings.out, cell), record, done.records, done.kept)
    for name, refs in data["references"].items():
        task = get_task(name)
        _write_new(settings.out / "references" / f"{task.id}.json", refs, done.references, done.kept)
        # The cache is keyed by the official evaluation settings: references of smoke settings stay out.
        official = all(refs.get(k) == v for k, v in reference_settings(task, settings).items())
        for spec, agent in refs.get("agents", {}).items():
            if not official or "per_episode" not in agent or "wall_seconds" not in agent:
                done.uncached.append(f"{task.id}/{spec}")
                continue
            cached = {"agent": spec, "provenance": None, **agent}
            _write_new(agent_cache_path(task, spec, settings), cached, done.agents, done.kept)
    return done


def format_restored(done: Restored, out: str | Path) -> str:
    """One paragraph for the command line."""
    lines = [
        f"restored into {out}: {len(done.records)} run records, {len(done.references)} task references, "
        f"{len(done.agents)} cached reference agents; {len(done.kept)} existing files kept"
    ]
    if done.uncached:
        lines.append(
            f"not cached ({len(done.uncached)} reference agents without per-seed values and wall seconds "
            "of the official settings in the JSON): a re-run cell evaluates its task's references again, "
            "and the page's wall time leaves them out until then"
        )
    return "\n".join(lines)


__all__ = ["RUN_FIELDS", "Restored", "format_restored", "restore"]
