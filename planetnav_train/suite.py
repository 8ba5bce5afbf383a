"""The benchmark suite (issue 19): versioned tasks, the algorithms that run on them, two tracks, and the
runner behind ``python train.py suite`` that trains, evaluates, scores and aggregates a grid of cells
(task x algorithm x track x training seed), one run record per cell, resumable (docs/suite.md).

- :class:`Task`: one frozen entry per task (:data:`TASKS`): its environment id and version, objective,
  100 held-out evaluation seeds with per-step noise streams, training budget in environment steps, the
  random reference and the candidates for the best non-learned reference, and the action kind. Adding a
  task is adding one entry.
- :data:`ALGOS`: the algorithms per action kind, with the suite's settings for each (policy, ``n_envs``,
  hyper-parameters). Their classes come from the one registry,
  :func:`planetnav_agents.sb3.algorithm_class` (SB3 and sb3-contrib), or RLlib
  (:data:`planetnav_train.config.RLLIB_ALGOS`).
- Tracks: ``raw`` trains on the environment as registered (its own observation and reward, no cloning,
  no features, no action repeat); ``assisted`` adds the named assists of ``configs/suite/assisted.yaml``.
- :func:`run_suite`: the grid, sequentially or as a Ray Tune grid; each finished cell writes
  ``OUT/runs/<cell>.json`` at once, and ``--resume`` skips the cells whose record exists.

The suite imports nothing from ``train.py``; scores and aggregation are :mod:`planetnav_train.scores`.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import os
import shlex
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planetnav_agents.stats import mean_ci
from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_env.registration import ENV_IDS
from planetnav_train.config import ROOT, TrainConfig, is_rllib_algo, parse_config

#: Version of the suite's protocol (seeds, objectives, scoring); a task's own version is its env id's.
SUITE_VERSION = 0
#: First held-out evaluation seed of every task: disjoint from training (0..), train.py's evaluation
#: (10_000..) and the periodic sweep (20_000..), so no setting was tuned on these seeds.
SUITE_EVAL_SEED = 50_000
SUITE_EVAL_EPISODES = 100
TRACKS = ("raw", "assisted")
ACTION_KINDS = ("discrete", "continuous")
DEFAULT_ASSISTS = ROOT / "configs" / "suite" / "assisted.yaml"


# ---------------------------------------------------------------------------------------------------------
# Objectives and tasks
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Objective:
    """How a task's objective (lower is better) is read from an evaluation's metrics
    (:func:`planetnav_train.evaluate.evaluate_agent`): the mean over episodes of ``per_episode``. With
    ``kind`` set, the evaluation's ``objective_kind`` must be it (an operations J read from an environment
    without operations would silently be the mean position error)."""

    name: str
    per_episode: str  # the metrics key with one value per evaluation seed
    unit: str
    description: str
    kind: str | None = None  # the evaluation's "objective_kind" this objective needs, when it needs one

    def values(self, metrics: Mapping[str, Any]) -> np.ndarray:
        """The objective's per-episode values from evaluation ``metrics``."""
        if self.per_episode not in metrics:
            raise ConfigError(f"objective {self.name!r}: the evaluation has no {self.per_episode!r}")
        if self.kind is not None and metrics.get("objective_kind") != self.kind:
            raise ConfigError(
                f"objective {self.name!r} needs an evaluation of kind {self.kind!r}, got "
                f"{metrics.get('objective_kind')!r}"
            )
        return np.asarray(metrics[self.per_episode], dtype=float)


OBJECTIVES: dict[str, Objective] = {
    "mean_pos_err_km": Objective(
        "mean_pos_err_km",
        "per_episode_mean_pos_err_km",
        "km",
        "mean over the episode's steps of the true position error of the filter, averaged over the seeds",
    ),
    # The one definition of J is planetnav_train.evaluate.episode_objective (compare reports the same
    # per_episode_objective): info["objective"] at the episode's end.
    "operations_J_km": Objective(
        "operations_J_km",
        "per_episode_objective",
        "km",
        "the scenario's J at the episode's end (info['objective']: the knowledge mapped to the encounter at "
        "each TCM deadline plus w x delta-v lost; docs/operations.md §3.2), averaged over the seeds",
        kind="operations J",
    ),
}


