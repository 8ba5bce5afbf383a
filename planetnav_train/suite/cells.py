"""The suite's grid: tracks, assists, cells (task x algorithm x track x training seed), the published grid
and its coverage, and the training configuration and re-run command of one cell.

Tracks: ``raw`` trains on the environment as registered (its own observation, reward and decision
interface, no cloning, no features); ``assisted`` adds the named assists of
``configs/suite/assisted.yaml``.
"""

from __future__ import annotations

import copy
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from planetnav_env.errors import ConfigError, with_prefix
from planetnav_train.config import TrainConfig, is_rllib_algo, parse_config
from planetnav_train.moved_options import moved_option_error, moved_options_in
from planetnav_train.suite.tasks import (
    ALGOS,
    DEFAULT_ASSISTS,
    SUITE_VERSION,
    SUITES,
    TRACKS,
    Algo,
    get_algo,
    get_task,
    records_version,
)

# ---------------------------------------------------------------------------------------------------------
# Tracks and cells
# ---------------------------------------------------------------------------------------------------------

#: Keys an assist may set: every one is an option of a training config (the decision interface is in ``env``).
ASSIST_KEYS = {"env", "features", "shaping", "pretrain", "hyperparams"}


def load_assists(path: str | Path = DEFAULT_ASSISTS) -> dict[str, Any]:
    """The assisted track's configuration: ``assists`` (name -> training config fragment) and ``tasks``
    (task id -> the assist names it uses). Raises :class:`ConfigError` naming bad entries."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"no assists configuration {p}")
    data = yaml.safe_load(p.read_text()) or {}
    assists, tasks = data.get("assists") or {}, data.get("tasks") or {}
    for name, frag in assists.items():
        moved = moved_options_in(frag) if isinstance(frag, Mapping) else []
        if moved:
            raise with_prefix(moved_option_error(*moved[0]), f"{p}: assist {name!r}")
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
    # evaluate_agent's exact_actions for a continuous policy. False (the suite's default): one forward pass
    # for all evaluation rows, equal to the one-episode evaluation to float rounding; on the 1-s torque
    # tasks several times faster than row by row, which the suite's wall time needs.
    # True: row by row, equal to it exactly. Recorded and in the command.
    exact_actions: bool = False
    # --resume: finished cells are skipped and a cell killed mid-training continues from its checkpoint
    # (planetnav_train.checkpoint) instead of starting again. Not recorded: it changes no result's meaning.
    resume: bool = False

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


def make_cells(
    tasks: Sequence[str], algos: Sequence[str], seeds: Sequence[int], track: str, table_only: bool = False
) -> list[Cell]:
    """The grid: every applicable (task, algorithm) pair x ``seeds``; an algorithm that fits none of the
    given tasks' action kinds is an error naming it (one that fits some is skipped on the others).
    ``table_only``: only the pairs the published table runs (:meth:`Algo.in_table`)."""
    if track not in TRACKS:
        raise ConfigError(f"--track {track!r} is not one of {TRACKS}")
    if any(int(s) < 0 for s in seeds):
        raise ConfigError(f"--seeds must be >= 0, got {list(seeds)}")
    ts = [get_task(t) for t in tasks]
    cells = []
    for name in algos:
        algo = get_algo(name)
        fits = [t for t in ts if (algo.in_table(t) if table_only else t.action_kind in algo.kinds)]
        if not fits and not table_only:
            raise ConfigError(
                f"algorithm {algo.name!r} runs on {algo.kinds} tasks; none of {[t.id for t in ts]} is one"
            )
        cells += [Cell(t.id, algo.name, track, int(s)) for t in fits for s in seeds]
    return cells


#: The published table's training seeds and the assisted track's algorithms (docs/suite.md).
PUBLISHED_SEEDS: tuple[int, ...] = (0, 1, 2, 3, 4)
ASSISTED_ALGOS: tuple[str, ...] = ("ppo",)


def published_grid(version: int = SUITE_VERSION) -> list[Cell]:
    """Every cell of suite ``version``'s table: raw, each task x the algorithms that run on it
    (:meth:`Algo.in_table`: its action kind's; in version 1 also RecurrentPPO on the Mars approach and
    RLlib's PPO on Cruise-Target-v1); assisted, each task the assisted track's configuration names
    (:func:`load_assists`: the v1 tasks, whose observations its assists were built for) x
    :data:`ASSISTED_ALGOS`; five seeds each."""
    if version not in SUITES:
        raise ConfigError(f"unknown suite version {version!r}; the versions are {sorted(SUITES)}")
    assisted = load_assists()["tasks"]
    cells = []
    for t in SUITES[version]:
        raw = [a.name for a in ALGOS.values() if a.in_table(t)]
        cells += make_cells([t.id], raw, PUBLISHED_SEEDS, "raw")
        if t.id in assisted:
            cells += make_cells([t.id], ASSISTED_ALGOS, PUBLISHED_SEEDS, "assisted")
    return cells


def is_short_budget(cell: Cell) -> bool:
    """Whether ``cell`` trains for fewer physics steps than its task's budget (:meth:`Algo.budget`), so
    that its entry is "(short budget)": shown, never ranked (the rule of
    :func:`planetnav_train.suite.scoring.entry_name`, applied to the grid)."""
    task = get_task(cell.task)
    return get_algo(cell.algo).budget(task) < 0.99 * task.budget


def coverage(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """How much of the published grid of the records' suite version the official ``records`` cover: per
    task and track the cells finished and expected, and the totals (``done``, ``expected``), of which
    short-budget cells (:func:`is_short_budget`: never ranked) ``short_done`` and ``short_expected``."""
    done = {(r["task"], r["algorithm"], r["track"], int(r["seed"])) for r in records if r.get("official")}
    per: dict[str, dict[str, list[int]]] = {}
    short = [0, 0]
    for c in published_grid(records_version(records)):
        row = per.setdefault(c.task, {}).setdefault(c.track, [0, 0])
        finished = (c.task, c.algo, c.track, c.seed) in done
        row[0] += finished
        row[1] += 1
        if is_short_budget(c):
            short[0] += finished
            short[1] += 1
    total = [sum(v[i] for t in per.values() for v in t.values()) for i in (0, 1)]
    return {"per_task": per, "done": total[0], "expected": total[1], "short_done": short[0],
            "short_expected": short[1]}  # fmt: skip


def coverage_lines(records: Sequence[Mapping[str, Any]], table: bool = True) -> list[str]:
    """Markdown: a line saying whether the records are the whole published table, counting its ranked
    cells apart from its short-budget ones (and, with ``table``, the cells finished per task and track)."""
    cov = coverage(records)
    ranked = (cov["done"] - cov["short_done"], cov["expected"] - cov["short_expected"])
    short = (cov["short_done"], cov["short_expected"])
    if cov["done"] == cov["expected"]:
        head = (f"Complete: all {ranked[1]} ranked cells of the published table, and its {short[1]} "
                "short-budget cells (shown, never ranked)." if short[1]
                else f"Complete: all {cov['expected']} cells of the published table.")  # fmt: skip
    else:
        also = f" (and {short[0]} of its {short[1]} short-budget cells, never ranked)" if short[1] else ""
        head = (
            f"**Partial**: {ranked[0]} of the published table's {ranked[1]} ranked cells are finished{also} "
            "(the rest run in later invocations with `--resume`); aggregates over tasks cover only the "
            "tasks listed."
        )
    if not table:
        return [head, ""]
    tracks = [k for k in TRACKS if any(k in t for t in cov["per_task"].values())]  # the grid's tracks
    lines = [
        head,
        "",
        "| task | " + " | ".join(f"{k} cells" for k in tracks) + " |",
        "|---" * (len(tracks) + 1) + "|",
    ]
    for task, done in cov["per_task"].items():
        lines.append(f"| {task} | " + " | ".join(f"{done[k][0]} / {done[k][1]}" for k in tracks) + " |")
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
        "hyperparams": algo.hyperparams_for(task),
        "env": {
            **algo.env_for(task),
            **({"episode_steps": settings.episode_steps} if settings.episode_steps else {}),
        },
    }
    names: list[str] = []
    if cell.track == "assisted":
        conf = assists if assists is not None else load_assists(settings.assists_path)
        names = list(conf["tasks"].get(cell.task, []))
        for name in names:
            data = _merge(data, conf["assists"][name])
    # The budget counts physics steps; a decision is the cell's decision_steps of them (the id's, or an
    # assist's env option).
    per_decision = TrainConfig(env_id=task.env_id, env=data["env"]).env_config().decision_steps
    decisions = max(1, round(algo.budget(task) * settings.budget_scale) // per_decision)
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
    if settings.exact_actions:
        args += ["--exact-actions"]
    if cell.track == "assisted" and Path(settings.assists_path).resolve() != DEFAULT_ASSISTS.resolve():
        args += ["--assists", settings.assists_path]
    return shlex.join(args)
