"""Speed of the operations scenario ``planetnav/ThrustArc-TCM-v0`` against ``planetnav/Cruise-Target-v0``,
measured in the same run: vector-env steps/s of each and their ratio (target >= 0.5).

    python benchmarks/bench_operations.py            # 16 rows, 3 blocks of 200 steps
    python benchmarks/bench_operations.py --rows 64 --steps 400

The action stream is a mission-like schedule for ThrustArc (stay at the thrust attitude, with a 12-step
imaging session on a planet every 100 steps; one step is 600 s) and held targets for the cruise (each row
keeps a planet for 60 steps; one step is 60 s). Each rate is the best of ``--repeats`` blocks timed in
this process's CPU time (the machine is shared: wall time counts other processes' load; both ids run on one
thread below 64 rows, so CPU time is their cost). Simulated days per CPU second are printed too: a
ThrustArc step covers ten times the time of a cruise step. A random policy (a slew nearly every step,
600 one-second sub-steps each) is several times slower than this schedule.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.envs.vector_env import PlanetNavVectorEnv


def _acts(env_id: str, n: int, k: int) -> np.ndarray:
    if env_id.endswith("ThrustArc-TCM-v0"):
        stay = 3  # P planets, then "stay at the mission attitude"
        phase = (k + 7 * np.arange(n)) % 100
        return np.where(phase < 12, (k // 100 + np.arange(n)) % 3, stay)
    return (np.arange(n) + k // 60) % 3


def rate(env_id: str, rows: int, steps: int, repeats: int) -> tuple[float, float]:
    """(steps/s over all rows, simulated days per wall second) of the best of ``repeats`` blocks."""
    env = PlanetNavVectorEnv(rows, env_id, episode_steps=100_000)
    env.reset(seed=0)
    step_s = env.config.step_s
    for k in range(20):  # warm-up (compilation, first slews)
        env.step(_acts(env_id, rows, k))
    best = 0.0
    k0 = 20
    for _ in range(repeats):
        t = time.process_time()
        for k in range(k0, k0 + steps):
            env.step(_acts(env_id, rows, k))
        best = max(best, rows * steps / (time.process_time() - t))
        k0 += steps
    env.close()
    return best, best * step_s / 86400.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=16)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    out = {}
    for env_id in ("planetnav/ThrustArc-TCM-v0", "planetnav/Cruise-Target-v0"):
        out[env_id] = rate(env_id, args.rows, args.steps, args.repeats)
        sps, days = out[env_id]
        print(f"{env_id:32s} {sps:10.0f} steps/s  {days:8.1f} simulated days/s  ({args.rows} rows)")
    ratio = out["planetnav/ThrustArc-TCM-v0"][0] / out["planetnav/Cruise-Target-v0"][0]
    print(f"ratio ThrustArc / Cruise (steps/s): {ratio:.2f}  (target >= 0.5)")


if __name__ == "__main__":
    main()
