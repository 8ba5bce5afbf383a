"""Does a selected learned policy hold its lead on seeds it was not selected on?

    python -m planetnav_train.suite.v3 learners --task MarsApproach-Tasking-v3 --algo dqn --seed 1 \
        --save-model M.zip --out rows.json
    python research/tasks_v3/fresh_seed_check.py --task MarsApproach-Tasking-v3 --model M.zip --algo dqn

A learner run is scored on the first 100 evaluation seeds (130,000..130,099); picking the best of several
runs by that score flatters it (the winner's curse). This scores the saved model, acting as the suite
scores it (``v3.LEARNERS``: DQN and SAC deterministic, PPO sampled), on the evaluation seeds after those
(130,100.. by default, 900 of them: seeds no run was picked on) beside every non-privileged rule the
task has: the published blind zero and each of its finalists, and each reference. Per policy: J [km]
with its interval; the model's paired difference from each [km] (negative: the model is better); and
what the model and the zero do (diagnose_learners.describe: fixes per target, NIS, action changes,
action frequencies per third of the episode).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3

sys.path.insert(0, str(Path(__file__).resolve().parent))
from diagnose_learners import describe  # a sibling research script


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", required=True, choices=list(v3.V3_TASKS))
    ap.add_argument("--model", required=True, help="SB3 zip from `learners --save-model`")
    ap.add_argument("--algo", default="ppo", choices=sorted(v3.LEARNERS))
    ap.add_argument("--first", type=int, default=v3.EVAL_SEED + 100, help="the first seed")
    ap.add_argument("--episodes", type=int, default=900)
    args = ap.parse_args()
    import stable_baselines3

    t0 = time.time()
    cfg = v3.eval_config(f"planetnav/{args.task}")
    seeds = range(args.first, args.first + args.episodes)
    cls_name, acting = v3.LEARNERS[args.algo]
    model = getattr(stable_baselines3, cls_name).load(args.model, device="cpu")
    act = v3._policy_fn(model, [], acting == "deterministic")
    out = v3.roll_out(cfg, act, seeds, final=True, actions=True)
    jm = out.objective
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][args.task]
    rules = {}
    zero_out = None
    for name in [blind["winner"], *(s for s in blind["finalists"] if s != blind["winner"])]:
        policy = v3.policy_from_record(name, blind["policies"][name])
        o = v3.roll_out(cfg, policy, seeds, final=True, actions=True)
        zero_out = zero_out if zero_out is not None else o
        rules[f"blind {name}"] = o.objective
    for spec in v3.V3_TASKS[args.task]:
        rules[f"reference {spec}"] = v3.policy_objective(cfg, spec, seeds.start, len(seeds))
    print(f"{args.task}: {args.model} ({cls_name}, {acting}) on seeds {seeds.start}..{seeds.stop - 1}")
    print(f"  model: J {mean_ci(jm).format('{:.1f}')}")
    for name, j in rules.items():
        d = paired_difference(jm, j)
        diff = f"{d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}]"
        print(f"  {name}: J {mean_ci(j).format('{:.1f}')}; model - it {diff}")
    best = min(rules, key=lambda k: rules[k].mean())
    d = paired_difference(jm, rules[best])
    print(f"  the best rule here: {best}; model - it {d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}] km")
    describe(f"model ({cls_name}, {acting})", cfg, out)
    describe(f"blind zero ({blind['winner']})", cfg, zero_out)
    print(f"({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
