"""The published table's wall time: what its finished cells and references cost, measured, and what the
unfinished cells will cost, projected from the finished ones (docs/suite.md, "Wall time of the table").

Every cell and every reference agent records its own wall seconds (``wall_seconds`` in its record and in
the per-agent reference cache ``OUT/references/agents/``). A cell of the table that has not run is
projected from the finished cells of the same algorithm and track: the mean wall time of that (task,
algorithm, track) where it ran, else that algorithm and track's mean wall time per physics step of
budget on the other tasks of the same action kind, times this task's budget. A cell with neither basis is
counted as not projected, and the total says so instead of leaving it out silently.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_train.suite.cells import Cell, published_grid
from planetnav_train.suite.tasks import get_algo, get_task, records_version

#: The table runs on one worker per core of the 2-core reference machine (docs/suite.md).
WORKERS = 2
#: The table's time limit, hours on :data:`WORKERS` workers.
LIMIT_HOURS = 8.0


@dataclass(frozen=True)
class WallTime:
    """Worker-seconds of the published table: measured (finished cells, references) and projected."""

    measured_cells: int
    measured_cell_s: float
    projected_cells: int
    projected_cell_s: float
    unprojected: tuple[str, ...]  # "task algo track" of cells with no basis for a projection
    reference_s: float  # every reference agent evaluated, all tasks
    reference_tasks: int
    unreferenced: tuple[str, ...] = ()  # tasks of the table whose references have not been evaluated
    #: "algorithm track" -> (cells, worker-seconds measured + projected): where the time goes.
    by_algo: tuple[tuple[str, int, float], ...] = ()

    @property
    def total_s(self) -> float:
        """Measured plus projected worker-seconds."""
        return self.measured_cell_s + self.projected_cell_s + self.reference_s

    @property
    def hours(self) -> float:
        """The total on :data:`WORKERS` workers, in hours."""
        return self.total_s / WORKERS / 3600.0


def _budget(cell: Cell) -> float:
    """The cell's training budget in physics steps."""
    return get_algo(cell.algo).budget(get_task(cell.task))


def reference_seconds(out: Path) -> dict[str, float]:
    """Per task, the wall seconds of every reference agent cached under ``out/references/agents``."""
    per: dict[str, float] = {}
    for p in sorted((out / "references" / "agents").glob("*.json")):
        data = json.loads(p.read_text())
        task = p.name.split("__", 1)[0]
        per[task] = per.get(task, 0.0) + float(data.get("wall_seconds", 0.0))
    return per


def table_wall_time(records: Sequence[Mapping[str, Any]], references_s: Mapping[str, float]) -> WallTime:
    """The published table's worker-seconds from the official ``records`` (each with ``wall_seconds``) and
    the reference agents' seconds per task (:func:`reference_seconds`); see the module docstring for the
    projection of the cells that have not run."""
    done: dict[tuple[str, str, str, int], float] = {
        (r["task"], r["algorithm"], r["track"], int(r["seed"])): float(r["wall_seconds"])
        for r in records if r.get("official")
    }  # fmt: skip
    grid = published_grid(records_version(records))
    tasks = {c.task for c in grid}
    key = {c: (c.task, c.algo, c.track, c.seed) for c in grid}
    finished = [c for c in grid if key[c] in done]
    same: dict[tuple[str, str, str], list[float]] = {}
    per_step: dict[tuple[str, str, str], list[float]] = {}
    for c in finished:
        same.setdefault((c.task, c.algo, c.track), []).append(done[key[c]])
        kind = get_task(c.task).action_kind
        per_step.setdefault((kind, c.algo, c.track), []).append(done[key[c]] / _budget(c))
    measured = [done[key[c]] for c in finished]
    projected, missing = [], []
    parts: dict[str, list[float]] = {}
    for c in grid:
        kind = get_task(c.task).action_kind
        if key[c] in done:
            cost = done[key[c]]
        elif (c.task, c.algo, c.track) in same:
            cost = float(np.mean(same[(c.task, c.algo, c.track)]))
            projected.append(cost)
        elif (kind, c.algo, c.track) in per_step:
            cost = float(np.mean(per_step[(kind, c.algo, c.track)])) * _budget(c)
            projected.append(cost)
        else:
            missing.append(f"{c.task} {c.algo} {c.track}")
            continue
        parts.setdefault(f"{c.algo} {c.track}", []).append(cost)
    return WallTime(
        measured_cells=len(measured),
        measured_cell_s=sum(measured),
        projected_cells=len(projected),
        projected_cell_s=sum(projected),
        unprojected=tuple(sorted(set(missing))),
        reference_s=sum(v for t, v in references_s.items() if t in tasks),
        reference_tasks=len(tasks & set(references_s)),
        unreferenced=tuple(sorted(tasks - set(references_s))),
        by_algo=tuple((k, len(v), sum(v)) for k, v in sorted(parts.items())),
    )


def wall_time_lines(wall: WallTime) -> list[str]:
    """Markdown: the table's measured and projected worker-seconds and hours on :data:`WORKERS` workers."""
    lines = [
        "| part | cells | worker-seconds |",
        "|---|---|---|",
        f"| cells finished (measured) | {wall.measured_cells} | {wall.measured_cell_s:,.0f} |",
        f"| cells not yet run (projected) | {wall.projected_cells} | {wall.projected_cell_s:,.0f} |",
        f"| references ({wall.reference_tasks} tasks, measured) | - | {wall.reference_s:,.0f} |",
        f"| **total** | {wall.measured_cells + wall.projected_cells} | **{wall.total_s:,.0f}** |",
        "",
        f"On {WORKERS} workers: **{wall.hours:.1f} h** (limit {LIMIT_HOURS:.0f} h).",
    ]
    if wall.by_algo:
        lines += ["", "Where it goes (cells measured and projected):", "",
                  "| algorithm, track | cells | worker-seconds |", "|---|---|---|"]  # fmt: skip
        lines += [f"| {name} | {n} | {s:,.0f} |" for name, n, s in wall.by_algo]
    if wall.unprojected:
        lines += [
            "",
            f"Not in the total: no finished cell of the same algorithm and track on a task of the same "
            f"action kind to project from, for {', '.join(wall.unprojected)} (5 seeds each).",
        ]
    if wall.unreferenced:
        lines += ["", f"Not in the total: the references of {', '.join(wall.unreferenced)}."]
    return [*lines, ""]


__all__ = ["LIMIT_HOURS", "WORKERS", "WallTime", "reference_seconds", "table_wall_time", "wall_time_lines"]
