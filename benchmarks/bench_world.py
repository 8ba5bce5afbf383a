"""The flight world's cost: steps/s of the native vector env in the flight world against the matched world,
measured in the same run, and their ratio (target >= 0.6x).

    python benchmarks/bench_world.py               # N = 1024, 40 steps per timed block, 3 blocks per world
    python benchmarks/bench_world.py --steps 10    # shorter

Both worlds run the same action stream (``held``: each row keeps its target for 60 steps, as rule agents
and trained policies act, so most steps hold a fix), alternating blocks (matched, flight, matched, ...) so
that a slow spell of a shared machine hits both; each rate is the best block. Ratios, not absolute numbers,
are the stable figures on a shared machine (bench_vec.py says why).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.envs.vector_env import PlanetNavVectorEnv

WORLDS = ("matched", "flight")


def rates(n: int, steps: int, repeats: int) -> dict[str, float]:
    """Best rows x steps per second of ``repeats`` blocks of ``steps`` steps, per world."""
    envs = {w: PlanetNavVectorEnv(n, world=w, episode_steps=100_000) for w in WORLDS}
    acts = [(np.arange(n) + k // 60) % 3 for k in range(steps * repeats + 1)]
    for env in envs.values():
        env.reset(seed=0)
        env.step(acts[0])  # compile and warm up, untimed
    best = dict.fromkeys(WORLDS, 0.0)
    for b in range(repeats):
        for w, env in envs.items():
            t = time.perf_counter()
            for k in range(b * steps, (b + 1) * steps):
                env.step(acts[k + 1])
            best[w] = max(best[w], n * steps / (time.perf_counter() - t))
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1024, help="rows of the vector env")
    ap.add_argument("--steps", type=int, default=40, help="steps per timed block")
    ap.add_argument("--repeats", type=int, default=3, help="timed blocks per world (the best counts)")
    args = ap.parse_args()
    best = rates(args.n, args.steps, args.repeats)
    print(f"vector env, N = {args.n}, target mode, held targets; best of {args.repeats} x {args.steps} steps")
    for w in WORLDS:
        print(f"  {w:8s} {best[w]:12,.0f} steps/s")
    print(f"  flight / matched: {best['flight'] / best['matched']:.2f}x (target >= 0.6x)")


if __name__ == "__main__":
    main()
