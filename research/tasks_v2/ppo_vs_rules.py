"""PPO on a v2 task against the rules, on the evaluation seeds: each training seed and the mean over the
five seeds per evaluation seed, paired with the nominal greedy, the adaptive greedy and the best blind
schedule, and the blind-zero score with its paired bootstrap interval.

    python research/tasks_v2/ppo_vs_rules.py research/tasks_v2/ppo_cruise_target_v2.json \
        docs/tasks_v2_blind.json Cruise-Target-v2

The first file is `train.py compare --json` over the PPO runs and the rules (the command is in
research/tasks_v2/README.md); the second the blind search's JSON (its winner and best reference).
"""

from __future__ import annotations

import json
import sys

import numpy as np

from planetnav_train.stats import paired_difference
from planetnav_train.suite.blind import paired_ratio_ci


def main(compare_path: str, blind_path: str, task: str) -> None:
    agents = json.load(open(compare_path))["agents"]
    rec = json.load(open(blind_path))["tasks"][task]
    blind = np.asarray(rec["agents"][rec["blind_winner"]]["per_seed"])
    best = np.asarray(rec["agents"][rec["best_reference"]]["per_seed"])
    nominal = np.asarray(rec["agents"]["greedy"]["per_seed"])
    learned = ("ppo:", "dqn:", "sac:", "recurrent_ppo:")  # trained runs, as compare names them
    runs = {
        k: np.asarray(v["per_episode_mean_pos_err_km"]) for k, v in agents.items() if k.startswith(learned)
    }
    sampled = [v for k, v in runs.items() if k.endswith(":stochastic")]
    mode = "sampled" if sampled else "argmax"
    pooled = sampled or list(runs.values())  # a file of argmax runs only: average those
    algo = next(iter(runs)).split(":")[0].upper()
    rows = {**runs, f"{algo} {mode}, mean of {len(pooled)} seeds": np.mean(pooled, axis=0)}
    print(f"{task}: blind {rec['blind_winner']} {blind.mean():.1f} km, best {rec['best_reference']} "
          f"{best.mean():.1f} km, nominal greedy {nominal.mean():.1f} km")
    for name, v in rows.items():
        dn, db, dz = (paired_difference(v, x) for x in (nominal, best, blind))
        s = paired_ratio_ci(blind, best, v)
        print(f"{name:42s} {v.mean():7.1f} km  vs nominal {dn.mean:+6.1f} [{dn.low:+.1f}, {dn.high:+.1f}]  "
              f"vs adaptive {db.mean:+6.1f} [{db.low:+.1f}, {db.high:+.1f}]  vs blind {dz.mean:+6.1f} "
              f"[{dz.low:+.1f}, {dz.high:+.1f}]  blind-zero score {s['score']:+.2f} [{s['score_lo']:+.2f}, "
              f"{s['score_hi']:+.2f}]")


if __name__ == "__main__":
    main(*sys.argv[1:4])
