"""The suite v3 learner table from the rows ``python -m planetnav_train.suite.v3 learners`` wrote.

    python research/tasks_v3/learner_table.py research/tasks_v3/learners/*.json

Per task: the number of training seeds, and for each row (untrained network, uniform random, SB3 PPO) the
mean J over the runs [km], the range of the runs' J, the mean entropy [nats], and the paired difference
from the published blind zero and from the best reference on the same 100 evaluation seeds: the mean
over runs with a 95 % interval over the training seeds (Student t on the runs' paired means; the
evaluation seeds are the same in every run, so their own spread is each run's interval in the JSON).
Runs are grouped by task, learner and target actions; where a task has PPO runs with absolute and with
relative target actions, the relative minus absolute J per training seed follows (same seeds, budget).
A relative run written before the published rows acted in the task's own interface has a zero row that
is another policy; its paired columns are not printed.
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy import stats


def interval(x: list[float]) -> str:
    a = np.asarray(x, float)
    if a.size < 2:
        return f"{a.mean():+.1f}"
    h = stats.t.ppf(0.975, a.size - 1) * a.std(ddof=1) / np.sqrt(a.size)
    return f"{a.mean():+.1f} [{a.mean() - h:+.1f}, {a.mean() + h:+.1f}]"


def main(paths: list[str]) -> None:
    by_task: dict[tuple[str, str, str], list[dict]] = defaultdict(list)
    for p in paths:
        d = json.loads(Path(p).read_text())
        # agent-rows files (the single-file PPO) carry neither: the training seed is the file name's last
        # field, the budget the baselines script's.
        d.setdefault("seed", int(Path(p).stem.rsplit("-", 1)[-1]))
        d.setdefault("budget_decisions", 300_000)
        by_task[(d["task"], d.get("algo", "ppo"), d.get("target_actions", "absolute"))].append(d)
    for (task, algo, actions), runs in sorted(by_task.items()):
        seeds = sorted(r["seed"] for r in runs)
        budget, episodes = runs[0]["budget_decisions"], runs[0]["episodes"]
        print(f"## {task}, {algo}, {actions} target actions: {len(runs)} runs (seeds {seeds}), "
              f"{budget:,} decisions, {episodes} evaluation seeds")  # fmt: skip
        stale = actions == "relative" and "per_seed" not in runs[0]
        for r in runs[0]["rows"]:
            if "entropy_nats" not in r and not stale:
                print(f"  {r['policy']}: J {r['J']['mean']:.1f}")
        names = [r["policy"] for r in runs[0]["rows"] if "entropy_nats" in r]
        for name in names:
            rows = [next(x for x in run["rows"] if x["policy"] == name) for run in runs]
            j = [x["J"]["mean"] for x in rows]
            line = (f"  {name}: J {np.mean(j):.1f} (runs {min(j):.1f}..{max(j):.1f}), "
                    f"entropy {np.mean([x['entropy_nats'] for x in rows]):.3f}")  # fmt: skip
            for key in ("minus_zero", "minus_best_reference"):
                if key in rows[0] and not (stale and key == "minus_zero"):
                    line += f", {key} {interval([x[key]['mean'] for x in rows])}"
            t = [x["train_seconds"] for x in rows if "train_seconds" in x]
            if t:
                line += f", train {np.mean(t):.0f} s"
            print(line)
    for (task, algo, actions), runs in sorted(by_task.items()):
        absolute = {r["seed"]: r for r in by_task.get((task, algo, "absolute"), [])}
        if actions != "relative" or not absolute:
            continue
        pairs = [(r, absolute[r["seed"]]) for r in runs if r["seed"] in absolute]
        d = [_learner_j(r) - _learner_j(a) for r, a in pairs]
        print(f"## {task}, {algo}: relative minus absolute target actions, J per training seed "
              f"{sorted(r['seed'] for r, _ in pairs)}: {interval(d)} km")  # fmt: skip


def _learner_j(run: dict) -> float:
    return next(r["J"]["mean"] for r in run["rows"] if r["policy"].startswith("SB3"))


if __name__ == "__main__":
    main(sys.argv[1:])
