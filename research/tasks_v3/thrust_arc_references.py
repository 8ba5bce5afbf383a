"""ThrustArc-TCM-v3's non-privileged references on the first 100 evaluation seeds (130,000..), the figures
the learner table compares PPO with while the task has no published normalization.

    python research/tasks_v3/thrust_arc_references.py      # log: thrust_arc_references.log beside it
"""

from __future__ import annotations

import time

from planetnav_train.suite import v3


def main() -> None:
    cfg = v3.eval_config("planetnav/ThrustArc-TCM-v3")
    for spec in v3.V3_TASKS["ThrustArc-TCM-v3"]:
        t = time.time()
        try:
            j = v3.policy_objective(cfg, spec, v3.EVAL_SEED, 100)
        except Exception as exc:  # a reference that cannot act here is reported
            print(f"{spec}: not evaluated ({type(exc).__name__}: {exc})", flush=True)
            continue
        m = v3.mean_interval(j)
        took = time.time() - t
        print(f"{spec}: J {m['mean']:.1f} [{m['lo']:.1f}, {m['hi']:.1f}] ({took:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
