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

import numpy as np

from planetnav_env.errors import ConfigError
from planetnav_train import extensions
from planetnav_train.config import TrainConfig, is_rllib_algo
from planetnav_train.provenance import provenance
from planetnav_train.stats import mean_ci
from planetnav_train.suite.cells import Cell, Settings, cell_config, load_assists, rerun_command
from planetnav_train.suite.tasks import (
    INTERFACE_RANDOM,
    OBJECTIVES,
    Objective,
    Task,
    get_algo,
    get_task,
)

# ---------------------------------------------------------------------------------------------------------
# References
# ---------------------------------------------------------------------------------------------------------


def _agent_key(task: Task, spec: str, settings: Settings) -> str:
    """The reference cache's key of agent ``spec`` on ``task``: what its values depend on (the env, the
    objective, the seeds, the episode length, the noise streams, the protocol), not the task's budget or
    its other candidates, so adding a candidate evaluates that one agent only."""
    what = [task.env_id, task.objective, spec, task.eval_seed, settings.eval_episodes or task.eval_episodes,
            settings.episode_steps, task.noise_streams, task.suite_version]  # fmt: skip
    return hashlib.sha256(json.dumps(what).encode()).hexdigest()[:12]


def _agent_summary(objective: Objective, metrics: Mapping[str, Any]) -> dict[str, Any]:
    values = objective.values(metrics)
    ci = mean_ci(values)
    return {"objective": ci.mean, "ci95": [ci.low, ci.high], "per_episode": values.tolist()}


def agent_cache_path(task: Task, spec: str, settings: Settings) -> Path:
    """Where :func:`reference_agent` caches agent ``spec``'s values on ``task`` under ``settings.out``."""
    return settings.out / "references" / "agents" / f"{task.id}__{_agent_key(task, spec, settings)}.json"


def reference_agent(task: Task, spec: str, settings: Settings) -> dict[str, Any]:
    """Agent ``spec``'s objective on ``task``'s evaluation seeds (mean, 95 % t-interval, per-episode
    values, wall seconds, provenance), cached in ``OUT/references/agents/`` per agent (the planner and the
    3,000-step tasks take minutes per agent). The references and the zero point are properties of the
    physical task: every agent acts in the interface the task declares for its rule agents
    (:meth:`Task.rule_config`: one decision per physics step, absolute targets), ``random`` included;
    :data:`INTERFACE_RANDOM` is the random policy in the task's own interface."""
    from planetnav_train.evaluate import evaluate_agent

    path = agent_cache_path(task, spec, settings)
    if path.is_file():
        return json.loads(path.read_text())
    if spec == INTERFACE_RANDOM:
        spec, env_cfg = task.random, task.eval_config(settings.episode_steps)
    else:
        env_cfg = task.rule_config(settings.episode_steps)
    episodes = settings.eval_episodes or task.eval_episodes
    t0 = time.perf_counter()
    result = evaluate_agent(spec, env_cfg, episodes, task.eval_seed, progress=settings.progress)
    wall_s = time.perf_counter() - t0
    summary = {"agent": spec, **_agent_summary(OBJECTIVES[task.objective], result.metrics),
               "wall_seconds": wall_s, "provenance": provenance(wall_s=wall_s)}  # fmt: skip
    write_json_atomic(path, summary)
    return summary


def zero_candidates(task: Task, env_cfg: Any) -> tuple[str, ...]:
    """The agents of ``task.zero`` that can act on the task (``idle`` needs the target-choice "camera off"
    action): the score's zero point is the better of them."""
    from planetnav_agents import not_applicable

    out = tuple(s for s in task.zero if not_applicable(s, env_cfg) is None)
    return out or (task.random,)


def reference_settings(task: Task, settings: Settings) -> dict[str, Any]:
    """What a task's references were evaluated on (the head of ``OUT/references/<task>.json``): the task,
    its objective, the seeds, the episode length and the noise streams."""
    return {
        "task": task.id,
        "objective": task.objective,
        "eval_seed": task.eval_seed,
        "eval_episodes": settings.eval_episodes or task.eval_episodes,
        "episode_steps": settings.episode_steps or task.eval_config(settings.episode_steps).episode_steps,
        "noise_streams": task.noise_streams,
    }


