"""The shipped ``suite:<task>`` baselines scored on seeds the suite never used (70,000..), against the zero
point (the better of random and idle) and the task's best reference, all on those same seeds with per-step
noise streams; the references act at the physics step, as in the suite.

    python research/tasks_v1/holdout.py --tasks Cruise-Target-v1 [--episodes 100] [--out runs/holdout]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from planetnav_train.evaluate import evaluate_agent
from planetnav_train.shipped import load_manifest
from planetnav_train.stats import mean_ci
from planetnav_train.suite import Settings, get_task, task_references
from planetnav_train.suite.scoring import normalized_score
from planetnav_train.suite.tasks import OBJECTIVES

HOLDOUT_SEED = 70_000


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tasks", nargs="+", required=True)
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--out", default="runs/holdout")
    args = ap.parse_args()
    manifest = load_manifest()["baselines"]
    for name in args.tasks:
        task = get_task(name)
        best = manifest[task.id]["reference"]["best"]
        held = dataclasses.replace(
            task, eval_seed=HOLDOUT_SEED, eval_episodes=args.episodes, references=(best,)
        )
        refs = task_references(held, Settings(out=Path(args.out)))
        m = evaluate_agent(
            f"suite:{task.id}", held.eval_config(), args.episodes, HOLDOUT_SEED, progress=False
        )
        values = OBJECTIVES[task.objective].values(m.metrics)
        ci = mean_ci(values)
        score = normalized_score(ci.mean, refs["J_zero"], refs["J_best"])
        # The score's interval from the paired per-seed values of the policy and the two references.
        zero = np.asarray(refs["agents"][refs["zero"]]["per_episode"])
        ref = np.asarray(refs["agents"][best]["per_episode"])
        rng = np.random.default_rng(0)
        idx = rng.integers(0, len(values), size=(10_000, len(values)))
        boot = (zero[idx].mean(1) - values[idx].mean(1)) / (zero[idx].mean(1) - ref[idx].mean(1))
        lo, hi = np.percentile(boot, [2.5, 97.5])
        row = {"task": task.id, "seeds": [HOLDOUT_SEED, HOLDOUT_SEED + args.episodes - 1],
               "policy": m.name, "objective": ci.mean, "zero": refs["zero"], "J_zero": refs["J_zero"],
               "best": best, "J_best": refs["J_best"], "score": score, "score_ci95": [lo, hi]}  # fmt: skip
        print(json.dumps(row))


if __name__ == "__main__":
    main()
