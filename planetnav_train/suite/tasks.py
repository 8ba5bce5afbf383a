"""The benchmark suite's registry: versioned tasks with their objectives, and the algorithms that run on them.

- :class:`Task`: one frozen entry per task (:data:`TASKS`): its environment id and version, objective,
  100 held-out evaluation seeds with per-step noise streams, training budget in environment steps, the
  random reference and the candidates for the best non-learned reference, and the action kind. Adding a
  task is adding one entry.
- :data:`ALGOS`: the algorithms per action kind, with the suite's settings for each (policy, ``n_envs``,
  hyper-parameters). Their classes come from the one registry,
  :func:`planetnav_train.sb3.algorithm_class` (SB3 and sb3-contrib), or RLlib
  (:data:`planetnav_train.config.RLLIB_ALGOS`, trained by the package that registers it,
  :mod:`planetnav_train.extensions`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_env.tasks import VERSIONS, get_version
from planetnav_train.config import ROOT

#: The suite version of the published table (:data:`TASKS`); :data:`SUITES` holds every version's tasks, so a
#: table of an earlier version stays restorable and publishable as what it was.
SUITE_VERSION = 2
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
        "each TCM deadline plus w x delta-v lost), averaged over the seeds",
        kind="operations J",
    ),
}


@dataclass(frozen=True)
class Task:
    """One benchmark task. ``id`` is the registered environment's name with its version (``-v0``); a change
    that could alter results bumps the environment's version, hence the task's."""

    env_id: str  # registered id, e.g. "planetnav/Cruise-Target-v0"
    action_kind: str  # "discrete" (target choice) or "continuous" (torque, target+torque)
    budget: int  # on-policy training budget in physics steps (decisions x decision_steps)
    references: tuple[str, ...]  # candidates for the best non-learned reference (agent specs)
    objective: str = "mean_pos_err_km"
    random: str = "random"
    #: The score's zero point: the better (lower objective) of these, where they apply (``idle`` needs the
    #: target-choice "camera off" action). The random-based score is recorded too.
    zero: tuple[str, ...] = ("random", "idle")
    eval_seed: int = SUITE_EVAL_SEED
    eval_episodes: int = SUITE_EVAL_EPISODES
    noise_streams: str = "per_step"  # common random numbers: every agent draws the same sensor noise
    #: The discount per decision the task is posed for, given to every algorithm in place of its own
    #: ``gamma`` (part of the task, not of an algorithm's tuning: a credit horizon of ``1 / (1 - discount)``
    #: decisions that reaches the task's delayed payoffs); None: each algorithm's own.
    discount: float | None = None
    #: In the version's headline task set: its closed-loop gap (the share of the best blind policy's error
    #: that only a policy reading the state removes) is 25 % or more on the evaluation seeds
    #: (docs/tasks_v2_blind.json; a test holds the flag to it).
    headline: bool = False

    def __post_init__(self) -> None:
        # Every field with a closed set of values, checked in one pass (one error names every bad value).
        choices: dict[str, Sequence[str]] = {
            "env_id": sorted(VERSIONS), "action_kind": ACTION_KINDS, "objective": sorted(OBJECTIVES),
        }  # fmt: skip
        bad = [f"{k} {getattr(self, k)!r} is not one of {list(v)}" for k, v in choices.items()
               if getattr(self, k) not in v]  # fmt: skip
        if self.discount is not None and not (0.0 < self.discount < 1.0):
            bad.append(f"discount {self.discount!r} must lie in (0, 1)")
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
    def suite_version(self) -> int:
        """The suite version the task belongs to: 1 for the ``-v0``/``-v1`` ids, 2 for the ``-v2`` ids."""
        return 1 if self.version <= 1 else 2

    @property
    def eval_seeds(self) -> tuple[int, ...]:
        """The held-out evaluation seeds."""
        return tuple(range(self.eval_seed, self.eval_seed + self.eval_episodes))

    def env_config(self, episode_steps: int | None = None) -> EnvConfig:
        """The registered environment, from the task's declaration (optionally with a shorter episode, for
        smoke runs)."""
        over = {"episode_steps": episode_steps} if episode_steps else {}
        return get_version(self.env_id).config(**over)

    def eval_config(self, episode_steps: int | None = None) -> EnvConfig:
        """The evaluation environment: the registered one with the task's noise streams."""
        return EnvConfig.from_dict(self.env_config(episode_steps).to_dict(), noise_streams=self.noise_streams)

    def rule_config(self, episode_steps: int | None = None) -> EnvConfig:
        """The evaluation environment in the interface the task's declaration gives its rule agents
        (:attr:`planetnav_env.tasks.TaskVersion.rules`): the same physics, seeds and objective."""
        rules = get_version(self.env_id).rules.options()
        return EnvConfig.from_dict(self.eval_config(episode_steps).to_dict(), **rules)

    def to_dict(self) -> dict[str, Any]:
        """The task as JSON data (recorded with the runs)."""
        return {**dataclasses.asdict(self), "id": self.id, "version": self.version}