def task_references(task: Task, settings: Settings) -> dict[str, Any]:
    """The task's reference values on its evaluation seeds: ``random``, the zero-point candidates and every
    best-reference candidate with 95 % t-intervals (:func:`reference_agent`, cached per agent); the zero
    point (the better of the zero candidates) and the best candidate (the lowest objective), chosen from
    the data. Each agent keeps the provenance of its evaluation (None for one cached before records
    carried it). Written to ``OUT/references/<task>.json``."""
    agents = {}
    zeros = zero_candidates(task, task.rule_config(settings.episode_steps))
    for spec in dict.fromkeys((task.random, *zeros, *task.references, INTERFACE_RANDOM)):
        summary = reference_agent(task, spec, settings)
        agents[spec] = {k: summary[k] for k in ("objective", "ci95", "per_episode", "wall_seconds")}
        agents[spec]["provenance"] = summary.get("provenance")
    best = min(task.references, key=lambda s: agents[s]["objective"])
    zero = min(zeros, key=lambda s: agents[s]["objective"])
    refs = {
        **reference_settings(task, settings),
        "agents": agents,
        "random": task.random,
        "zero": zero,
        "best": best,
        "J_random": agents[task.random]["objective"],
        "J_zero": agents[zero]["objective"],
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
    tc: TrainConfig,
    run_dir: Path,
    progress: bool = False,
    resume: bool = False,
    callbacks: Sequence[Any] = (),
) -> tuple[Path, dict[str, Any]]:
    """Train one cell's configuration (SB3 / sb3-contrib, or RLlib) into ``run_dir``, from its last
    checkpoint with ``resume``; the model path and the training statistics. ``callbacks``: SB3 callbacks
    (the learning curve). Tests replace this to count trainings."""
    if is_rllib_algo(tc.algo):
        return extensions.trainer(tc.algo).train(tc, run_dir, progress=progress, resume=resume)
    from planetnav_train.training import train

    return train(tc, run_dir, progress=progress, resume=resume, callbacks=callbacks)


#: Episodes of each learning-curve point: the first of the task's evaluation seeds (the same noise
#: streams), so that a point is scored against the published references' values on the very seeds it was
#: played on; 20 at least, so that a point's noise is a fraction of the score's scale.
CURVE_EPISODES = 20
#: Points of a learning curve (the budget's tenths); the last, at the end of training, is the final
#: evaluation itself (every evaluation seed), so the curve ends on the figure the table reports.
CURVE_POINTS = 10
EVAL_MODES = ("argmax", "sampled")


def _mode_spec(model_path: Path | str, mode: str) -> str:
    """The agent spec that scores a saved model's ``mode`` actions (``PATH@sampled`` for sampled)."""
    return f"{model_path}@sampled" if mode == "sampled" else str(model_path)


def curve_references(references: Mapping[str, Any]) -> dict[str, Any]:
    """The zero point's and the best reference's objective on the curve's episodes: the means of the
    published references' per-episode values (``references``, :func:`task_references`) over the first
    :data:`CURVE_EPISODES` evaluation seeds (all of them when there are fewer)."""
    agents = references["agents"]
    n = min(CURVE_EPISODES, len(agents[references["zero"]]["per_episode"]))
    return {
        "episodes": n,
        "J_zero": float(np.mean(agents[references["zero"]]["per_episode"][:n])),
        "J_best": float(np.mean(agents[references["best"]]["per_episode"][:n])),
    }


