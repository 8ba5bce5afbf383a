"""Is PPO's loss on a v3 task its discount's horizon? SB3's PPO with one default changed, ``gamma``, at
the suite's budget, scored as the published learner rows are (the first 100 evaluation seeds, beside the
untrained network, uniform random, the published zero and best reference).

SB3's default gamma = 0.99 discounts over about 100 decisions; the Mars approach has 282, and the rule that
beats the zero there spends its first third on Mars, whose fixes pay later in the episode. A diagnosis,
not a posing: a row made here is not "SB3 with its defaults" (its file names the override).

    python research/tasks_v3/horizon_probe.py --task MarsApproach-Tasking-v3 --gamma 0.999 --seed S \
        --out research/tasks_v3/horizon/MarsApproach-Tasking-v3-gamma0.999-S.json
    python research/tasks_v3/learner_table.py research/tasks_v3/horizon/*.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from planetnav_train.suite import v3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", required=True)
    ap.add_argument("--gamma", type=float, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=300_000)
    ap.add_argument("--save-model", default=None)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    rows = v3.learner_rows(args.task, args.budget, args.seed, ppo_overrides={"gamma": args.gamma},
                           save_model=args.save_model)  # fmt: skip
    Path(args.out).write_text(json.dumps(rows, indent=1) + "\n")
    for r in rows["rows"]:
        print(r["policy"], f"J {r['J']['mean']:.1f}", r.get("score", ""))


if __name__ == "__main__":
    main()
