"""The suite v3 learner table from the rows ``python -m planetnav_train.suite.v3 learners`` wrote.

    python research/tasks_v3/learner_table.py research/tasks_v3/learners/*.json

Per task: the number of training seeds, and for each row (untrained network, uniform random, SB3 PPO) the
mean J over the runs [km], the range of the runs' J, the mean entropy [nats], and the paired difference
from the published blind zero and from the best reference on the same 100 evaluation seeds: the mean
over runs with a 95 % interval over the training seeds (Student t on the runs' paired means; the
evaluation seeds are the same in every run, so their own spread is each run's interval in the JSON).
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
    by_task: dict[str, list[dict]] = defaultdict(list)
    for p in paths:
        d = json.loads(Path(p).read_text())
        by_task[d["task"]].append(d)
    for task, runs in sorted(by_task.items()):
        seeds = sorted(r["seed"] for r in runs)
        print(f"## {task}: {len(runs)} runs (seeds {seeds}), {runs[0]['budget_decisions']:,} decisions, "
              f"{runs[0]['episodes']} evaluation seeds")  # fmt: skip
        for r in runs[0]["rows"]:
            if "entropy_nats" not in r:
                print(f"  {r['policy']}: J {r['J']['mean']:.1f}")
        names = [r["policy"] for r in runs[0]["rows"] if "entropy_nats" in r]
        for name in names:
            rows = [next(x for x in run["rows"] if x["policy"] == name) for run in runs]
            j = [x["J"]["mean"] for x in rows]
            line = (f"  {name}: J {np.mean(j):.1f} (runs {min(j):.1f}..{max(j):.1f}), "
                    f"entropy {np.mean([x['entropy_nats'] for x in rows]):.3f}")  # fmt: skip
            for key in ("minus_zero", "minus_best_reference"):
                if key in rows[0]:
                    line += f", {key} {interval([x[key]['mean'] for x in rows])}"
            t = [x["train_seconds"] for x in rows if "train_seconds" in x]
            if t:
                line += f", train {np.mean(t):.0f} s"
            print(line)


if __name__ == "__main__":
    main(sys.argv[1:])
