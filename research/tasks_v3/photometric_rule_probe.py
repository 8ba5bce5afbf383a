"""A reference rule on the search's second-stage seeds, paired with the task's published blind zero.

    python research/tasks_v3/photometric_rule_probe.py --task MarsApproach-Tasking-v3 [--specs S ...]

Seeds 115,000.. (the second stage's block, apart from the evaluation seeds), per-step noise streams; each
spec's J [km] with its 95 % interval and its paired difference from the zero. The default spec is
``greedy:bias=photometric`` beside plain ``greedy``: the look that decided whether the rule was worth
scoring on the evaluation seeds (``normalize --add-reference``).
"""

from __future__ import annotations

import argparse
import time

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--task", required=True)
    ap.add_argument("--specs", nargs="+", default=["greedy:bias=photometric", "greedy"])
    ap.add_argument("--first", type=int, default=v3.FINAL_SEED)
    ap.add_argument("--episodes", type=int, default=100)
    args = ap.parse_args()
    cfg = v3.eval_config(f"planetnav/{args.task}")
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][args.task]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    seeds = range(args.first, args.first + args.episodes)
    jz = v3.roll_out(cfg, zero, seeds).objective
    print(f"{args.task}: seeds {seeds.start}..{seeds.stop - 1}; the zero ({blind['winner']}) "
          f"J {mean_ci(jz).format('{:.1f}')}")  # fmt: skip
    for spec in args.specs:
        t0 = time.time()
        j = v3.policy_objective(cfg, spec, args.first, args.episodes)
        d = paired_difference(j, jz)
        print(f"  {spec}: J {mean_ci(j).format('{:.1f}')}; minus the zero {d.mean:+.1f} [{d.low:+.1f}, "
              f"{d.high:+.1f}]  ({time.time() - t0:.0f} s)", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
