"""The tasks: one explicit declaration per task, in one module per task family.

=====================  ==========================================  =========================
module                 tasks                                        versions
=====================  ==========================================  =========================
``cruise_target``      Cruise-Target                                v0, v1, v2
``cruise_torque``      Cruise-Torque, Cruise-TargetTorque           v0-v2, v0-v1
``random_cruise``      RandomCruise-Target                          v0, v1, v2
``torque_control``     Cruise-TorqueControl, Cruise-Hybrid          v0, v1
``mars_approach``      MarsApproach-Tasking                         v0, v1, v2
``thrust_arc``         ThrustArc-TCM                                v0, v1, v2
=====================  ==========================================  =========================

Each task is a :class:`~planetnav_env.tasks.spec.TaskSpec` whose versions state their layout, parameters,
reward, decision interface, the rule agents' interface and their card note
(:mod:`planetnav_env.tasks.spec`). :mod:`planetnav_env.envs.registration` registers every version with
Gymnasium from :data:`TASKS`; ``docs/tasks/<name>.md`` is generated from the same records
(``python -m planetnav_train.suite.cards``). Adding a task is one more record here; a new version of a
task is one more :class:`~planetnav_env.tasks.spec.TaskVersion` in its declaration.
"""

from __future__ import annotations

from planetnav_env.errors import ConfigError
from planetnav_env.tasks.cruise_target import CRUISE_TARGET
from planetnav_env.tasks.cruise_torque import CRUISE_TARGET_TORQUE, CRUISE_TORQUE
from planetnav_env.tasks.mars_approach import MARS_APPROACH_TASKING
from planetnav_env.tasks.random_cruise import RANDOM_CRUISE_TARGET
from planetnav_env.tasks.spec import (
    PHYSICS_STEP,
    Card,
    Interface,
    Layout,
    Params,
    Reward,
    TaskSpec,
    TaskVersion,
)
from planetnav_env.tasks.thrust_arc import THRUST_ARC_TCM
from planetnav_env.tasks.torque_control import CRUISE_HYBRID, CRUISE_TORQUE_CONTROL

#: Every task, in the order of the documentation.
TASKS: tuple[TaskSpec, ...] = (
    CRUISE_TARGET,
    CRUISE_TORQUE,
    CRUISE_TARGET_TORQUE,
    RANDOM_CRUISE_TARGET,
    CRUISE_TORQUE_CONTROL,
    CRUISE_HYBRID,
    MARS_APPROACH_TASKING,
    THRUST_ARC_TCM,
)

#: Every registered version by its id (``planetnav/Cruise-Target-v2``): all v0 ids, then v1, then v2.
VERSIONS: dict[str, tuple[TaskSpec, TaskVersion]] = {
    task.env_id(v.version): (task, v)
    for n in range(max(len(t.versions) for t in TASKS))
    for task in TASKS
    for v in task.versions[n : n + 1]
}

#: Every registered id's options (``gym.make(id)`` passes them), in the order of :data:`VERSIONS`.
ID_OPTIONS: dict[str, dict] = {env_id: v.options() for env_id, (_, v) in VERSIONS.items()}


def get_task(name: str) -> TaskSpec:
    """A task by name (``Cruise-Target``); :class:`ConfigError` naming the tasks otherwise."""
    for task in TASKS:
        if task.name == name:
            return task
    raise ConfigError(f"unknown task {name!r}; the tasks are {[t.name for t in TASKS]}")


def get_version(env_id: str) -> TaskVersion:
    """The declaration of a registered id (``planetnav/Cruise-Target-v2``, ``Cruise-Target-v2`` or
    ``module:planetnav/...``); :class:`ConfigError` naming the ids otherwise."""
    name = env_id.split(":", 1)[-1]
    name = name if "/" in name else f"planetnav/{name}"
    if name not in VERSIONS:
        raise ConfigError(f"unknown environment id {env_id!r}; the planetnav ids are {sorted(VERSIONS)}")
    return VERSIONS[name][1]


__all__ = [
    "ID_OPTIONS", "PHYSICS_STEP", "TASKS", "VERSIONS", "Card", "Interface", "Layout", "Params", "Reward",
    "TaskSpec", "TaskVersion", "get_task", "get_version",
]  # fmt: skip
