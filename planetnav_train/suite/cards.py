"""The task cards, ``docs/tasks/<name>.md``, written from the task declarations and the suite's records.

What the environment defines comes from :mod:`planetnav_env.tasks`: each version's note, observation (with
the float count ``observation_space`` reports), action and reward (:mod:`planetnav_env.tasks.describe`),
and the task's lead, physics and commands. What the suite defines comes from here: each version's budget
(:data:`~planetnav_train.suite.tasks.SUITES`, the algorithms' fractions), its zero point and its
references, with the figures of the published tables (:data:`PUBLISHED`) and of the blind search
(:data:`BLIND`). The env package does not import the suite, so the suite writes the cards::

    python -m planetnav_train.suite.cards           # rewrite docs/tasks/*.md
    python -m planetnav_train.suite.cards --check   # exit 1 naming each card that differs

``tests/train/test_task_cards.py`` holds the files to what :func:`render` writes.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

from planetnav_env.tasks import TASKS, TaskSpec, TaskVersion
from planetnav_env.tasks.describe import action_text, observation_text, reward_text
from planetnav_train.config import ROOT
from planetnav_train.suite.tasks import ALGOS, INTERFACE_RANDOM, OBJECTIVES, SUITES, Task

CARDS = ROOT / "docs" / "tasks"
#: The published table of each suite version: its ``references`` hold every reference's objective.
PUBLISHED: dict[int, Path] = {1: ROOT / "docs" / "benchmark_v1.json", 2: ROOT / "docs" / "benchmark.json"}
#: The published blind search of suite version 2 (docs/suite.md describes it): each zero's closed-loop gap.
BLIND = ROOT / "docs" / "tasks_v2_blind.json"


@cache
def _json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text())


def suite_task(env_id: str) -> Task | None:
    """The suite's task of a registered id, or None when no suite version benchmarks it."""
    for tasks in SUITES.values():
        for task in tasks:
            if task.env_id == env_id:
                return task
    return None


def _km(x: float) -> str:
    return f"{x:,.2f}" if abs(x) < 10 else f"{x:,.1f}"


def budget_text(task: Task | None) -> str:
    """Each algorithm's training budget on ``task`` (physics steps), as the suite trains it."""
    if task is None:
        return "none: no suite version benchmarks this version"
    parts = []
    for algo in ALGOS.values():
        if not algo.in_table(task):
            continue
        steps = round(algo.budget(task))
        short = task.suite_version == 2 and algo.short_fraction < 1
        parts.append(f"{algo.name} {steps:,}" + (" (short budget: shown, never ranked)" if short else ""))
    text = f"{task.budget:,} physics steps (suite version {task.suite_version}); per algorithm: " + ", ".join(
        parts
    )
    if task.discount is not None:
        text += f"; every algorithm trains with the task's discount of {task.discount:g} per decision"
    return text


def _references(task: Task) -> Mapping[str, Any]:
    return _json(PUBLISHED[task.suite_version])["references"][task.id]


def zero_text(task: Task | None) -> str:
    """The score's zero point: the agent and its objective on the evaluation seeds."""
    if task is None:
        return "none: no suite version benchmarks this version"
    ref = _references(task)
    unit = OBJECTIVES[task.objective].unit
    text = f"`{ref['zero']}`, {_km(ref['J_zero'])} {unit} on the {task.eval_episodes} evaluation seeds"
    if task.suite_version == 1:
        return f"the better of {', '.join(f'`{z}`' for z in task.zero)}: {text}"
    blind = _json(BLIND)["tasks"][task.id]
    gap = blind["closed_loop_gap"]
    headline = "in the headline set (25 % or more)" if task.headline else "below the headline set's 25 %"
    return (
        "the best blind policy, the winner of the published search over policies that ignore the "
        "observation ([tasks_v2_blind.json](../tasks_v2_blind.json); its protocol: [suite.md](../suite.md)): "
        f"{text}; closed-loop gap (J_blind − J_best) / J_blind {100 * gap['gap']:.1f} % "
        f"[{100 * gap['gap_lo']:.1f}, {100 * gap['gap_hi']:.1f}], {headline}"
    )