@dataclass(frozen=True)
class Task:
    """One benchmark task. ``id`` is the registered environment's name with its version (``-v0``); a change
    that could alter results bumps the environment's version, hence the task's."""

    env_id: str  # registered id, e.g. "planetnav/Cruise-Target-v0"
    action_kind: str  # "discrete" (target choice) or "continuous" (torque, target+torque)
    budget: int  # training budget in environment steps (decisions x action_repeat)
    references: tuple[str, ...]  # candidates for the best non-learned reference (agent specs)
    objective: str = "mean_pos_err_km"
    random: str = "random"
    eval_seed: int = SUITE_EVAL_SEED
    eval_episodes: int = SUITE_EVAL_EPISODES
    noise_streams: str = "per_step"  # common random numbers: every agent draws the same sensor noise

    def __post_init__(self) -> None:
        # Every field with a closed set of values, checked in one pass (one error names every bad value).
        choices: dict[str, Sequence[str]] = {
            "env_id": sorted(ENV_IDS), "action_kind": ACTION_KINDS, "objective": sorted(OBJECTIVES),
        }  # fmt: skip
        bad = [f"{k} {getattr(self, k)!r} is not one of {list(v)}" for k, v in choices.items()
               if getattr(self, k) not in v]  # fmt: skip
        if self.budget < 1 or not self.references:
            bad.append(f"budget {self.budget!r} must be >= 1 and references {self.references!r} non-empty")
        if bad:
            raise ConfigError(f"task {self.env_id!r}: " + "; ".join(bad))

    @property
    def id(self) -> str:
        """``Name-vN``: the environment id without its namespace."""
        return self.env_id.split("/", 1)[-1]

    @property
    def version(self) -> int:
        """N of the id's ``-vN``."""
        return int(self.id.rsplit("-v", 1)[1])

    @property
    def eval_seeds(self) -> tuple[int, ...]:
        """The held-out evaluation seeds."""
        return tuple(range(self.eval_seed, self.eval_seed + self.eval_episodes))

    def env_config(self, episode_steps: int | None = None) -> EnvConfig:
        """The registered environment (optionally with a shorter episode, for smoke runs)."""
        over = {"episode_steps": episode_steps} if episode_steps else {}
        return EnvConfig.from_dict({**ENV_IDS[self.env_id], **over})

    def eval_config(self, episode_steps: int | None = None) -> EnvConfig:
        """The evaluation environment: the registered one with the task's noise streams."""
        return EnvConfig.from_dict(self.env_config(episode_steps).to_dict(), noise_streams=self.noise_streams)

    def to_dict(self) -> dict[str, Any]:
        """The task as JSON data (recorded with the runs)."""
        return {**dataclasses.asdict(self), "id": self.id, "version": self.version}


_TARGET_REFS = ("greedy", "periodic", "planner")
#: Mars approach: one planet (periodic's cycles are over planets, so it has no schedule to run there).
_APPROACH_REFS = ("greedy", "planner", "baseline")
_TORQUE_REFS = ("greedy", "periodic", "planner", "baseline")
#: Wheel torques at 1 s (issue 18): greedy's choice executed by the PD law (docs/training.md).
_TORQUE_1S_REFS = ("greedy-pd",)
#: The thrust arc (issue 17, docs/operations.md §7): the tuned periodic schedule (2-h sessions every 3 d
#: from day 0.75), the tuned deadline-anchored periodic rule (§7.5: blocks ending at each TCM), the tuned
#: deadline-aware greedy and the open-loop optimum (§3.5); the lower J on the task's seeds is the best.
#: Another candidate is one more entry here (only it is then evaluated).
_THRUST_ARC_REFS = (
    "periodic:period=432,session=12,phase=108,cycle=0-1-2",
    "periodic:lead=0,session=24-42-12,start=6,dwell=3,cycle=0-1-2",
    "greedy:threshold=4",
    "optimum",
)
#: The task list. Budgets: docs/suite.md ("Budgets") derives them from measured training speed so the
#: published table (both tracks, 5 seeds) re-runs in under 8 hours on 2 cores.
TASKS: tuple[Task, ...] = (
    Task("planetnav/Cruise-Target-v0", "discrete", 200_000, _TARGET_REFS),
    Task("planetnav/RandomCruise-Target-v0", "discrete", 200_000, _TARGET_REFS),
    Task("planetnav/MarsApproach-Tasking-v0", "discrete", 200_000, _APPROACH_REFS),
    # Off-policy learners train at 120-190 env steps/s here even at one gradient step per 4 env steps.
    Task("planetnav/Cruise-Torque-v0", "continuous", 30_000, _TORQUE_REFS),
    Task("planetnav/Cruise-TargetTorque-v0", "continuous", 30_000, _TORQUE_REFS),
    Task("planetnav/Cruise-TorqueControl-v0", "continuous", 30_000, _TORQUE_1S_REFS),
    Task("planetnav/Cruise-Hybrid-v0", "continuous", 30_000, _TORQUE_1S_REFS),
    Task("planetnav/ThrustArc-TCM-v0", "discrete", 100_000, _THRUST_ARC_REFS, objective="operations_J_km"),
)
TASKS_BY_ID: dict[str, Task] = {t.id: t for t in TASKS}


