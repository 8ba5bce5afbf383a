"""The suite v3 learner table from the rows ``python -m planetnav_train.suite.v3 learners`` wrote.

    python research/tasks_v3/learner_table.py research/tasks_v3/learners/*.json

Per task: the number of training seeds, and for each row (untrained network, uniform random, SB3 PPO) the
mean J over the runs [km], the range of the runs' J, the mean entropy [nats], and the paired difference
from the published blind zero and from the best reference on the same 100 evaluation seeds: the mean
over runs with a 95 % interval over the training seeds (Student t on the runs' paired means; the
evaluation seeds are the same in every run, so their own spread is each run's interval in the JSON).
Where the task's published blind-zero score is defined, each row's score (J_zero - J) / (J_zero - J_best)
follows: with the runs' per-seed J, ``v3.run_score``'s bootstrap over training and evaluation seeds;
for rows written before they carried it, a t-interval over the training seeds alone (marked).
Where the rows' best reference is not the one published now (a reference added to the task's
normalization after the rows were written), the published one's J on the same seeds, from the
normalization record's per-seed J, and each row's ``minus_published_reference`` follow.
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

from planetnav_train.stats import mean_ci
from planetnav_train.suite import v3


def interval(x: list[float], fmt: str = ".1f") -> str:
    """The mean of ``x`` with its Student-t 95 % interval, signed (the mean alone for one value)."""
    return mean_ci(x).format("{:+" + fmt + "}")


def _published_reference(task: str, runs: list[dict]) -> tuple[str, float] | None:
    """(name, mean J on the runs' evaluation seeds) of the task's published best reference where the runs'
    own reference row names another (rows written before a reference was added): its per-seed J from the
    normalization record, on the same seeds. None where the rows' reference is the published one, or the
    runs are not scored on the record's first seeds in the task's own world."""
    try:
        norm = v3.normalization(task)
    except v3.ConfigError:  # not normalized
        return None
    best = norm["best_reference"]
    stored = [r["policy"] for r in runs[0]["rows"] if r["policy"].startswith("best reference")]
    if stored == [f"best reference ({best})"] or any(run.get("world_overrides") for run in runs):
        return None
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + runs[0]["episodes"])
    recorded = v3._recorded_per_seed(norm, v3.eval_config(f"planetnav/{task}"), task, seeds)
    return None if recorded is None else (best, float(recorded["best"].mean()))


def main(paths: list[str]) -> None:
    by_task: dict[tuple[str, str, str], list[dict]] = defaultdict(list)
    for p in paths:
        d = json.loads(Path(p).read_text())
        # agent-rows files (the single-file PPO) carry neither: the training seed is the file name's last
        # field, the budget the baselines script's.
        d.setdefault("seed", int(Path(p).stem.rsplit("-", 1)[-1]))
        d.setdefault("budget_decisions", 300_000)
        key = (d["task"], d.get("algo", "ppo"), d.get("target_actions", "absolute"))
        if d["budget_decisions"] != 300_000:  # another budget: its own group
            key = (key[0], f"{key[1]} at {d['budget_decisions']:,} decisions", key[2])
        if d.get("learner_overrides"):  # another learner: its own group
            key = (key[0], f"{key[1]} {json.dumps(d['learner_overrides'], sort_keys=True)}", key[2])
        by_task[key].append(d)
    for (task, algo, actions), runs in sorted(by_task.items()):
        seeds = sorted(r["seed"] for r in runs)
        budget, episodes = runs[0]["budget_decisions"], runs[0]["episodes"]
        over = runs[0].get("learner_overrides")
        print(f"## {task}, {algo}, {actions} target actions: {len(runs)} runs (seeds {seeds}), "
              f"{budget:,} decisions, {episodes} evaluation seeds"
              + (f"; the learner's defaults changed: {over}" if over else ""))  # fmt: skip
        stale = actions == "relative" and "per_seed" not in runs[0]
        for r in runs[0]["rows"]:
            if "entropy_nats" not in r and not stale:
                print(f"  {r['policy']}: J {r['J']['mean']:.1f}")
        published = None if stale else _published_reference(task, runs)
        if published is not None:
            print(f"  published best reference ({published[0]}): J {published[1]:.1f} (the normalization's "
                  "per-seed J on these seeds; the rows' own reference row predates it)")  # fmt: skip
        names = [r["policy"] for r in runs[0]["rows"] if "entropy_nats" in r]
        for name in names:
            rows = [next(x for x in run["rows"] if x["policy"] == name) for run in runs]
            j = [x["J"]["mean"] for x in rows]
            line = (f"  {name}: J {np.mean(j):.1f} (runs {min(j):.1f}..{max(j):.1f}), "
                    f"entropy {np.mean([x['entropy_nats'] for x in rows]):.3f}")  # fmt: skip
            for key in ("minus_zero", "minus_best_reference"):
                if key in rows[0] and not (stale and key == "minus_zero"):
                    line += f", {key} {interval([x[key]['mean'] for x in rows])}"
            if published is not None:  # the same seeds in every run: J minus the reference's mean
                line += f", minus_published_reference {interval([x - published[1] for x in j])}"
            scale = v3.published_scale(task)
            if scale is not None:
                jz, jb = scale
                seeds = [run.get("per_seed", {}).get(name) for run in runs]
                if all(x is not None for x in seeds):  # a bootstrap over training and evaluation seeds
                    sc = v3.run_score([np.asarray(x) for x in seeds], jz, jb)
                    line += f", score {sc['score']:+.2f} [{sc['lo']:+.2f}, {sc['hi']:+.2f}]"
                else:  # rows without per-seed J: the runs' spread only
                    per_run = [(jz - x) / (jz - jb) for x in j]
                    line += f", score {interval(per_run, '.2f')} (over training seeds)"
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
