"""Does the boresight drift make a blind cycle beat the covariance rules on Cruise-Target-v3?

    python research/tasks_v3/drift_probe.py [--episodes 100]

Scores the suite's blind zero of Cruise-Target-v3 (docs/tasks_v3_blind.json) and greedy with observed
success rates on the same seeds (the evaluation block, per-step noise streams), in the flight world and in
the flight world without the boresight drift (``world={"boresight_drift": False}`` over the id's world),
and prints each J with its interval and the paired difference greedy - zero [km].
"""

from __future__ import annotations

import argparse

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3

TASK = "planetnav/Cruise-Target-v3"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=100)
    args = ap.parse_args()
    blind = v3.read_json(v3.BLIND_FILE)["tasks"]["Cruise-Target-v3"]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    print(f"{args.episodes} seeds from {v3.EVAL_SEED}; zero {blind['winner']}\n")
    print("| world | J zero [km] | J greedy:success=observed [km] | greedy - zero [km] |")
    print("|---|---|---|---|")
    for name, world in (("flight", {}), ("flight, no boresight_drift", {"boresight_drift": False})):
        cfg = v3.eval_config(TASK, **({"world": world} if world else {}))
        jz = v3.policy_objective(cfg, zero, v3.EVAL_SEED, args.episodes)
        jg = v3.policy_objective(cfg, "greedy:success=observed", v3.EVAL_SEED, args.episodes)
        d = paired_difference(jg, jz)
        print(f"| {name} | {mean_ci(jz).format('{:.1f}')} | {mean_ci(jg).format('{:.1f}')} | "
              f"{d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}] |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
