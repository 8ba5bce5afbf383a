"""Where does the closed loop start to pay on Cruise-Target-v3? A regime map over the boresight drift.

    python research/tasks_v3/drift_regime_map.py [--episodes 100] [--sigmas 0 0.25 0.5 1.0]

Sweeps the planet camera's boresight drift (``world.drift_sigma_arcsec``; 0 is the flight world with
``boresight_drift`` off, 1.0 arcsec the flight value) and, at each value, scores the suite's blind zero
of Cruise-Target-v3 (docs/tasks_v3_blind.json) and the two non-privileged references of the task
(covariance greedy, and greedy with observed success rates) on the same evaluation seeds with per-step
noise streams. Prints each J [km] with its interval and the paired difference reference - zero: where
the interval lies below 0 the filter-driven rule beats the blind cycle, i.e. the regime in which the
task's closed-loop gap exists.
"""

from __future__ import annotations

import argparse
import time

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3

TASK = "planetnav/Cruise-Target-v3"
REFERENCES = ("greedy", "greedy:success=observed")


def world_for(sigma: float) -> dict:
    """The flight world's overrides for a drift of ``sigma`` arcsec per axis (0: the drift off)."""
    if sigma < 0.0:
        raise ValueError(f"drift sigma {sigma!r} arcsec: must be >= 0")
    return {"boresight_drift": False} if sigma == 0.0 else {"drift_sigma_arcsec": float(sigma)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--sigmas", type=float, nargs="+", default=[0.0, 0.25, 0.5, 1.0])
    args = ap.parse_args()
    blind = v3.read_json(v3.BLIND_FILE)["tasks"]["Cruise-Target-v3"]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    print(f"{args.episodes} seeds from {v3.EVAL_SEED}; zero {blind['winner']}\n")
    head = " | ".join(f"J {r} | {r} - zero" for r in REFERENCES)
    print(f"| drift sigma [arcsec] | J zero | {head} |")
    print("|---" * (2 + 2 * len(REFERENCES)) + "|")
    for sigma in args.sigmas:
        t0 = time.time()
        cfg = v3.eval_config(TASK, world=world_for(sigma))
        jz = v3.policy_objective(cfg, zero, v3.EVAL_SEED, args.episodes)
        cells = [f"{sigma:g}", mean_ci(jz).format("{:.1f}")]
        for ref in REFERENCES:
            jr = v3.policy_objective(cfg, ref, v3.EVAL_SEED, args.episodes)
            d = paired_difference(jr, jz)
            cells += [mean_ci(jr).format("{:.1f}"), f"{d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}]"]
        print("| " + " | ".join(cells) + f" |  ({time.time() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
