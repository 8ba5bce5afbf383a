#!/usr/bin/env python
"""Throughput of RLlib PPO with 1 and 2 env runners against SB3 PPO, and the wall time of the 4-trial smoke
sweep on one loopback node against two, all in one run on this machine (the numbers of docs/scaling.md).

    RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 .venv-ray/bin/python benchmarks/bench_ray.py   # = make bench-ray

Env steps/s count environment steps per second of training (sampling + learning, as ``train.py`` reports
for SB3), after two untimed warm-up iterations. Same environment
(Cruise-Target, one-day episodes, covariance reward), same PPO batch (4096 steps, minibatch 512, 5 epochs),
same 64x64 MLP, one torch thread for the learner. The machine is shared: rates vary by tens of percent
between runs, so compare within one run.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"  # before Ray is imported: stay on 127.0.0.1

from planetnav_train.config import ROOT, load_config, parse_config
from planetnav_train.training import train


def bench_rllib(num_env_runners: int, iterations: int) -> dict[str, float]:
    """Env steps/s of RLlib PPO (configs/rllib_ppo.yaml) with ``num_env_runners`` runners, local Ray."""
    import ray

    from planetnav_rl.cluster import init_ray, shutdown_ray
    from planetnav_rl.rllib import build_algorithm, iteration_summary

    tc = load_config(ROOT / "configs" / "rllib_ppo.yaml")
    tc.hyperparams["num_env_runners"] = num_env_runners
    # Same total envs either way (4): 1 runner x 4 envs or 2 runners x 2 envs.
    tc.n_envs = 4 // num_env_runners
    info = init_ray(None, num_cpus=2)
    try:
        algo = build_algorithm(tc)
        algo.train()  # warm-up: JIT, actor start, first rollout
        steps0 = iteration_summary(algo.train())["timesteps"]
        t0 = time.perf_counter()
        for _ in range(iterations):
            r = algo.train()
        elapsed = time.perf_counter() - t0
        steps = iteration_summary(r)["timesteps"] - steps0
        algo.stop()
    finally:
        shutdown_ray(info)
        assert not ray.is_initialized()
    return {"steps": steps, "seconds": elapsed, "steps_per_s": steps / elapsed}


#: The SB3 side of the comparison, spelled out rather than read from cruise_ppo.yaml (whose recipe may
#: change, e.g. to several environment steps per decision): PPO on every environment step, the same batch,
#: network, environment and reward as configs/rllib_ppo.yaml.
SB3_CONFIG = {
    "name": "bench_sb3",
    "algo": "ppo",
    "env_id": "planetnav/Cruise-Target-v0",
    "n_envs": 8,
    "seed": 0,
    "torch_threads": 1,
    "hyperparams": {
        "n_steps": 512,
        "batch_size": 512,
        "n_epochs": 5,
        "gamma": 0.995,
        "gae_lambda": 0.95,
        "learning_rate": 3.0e-4,
        "ent_coef": 0.01,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
    "env": {"episode_steps": 1440, "reward": "covariance"},
}


def bench_sb3(timesteps: int) -> dict[str, float]:
    """Env steps/s of SB3 PPO (:data:`SB3_CONFIG`: 8 envs x 512 steps per update), via
    :func:`planetnav_train.training.train`."""
    tc = parse_config({**SB3_CONFIG, "n_timesteps": timesteps})
    with tempfile.TemporaryDirectory() as tmp:
        _, stats = train(tc, Path(tmp), progress=False)
    return {"steps": stats["timesteps"], "seconds": stats["seconds"], "steps_per_s": stats["steps_per_s"]}


def bench_sweep(num_nodes: int) -> tuple[float, float]:
    """Wall time [s] and summed trial run time [s] of configs/sweep_smoke.yaml (4 trials) on ``num_nodes``
    loopback nodes of 1 CPU each."""
    import ray

    from planetnav_rl.cluster import loopback_cluster
    from planetnav_rl.tune import load_sweep, run_sweep

    sc = load_sweep(ROOT / "configs" / "sweep_smoke.yaml")
    cluster = loopback_cluster(num_nodes=num_nodes, cpus_per_node=1)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            summary = run_sweep(sc, Path(tmp) / "sweep")
            seconds = time.perf_counter() - t0
        nodes = {n for r in summary["rows"] for n in r["nodes_seen"].split()}
        assert len(nodes) == num_nodes, (nodes, num_nodes)
        trial_seconds = sum(float(r["seconds"] or 0.0) for r in summary["rows"])
    finally:
        ray.shutdown()
        cluster.shutdown()
    return seconds, trial_seconds


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--iterations", type=int, default=4, help="timed RLlib iterations of 4096 steps")
    p.add_argument("--sb3-timesteps", type=int, default=20480, help="SB3 steps (5 updates of 4096)")
    p.add_argument("--no-sweep", action="store_true", help="skip the sweep wall times")
    args = p.parse_args()
    # Other work on a shared machine slows everything here: print how busy it was at the start.
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at start", flush=True)
    rows = []
    for n in (1, 2):
        r = bench_rllib(n, args.iterations)
        rows.append((f"RLlib PPO, {n} env runner(s) x {4 // n} envs", r))
        print(
            f"{rows[-1][0]}: {r['steps_per_s']:.0f} env steps/s "
            f"({r['steps']:.0f} steps in {r['seconds']:.1f} s)",
            flush=True,
        )
    r = bench_sb3(args.sb3_timesteps)
    rows.append(("SB3 PPO, 8 envs in one process", r))
    print(
        f"{rows[-1][0]}: {r['steps_per_s']:.0f} env steps/s ({r['steps']:.0f} steps in {r['seconds']:.1f} s)",
        flush=True,
    )
    if not args.no_sweep:
        for n in (1, 2):
            wall, trials = bench_sweep(n)
            print(
                f"sweep_smoke (4 trials) on {n} loopback node(s) x 1 CPU: {wall:.1f} s wall, trials' own run "
                f"times summed {trials:.1f} s (load average before: {os.getloadavg()[0]:.1f})",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
