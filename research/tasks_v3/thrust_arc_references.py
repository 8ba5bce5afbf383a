"""A v3 task's non-privileged references on the first 100 evaluation seeds (130,000..), the figures the
learner table compares PPO with while the task has no published normalization; where the blind search
has a winner, each reference's paired difference from it on the same seeds.

    python research/tasks_v3/thrust_arc_references.py      # log: thrust_arc_references.log beside it
    python research/tasks_v3/thrust_arc_references.py --task Cruise-Torque-v3 --skip planner
    #                                                        log: torque_references.log
"""

from __future__ import annotations

import argparse
import time

from planetnav_train.suite import v3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", default="ThrustArc-TCM-v3", choices=sorted(v3.V3_TASKS))
    ap.add_argument("--skip", nargs="*", default=(), help="references left out (their cost)")
    ap.add_argument("--episodes", type=int, default=100)
    args = ap.parse_args()
    cfg = v3.eval_config(f"planetnav/{args.task}")
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + args.episodes)
    blind = v3.read_json(v3.BLIND_FILE)["tasks"].get(args.task)
    jz = None
    if blind is not None:
        zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
        jz = v3.roll_out(cfg, zero, seeds).objective
        m = v3.mean_interval(jz)
        print(f"blind zero {blind['winner']}: J {m['mean']:.1f} [{m['lo']:.1f}, {m['hi']:.1f}]", flush=True)
    for spec in v3.V3_TASKS[args.task]:
        if spec in args.skip:
            continue
        t = time.time()
        try:
            j = v3.policy_objective(cfg, spec, v3.EVAL_SEED, args.episodes)
        except Exception as exc:  # a reference that cannot act here is reported
            print(f"{spec}: not evaluated ({type(exc).__name__}: {exc})", flush=True)
            continue
        m = v3.mean_interval(j)
        took = time.time() - t
        line = f"{spec}: J {m['mean']:.1f} [{m['lo']:.1f}, {m['hi']:.1f}] ({took:.0f} s)"
        if jz is not None:
            d = v3.paired_difference(j, jz)
            line += f", minus zero {d['mean']:+.1f} [{d['lo']:+.1f}, {d['hi']:+.1f}]"
        print(line, flush=True)


if __name__ == "__main__":
    main()
