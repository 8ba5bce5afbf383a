"""The benchmark suite's reference values, behind ``python train.py suite-references`` (docs/suite.md):
``random`` and every best-reference candidate of the given tasks on each task's held-out seeds with
per-step noise streams, with 95 % t-intervals, the best candidate and the wall time per agent. The values
go to the per-agent cache the suite reads (``OUT/references/agents/``,
:func:`~planetnav_train.suite.runner.reference_agent`), so the published run does not evaluate them again.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

from planetnav_env.errors import ConfigError
from planetnav_train.suite.cells import Settings
from planetnav_train.suite.runner import reference_agent, task_references
from planetnav_train.suite.tasks import OBJECTIVES, Task, get_task


def reference_specs(task: Task, agents: Sequence[str] | None = None) -> list[str]:
    """The agents whose references ``task`` has: ``random`` and its candidates, or those of them in
    ``agents``; :class:`ConfigError` naming any of ``agents`` that is not one of them."""
    specs = [task.random, *task.references]
    if not agents:
        return specs
    unknown = sorted(set(agents) - set(specs))
    if unknown:
        raise ConfigError(f"--agents {unknown}: not among {task.id}'s references {specs}")
    return [s for s in specs if s in agents]


def reference_lines(
    tasks: Sequence[str], settings: Settings, agents: Sequence[str] | None = None
) -> Iterator[str]:
    """Evaluate (or read from the cache) each task's reference agents, one line each as it finishes (task |
    agent | objective [95 % t-interval] | seeds | wall seconds); without ``agents``, then the task's best
    candidate and ``J_best``, ``J_random`` (:func:`task_references`, which writes
    ``OUT/references/<task>.json``). Every task and agent name is checked before anything is evaluated."""
    chosen = [(task, reference_specs(task, agents)) for task in map(get_task, tasks)]
    for task, specs in chosen:
        unit = OBJECTIVES[task.objective].unit
        for spec in specs:
            r = reference_agent(task, spec, settings)
            yield (f"{task.id} | {spec} | {task.objective} {r['objective']:.1f} {unit} "
                   f"[{r['ci95'][0]:.1f}, {r['ci95'][1]:.1f}] | {len(r['per_episode'])} seeds from "
                   f"{task.eval_seed} | {r['wall_seconds']:.0f} s")  # fmt: skip
        if not agents:
            refs = task_references(task, settings)
            yield (f"{task.id} | best: {refs['best']} J_best {refs['J_best']:.1f}, J_random "
                   f"{refs['J_random']:.1f} {unit}")  # fmt: skip


__all__ = ["reference_lines", "reference_specs"]
