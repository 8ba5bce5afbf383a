"""The training curve of an operations run: the mean J [km] of its training episodes, in blocks, from the
run's ``monitor/vec.monitor.csv`` (SB3's Monitor: the episode return, its length, the wall time).

J = -return x ``reward_scale_km`` (the env's reward sums to -J / reward_scale_km; 1000 km in the shipped
configs). The training episodes act with sampled actions on the training seeds, so these are neither the
argmax policy's J nor held-out values (research/operations_log.md §7.6).

    .venv/bin/python research/operations/monitor_curve.py /tmp/h17/run_ppo12 --block 80
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--block", type=int, default=100, help="episodes per printed mean")
    ap.add_argument("--scale-km", type=float, default=1000.0, help="the config's env.reward_scale_km")
    args = ap.parse_args()
    if args.block < 1:
        raise SystemExit(f"--block must be >= 1, got {args.block}")
    path = args.run_dir / "monitor" / "vec.monitor.csv"
    if not path.is_file():
        raise SystemExit(f"{path}: no monitor file (is {args.run_dir} a train.py run directory?)")
    data = np.loadtxt(path, delimiter=",", skiprows=2, ndmin=2)
    j = -data[:, 0] * args.scale_km
    print(f"{path}: {j.size} training episodes")
    for start in range(0, j.size, args.block):
        part = j[start : start + args.block]
        last = start + part.size - 1
        print(f"episodes {start:6d}-{last:6d}  mean J {part.mean():9.1f} km  (wall {data[last, 2]:7.0f} s)")


if __name__ == "__main__":
    main()
