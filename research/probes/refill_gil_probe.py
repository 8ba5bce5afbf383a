"""Does drawing the device env's bank slow the stepping thread? The device env in host mode on a
short-episode id (Cruise-TorqueControl-v1 cut to 8 decisions, so episodes start at 1/8 of the steps),
stepped for 300 decisions of 512 rows with the refill off, drawn by the refill's thread in this process
(``bank_workers=0``) and by one drawing process (``bank_workers=1``), rounds in turn; prints each rate,
its ratio to the refill-off rate of the same round, and the substitutes.

    python research/probes/refill_gil_probe.py [--rounds 2]

Drawing is Python and holds the interpreter lock. On the 2-core machine (2026-11-28, two runs of two
rounds): off 115,000-134,000 decisions/s; the thread 0.22-0.28 of it, with no substitute (it kept up by
taking the stepping thread's time); one process 0.81-0.90, with substitutes for most episodes (one
process cannot draw an episode every 8 decisions of 512 rows, and it shares the two cores).
"""

from __future__ import annotations

import argparse
import time

import torch

import planetnav_env  # noqa: F401
from planetnav_env.device.vector_env import DeviceVectorEnv

N, DECISIONS = 512, 300


def rate(refill: str, workers: int) -> tuple[float, dict]:
    env = DeviceVectorEnv("planetnav/Cruise-TorqueControl-v1", N, device="cpu", bank_size=2 * N,
                          refill=refill, bank_workers=workers, episode_steps=8)  # fmt: skip
    env.reset(seed=0)
    zero = torch.zeros((N, 3))
    for _ in range(10):
        env.step(zero)
    t = time.perf_counter()
    for _ in range(DECISIONS):
        env.step(zero)
    r = N * DECISIONS / (time.perf_counter() - t)
    stats = env.bank_stats()
    env.close()
    return r, stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    for k in range(args.rounds):
        off, _ = rate("off", 0)
        print(f"round {k}: off {off:,.0f} decisions/s")
        for name, workers in (("thread", 0), ("one process", 1)):
            r, stats = rate("thread", workers)
            print(f"round {k}: {name} {r:,.0f} ({r / off:.2f}), {stats['substituted']} substitutes "
                  f"of {stats['episodes']} episodes")  # fmt: skip


if __name__ == "__main__":
    main()