def learning_curve_callback(
    task: Task,
    settings: Settings,
    references: Mapping[str, Any],
    run_dir: Path,
    decisions: int,
    mode: str,
    per_decision: int,
) -> Any:
    """An SB3 callback that scores the policy at :data:`CURVE_POINTS` points during training on the first
    evaluation seeds (normalized against :func:`curve_references`) in the protocol's ``mode``; ``.points``
    holds ``[physics steps, score]`` pairs. The point at the end of training is the final evaluation's,
    which :func:`run_cell` appends."""
    from stable_baselines3.common.callbacks import BaseCallback

    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.suite.scoring import normalized_score

    refs = curve_references(references)
    objective = OBJECTIVES[task.objective]
    every = max(1, decisions // CURVE_POINTS)

    class LearningCurve(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.points: list[list[float]] = []
            self._next = every

        def score(self) -> None:
            path = run_dir / "curve_model.zip"  # beside the run's config.yaml, which the loader reads
            self.model.save(path)
            m = evaluate_agent(_mode_spec(path, mode), task.eval_config(settings.episode_steps),
                               refs["episodes"], task.eval_seed, progress=False,
                               exact_actions=settings.exact_actions).metrics  # fmt: skip
            j = float(np.mean(objective.values(m)))
            steps = int(self.model.num_timesteps) * per_decision
            self.points.append([steps, normalized_score(j, refs["J_zero"], refs["J_best"])])

        def _on_step(self) -> bool:
            # The end of training is the final evaluation's point, not scored here.
            if self.model.num_timesteps >= self._next and self._next < decisions:
                self._next += every
                self.score()
            return True

    return LearningCurve()


def run_cell(cell: Cell, settings: Settings, references: Mapping[str, Any]) -> dict[str, Any]:
    """Train, evaluate and score one cell; its run record (docs/suite.md lists the fields), with the
    :func:`~planetnav_train.provenance.provenance` of the process that ran it (on a grid runner's worker,
    that worker's) and the cell's wall seconds."""
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.suite.scoring import normalized_score

    task = get_task(cell.task)
    algo = get_algo(cell.algo)
    tc, assist_names = cell_config(cell, settings)
    objective = OBJECTIVES[task.objective]
    t0 = time.perf_counter()
    run_dir = settings.out / "models" / cell.key
    callbacks = []
    per_decision = tc.env_config().decision_steps
    if not is_rllib_algo(cell.algo):
        callbacks.append(learning_curve_callback(
            task, settings, references, run_dir, tc.n_timesteps, algo.eval_mode, per_decision))  # fmt: skip
    model_path, stats = train_cell(tc, run_dir, settings.progress, settings.resume, callbacks)
    train_s = time.perf_counter() - t0
    episodes = settings.eval_episodes or task.eval_episodes
    # argmax batched: the seeds as rows of the native vector env, one predict per decision for all of them
    # (evaluate.batch_reason says which models fall back to one episode at a time); sampled: per episode.
    modes = EVAL_MODES if not is_rllib_algo(cell.algo) else ("argmax",)
    evals = {}
    for mode in modes:
        result = evaluate_agent(
            _mode_spec(model_path, mode),
            task.eval_config(settings.episode_steps),
            episodes,
            task.eval_seed,
            settings.progress,
            batched=True,
            exact_actions=settings.exact_actions,
        )
        summary = _agent_summary(objective, result.metrics)
        j, j_best = summary["objective"], references["J_best"]
        evals[mode] = {
            "objective": j,
            "objective_ci95": summary["ci95"],
            "per_episode": summary["per_episode"],
            "normalized_score": normalized_score(j, references["J_zero"], j_best),
            "score_vs_random": normalized_score(j, references["J_random"], j_best),
        }
    mode = algo.eval_mode if algo.eval_mode in evals else "argmax"
    head = evals[mode]
    env_steps = int(stats.get("env_steps", stats.get("timesteps", 0) * per_decision))
    # The curve ends on the final evaluation (every evaluation seed, the protocol's mode).
    curve = [*callbacks[0].points, [env_steps, head["normalized_score"]]] if callbacks else []
    wall_s = time.perf_counter() - t0
    return {
        "suite_version": task.suite_version,
        "task": task.id,
        "task_version": task.version,
        "algorithm": cell.algo,
        "track": cell.track,
        "assists": assist_names,
        "seed": cell.seed,
        "objective_name": task.objective,
        "eval_mode": mode,
        "objective": head["objective"],
        "objective_ci95": head["objective_ci95"],
        "per_episode": head["per_episode"],
        "normalized_score": head["normalized_score"],
        "score_vs_random": head["score_vs_random"],
        "evaluations": evals,
        "learning_curve": curve,
        # Seeds of the points before the last ([first, end)); the last point is the final evaluation's.
        # None without a curve (RLlib cells).
        "curve_seeds": [task.eval_seed, task.eval_seed + curve_references(references)["episodes"]]
        if callbacks
        else None,
        "reference": {k: references[k] for k in ("random", "zero", "best", "J_random", "J_zero", "J_best")},
        # Physics steps: SB3's training reports them (env_steps); RLlib's counts decisions (timesteps).
        "env_steps": env_steps,
        "train_seconds": train_s,
        "wall_seconds": wall_s,
        "eval_episodes": episodes,
        "eval_seed": task.eval_seed,
        "episode_steps": settings.episode_steps,
        "budget_scale": settings.budget_scale,
        "exact_actions": settings.exact_actions,
        "official": settings.official,
        "config": tc.to_dict(),
        "command": rerun_command(cell, settings),
        "provenance": provenance(wall_s=wall_s),
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
