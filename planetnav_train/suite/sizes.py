"""Bytes of a saved model and of its policy-only export per suite algorithm and task, behind
``python train.py suite-sizes`` (docs/suite.md, "Shipped baselines"): which algorithms' best policies can
ship as a baseline (under 1 MB, :data:`planetnav_train.shipped.MAX_BASELINE_BYTES`), as the full model or
as the export (:func:`planetnav_train.export.export_policy`, which also checks the export acts as the
model).

Each model is built with the suite's settings of its raw-track cell (policy and hyper-parameters of
:func:`~planetnav_train.suite.cells.cell_config`), updated once (so its optimizers hold their state, as
after training) and saved by SB3 as training saves it (networks, target networks and optimizer state; no
replay buffer). More training changes the weights, not the size (the export is deflated float32: trained
weights compress no better than these).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.errors import ConfigError
from planetnav_train.config import TrainConfig, is_rllib_algo
from planetnav_train.export import export_policy
from planetnav_train.sb3 import algorithm_class
from planetnav_train.shipped import MAX_BASELINE_BYTES
from planetnav_train.suite.cells import Cell, Settings, cell_config
from planetnav_train.suite.tasks import ALGOS_BY_KIND, Task, get_algo, get_task

#: Episode length of the environment the models are built on (it sets the spaces, not the sizes).
_BUILD_EPISODE_STEPS = 10


def save_cell_model(task: Task, algo: str, env: PlanetNavEnv, tc: TrainConfig, folder: Path) -> Path:
    """Build ``algo`` with the suite cell's settings ``tc`` on ``env``, update it once (so its optimizers
    hold their state, Adam's moments: 2x the weights, as after training; an untrained model saves empty
    optimizer state) and save it as training does; the zip's path."""
    hp = dict(tc.hyperparams)
    if "train_freq" in hp or algo == "dqn":
        hp["buffer_size"] = 1_000  # not saved; the default 10^6 rows would only take memory
        hp["learning_starts"] = 0  # an update within the few steps below
    model = algorithm_class(algo)(tc.policy, env, seed=0, **hp)
    model.learn(getattr(model, "n_steps", 8) * model.n_envs)
    path = folder / f"{task.id}__{algo}.zip"
    model.save(path)
    return path


def ships_as(full: int, policy_only: int | None, limit: int = MAX_BASELINE_BYTES) -> str:
    """The form a model of ``full`` bytes whose export has ``policy_only`` bytes (None: not exported)
    ships in: ``full``, ``policy-only`` or ``none (refused)``; without the export, ``no`` for a model of
    ``limit`` bytes or more."""
    if full < limit:
        return "full"
    if policy_only is None:
        return "no"
    return "policy-only" if policy_only < limit else "none (refused)"


def cell_sizes(
    tasks: Sequence[str], algos: Sequence[str] | None = None, export: bool = True
) -> Iterator[dict[str, Any]]:
    """One row per task and algorithm (``algos``, default: each task's SB3 algorithms of the published
    table), as each model is built: ``task``, ``algorithm``, ``obs`` (observation length), ``full``
    (bytes of the saved model), ``policy_only`` (bytes of its export; None without ``export``),
    ``ships_as`` (:func:`ships_as`), or ``error`` for a cell that cannot be built or exported (an
    algorithm of another action kind, an RLlib one, a missing extra, a configuration or export error:
    one bad cell does not hide the others' sizes). Unknown task or algorithm names raise
    :class:`ConfigError` here, before anything is built."""
    chosen = [get_task(t) for t in tasks]
    for a in algos or ():
        get_algo(a)
    return _rows(chosen, algos, export)


def _rows(tasks: Sequence[Task], algos: Sequence[str] | None, export: bool) -> Iterator[dict[str, Any]]:
    with tempfile.TemporaryDirectory(prefix="planetnav-sizes-") as tmp:
        folder = Path(tmp)
        settings = Settings(out=folder)
        for task in tasks:
            env = PlanetNavEnv(task.env_config(episode_steps=_BUILD_EPISODE_STEPS))
            obs = int(env.observation_space.shape[0])
            for algo in algos or ALGOS_BY_KIND[task.action_kind]:
                row: dict[str, Any] = {"task": task.id, "algorithm": algo, "obs": obs}
                kinds = get_algo(algo).kinds
                if task.action_kind not in kinds:
                    yield {**row, "error": f"runs on {' and '.join(kinds)} actions, not {task.action_kind}"}
                    continue
                if is_rllib_algo(algo):
                    yield {**row, "error": "an RLlib checkpoint (a folder), not an SB3 model: does not ship"}
                    continue
                try:
                    tc, _ = cell_config(Cell(task.id, algo, "raw", 0), settings)
                    path = save_cell_model(task, algo, env, tc, folder)
                except ConfigError as exc:  # the cell's settings, or a library its algorithm needs
                    yield {**row, "error": f"config error: {exc}"}
                    continue
                row["full"] = path.stat().st_size
                row["policy_only"] = None
                if export:
                    try:
                        small = export_policy(path, path.with_suffix(".policy.zip"), algo)
                    except ValueError as exc:  # a space or parameter the export cannot hold: named in exc
                        yield {**row, "error": f"no policy-only export: {exc}"}
                        continue
                    row["policy_only"] = small.stat().st_size
                row["ships_as"] = ships_as(row["full"], row["policy_only"])
                yield row
            env.close()


def table_header(export: bool = True) -> list[str]:
    """The markdown table's header lines for :func:`table_row`."""
    if export:
        return [
            "| task | algorithm | obs | full bytes | policy-only bytes | ships as |",
            "|---|---|---|---|---|---|",
        ]
    return ["| task | algorithm | obs | bytes | ships (< 1 MB) |", "|---|---|---|---|---|"]


def table_row(row: Mapping[str, Any], export: bool = True) -> str:
    """One row of :func:`cell_sizes` as a markdown table row under :func:`table_header`."""
    head = f"| {row['task']} | {row['algorithm']} | {row['obs']} |"
    if "error" in row:
        full = f"{row['full']:,}" if "full" in row else "-"
        return f"{head} {full} | - | {row['error']} |" if export else f"{head} {full} | {row['error']} |"
    if export:
        return f"{head} {row['full']:,} | {row['policy_only']:,} | {row['ships_as']} |"
    return f"{head} {row['full']:,} | {'yes' if row['ships_as'] == 'full' else 'no'} |"


__all__ = ["cell_sizes", "save_cell_model", "ships_as", "table_header", "table_row"]
