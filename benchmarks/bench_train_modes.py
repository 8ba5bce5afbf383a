"""Training throughput per action mode: environment steps per second of PPO training (environment and
learning together, ``model.learn``) on the native vector env against SB3's DummyVecEnv of single envs,
same run, plus the training env alone (seeded random actions, no learning).

    python benchmarks/bench_train_modes.py                    # configs/torque.yaml, 2 PPO updates per path
    python benchmarks/bench_train_modes.py --quick            # 1 short update per path (~1 min)
    python benchmarks/bench_train_modes.py --config configs/target_torque.yaml --n-envs 8 32
    python benchmarks/bench_train_modes.py --config configs/torque_control.yaml old.yaml --quick  # 2 configs
    python benchmarks/bench_train_modes.py --config configs/torque_control.yaml --profile  # where time goes

Several configs (or ``--n-envs`` values) are timed in the same run, so that they share the machine's load;
each line also prints this process's CPU time over the wall time of its PPO runs (below 1: other processes
took the CPU) and the load average, since the rates on a shared machine scale with both.

Both paths run the same option layers (``planetnav_train.batch_wrappers``: the torque recipe's
``pd_torque`` feature and pointing shaping included), which ``tests/train/test_vec_training.py`` holds equal:
the native path steps all rows in one compiled loop with the options on arrays; the DummyVecEnv path
(``vec_env: dummy``, what torque modes trained on before: a Python env object per row, options computed
one row at a time) runs them with N = 1 per env. The target is >= 20,000 env steps/s of torque-mode PPO
training on the native path. The rate counts physics steps (decisions x the env's ``decision_steps``).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from bench_train import rate

from planetnav_train.config import TrainConfig, load_config
from planetnav_train.envs import make_training_env


def env_rate(tc: TrainConfig, vec_env: str, decisions: int) -> float:
    """Environment steps/s of the training VecEnv alone: ``decisions`` steps of seeded random actions."""
    tc.vec_env = vec_env
    venv = make_training_env(tc, None)
    venv.action_space.seed(0)
    actions = np.stack([venv.action_space.sample() for _ in range(venv.num_envs)])
    venv.reset()
    steps = decisions // venv.num_envs
    t = time.perf_counter()
    for _ in range(steps):
        venv.step(actions)
    elapsed = time.perf_counter() - t
    venv.close()
    return steps * venv.num_envs * tc.env_config().decision_steps / elapsed


def config(path: str, n_envs: int | None, quick: bool) -> TrainConfig:
    """The training config of ``path`` with ``n_envs`` rows (None: the file's); ``quick``: rollouts of at
    most 128 steps (a config's shorter ones are kept)."""
    tc = load_config(path)
    if n_envs is not None:
        tc.n_envs = n_envs
    if quick:
        n_steps = min(int(tc.hyperparams.get("n_steps", 2048)), 128)
        tc.hyperparams["n_steps"] = n_steps
        tc.hyperparams["batch_size"] = min(int(tc.hyperparams.get("batch_size", 64)), n_steps * tc.n_envs)
    return tc


def timed_rate(tc: TrainConfig, vec_env: str, decisions: int) -> tuple[float, float]:
    """(env steps/s of PPO training, this process's CPU seconds / wall seconds) on the ``vec_env`` path."""
    cpu, wall = time.process_time(), time.perf_counter()
    steps_per_s = rate(tc, vec_env, decisions)
    return steps_per_s, (time.process_time() - cpu) / (time.perf_counter() - wall)


def profile(tc: TrainConfig, decisions: int) -> dict[str, float]:
    """Microseconds per environment step of native-path PPO training, split by ``cProfile`` into the
    environment stack (``VecEnv.step``: compiled step, option layers, adapter, ``VecMonitor``), the rest of
    the rollout (policy forward pass, rollout buffer, callbacks) and the update (``PPO.train``), over
    ``decisions`` decisions after one warm-up update."""
    import cProfile
    import pstats

    import torch

    from planetnav_train.algorithms import algo_kwargs
    from planetnav_train.sb3 import algorithm_class

    torch.set_num_threads(tc.torch_threads)
    venv = make_training_env(tc, None)
    model = algorithm_class(tc.algo)(
        tc.policy, venv, seed=tc.seed, device="cpu", verbose=0, **algo_kwargs(tc)
    )
    model.learn(total_timesteps=int(tc.hyperparams.get("n_steps", 2048)) * tc.n_envs)  # warm-up
    prof = cProfile.Profile()
    prof.enable()
    model.learn(total_timesteps=decisions)
    prof.disable()
    venv.close()
    cum = {f"{Path(k[0]).name}:{k[2]}": v[3] for k, v in pstats.Stats(prof).stats.items()}  # type: ignore[attr-defined]
    steps = model.num_timesteps * tc.env_config().decision_steps
    rollout, env = cum["on_policy_algorithm.py:collect_rollouts"], cum["base_vec_env.py:step"]
    return {
        "environment stack": 1e6 * env / steps,
        "rest of the rollout": 1e6 * (rollout - env) / steps,
        "update": 1e6 * cum["ppo.py:train"] / steps,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", nargs="+", default=["configs/torque.yaml"], help="one or more configs")
    ap.add_argument("--updates", type=int, default=2, help="PPO rollouts + updates timed per path")
    ap.add_argument("--n-envs", type=int, nargs="*", default=[None], help="rows (default: the config's)")
    ap.add_argument("--quick", action="store_true", help="one 128-step rollout + update per path")
    ap.add_argument(
        "--profile", action="store_true", help="only the native path, its time per env step split by cProfile"
    )
    args = ap.parse_args()
    updates = 1 if args.quick else args.updates
    if args.profile:
        print(
            "| config | env rows | n_steps, batch, epochs | us per env step: environment stack "
            "| rest of the rollout | update | total (profiled) |"
        )
        print("|---|---|---|---|---|---|---|")
        for path_cfg in args.config:
            for n_envs in args.n_envs:
                tc = config(path_cfg, n_envs, args.quick)
                hp = tc.hyperparams
                us = profile(tc, updates * int(hp.get("n_steps", 2048)) * tc.n_envs)
                cells = " | ".join(f"{v:.1f}" for v in us.values())
                print(
                    f"| {path_cfg} | {tc.n_envs} | {hp.get('n_steps')}, {hp.get('batch_size')}, "
                    f"{hp.get('n_epochs', 10)} | {cells} | {sum(us.values()):.1f} |",
                    flush=True,
                )
        print(f"load average {', '.join(f'{x:.1f}' for x in os.getloadavg())} over {os.cpu_count()} CPUs")
        return
    print(
        "| config | env rows | n_steps, batch, epochs | training env | PPO env steps/s (env + learning) "
        "| CPU / wall | env alone | ratio to the first DummyVecEnv line |"
    )
    print("|---|---|---|---|---|---|---|---|")
    # Warm-up of both paths: compile the kernels (the serial and the threaded step, the single env's) and
    # build torch's caches outside the timing; without it the first path timed pays seconds of compiling.
    for warm_rows in (1, 16, 256):
        for path in ("native", "dummy"):
            tc = config(args.config[0], warm_rows, True)
            tc.hyperparams.update(n_steps=8, batch_size=8 * warm_rows, n_epochs=1)
            rate(tc, path, 8 * warm_rows)
    base = None
    for path_cfg in args.config:
        for n_envs in args.n_envs:
            tc = config(path_cfg, n_envs, args.quick)
            hp = tc.hyperparams
            decisions = updates * int(hp.get("n_steps", 2048)) * tc.n_envs
            for path in ("dummy", "native"):
                ppo, cpu = timed_rate(config(path_cfg, n_envs, args.quick), path, decisions)
                alone = env_rate(config(path_cfg, n_envs, args.quick), path, decisions)
                base = base or ppo
                names = {"native": "native vector env", "dummy": "DummyVecEnv of single envs"}
                print(
                    f"| {path_cfg} | {tc.n_envs} | {hp.get('n_steps')}, {hp.get('batch_size')}, "
                    f"{hp.get('n_epochs', 10)} | {names[path]} | {ppo:,.0f} | {cpu:.2f} | {alone:,.0f} "
                    f"| {ppo / base:.2f}x |",
                    flush=True,
                )
    print(
        f"{updates} PPO update(s) of n_steps x n_envs decisions per path; load average "
        f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} over {os.cpu_count()} CPUs at the end. "
        "Target: native torque-mode PPO training >= 20,000 env steps/s."
    )


if __name__ == "__main__":
    main()
