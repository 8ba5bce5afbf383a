"""Tuning sweep of the operations references on planetnav/ThrustArc-TCM-v0 (docs/operations.md §7):
``periodic`` (period, session, phase, cycle) and ``greedy:threshold=θ`` on tuning seeds (20000+, disjoint
from the evaluation seeds 10000+), per-step noise streams, ``reward: covariance`` (J is then a function of
the schedule). Prints one line per setting: mean J [km] over the seeds, mean Δv lost [m/s], CPU s.

    NUMBA_CACHE_DIR=/tmp/nb_ops2 nice -n 10 .venv/bin/python configs/operations/sweep_thrust_arc.py \
        --part periodic --episodes 4
"""

from __future__ import annotations

import argparse
import time

from planetnav_train.config import load_config
from planetnav_train.evaluate import SWEEP_SEED, evaluate_agent, evaluation_env

PERIODS_D = (0.5, 1, 1.5, 2, 3, 4, 5, 7)  # days (x 144 steps of 600 s)
SESSIONS = (6, 12, 18, 24)  # steps: 1, 2, 3, 4 h
CYCLES = ("0", "0-1", "0-1-2")
THRESHOLDS = (0, 0.25, 0.5, 1, 1.5, 2, 3, 4, 8, 16)


def specs(part: str, base: list[str], phases: int) -> list[str]:
    """The grid (shortened: docs/operations.md §7 says which). ``phase``: the settings ``base``
    (``period,session,cycle`` as ``P,S,C``) at ``phases`` phases evenly over the period."""
    if part == "greedy":
        return [f"greedy:threshold={t:g}" for t in THRESHOLDS]
    if part == "phase":
        out = []
        for item in base:
            period, session, cycle = item.split(",")
            for j in range(phases):
                phase = int(period) * j // phases
                out.append(f"periodic:period={period},session={session},phase={phase},cycle={cycle}")
        return out
    return [
        f"periodic:period={round(d * 144)},session={s},phase=0,cycle={c}"
        for d in PERIODS_D
        for s in SESSIONS
        for c in CYCLES
    ]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--part", choices=("periodic", "phase", "greedy"), required=True)
    ap.add_argument("--episodes", type=int, default=4)
    ap.add_argument("--base", nargs="*", default=[], help="phase part: PERIOD,SESSION,CYCLE settings")
    ap.add_argument("--phases", type=int, default=8)
    ap.add_argument("--only", type=int, nargs=2, metavar=("START", "STOP"), help="a slice of the grid")
    args = ap.parse_args()
    cfg = load_config("configs/operations/thrust_arc_tcm.yaml")
    env_cfg = evaluation_env(cfg.env_config(), None, "per_step")
    grid = specs(args.part, args.base, args.phases)
    for spec in grid[slice(*args.only)] if args.only else grid:
        t0 = time.process_time()
        m = evaluate_agent(spec, env_cfg, args.episodes, SWEEP_SEED, progress=False).metrics
        print(
            f"{spec:58s} J {m['objective_mean']:8.1f} km [{m['objective_ci95'][0]:8.1f}, "
            f"{m['objective_ci95'][1]:8.1f}]  imaging {m['measured_fraction']:.3f}  "
            f"cpu {time.process_time() - t0:4.1f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
