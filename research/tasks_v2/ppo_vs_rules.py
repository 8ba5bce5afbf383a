"""PPO on a v2 task against the rules, on the evaluation seeds: each training seed and the mean over the
five seeds per evaluation seed (per evaluation mode), paired with the nominal greedy (the best rule where
the task has no greedy reference), the best rule (the adaptive greedy on the event tasks) and the best blind
policy, and the blind-zero score with its paired bootstrap interval. The objective is the operations J on
the thrust arc, the mean true position error elsewhere.

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


def _objective(metrics: dict) -> np.ndarray:
    """Per-episode objective: the operations J where the compare recorded one, else the mean error."""
    key = "per_episode_objective" if "per_episode_objective" in metrics else "per_episode_mean_pos_err_km"
    return np.asarray(metrics[key])


def main(compare_path: str, blind_path: str, task: str) -> None:
    agents = json.load(open(compare_path))["agents"]
    rec = json.load(open(blind_path))["tasks"][task]
    blind = np.asarray(rec["agents"][rec["blind_winner"]]["per_seed"])
    best = np.asarray(rec["agents"][rec["best_reference"]]["per_seed"])
    # The nominal rule: greedy on the filter's model where the task has it as a reference, else the best.
    nominal_name = "greedy" if "greedy" in rec["agents"] else rec["best_reference"]
    nominal = np.asarray(rec["agents"][nominal_name]["per_seed"])
    learned = ("ppo:", "dqn:", "sac:", "recurrent_ppo:")  # trained runs, as compare names them
    runs = {k: _objective(v) for k, v in agents.items() if k.startswith(learned)}
    algo = next(iter(runs)).split(":")[0].upper()
    rows = dict(runs)
    for mode, pick in (
        ("sampled", lambda k: k.endswith(":stochastic")),
        ("argmax", lambda k: not k.endswith(":stochastic")),
    ):
        pooled = [v for k, v in runs.items() if pick(k)]
        if pooled:
            rows[f"{algo} {mode}, mean of {len(pooled)} seeds"] = np.mean(pooled, axis=0)
    print(
        f"{task}: blind {rec['blind_winner']} {blind.mean():.1f} km, best {rec['best_reference']} "
        f"{best.mean():.1f} km, nominal {nominal_name} {nominal.mean():.1f} km"
    )
    for name, v in rows.items():
        dn, db, dz = (paired_difference(v, x) for x in (nominal, best, blind))
        s = paired_ratio_ci(blind, best, v)
        print(
            f"{name:42s} {v.mean():7.1f} km  vs nominal {dn.mean:+6.1f} [{dn.low:+.1f}, {dn.high:+.1f}]  "
            f"vs best rule {db.mean:+6.1f} [{db.low:+.1f}, {db.high:+.1f}]  vs blind {dz.mean:+6.1f} "
            f"[{dz.low:+.1f}, {dz.high:+.1f}]  blind-zero score {s['score']:+.2f} [{s['score_lo']:+.2f}, "
            f"{s['score_hi']:+.2f}]"
        )


if __name__ == "__main__":
    main(*sys.argv[1:4])
