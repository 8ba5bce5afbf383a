"""The benchmark suite (docs/suite.md): versioned tasks, the algorithms that run on them, two tracks, and
the runner behind ``python train.py suite`` that trains, evaluates, scores and aggregates a grid of cells
(task x algorithm x track x training seed), one run record per cell, resumable.

Modules, by what they hold:

- :mod:`~planetnav_train.suite.tasks`: the registry: objectives, :data:`TASKS`, :data:`ALGOS`;
- :mod:`~planetnav_train.suite.cells`: tracks, assists, cells, the published grid and its coverage, a
  cell's training configuration and re-run command;
- :mod:`~planetnav_train.suite.runner`: the references, one cell trained, evaluated and scored, the grid
  (sequential, or a registered grid runner: Ray Tune from :mod:`planetnav_rl.suite_grid`);
- :mod:`~planetnav_train.suite.scoring`: the normalized score, IQM intervals, profiles, P(improvement)
  (rliable), aggregation of the records;
- :mod:`~planetnav_train.suite.leaderboard`: ``suite.json``, the markdown summary and leaderboard page;
- :mod:`~planetnav_train.suite.publish`: the published JSON, the README summary, the shipped baselines.
- :mod:`~planetnav_train.suite.references`, :mod:`~planetnav_train.suite.rerun`,
  :mod:`~planetnav_train.suite.sizes`: behind ``train.py suite-references`` (reference values, cached),
  ``suite-rerun`` (recorded cells re-run and compared) and ``suite-sizes`` (model and export bytes).

The names below are the suite's interface, imported from those modules.
"""

from planetnav_train.suite.cells import (
    Cell,
    Settings,
    cell_config,
    coverage,
    coverage_lines,
    load_assists,
    make_cells,
    published_grid,
    rerun_command,
)
from planetnav_train.suite.leaderboard import (
    aggregate_rows,
    best_per_task_rows,
    finish,
    suite_json,
    summary_markdown,
    write_leaderboard,
)
from planetnav_train.suite.runner import (
    load_records,
    record_path,
    reference_agent,
    run_cell,
    run_suite,
    task_references,
    train_cell,
)
from planetnav_train.suite.scoring import aggregate, score_matrices
from planetnav_train.suite.tasks import (
    ALGOS,
    ALGOS_BY_KIND,
    OBJECTIVES,
    SUITE_VERSION,
    SUITES,
    TASKS,
    TASKS_BY_ID,
    TASKS_V1,
    TASKS_V2,
    TRACKS,
    Algo,
    Objective,
    Task,
    get_algo,
    get_task,
    records_version,
)

__all__ = [
    "ALGOS",
    "ALGOS_BY_KIND",
    "OBJECTIVES",
    "SUITES",
    "SUITE_VERSION",
    "TASKS",
    "TASKS_BY_ID",
    "TASKS_V1",
    "TASKS_V2",
    "TRACKS",
    "Algo",
    "Cell",
    "Objective",
    "Settings",
    "Task",
    "aggregate",
    "aggregate_rows",
    "best_per_task_rows",
    "cell_config",
    "coverage",
    "coverage_lines",
    "finish",
    "get_algo",
    "get_task",
    "load_assists",
    "load_records",
    "make_cells",
    "published_grid",
    "record_path",
    "records_version",
    "reference_agent",
    "rerun_command",
    "run_cell",
    "run_suite",
    "score_matrices",
    "suite_json",
    "summary_markdown",
    "task_references",
    "train_cell",
    "write_leaderboard",
]