#: The reference key of the random policy in the task's own interface (a ``-v1`` id's held decisions and
#: relative actions): reported beside the score on v1, and the zero point of a v2 task whose best blind
#: policy it is (the blind family's ``random`` acts in the task's interface).
INTERFACE_RANDOM = "random@interface"
_TARGET_REFS = ("greedy", "periodic", "planner")
#: Mars approach: one planet (periodic's cycles are over planets, so it has no schedule to run there).
_APPROACH_REFS = ("greedy", "planner", "baseline")
TORQUE_REFS = ("greedy", "periodic", "planner", "baseline")
#: Wheel torques at 1 s: greedy's choice executed by the PD law.
_TORQUE_1S_REFS = ("greedy-pd",)
#: The thrust arc: the tuned periodic schedule (2-h sessions every 3 d from day 0.75), the tuned
#: deadline-anchored periodic rule (blocks ending at each TCM), the tuned deadline-aware greedy and the
#: open-loop optimum; the lower J on the task's seeds is the best.
#: Another candidate is one more entry here (only it is then evaluated).
THRUST_ARC_REFS = (
    "periodic:period=432,session=12,phase=108,cycle=0-1-2",
    "periodic:lead=0,session=24-42-12,start=6,dwell=3,cycle=0-1-2",
    "greedy:threshold=4",
    "optimum",
)
#: Suite version 1's tasks: the ``-v1`` ids (the ``-v0`` physics posed for learners; docs/suite.md "Tasks
#: v1"). ``budget``: the on-policy algorithms' training budget in physics steps; an algorithm's
#: ``budget_fraction`` scaled it in version 1 (docs/suite.md).
TASKS_V1: tuple[Task, ...] = (
    Task("planetnav/Cruise-Target-v1", "discrete", 3_000_000, _TARGET_REFS),
    Task("planetnav/RandomCruise-Target-v1", "discrete", 3_000_000, _TARGET_REFS),
    Task("planetnav/MarsApproach-Tasking-v1", "discrete", 3_000_000, _APPROACH_REFS),
    Task("planetnav/Cruise-Torque-v1", "continuous", 1_000_000, TORQUE_REFS),
    Task("planetnav/Cruise-TargetTorque-v1", "continuous", 1_000_000, TORQUE_REFS),
    Task("planetnav/Cruise-TorqueControl-v1", "continuous", 1_000_000, _TORQUE_1S_REFS),
    Task("planetnav/Cruise-Hybrid-v1", "continuous", 1_000_000, _TORQUE_1S_REFS),
    Task("planetnav/ThrustArc-TCM-v1", "discrete", 3_000_000, THRUST_ARC_REFS, objective="operations_J_km"),
)
#: Suite version 2's tasks: the ``-v2`` ids (docs/tasks_v2.md). Each task's zero point is the winner of its
#: published blind search (docs/tasks_v2_blind.json; ``random`` there acts in the
#: task's interface), its references the search's non-privileged ones: on the event tasks nominal and adaptive
#: greedy (the oracle is privileged, never the 1), on the posing fixes the v1 task's.
_V2_EVENT_REFS = ("greedy", "greedy:success=observed")
TASKS_V2: tuple[Task, ...] = (
    Task("planetnav/Cruise-Target-v2", "discrete", 3_000_000, _V2_EVENT_REFS,
         zero=("schedule:targets=0-1-2,steps=20",)),
    Task("planetnav/RandomCruise-Target-v2", "discrete", 3_000_000, _V2_EVENT_REFS, zero=(INTERFACE_RANDOM,),
         headline=True),
    Task("planetnav/MarsApproach-Tasking-v2", "discrete", 3_000_000, _V2_EVENT_REFS,
         zero=("schedule:targets=0-2-1,steps=16-4-4",)),
    Task("planetnav/Cruise-Torque-v2", "continuous", 1_000_000, TORQUE_REFS, zero=(INTERFACE_RANDOM,),
         headline=True),
    # 2-h decisions and a discount of 0.995 per decision (~17 days): every knowledge deadline (7, 16 and
    # 19.5 days) lies within the credit horizon of the decisions that pay for it (docs/tasks_v2.md).
    Task("planetnav/ThrustArc-TCM-v2", "discrete", 3_000_000, THRUST_ARC_REFS, objective="operations_J_km",
         zero=("schedule:targets=0-off-1-off-2-off,steps=12-420-12-420-12-420,phase=1188",), discount=0.995),
)  # fmt: skip
#: Every suite version's tasks.
SUITES: dict[int, tuple[Task, ...]] = {1: TASKS_V1, 2: TASKS_V2}
#: The published table's tasks: those of :data:`SUITE_VERSION`.
TASKS: tuple[Task, ...] = SUITES[SUITE_VERSION]
TASKS_BY_ID: dict[str, Task] = {t.id: t for tasks in SUITES.values() for t in tasks}


