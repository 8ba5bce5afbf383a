"""Tuning sweep of the operations references on planetnav/ThrustArc-TCM-v0 (research/operations_log.md §7):
``periodic`` (period, session, phase, cycle) and ``greedy:threshold=θ`` on tuning seeds (20000+, disjoint
from the evaluation seeds 10000+), per-step noise streams, ``reward: covariance`` (J is then a function of
the schedule). Prints one line per setting: mean J [km] over the seeds, mean Δv lost [m/s], CPU s.

    NUMBA_CACHE_DIR=/tmp/nb_ops2 nice -n 10 .venv/bin/python research/operations/sweep_thrust_arc.py \
        --part periodic --episodes 4

``--part deadline`` sweeps the deadline-anchored sessions ``periodic:lead=L,session=S1-S2-S3,start=S0,
dwell=D,cycle=C`` (agents/periodic.py; research/operations_log.md §7.5) over the product of ``--leads``,
``--s1``,
``--s2``, ``--s3`` (block length before each deadline), ``--starts``, ``--dwells`` and ``--cycles`` (all in
600-s steps), with the tuned periodic of §7.1 first as the bar, and ends with the ``--top`` best settings.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from planetnav_train.config import load_config
from planetnav_train.evaluate import SWEEP_SEED, evaluate_agent, evaluation_env

ROOT = Path(__file__).resolve().parents[2]

PERIODS_D = (0.5, 1, 1.5, 2, 3, 4, 5, 7)  # days (x 144 steps of 600 s)
SESSIONS = (6, 12, 18, 24)  # steps: 1, 2, 3, 4 h
CYCLES = ("0", "0-1", "0-1-2")
THRESHOLDS = (0, 0.25, 0.5, 1, 1.5, 2, 3, 4, 8, 16)
#: The tuned periodic rule (§7.1), printed first in the deadline part as the bar.
TUNED_PERIODIC = "periodic:period=432,session=12,phase=108,cycle=0-1-2"


def deadline_specs(args: argparse.Namespace) -> list[str]:
    """The deadline-anchored grid: every combination of the lists in ``args`` (steps of 600 s)."""
    return [
        f"periodic:lead={lead},session={s1}-{s2}-{s3},start={start},dwell={dwell},cycle={c}"
        for lead in args.leads
        for s1 in args.s1
        for s2 in args.s2
        for s3 in args.s3
        for start in args.starts
        for dwell in args.dwells
        for c in args.cycles
    ]


def specs(part: str, base: list[str], phases: int) -> list[str]:
    """The grid (shortened: research/operations_log.md §7 says which). ``phase``: the settings ``base``
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
    ap.add_argument("--part", choices=("periodic", "phase", "greedy", "deadline"), required=True)
    ap.add_argument("--episodes", type=int, default=4)
    ap.add_argument("--base", nargs="*", default=[], help="phase part: PERIOD,SESSION,CYCLE settings")
    ap.add_argument("--phases", type=int, default=8)
    ap.add_argument("--only", type=int, nargs=2, metavar=("START", "STOP"), help="a slice of the grid")
    # Deadline part (steps of 600 s): lead from a block's end to its deadline, block lengths before
    # E-14 d, E-5 d and E-1.5 d, the start session, the piece per planet within a session.
    ap.add_argument("--leads", type=int, nargs="+", default=[0, 6])
    ap.add_argument("--s1", type=int, nargs="+", default=[12, 24, 36])
    ap.add_argument("--s2", type=int, nargs="+", default=[24, 36, 48, 60])
    ap.add_argument("--s3", type=int, nargs="+", default=[6, 12, 18])
    ap.add_argument("--starts", type=int, nargs="+", default=[0, 6, 12])
    ap.add_argument("--dwells", type=int, nargs="+", default=[6])
    ap.add_argument("--cycles", nargs="+", default=["0-1-2", "0-1"])
    ap.add_argument("--top", type=int, default=10, help="deadline part: the best settings again at the end")
    args = ap.parse_args()
    cfg = load_config(ROOT / "configs" / "operations" / "thrust_arc_tcm.yaml")
    env_cfg = evaluation_env(cfg.env_config(), None, "per_step")
    if args.part == "deadline":
        grid = [TUNED_PERIODIC, *deadline_specs(args)]
    else:
        grid = specs(args.part, args.base, args.phases)
    results = []
    for spec in grid[slice(*args.only)] if args.only else grid:
        t0 = time.process_time()
        m = evaluate_agent(spec, env_cfg, args.episodes, SWEEP_SEED, progress=False).metrics
        results.append((m["objective_mean"], spec, m["measured_fraction"]))
        print(
            f"{spec:58s} J {m['objective_mean']:8.1f} km [{m['objective_ci95'][0]:8.1f}, "
            f"{m['objective_ci95'][1]:8.1f}]  imaging {m['measured_fraction']:.3f}  "
            f"cpu {time.process_time() - t0:4.1f} s",
            flush=True,
        )
    if args.part == "deadline":
        print(
            f"--- best {args.top} of {len(results)} (J km, mean over {args.episodes} seeds; imaging fraction)"
        )
        for j, spec, frac in sorted(results)[: args.top]:
            print(f"{spec:72s} J {j:8.1f} km  imaging {frac:.3f}")


if __name__ == "__main__":
    main()
