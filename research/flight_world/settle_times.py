"""Settle times of the PD law for the shipped gains and the thesis's, at the attitude sub-steps of the env.

    python research/flight_world/settle_times.py            # 20 random attitudes, up to 8,000 s
    python research/flight_world/settle_times.py --seeds 5

Each case starts at rest at a seeded random attitude and points the camera (body +x) at a fixed planet
direction with the closed loop of ``attitude.pointing.propagate_pointing`` (PD law -> default wheel limits,
0.01 N m and 0.5 N m s -> RK4) at the sub-step ``dt``; the settle time is the first time from which the
boresight stays within 0.01 deg to the end of the run (sampled every 10 s). "never" counts the runs that
have not settled by the end. Prints one Markdown row per (gains, sub-step).
"""

from __future__ import annotations

import argparse

import numpy as np

from planetnav_env.attitude.plant import AttitudeConfig
from planetnav_env.attitude.pointing import pointing_error, propagate_pointing
from planetnav_env.attitude.quaternion import normalize

GAINS = {"shipped (k_a = 0.02 N m, k_w = 1 N m s)": (0.02, 1.0), "thesis (k_a = k_w = 1)": (1.0, 1.0)}
SUBSTEPS_S = (1.0, 0.5, 0.2, 0.1)
TOL_RAD = np.radians(0.01)
SAMPLE_S = 10.0


def settle_time(q0: np.ndarray, k_a: float, k_w: float, dt: float, horizon_s: float) -> float:
    """First time [s] from which the pointing error stays below TOL_RAD until ``horizon_s`` (inf: never)."""
    cfg = AttitudeConfig()
    target = np.array([-2.8, 1.7, 0.4])  # R - X of docs/attitude.md's convergence table
    roll = np.array([1.8, 0.3, 0.1])
    q, w, h = q0, np.zeros(3), np.zeros(3)
    n = round(SAMPLE_S / dt)
    last_out = 0.0
    t = 0.0
    while t < horizon_s:
        q, w, h = propagate_pointing(q, w, h, target, dt, n, cfg, roll_ref_inertial=roll, k_a=k_a, k_w=k_w)
        t += SAMPLE_S
        if float(pointing_error(q, target)) >= TOL_RAD:
            last_out = t
    return last_out if last_out < horizon_s else float("inf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--horizon", type=float, default=8000.0, help="run length [s]")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    starts = [normalize(rng.normal(size=4)) for _ in range(args.seeds)]
    print(f"| gains | sub-step [s] | settled (of {args.seeds}) | min / median / max [s] |")
    print("|---|---|---|---|")
    for name, (k_a, k_w) in GAINS.items():
        for dt in SUBSTEPS_S:
            times = np.array([settle_time(q0, k_a, k_w, dt, args.horizon) for q0 in starts])
            ok = times[np.isfinite(times)]
            stats = f"{ok.min():.0f} / {np.median(ok):.0f} / {ok.max():.0f}" if ok.size else "-"
            print(f"| {name} | {dt:g} | {ok.size} | {stats} |")


if __name__ == "__main__":
    main()