def records_version(records: Sequence[Mapping[str, Any]]) -> int:
    """The suite version of ``records`` (run records with a ``task``): that of their tasks, which must be
    one; :data:`SUITE_VERSION` for none. :class:`ConfigError` naming the versions when they mix (a table
    ranks one version's tasks)."""
    versions = sorted({get_task(str(r["task"])).suite_version for r in records})
    if len(versions) > 1:
        raise ConfigError(f"the records mix suite versions {versions}: publish each version's table apart")
    return versions[0] if versions else SUITE_VERSION


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
    #: Suite version 1 only: the share of a task's (on-policy) budget this algorithm trained for.
    budget_fraction: float = 1.0
    #: Suite version 2: every algorithm trains for the task's budget; below 1 only where that does not fit
    #: the table's wall time, which marks the algorithm's entries "(short budget)" and keeps them unranked.
    short_fraction: float = 1.0
    #: ``sampled`` or ``argmax``: the action the protocol scores (both are recorded).
    eval_mode: str = "argmax"
    extra: str = "train"  # the pyproject extra it needs: train (SB3), bench (sb3-contrib), ray (RLlib)
    #: The published table's tasks it runs on; empty: every task of its action kinds.
    tasks: tuple[str, ...] = ()
    #: Per task id, hyperparameters that replace those of ``hyperparams`` there (each chosen by an ablation
    #: on seeds the suite does not evaluate on; docs/suite.md names it).
    task_hyperparams: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    #: Per task id, the unit of the reward this algorithm trains on (``reward_scale_km``; the id's own
    #: otherwise). Dividing every reward by a constant changes no policy's ranking, so the task stays the
    #: task; what it changes is the learner's update (PPO's value loss shares one clipped gradient norm
    #: with its policy loss). Chosen by ablations like ``task_hyperparams``.
    task_reward_scale_km: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        named = set(self.tasks) | set(self.task_hyperparams) | set(self.task_reward_scale_km)
        unknown = sorted(named - set(TASKS_BY_ID))
        if unknown:
            raise ConfigError(
                f"algorithm {self.name!r}: unknown task(s) {unknown}; the tasks: {sorted(TASKS_BY_ID)}"
            )
        for task, scale in self.task_reward_scale_km.items():
            if not (isinstance(scale, (int, float)) and np.isfinite(scale) and scale > 0):
                raise ConfigError(
                    f"algorithm {self.name!r}: reward scale of {task} must be > 0 km, got {scale!r}"
                )

    def in_table(self, task: Task) -> bool:
        """Whether the published table runs this algorithm on ``task``."""
        return task.action_kind in self.kinds and (not self.tasks or task.id in self.tasks)

    def hyperparams_for(self, task: Task) -> dict[str, Any]:
        """The hyperparameters this algorithm trains with on ``task``: its own, with the task's overrides,
        and the task's discount (:attr:`Task.discount`) where it states one."""
        out = {**self.hyperparams, **self.task_hyperparams.get(task.id, {})}
        if task.discount is not None:  # SB3 and RLlib both name it gamma
            out["gamma"] = task.discount
        return out

    def env_for(self, task: Task) -> dict[str, Any]:
        """The environment options this algorithm trains with on ``task`` over the id's own: at most its
        reward's unit (:attr:`task_reward_scale_km`)."""
        scale = self.task_reward_scale_km.get(task.id)
        return {} if scale is None else {"reward_scale_km": float(scale)}

    def budget(self, task: Task) -> float:
        """This algorithm's training budget on ``task`` in physics steps: the task's, times the fraction of
        the task's suite version (:attr:`budget_fraction` on v1, :attr:`short_fraction` on v2)."""
        return task.budget * (self.budget_fraction if task.suite_version == 1 else self.short_fraction)

    def check_installed(self) -> None:
        """Raise :class:`ConfigError` naming the extra when the algorithm's library is missing."""
        import importlib.util

        module = {"bench": "sb3_contrib", "ray": "ray", "train": "stable_baselines3"}[self.extra]
        if importlib.util.find_spec(module) is None:
            raise ConfigError(
                f"algorithm {self.name!r} needs {module}, which is not installed: "
                f'pip install -e ".[{self.extra}]"'
            )