def get_task(name: str) -> Task:
    """A task by id (``Cruise-Target-v0``) or environment id (``planetnav/Cruise-Target-v0``)."""
    key = name.split("/", 1)[-1]
    if key not in TASKS_BY_ID:
        raise ConfigError(f"unknown task {name!r}; the suite's tasks are {sorted(TASKS_BY_ID)}")
    return TASKS_BY_ID[key]


# ---------------------------------------------------------------------------------------------------------
# Algorithms
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Algo:
    """The suite's settings of one algorithm (``name`` is a training config's ``algo``)."""

    name: str
    kinds: tuple[str, ...]  # the action kinds it runs on
    policy: str = "MlpPolicy"
    n_envs: int = 8
    hyperparams: Mapping[str, Any] = field(default_factory=dict)
    extra: str = "train"  # the pyproject extra it needs: train (SB3), bench (sb3-contrib), ray (RLlib)

    def check_installed(self) -> None:
        """Raise :class:`ConfigError` naming the extra when the algorithm's library is missing."""
        import importlib.util

        module = {"bench": "sb3_contrib", "ray": "ray", "train": "stable_baselines3"}[self.extra]
        if importlib.util.find_spec(module) is None:
            raise ConfigError(
                f"algorithm {self.name!r} needs {module}, which is not installed: "
                f'pip install -e ".[{self.extra}]"'
            )


# 8 envs x 256 = 2,048 steps per update, 5 epochs of 4 minibatches (as configs/cruise_ppo.yaml's update)
_ON_POLICY = {"n_steps": 256, "batch_size": 512, "n_epochs": 5}
# One gradient step per 4 env steps (configs/experiments/torque_sac.yaml): SB3's default of one per step
# trains at ~20 env steps/s on the loaded 2-core machine, which no 8-hour table affords.
_OFF_POLICY = {"train_freq": 4, "gradient_steps": 1}
#: The suite's algorithms: SB3 defaults except where the budget asks for more frequent updates.
ALGOS: dict[str, Algo] = {
    a.name: a
    for a in (
        Algo("ppo", ACTION_KINDS, hyperparams=_ON_POLICY),
        Algo("a2c", ("discrete",)),
        Algo("dqn", ("discrete",), n_envs=1),
        Algo("recurrent_ppo", ("discrete",), policy="MlpLstmPolicy", hyperparams=_ON_POLICY, extra="bench"),
        Algo("maskable_ppo", ("discrete",), hyperparams=_ON_POLICY, extra="bench"),
        Algo("sac", ("continuous",), n_envs=1, hyperparams=_OFF_POLICY),
        Algo("td3", ("continuous",), n_envs=1, hyperparams=_OFF_POLICY),
        Algo("tqc", ("continuous",), n_envs=1, hyperparams=_OFF_POLICY, extra="bench"),
        # Samples in its own process (no env-runner actors): one CPU per cell, in a Tune grid too.
        Algo("rllib_ppo", ACTION_KINDS, n_envs=8, hyperparams={"num_env_runners": 0}, extra="ray"),
    )
}
#: The algorithms of the published table per action kind (RLlib's PPO on at least one task: see
#: docs/suite.md).
ALGOS_BY_KIND: dict[str, tuple[str, ...]] = {
    kind: tuple(a.name for a in ALGOS.values() if kind in a.kinds and a.extra != "ray")
    for kind in ACTION_KINDS
}


def get_algo(name: str) -> Algo:
    """An algorithm of :data:`ALGOS` by name (any case)."""
    key = str(name).lower()
    if key not in ALGOS:
        raise ConfigError(f"unknown algorithm {name!r}; the suite's algorithms are {sorted(ALGOS)}")
    return ALGOS[key]


# ---------------------------------------------------------------------------------------------------------
# Tracks and cells
# ---------------------------------------------------------------------------------------------------------

#: Keys an assist may set: every one is a training-side option of a training config.
ASSIST_KEYS = {"env", "features", "action_repeat", "relative_actions", "shaping", "pretrain", "hyperparams"}


