"""The planner reference on Cruise-Torque-v3's first 100 evaluation seeds, paired with covariance greedy:
the measurement behind leaving it out of the task's normalization set (its cost, ~5 s an episode).

    python research/tasks_v3/torque_planner_100.py     # log: torque_planner_100.log beside it
"""

from __future__ import annotations

import time

from planetnav_train.suite import v3


def main() -> None:
    cfg = v3.eval_config("planetnav/Cruise-Torque-v3")
    t = time.time()
    j = v3.policy_objective(cfg, "planner", v3.EVAL_SEED, 100)
    print("planner", v3.mean_interval(j), time.time() - t, flush=True)
    g = v3.policy_objective(cfg, "greedy", v3.EVAL_SEED, 100)
    print("planner minus greedy", v3.paired_difference(j, g))


if __name__ == "__main__":
    main()