def _role(task: Task, ref: Mapping[str, Any], agent: str) -> str:
    if agent == ref["best"]:
        return "**best** (score 1)"
    if agent == ref["zero"]:
        return "zero (score 0)"
    if agent in task.references:
        return "candidate"
    if agent == INTERFACE_RANDOM:
        return "random in the task's interface (reported)"
    return "reported"


def references_lines(version: TaskVersion, task: Task | None, v1: Task | None) -> list[str]:
    """The references table of a benchmarked version; for a version no suite benchmarks, where to read
    them (a v0 id's rule agents play v1's configuration but for the reward, which no rule agent reads)."""
    if task is None:
        if v1 is None:
            return ["none: no suite version benchmarks this version"]
        return [
            f"the rule agents play v0 and v1 on one configuration but for the reward, which no rule agent "
            f"reads: v1's references are v0's (`{v1.env_id}` below)"
        ]
    ref = _references(task)
    unit = OBJECTIVES[task.objective].unit
    lines = [
        f"{task.eval_episodes} held-out seeds from {task.eval_seed:,}, per-step noise streams, printed by "
        f"`python train.py suite-references --tasks {task.id}` (mean [95 % t-interval]; published in "
        f"[{PUBLISHED[task.suite_version].name}](../{PUBLISHED[task.suite_version].name})); the rule agents "
        "play " + ("the physics step" if version.rules.decision_steps == 1 else "their interface") + ":",
        "",
        f"| agent | objective {unit} [95 % CI] | role |",
        "|---|---|---|",
    ]
    for agent, res in ref["agents"].items():
        lo, hi = res["ci95"]
        lines.append(
            f"| `{agent}` | {_km(res['objective'])} [{_km(lo)}, {_km(hi)}] | {_role(task, ref, agent)} |"
        )
    return lines


def version_section(spec: TaskSpec, version: TaskVersion) -> list[str]:
    env_id = spec.env_id(version.version)
    task = suite_task(env_id)
    v1 = suite_task(spec.env_id(1)) if version.version == 0 and len(spec.versions) > 1 else None
    lines = [
        f"## v{version.version}: `{env_id}`",
        "",
        f"- version: {version.note}",
        f"- observation: {observation_text(version)} (the blocks: [environment.md](../environment.md), "
        '"Observation")',
        f"- action: {action_text(version)}",
        f"- reward: {reward_text(version)}",
        f"- budget: {budget_text(task)}",
        f"- zero (score 0): {zero_text(task)}",
    ]
    refs = references_lines(version, task, v1)
    lines.append(f"- references: {refs[0]}")
    lines += refs[1:]
    return lines + [""]


def render(spec: TaskSpec) -> str:
    """The card of ``spec``: lead, version table, one section per version (newest first), physics,
    objective, commands."""
    module = spec.module.replace(".", "/") + ".py"
    latest = suite_task(spec.env_id(spec.latest.version))
    fallback = "operations_J_km" if spec.latest.params.operations is not None else "mean_pos_err_km"
    objective = OBJECTIVES[latest.objective if latest else fallback]
    lines = [
        f"# {spec.name}",
        "",
        spec.card.lead,
        "",
        f"<!-- Written by `python -m planetnav_train.suite.cards` from {module} and the suite's records; "
        "edit those, not this file. -->",
        "",
        "| id | version |",
        "|---|---|",
    ]
    lines += [f"| `{spec.env_id(v.version)}` | {v.note} |" for v in spec.versions]
    lines.append("")
    for version in reversed(spec.versions):
        lines += version_section(spec, version)
    lines += ["## Physics", "", spec.card.physics, "", "## Objective", ""]
    lines += [
        f"The suite's `{objective.name}` (lower is better): {objective.description}; the score is "
        "(J_zero − J) / (J_zero − J_best). Protocol: [suite.md](../suite.md).",
        "",
    ]
    if spec.card.commands:
        lines += ["## Commands", "", "```bash", *spec.card.commands, "```", ""]
    return "\n".join(lines)


def card_path(spec: TaskSpec) -> Path:
    return CARDS / f"{spec.name}.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a card differs")
    args = parser.parse_args(argv)
    stale = []
    for spec in TASKS:
        path, text = card_path(spec), render(spec)
        if path.exists() and path.read_text() == text:
            continue
        stale.append(path)
        if not args.check:
            path.write_text(text)
    verb = "differ from what the declarations write" if args.check else "written"
    for path in stale:
        print(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: {verb}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
