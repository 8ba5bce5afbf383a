"""The benchmark suite's reference values (docs/suite.md): ``random`` and every best-reference candidate of
the given tasks on the task's 100 held-out seeds with per-step noise streams, with 95 % t-intervals, the
best candidate, and the wall time per agent. The values go to the same per-agent cache the suite reads
(``OUT/references/agents/``; default ``runs/suite``), so the published run does not evaluate them again.

    python benchmarks/suite_references.py --tasks ThrustArc-TCM-v0
    python benchmarks/suite_references.py --tasks Cruise-Hybrid-v0 --agents random   # one agent (a 2nd core)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from planetnav_train import suite


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=[t.id for t in suite.TASKS], help="task ids")
    ap.add_argument("--agents", nargs="+", help="only these of the tasks' random + candidates (cached)")
    ap.add_argument("--out", default="runs/suite", help="the suite's output directory (the cache)")
    ap.add_argument("--eval-episodes", type=int, help="fewer seeds (smoke; not the published values)")
    ap.add_argument("--episode-steps", type=int, help="shorter episodes (smoke)")
    args = ap.parse_args(argv)
    settings = suite.Settings(out=Path(args.out), eval_episodes=args.eval_episodes,
                              episode_steps=args.episode_steps)  # fmt: skip
    for name in args.tasks:
        task = suite.get_task(name)
        specs = [task.random, *task.references]
        if args.agents:
            unknown = sorted(set(args.agents) - set(specs))
            if unknown:
                raise SystemExit(f"--agents {unknown}: not among {task.id}'s references {specs}")
            specs = [s for s in specs if s in args.agents]
        unit = suite.OBJECTIVES[task.objective].unit
        for spec in specs:
            r = suite.reference_agent(task, spec, settings)
            print(f"{task.id} | {spec} | {task.objective} {r['objective']:.1f} {unit} "
                  f"[{r['ci95'][0]:.1f}, {r['ci95'][1]:.1f}] | {len(r['per_episode'])} seeds from "
                  f"{task.eval_seed} | {r['wall_seconds']:.0f} s", flush=True)  # fmt: skip
        if not args.agents:
            refs = suite.task_references(task, settings)
            print(f"{task.id} | best: {refs['best']} J_best {refs['J_best']:.1f}, J_random "
                  f"{refs['J_random']:.1f} {unit}", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
