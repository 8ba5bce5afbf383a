"""How good is a uniformly random policy as the decision interval grows (Cruise-Target, relative
actions, covariance reward): the zero point of a normalized score must stay far from the reference.

    python research/tasks_v1/random_vs_interval.py [--episodes 20]
"""

from __future__ import annotations

import argparse

from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.evaluate import evaluate_agent


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--task", default="Cruise-Target")
    ap.add_argument("--intervals", type=int, nargs="+", default=[1, 2, 3, 5, 10])
    args = ap.parse_args()
    base = {**ENV_IDS[f"planetnav/{args.task}-v1"], "noise_streams": "per_step"}
    greedy = evaluate_agent("greedy", EnvConfig.from_dict(base), args.episodes, 50_000, progress=False)
    print(f"greedy (physics step): {greedy.metrics['objective_mean']:.1f} km")
    for k in args.intervals:
        cfg = EnvConfig.from_dict({**base, "decision_steps": k})
        r = evaluate_agent("random", cfg, args.episodes, 50_000, progress=False).metrics
        lo, hi = r["objective_ci95"]
        print(f"random, decision every {k} step(s): {r['objective_mean']:.1f} km [{lo:.1f}, {hi:.1f}], "
              f"measured {r['measured_fraction']:.2f}")


if __name__ == "__main__":
    main()
