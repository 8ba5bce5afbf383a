"""The runner behind ``python train.py suite``: the references of each task, then each cell trained,
evaluated and scored into one run record, sequentially or on a registered grid runner (``ray``, from
:mod:`planetnav_rl.suite_grid`); each finished cell writes ``OUT/runs/<cell>.json`` at once, and
``--resume`` skips the cells whose record exists (docs/suite.md).

The suite imports nothing from ``train.py``; scores and aggregation are :mod:`planetnav_train.suite.scoring`.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from planetnav_env.errors import ConfigError
from planetnav_train import extensions
from planetnav_train.config import TrainConfig, is_rllib_algo
from planetnav_train.stats import mean_ci
from planetnav_train.suite.cells import Cell, Settings, cell_config, load_assists, rerun_command
from planetnav_train.suite.tasks import OBJECTIVES, SUITE_VERSION, Objective, Task, get_algo, get_task

# ---------------------------------------------------------------------------------------------------------
# References
# ---------------------------------------------------------------------------------------------------------


def _agent_key(task: Task, spec: str, settings: Settings) -> str:
    """The reference cache's key of agent ``spec`` on ``task``: what its values depend on (the env, the
    objective, the seeds, the episode length, the noise streams, the protocol), not the task's budget or
    its other candidates, so adding a candidate evaluates that one agent only."""
    what = [task.env_id, task.objective, spec, task.eval_seed, settings.eval_episodes or task.eval_episodes,
            settings.episode_steps, task.noise_streams, SUITE_VERSION]  # fmt: skip
    return hashlib.sha256(json.dumps(what).encode()).hexdigest()[:12]


def _agent_summary(objective: Objective, metrics: Mapping[str, Any]) -> dict[str, Any]:
    values = objective.values(metrics)
    ci = mean_ci(values)
    return {"objective": ci.mean, "ci95": [ci.low, ci.high], "per_episode": values.tolist()}


def reference_agent(task: Task, spec: str, settings: Settings) -> dict[str, Any]:
    """Agent ``spec``'s objective on ``task``'s evaluation seeds (mean, 95 % t-interval, per-episode
    values, wall seconds), cached in ``OUT/references/agents/`` per agent (the planner and the 3,000-step
    tasks take minutes per agent)."""
    from planetnav_train.evaluate import evaluate_agent

    path = settings.out / "references" / "agents" / f"{task.id}__{_agent_key(task, spec, settings)}.json"
    if path.is_file():
        return json.loads(path.read_text())
    env_cfg = task.eval_config(settings.episode_steps)
    episodes = settings.eval_episodes or task.eval_episodes
    t0 = time.perf_counter()
    result = evaluate_agent(spec, env_cfg, episodes, task.eval_seed, progress=settings.progress)
    summary = {"agent": spec, **_agent_summary(OBJECTIVES[task.objective], result.metrics),
               "wall_seconds": time.perf_counter() - t0}  # fmt: skip
    write_json_atomic(path, summary)
    return summary


def task_references(task: Task, settings: Settings) -> dict[str, Any]:
    """The task's reference values on its evaluation seeds: ``random`` and every candidate with 95 %
    t-intervals (:func:`reference_agent`, cached per agent), and the best candidate: the one with the
    lowest objective, chosen from the data. Written to ``OUT/references/<task>.json``."""
    env_cfg = task.eval_config(settings.episode_steps)
    episodes = settings.eval_episodes or task.eval_episodes
    agents = {}
    for spec in (task.random, *task.references):
        summary = reference_agent(task, spec, settings)
        agents[spec] = {k: summary[k] for k in ("objective", "ci95", "per_episode")}
    best = min(task.references, key=lambda s: agents[s]["objective"])
    refs = {
        "task": task.id,
        "objective": task.objective,
        "eval_seed": task.eval_seed,
        "eval_episodes": episodes,
        "episode_steps": settings.episode_steps or env_cfg.episode_steps,
        "noise_streams": task.noise_streams,
        "agents": agents,
        "random": task.random,
        "best": best,
        "J_random": agents[task.random]["objective"],
        "J_best": agents[best]["objective"],
    }
    write_json_atomic(settings.out / "references" / f"{task.id}.json", refs)
    return refs


# ---------------------------------------------------------------------------------------------------------
# One cell
# ---------------------------------------------------------------------------------------------------------


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON so that an interrupted run leaves either the old file or the new one, never half."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def train_cell(
    tc: TrainConfig, run_dir: Path, progress: bool = False, resume: bool = False
) -> tuple[Path, dict[str, Any]]:
    """Train one cell's configuration (SB3 / sb3-contrib, or RLlib) into ``run_dir``, from its last
    checkpoint with ``resume``; the model path and the training statistics. Tests replace this to count
    trainings."""
    if is_rllib_algo(tc.algo):
        return extensions.trainer(tc.algo).train(tc, run_dir, progress=progress, resume=resume)
    from planetnav_train.training import train

    return train(tc, run_dir, progress=progress, resume=resume)


def run_cell(cell: Cell, settings: Settings, references: Mapping[str, Any]) -> dict[str, Any]:
    """Train, evaluate and score one cell; its run record (docs/suite.md lists the fields)."""
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.suite.scoring import normalized_score

    task = get_task(cell.task)
    tc, assist_names = cell_config(cell, settings)
    objective = OBJECTIVES[task.objective]
    t0 = time.perf_counter()
    model_path, stats = train_cell(tc, settings.out / "models" / cell.key, settings.progress, settings.resume)
    train_s = time.perf_counter() - t0
    episodes = settings.eval_episodes or task.eval_episodes
    # batched: the seeds as rows of the native vector env, one predict per decision for all of them
    # (evaluate.batch_reason says which models fall back to one episode at a time).
    result = evaluate_agent(
        str(model_path),
        task.eval_config(settings.episode_steps),
        episodes,
        task.eval_seed,
        settings.progress,
        batched=True,
        exact_actions=settings.exact_actions,
    )
    summary = _agent_summary(objective, result.metrics)
    return {
        "suite_version": SUITE_VERSION,
        "task": task.id,
        "task_version": task.version,
        "algorithm": cell.algo,
        "track": cell.track,
        "assists": assist_names,
        "seed": cell.seed,
        "objective_name": task.objective,
        "objective": summary["objective"],
        "objective_ci95": summary["ci95"],
        "per_episode": summary["per_episode"],
        "normalized_score": normalized_score(
            summary["objective"], references["J_random"], references["J_best"]
        ),
        "reference": {k: references[k] for k in ("random", "best", "J_random", "J_best")},
        "env_steps": int(stats.get("env_steps", stats.get("timesteps", 0))),
        "train_seconds": train_s,
        "wall_seconds": time.perf_counter() - t0,
        "eval_episodes": episodes,
        "eval_seed": task.eval_seed,
        "episode_steps": settings.episode_steps,
        "budget_scale": settings.budget_scale,
        "exact_actions": settings.exact_actions,
        "official": settings.official,
        "config": tc.to_dict(),
        "command": rerun_command(cell, settings),
    }


# ---------------------------------------------------------------------------------------------------------
# The grid
# ---------------------------------------------------------------------------------------------------------


def record_path(out: Path, cell: Cell) -> Path:
    """Where the record of ``cell`` lives; its existence is what makes the cell finished."""
    return out / "runs" / f"{cell.key}.json"


def load_records(out: Path) -> list[dict[str, Any]]:
    """Every finished run record under ``out/runs``, sorted by cell."""
    return [json.loads(p.read_text()) for p in sorted((out / "runs").glob("*.json"))]


def _run_sequential(
    cells: Sequence[Cell], settings: Settings, refs: Mapping[str, Any]
) -> list[dict[str, Any]]:
    records = []
    for i, cell in enumerate(cells):
        print(f"[{i + 1}/{len(cells)}] {cell.key}", flush=True)
        record = run_cell(cell, settings, refs[cell.task])
        write_json_atomic(record_path(settings.out, cell), record)  # finished: --resume skips it from now
        print(f"  objective {record['objective']:.1f}, score {record['normalized_score']:+.2f}, "
              f"{record['wall_seconds']:.0f} s", flush=True)  # fmt: skip
        records.append(record)
    return records


def ray_available() -> bool:
    """Whether Ray (the ``ray`` extra) is installed: then the grid runs on Ray Tune."""
    import importlib.util

    return importlib.util.find_spec("ray") is not None


def run_suite(
    cells: Sequence[Cell],
    settings: Settings,
    resume: bool = False,
    use_ray: bool | None = None,
    address: str | None = None,
) -> dict[str, Any]:
    """Run the ``cells`` not yet finished under ``settings.out`` (with ``resume``; without it, a finished
    cell in the way is an error), then score and aggregate every record there. Returns
    ``{"ran": records of this invocation, "skipped": keys of finished cells, "records": all, ...}``."""
    settings.out.mkdir(parents=True, exist_ok=True)
    for name in sorted({c.algo for c in cells}):
        get_algo(name).check_installed()
    done = [c for c in cells if record_path(settings.out, c).is_file()]
    if done and not resume:
        raise ConfigError(
            f"{len(done)} of the cells already have records in {settings.out}/runs (e.g. {done[0].key}): "
            "pass --resume to skip them, or another --out"
        )
    todo = [c for c in cells if c not in done]
    if any(c.track == "assisted" for c in todo):
        load_assists(settings.assists_path)  # a bad assists file fails before anything trains
    refs = {t: task_references(get_task(t), settings) for t in sorted({c.task for c in cells})}
    print(f"suite: {len(todo)} cell(s) to run, {len(done)} finished (skipped)", flush=True)
    use_ray = ray_available() if use_ray is None else use_ray
    if address and not use_ray:
        raise ConfigError(
            f"--address {address!r}: the suite runs on Ray only when Ray is installed ([ray] extra)"
        )
    if not todo:
        ran: list[dict[str, Any]] = []
    elif use_ray:
        ran = extensions.grid_runner("ray")(todo, settings, refs, address)
    else:
        ran = _run_sequential(todo, settings, refs)
    records = load_records(settings.out)
    return {"ran": ran, "skipped": [c.key for c in done], "records": records, "references": refs}
