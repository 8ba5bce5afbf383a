"""The benchmark suite's cells as a Ray Tune grid (``train.py suite`` where Ray is installed).

Registered as the ``ray`` grid runner of :func:`planetnav_train.suite.runner.run_suite`
(:mod:`planetnav_rl.extensions`). Each trial runs one cell with
:func:`~planetnav_train.suite.runner.run_cell`; the record goes back to the driver in the reported
metrics, and a driver-side callback writes it as it arrives, so an interrupted grid resumes from the
records like the sequential path, even when the trial ran on another node of a cluster.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from planetnav_train.suite.cells import Cell, Settings
from planetnav_train.suite.runner import record_path, run_cell, write_json_atomic


def _ray_cell(config: dict[str, Any]) -> None:
    """A Tune trial: one cell, its record reported to the driver."""
    from ray import tune

    cell = Cell(**config["cell"])
    settings = Settings(**{**config["settings"], "out": Path(config["settings"]["out"])})
    record = run_cell(cell, settings, config["references"][cell.task])
    tune.report({"record": json.dumps(record), "normalized_score": record["normalized_score"]})


def run_ray_grid(
    cells: Sequence[Cell], settings: Settings, refs: Mapping[str, Any], address: str | None
) -> list[dict[str, Any]]:
    """The cells as a Ray Tune grid (one CPU each); the records of this invocation."""
    from ray import tune

    from planetnav_rl.cluster import init_ray, shutdown_ray

    records: list[dict[str, Any]] = []

    class _Writer(tune.Callback):
        def on_trial_result(
            self, iteration: int, trials: list, trial: Any, result: dict, **info: Any
        ) -> None:
            record = json.loads(result["record"])
            cell = Cell(record["task"], record["algorithm"], record["track"], record["seed"])
            write_json_atomic(record_path(settings.out, cell), record)
            records.append(record)

    base_settings = {**dataclasses.asdict(settings), "out": str(settings.out.resolve())}
    space = {
        "cell": tune.grid_search([dataclasses.asdict(c) for c in cells]),
        "settings": base_settings,
        "references": {c.task: refs[c.task] for c in cells},
    }
    info = init_ray(address)
    try:
        tuner = tune.Tuner(
            tune.with_resources(_ray_cell, {"cpu": 1}),
            param_space=space,
            run_config=tune.RunConfig(
                name="suite",
                storage_path=str((settings.out / "tune").resolve()),
                callbacks=[_Writer()],
                verbose=1,
            ),
        )
        grid = tuner.fit()
    finally:
        shutdown_ray(info)
    failed = [grid[i].config["cell"] for i in range(len(grid)) if grid[i].error]
    if failed:  # the finished cells' records are written; --resume runs the failed ones again
        keys = [Cell(**c).key for c in failed]
        raise RuntimeError(f"{len(failed)} cell(s) failed on Ray ({keys}); see {settings.out / 'tune'}")
    return records


__all__ = ["run_ray_grid"]
