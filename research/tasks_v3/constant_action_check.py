"""Is a learner row's policy one constant action? Each constant action against the row, seed by seed.

    python research/tasks_v3/constant_action_check.py research/tasks_v3/learners/ThrustArc-TCM-v3-dqn-*.json
    #                                                     log: constant_action_check.log beside it

A deterministic learner (DQN, scored by its argmax) whose J equals another run's on every evaluation seed
may have reached one state-dependent policy twice, or it may act the same way in every state. This rolls
out each constant action of the task (a one-hot blind schedule, ``weighted:w=...`` in the blind search's
family) on the records' evaluation seeds and prints, per record row, the largest |J_row - J_constant| over
the seeds [km]: 0 to rounding means the row's policy gives the constant action's J on every seed. The
records must share the task and seeds and carry no world overrides (the task's own world).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from planetnav_train.suite import v3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("records", nargs="+", type=Path, help="files from `suite.v3 learners`")
    args = ap.parse_args()
    recs = [json.loads(p.read_text()) for p in args.records]
    task, episodes = recs[0]["task"], recs[0]["episodes"]
    for p, r in zip(args.records, recs, strict=True):
        if (r["task"], r["episodes"]) != (task, episodes) or r.get("world_overrides"):
            raise SystemExit(
                f"{p}: task {r['task']!r}, {r['episodes']} episodes, world "
                f"{r.get('world_overrides')!r}; expected {task!r}, {episodes}, the task's world"
            )
    cfg = v3.eval_config(f"planetnav/{task}")
    if cfg.action_mode == "torque":
        raise SystemExit(f"{task}: a torque task has no constant target action")
    n_actions = cfg.n_target_actions
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + episodes)
    print(f"{task}: {episodes} evaluation seeds from {v3.EVAL_SEED}", flush=True)
    constant = {}
    for a in range(n_actions):
        schedule = v3.BlindTargets(f"action {a}", v3._one_hot([a], n_actions), 1)
        constant[a] = v3.roll_out(cfg, schedule, seeds).objective
        print(f"constant action {a}: J {constant[a].mean():.1f} km", flush=True)
    for p, r in zip(args.records, recs, strict=True):
        for name, j in r["per_seed"].items():
            j = np.asarray(j, float)
            gaps = {a: float(np.abs(j - c).max()) for a, c in constant.items()}
            a = min(gaps, key=gaps.get)
            print(
                f"{p.name} | {name}: J {j.mean():.1f}; nearest constant action {a}, "
                f"max |dJ| {gaps[a]:.3g} km",
                flush=True,
            )


if __name__ == "__main__":
    main()