def load_assists(path: str | Path = DEFAULT_ASSISTS) -> dict[str, Any]:
    """The assisted track's configuration: ``assists`` (name -> training config fragment) and ``tasks``
    (task id -> the assist names it uses). Raises :class:`ConfigError` naming bad entries."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"no assists configuration {p}")
    data = yaml.safe_load(p.read_text()) or {}
    assists, tasks = data.get("assists") or {}, data.get("tasks") or {}
    for name, frag in assists.items():
        if not isinstance(frag, Mapping) or not set(frag) <= ASSIST_KEYS:
            raise ConfigError(f"{p}: assist {name!r} must be a mapping of keys from {sorted(ASSIST_KEYS)}")
    for task, names in tasks.items():
        get_task(task)
        unknown = sorted(set(names) - set(assists))
        if unknown:
            raise ConfigError(f"{p}: task {task}: unknown assist(s) {unknown}; defined: {sorted(assists)}")
    return {"assists": dict(assists), "tasks": {k: list(v) for k, v in tasks.items()}}


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(dict(out[key]), value)
        elif isinstance(value, list) and isinstance(out.get(key), list):
            out[key] = out[key] + [v for v in value if v not in out[key]]
        else:
            out[key] = copy.deepcopy(value)
    return out


@dataclass(frozen=True)
class Settings:
    """What applies to every cell of one invocation (recorded in each run's command). Anything but the
    defaults (``budget_scale`` 1, the task's episodes and episode length) marks the run as not
    publishable (``official: false``)."""

    out: Path
    budget_scale: float = 1.0
    episode_steps: int | None = None  # smoke runs: shorter episodes in training and evaluation
    eval_episodes: int | None = None  # smoke runs: fewer evaluation seeds
    assists_path: str = str(DEFAULT_ASSISTS)
    progress: bool = False
    # False: a continuous policy predicts all evaluation rows in one call (evaluate_agent's exact_actions;
    # faster, equal to the one-episode evaluation to float rounding only). Recorded and in the command.
    exact_actions: bool = True

    @property
    def official(self) -> bool:
        return self.budget_scale == 1.0 and self.episode_steps is None and self.eval_episodes is None


@dataclass(frozen=True)
class Cell:
    """One run of the grid."""

    task: str
    algo: str
    track: str
    seed: int

    @property
    def key(self) -> str:
        """File-name-safe identity of the cell (its record is ``runs/<key>.json``)."""
        return f"{self.task}__{self.algo}__{self.track}__s{self.seed}"


def make_cells(tasks: Sequence[str], algos: Sequence[str], seeds: Sequence[int], track: str) -> list[Cell]:
    """The grid: every applicable (task, algorithm) pair x ``seeds``; an algorithm that fits none of the
    given tasks' action kinds is an error naming it (one that fits some is skipped on the others)."""
    if track not in TRACKS:
        raise ConfigError(f"--track {track!r} is not one of {TRACKS}")
    if any(int(s) < 0 for s in seeds):
        raise ConfigError(f"--seeds must be >= 0, got {list(seeds)}")
    ts = [get_task(t) for t in tasks]
    cells = []
    for name in algos:
        algo = get_algo(name)
        fits = [t for t in ts if t.action_kind in algo.kinds]
        if not fits:
            raise ConfigError(
                f"algorithm {algo.name!r} runs on {algo.kinds} tasks; none of {[t.id for t in ts]} is one"
            )
        cells += [Cell(t.id, algo.name, track, int(s)) for t in fits for s in seeds]
    return cells


#: The published table's training seeds, the assisted track's algorithms and RLlib's task (docs/suite.md).
PUBLISHED_SEEDS: tuple[int, ...] = (0, 1, 2, 3, 4)
ASSISTED_ALGOS: tuple[str, ...] = ("ppo",)
RLLIB_TASKS: tuple[str, ...] = ("Cruise-Target-v0",)


def published_grid() -> list[Cell]:
    """Every cell of the published table: raw, each task x the algorithms of its action kind (and
    ``rllib_ppo`` on :data:`RLLIB_TASKS`); assisted, each task x :data:`ASSISTED_ALGOS`; five seeds each."""
    cells = []
    for t in TASKS:
        raw = [*ALGOS_BY_KIND[t.action_kind], *(("rllib_ppo",) if t.id in RLLIB_TASKS else ())]
        cells += make_cells([t.id], raw, PUBLISHED_SEEDS, "raw")
        cells += make_cells([t.id], ASSISTED_ALGOS, PUBLISHED_SEEDS, "assisted")
    return cells


def coverage(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """How much of :func:`published_grid` the official ``records`` cover: per task and track the cells
    finished and expected, and the totals (``done``, ``expected``)."""
    done = {(r["task"], r["algorithm"], r["track"], int(r["seed"])) for r in records if r.get("official")}
    per: dict[str, dict[str, list[int]]] = {}
    for c in published_grid():
        row = per.setdefault(c.task, {}).setdefault(c.track, [0, 0])
        row[0] += (c.task, c.algo, c.track, c.seed) in done
        row[1] += 1
    total = [sum(v[i] for t in per.values() for v in t.values()) for i in (0, 1)]
    return {"per_task": per, "done": total[0], "expected": total[1]}


def coverage_lines(records: Sequence[Mapping[str, Any]], table: bool = True) -> list[str]:
    """Markdown: a line saying whether the records are the whole published table (and, with ``table``,
    the cells finished per task and track)."""
    cov = coverage(records)
    if cov["done"] == cov["expected"]:
        head = f"Complete: all {cov['expected']} cells of the published table."
    else:
        head = (
            f"**Partial**: {cov['done']} of the published table's {cov['expected']} cells are finished "
            "(the rest run in later invocations with `--resume`); aggregates over tasks cover only the "
            "tasks listed."
        )
    if not table:
        return [head, ""]
    lines = [head, "", "| task | raw cells | assisted cells |", "|---|---|---|"]
    for task, tracks in cov["per_task"].items():
        lines.append(f"| {task} | " + " | ".join(f"{tracks[k][0]} / {tracks[k][1]}" for k in TRACKS) + " |")
    return [*lines, ""]


def _fit_rollout(algo: Algo, hp: dict[str, Any], decisions: int) -> dict[str, Any]:
    """Smoke budgets: an on-policy rollout no longer than the budget (SB3 collects at least one)."""
    if "n_steps" in hp or algo.name in ("ppo", "a2c", "recurrent_ppo", "maskable_ppo"):
        n_steps = int(hp.get("n_steps", 5 if algo.name == "a2c" else 128))
        if n_steps * algo.n_envs > decisions:
            hp["n_steps"] = max(2, decisions // algo.n_envs)
            if "batch_size" in hp or algo.name != "a2c":
                hp["batch_size"] = max(2, hp["n_steps"] * algo.n_envs // 4)
    if algo.name in ("dqn", "sac", "td3", "tqc") and decisions < 1_000:
        hp["learning_starts"] = max(1, decisions // 4)  # learn at all within a smoke budget
    return hp


def cell_config(
    cell: Cell, settings: Settings, assists: Mapping[str, Any] | None = None
) -> tuple[TrainConfig, list[str]]:
    """The training configuration of ``cell`` and the names of the assists it uses (none on ``raw``)."""
    task, algo = get_task(cell.task), get_algo(cell.algo)
    data: dict[str, Any] = {
        "name": cell.key,
        "algo": algo.name,
        "env_id": task.env_id,
        "policy": algo.policy,
        "n_envs": algo.n_envs,
        "seed": cell.seed,
        "hyperparams": dict(algo.hyperparams),
        "env": {"episode_steps": settings.episode_steps} if settings.episode_steps else {},
    }
    names: list[str] = []
    if cell.track == "assisted":
        conf = assists if assists is not None else load_assists(settings.assists_path)
        names = list(conf["tasks"].get(cell.task, []))
        for name in names:
            data = _merge(data, conf["assists"][name])
    if algo.name == "maskable_ppo" and (data.get("features") or data.get("relative_actions")):
        # The mask reads the env's own observation layout and indexes its absolute target actions.
        raise ConfigError(
            f"{cell.key}: maskable_ppo masks the env's own targets; the assists {names} change the "
            "observation or the actions (features, relative_actions): run it on the raw track"
        )
    repeat = int(data.get("action_repeat", 1))
    decisions = max(1, round(task.budget * settings.budget_scale) // repeat)
    data["n_timesteps"] = decisions
    if not is_rllib_algo(algo.name):
        data["hyperparams"] = _fit_rollout(algo, dict(data["hyperparams"]), decisions)
    return parse_config(data, name=cell.key), names


def rerun_command(cell: Cell, settings: Settings) -> str:
    """The command that re-runs just ``cell`` (into its own output directory, so it never meets the
    original record), with this invocation's smoke settings."""
    args = ["python", "train.py", "suite", "--tasks", cell.task, "--algos", cell.algo, "--seeds",
            str(cell.seed), "--track", cell.track, "--out", f"runs/suite-rerun/{cell.key}"]  # fmt: skip
    if settings.budget_scale != 1.0:
        args += ["--budget-scale", repr(settings.budget_scale)]
    if settings.episode_steps:
        args += ["--episode-steps", str(settings.episode_steps)]
    if settings.eval_episodes:
        args += ["--eval-episodes", str(settings.eval_episodes)]
    if not settings.exact_actions:
        args += ["--no-exact-actions"]
    if cell.track == "assisted" and Path(settings.assists_path).resolve() != DEFAULT_ASSISTS.resolve():
        args += ["--assists", settings.assists_path]
    return shlex.join(args)


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
    _write_json_atomic(path, summary)
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
    _write_json_atomic(settings.out / "references" / f"{task.id}.json", refs)
    return refs


# ---------------------------------------------------------------------------------------------------------
# One cell
# ---------------------------------------------------------------------------------------------------------


def _write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON so that an interrupted run leaves either the old file or the new one, never half."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def train_cell(tc: TrainConfig, run_dir: Path, progress: bool = False) -> tuple[Path, dict[str, Any]]:
    """Train one cell's configuration (SB3 / sb3-contrib, or RLlib) into ``run_dir``; the model path and
    the training statistics. Tests replace this to count trainings."""
    if is_rllib_algo(tc.algo):
        from planetnav_rl.rllib import train as train_rllib

        return train_rllib(tc, run_dir, progress=progress)
    from planetnav_train.training import train

    return train(tc, run_dir, progress=progress)


def run_cell(cell: Cell, settings: Settings, references: Mapping[str, Any]) -> dict[str, Any]:
    """Train, evaluate and score one cell; its run record (docs/suite.md lists the fields)."""
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.scores import normalized_score

    task = get_task(cell.task)
    tc, assist_names = cell_config(cell, settings)
    objective = OBJECTIVES[task.objective]
    t0 = time.perf_counter()
    model_path, stats = train_cell(tc, settings.out / "models" / cell.key, settings.progress)
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
        _write_json_atomic(record_path(settings.out, cell), record)  # finished: --resume skips it from now
        print(f"  objective {record['objective']:.1f}, score {record['normalized_score']:+.2f}, "
              f"{record['wall_seconds']:.0f} s", flush=True)  # fmt: skip
        records.append(record)
    return records


def _ray_cell(config: dict[str, Any]) -> None:
    """A Tune trial: one cell; the record goes back to the driver in the reported metrics, so the driver
    writes it even when the trial ran on another node of a cluster."""
    from ray import tune

    cell = Cell(**config["cell"])
    settings = Settings(**{**config["settings"], "out": Path(config["settings"]["out"])})
    record = run_cell(cell, settings, config["references"][cell.task])
    tune.report({"record": json.dumps(record), "normalized_score": record["normalized_score"]})


def _run_ray(
    cells: Sequence[Cell], settings: Settings, refs: Mapping[str, Any], address: str | None
) -> list[dict[str, Any]]:
    """The cells as a Ray Tune grid (one CPU each); a driver-side callback writes each record as it
    arrives, so an interrupted grid resumes from the records like the sequential path."""
    from ray import tune

    from planetnav_rl.cluster import init_ray, shutdown_ray

    records: list[dict[str, Any]] = []

    class _Writer(tune.Callback):
        def on_trial_result(
            self, iteration: int, trials: list, trial: Any, result: dict, **info: Any
        ) -> None:
            record = json.loads(result["record"])
            cell = Cell(record["task"], record["algorithm"], record["track"], record["seed"])
            _write_json_atomic(record_path(settings.out, cell), record)
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
        ran = _run_ray(todo, settings, refs, address)
    else:
        ran = _run_sequential(todo, settings, refs)
    records = load_records(settings.out)
    return {"ran": ran, "skipped": [c.key for c in done], "records": records, "references": refs}


# ---------------------------------------------------------------------------------------------------------
# Aggregation and the leaderboard
# ---------------------------------------------------------------------------------------------------------


def score_matrices(
    records: Iterable[Mapping[str, Any]], track: str
) -> dict[str, tuple[list[str], np.ndarray]]:
    """Per algorithm of ``track``: its tasks and the ``(runs, tasks)`` score matrix, runs by seed order.
    Tasks with fewer seeds than the others of the algorithm are cut to the common count (rliable needs a
    full matrix); the cut is visible in the per-task table."""
    by: dict[str, dict[str, dict[int, float]]] = {}
    for r in records:
        if r["track"] == track:
            by.setdefault(r["algorithm"], {}).setdefault(r["task"], {})[int(r["seed"])] = r[
                "normalized_score"
            ]
    out = {}
    for algo, tasks in by.items():
        names = sorted(tasks)
        n = min(len(tasks[t]) for t in names)
        cols = [[tasks[t][s] for s in sorted(tasks[t])[:n]] for t in names]
        out[algo] = (names, np.array(cols, dtype=float).T)
    return out


def aggregate(records: Sequence[Mapping[str, Any]], reps: int | None = None) -> dict[str, Any]:
    """Per track: per-task and overall IQM with stratified-bootstrap 95 % intervals per algorithm,
    performance profiles, and the probability of improvement between every two algorithms that ran on the
    same tasks (:mod:`planetnav_train.scores`)."""
    from planetnav_train import scores

    reps = reps or scores.BOOTSTRAP_REPS
    out: dict[str, Any] = {}
    for track in TRACKS:
        mats = score_matrices(records, track)
        if not mats:
            continue
        per_task: dict[str, Any] = {}
        for algo, (names, m) in mats.items():
            for j, task in enumerate(names):
                per_task.setdefault(task, {}).update(scores.iqm_intervals({algo: m[:, [j]]}, reps))
        overall = scores.iqm_intervals({a: m for a, (_, m) in mats.items()}, reps)
        profiles = scores.performance_profiles({a: m for a, (_, m) in mats.items()}, reps=min(reps, 2_000))
        pairs = {
            (x, y): (mats[x][1], mats[y][1])
            for x in sorted(mats)
            for y in sorted(mats)
            if x < y and mats[x][0] == mats[y][0] and mats[x][1].shape == mats[y][1].shape
        }
        improvements = scores.improvement_probabilities(pairs, reps=min(reps, 2_000))
        out[track] = {
            "tasks": {a: names for a, (names, _) in mats.items()},
            "runs": {a: int(m.shape[0]) for a, (_, m) in mats.items()},
            "per_task": per_task,
            "overall": overall,
            "profiles": profiles,
            "improvement": improvements,
        }
    return out


def suite_json(
    records: Sequence[Mapping[str, Any]], references: Mapping[str, Any], agg: Mapping[str, Any]
) -> dict[str, Any]:
    """The published JSON: the protocol, the tasks, the references used, every run, and the aggregates."""
    return {
        "suite_version": SUITE_VERSION,
        "tasks": [t.to_dict() for t in TASKS],
        "references": dict(references),
        "runs": list(records),
        "aggregate": dict(agg),
    }


def _fmt_interval(v: Mapping[str, float]) -> str:
    return f"{v['iqm']:.2f} [{v['low']:.2f}, {v['high']:.2f}]"


#: What the normalized score and its aggregate mean, said once for the page and the README summary.
SCORE_LEGEND = (
    "Normalized score = (J_random − J) / (J_random − J_best): 0 is random, 1 the best non-learned "
    "reference; IQM over runs with stratified-bootstrap 95 % intervals (rliable)."
)


def aggregate_rows(track_agg: Mapping[str, Any]) -> list[str]:
    """Markdown table of one track's aggregate (:func:`aggregate`): per algorithm, the tasks it ran on, its
    runs per task and its IQM over tasks with the 95 % interval, best first."""
    overall = track_agg["overall"]
    lines = ["| algorithm | tasks | runs per task | IQM [95 % CI] |", "|---|---|---|---|"]
    for x in sorted(overall, key=lambda k: (-overall[k]["iqm"], k)):
        lines.append(
            f"| {x} | {len(track_agg['tasks'][x])} | {track_agg['runs'][x]} | {_fmt_interval(overall[x])} |"
        )
    return lines


def best_per_task_rows(track_agg: Mapping[str, Any], references: Mapping[str, Any]) -> list[str]:
    """Markdown table of one track: per task the algorithm with the highest IQM of the normalized score
    (ties: the first by name) and the best non-learned reference it is scored against (its objective
    in km, on the task's evaluation seeds)."""
    lines = ["| task | best algorithm | IQM [95 % CI] | best non-learned reference |", "|---|---|---|---|"]
    for task in sorted(track_agg["per_task"]):
        per = track_agg["per_task"][task]
        best = min(per, key=lambda k: (-per[k]["iqm"], k))
        ref = references.get(task)
        ref_text = f"{ref['best']} ({ref['J_best']:.1f} km)" if ref else "-"
        lines.append(f"| {task} | {best} | {_fmt_interval(per[best])} | {ref_text} |")
    return lines


def summary_markdown(data: Mapping[str, Any]) -> str:
    """The summary of a suite JSON (``OUT/suite.json``, :func:`suite_json`) as markdown: per track the
    algorithms' IQM over tasks with 95 % intervals and per task the best algorithm. Flags smoke-setting
    runs ("Not a leaderboard"). The README's summary block is this text (:mod:`planetnav_train.publish`)."""
    runs, agg = list(data.get("runs") or []), dict(data.get("aggregate") or {})
    if not runs or not agg:
        return "No run recorded yet.\n"
    tasks = sorted({r["task"] for r in runs})
    lines = [f"Suite version {data.get('suite_version')}: {len(runs)} runs on {len(tasks)} task(s). "
             + SCORE_LEGEND, ""]  # fmt: skip
    unofficial = sum(not r.get("official", False) for r in runs)
    if unofficial:
        lines += [f"**Not a leaderboard**: {unofficial} of {len(runs)} runs used smoke settings.", ""]
    lines += coverage_lines(runs, table=False)
    for track, a in agg.items():
        lines += [f"Track `{track}`, aggregated over tasks:", "", *aggregate_rows(a), ""]
        lines += [f"Track `{track}`, best algorithm per task:", ""]
        lines += [*best_per_task_rows(a, data.get("references") or {}), ""]
    return "\n".join(lines)


def write_leaderboard(
    records: Sequence[Mapping[str, Any]],
    references: Mapping[str, Any],
    agg: Mapping[str, Any],
    path: Path,
    plots: bool = True,
) -> Path:
    """The leaderboard markdown at ``path`` (plots beside it in ``<stem>_plots/``): the references used,
    per track the per-task and aggregated IQM tables, P(improvement), the plots, and every run with its
    command. Runs with smoke settings are flagged at the top: such a page is no leaderboard."""
    from planetnav_train import scores

    path.parent.mkdir(parents=True, exist_ok=True)
    lines = ["# planetnav benchmark suite: results", ""]
    unofficial = [r for r in records if not r.get("official", False)]
    if not records:
        lines += ["No run recorded yet.", ""]
    if unofficial:
        lines += [
            f"**Not a leaderboard**: {len(unofficial)} of {len(records)} runs used smoke settings (budget "
            "scale, episode length or evaluation seeds other than the task's). Their numbers check the "
            "machinery only.",
            "",
        ]
    lines += [SCORE_LEGEND, ""]
    lines += ["## Coverage", "", *coverage_lines(records)]
    lines += ["## References", "", "| task | agent | objective [95 % CI] | role |", "|---|---|---|---|"]
    for task, ref in sorted(references.items()):
        for agent, v in ref["agents"].items():
            role = (
                "random" if agent == ref["random"] else ("**best**" if agent == ref["best"] else "candidate")
            )
            lines.append(
                f"| {task} | {agent} | {v['objective']:.1f} [{v['ci95'][0]:.1f}, {v['ci95'][1]:.1f}] "
                f"| {role} |"
            )
    lines.append("")
    plot_dir = path.parent / f"{path.stem}_plots"
    for track, a in agg.items():
        lines += [f"## Track `{track}`", "", "### Per task (IQM of the normalized score over seeds)", ""]
        algos = sorted(a["overall"])
        lines += ["| task | " + " | ".join(algos) + " |", "|---|" + "---|" * len(algos)]
        for task in sorted(a["per_task"]):
            cells = [
                _fmt_interval(a["per_task"][task][x]) if x in a["per_task"][task] else "-" for x in algos
            ]
            lines.append(f"| {task} | " + " | ".join(cells) + " |")
        lines += ["", "### Aggregated over tasks", "", *aggregate_rows(a)]
        lines += ["", "### Best algorithm per task", "", *best_per_task_rows(a, references)]
        if a["improvement"]:
            lines += ["", "| P(X > Y) | probability [95 % CI] |", "|---|---|"]
            for row in a["improvement"]:
                lines.append(
                    f"| P({row['x']} > {row['y']}) | {row['probability']:.2f} "
                    f"[{row['low']:.2f}, {row['high']:.2f}] |"
                )
        if plots:
            for p in scores.write_plots(
                a["overall"], a["profiles"], a["improvement"], plot_dir, prefix=f"{track}_"
            ):
                lines += ["", f"![{p.stem}]({plot_dir.name}/{p.name})"]
        lines.append("")
    lines += ["## Runs", "", "| task | algorithm | track | seed | objective | score | wall s | command |",
              "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in sorted(records, key=lambda r: (r["track"], r["task"], r["algorithm"], r["seed"])):
        lines.append(f"| {r['task']} | {r['algorithm']} | {r['track']} | {r['seed']} | "
                     f"{r['objective']:.1f} | {r['normalized_score']:+.2f} | {r['wall_seconds']:.0f} | "
                     f"`{r['command']}` |")  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    return path


def finish(
    result: Mapping[str, Any],
    settings: Settings,
    json_path: str | None,
    markdown: Path | None,
    reps: int | None = None,
) -> dict[str, Any]:
    """Aggregate every record under ``settings.out``, write ``OUT/suite.json``, the invocation's runs to
    ``json_path`` (same form) and the leaderboard markdown (default ``OUT/benchmark.md``)."""
    records = result["records"]
    references = dict(result["references"])
    for p in sorted((settings.out / "references").glob("*.json")):  # tasks run by earlier invocations
        ref = json.loads(p.read_text())
        references.setdefault(ref["task"], ref)
    agg = aggregate(records, reps) if records else {}
    data = suite_json(records, references, agg)
    _write_json_atomic(settings.out / "suite.json", data)
    if json_path:
        _write_json_atomic(Path(json_path), {**data, "runs": list(result["ran"])})
    md = write_leaderboard(records, references, agg, markdown or settings.out / "benchmark.md")
    return {"json": settings.out / "suite.json", "markdown": md, "aggregate": agg}


__all__ = [
    "ALGOS",
    "ALGOS_BY_KIND",
    "OBJECTIVES",
    "SUITE_VERSION",
    "TASKS",
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
    "finish",
    "get_algo",
    "get_task",
    "load_assists",
    "make_cells",
    "published_grid",
    "rerun_command",
    "run_cell",
    "run_suite",
    "score_matrices",
    "summary_markdown",
    "task_references",
    "write_leaderboard",
]