# Many rows and large minibatches: throughput (benchmarks/bench_train.py measures the settings). 64 rows x
# 64 decisions = 4,096 decisions per update, 4 minibatches of 1,024, 5 epochs; the discount is per decision.
_ON_POLICY = {"n_steps": 64, "batch_size": 1024, "n_epochs": 5, "gamma": 0.95, "ent_coef": 0.01}
# Off-policy: many rows and few gradient steps per transition. SB3's default of one gradient step per
# step of one row trains at ~20 env steps/s on the 2-core machine, which no 8-hour table affords.
#: The suite's algorithms, each for what it adds: PPO (the on-policy reference, both action kinds), DQN
#: (value-based, discrete), RecurrentPPO (memory instead of the observation's history block), SAC
#: (off-policy, continuous); RLlib's PPO on one task (another library's PPO on the same env).
#: RecurrentPPO runs on the Mars approach only: every v1 observation carries its history block
#: (``since_measured``), and the LSTM's training speed would add hours to the suite's table on all four
#: discrete tasks; the approach, with its 1,000-s pulsar
#: integrations between planet images, is where memory has the most to add.
#: ``eval_mode``: which action the protocol scores (both are recorded): ``sampled`` for the stochastic
#: policy-gradient policies (their argmax can collapse to one action),
#: ``argmax`` for the value-based and the deterministic-actor ones.
ALGOS: dict[str, Algo] = {
    a.name: a
    for a in (
        # The Mars approach: minibatches of 256, 4x the gradient steps per update. RandomCruise: the same,
        # the per-target blocks read in the order of the relative actions, the reward in units of
        # 100,000 km, and one MLP that scores every target from its own features and their contrast across
        # the targets (planetnav_train.policies.PerTargetPolicy): together, not each alone, they close most
        # of the gap to greedy that the flat recipe leaves.
        Algo("ppo", ACTION_KINDS, n_envs=64, hyperparams=_ON_POLICY, eval_mode="sampled",
             task_hyperparams={
                 "MarsApproach-Tasking-v1": {"batch_size": 256},
                 "RandomCruise-Target-v1": {
                     "batch_size": 256,
                     "policy_kwargs": {
                         "features_extractor": "relative_order", "action_head": "per_target",
                         "contrast": True,
                     },
                 },
             },
             task_reward_scale_km={"RandomCruise-Target-v1": 100_000.0}),
        # 8 rows, 2 gradient steps per 4 steps of the rows (one per 16 transitions): 4x the throughput
        # of one row at one step per 4 transitions (921 against 225 decisions/s, the Mars approach).
        Algo("dqn", ("discrete",), n_envs=8, budget_fraction=1 / 3, eval_mode="argmax",
             hyperparams={"train_freq": 4, "gradient_steps": 2, "gamma": 0.95}),
        Algo("recurrent_ppo", ("discrete",), policy="MlpLstmPolicy", n_envs=64, budget_fraction=1 / 3,
             hyperparams=_ON_POLICY, extra="bench", eval_mode="sampled",
             tasks=("MarsApproach-Tasking-v1",)),
        # 8 rows, one gradient step per 2 steps of the rows (per 16 transitions): one row at one step per
        # 4 transitions trained at ~120 physics steps/s on the loaded machine, 14 min per cell.
        # Suite v2: at ~120 physics steps/s the torque task's 1M steps would take 2.3 h a seed, 11.6 h for
        # the cell's five: a tenth, marked short.
        Algo("sac", ("continuous",), n_envs=8, budget_fraction=0.1, short_fraction=0.1, eval_mode="argmax",
             hyperparams={"train_freq": 2, "gradient_steps": 1}),
        # Samples in its own process (no env-runner actors): one CPU per cell, in a Tune grid too.
        # A third of PPO's budget: it samples at ~2,000 physics steps/s here (SB3's PPO: ~17,000), and the
        # full budget would cost the table 2.2 of its 8 hours for 5 cells.
        Algo("rllib_ppo", ACTION_KINDS, n_envs=8, hyperparams={"num_env_runners": 0}, extra="ray",
             budget_fraction=1 / 3, eval_mode="argmax", tasks=("Cruise-Target-v1",)),
    )
}  # fmt: skip
#: The algorithms of the published table per action kind (RLlib's PPO on one task: see docs/suite.md).
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
