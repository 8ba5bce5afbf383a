"""Training throughput per action mode: environment steps per second of PPO training (environment and
learning together, ``model.learn``) on the native vector env against SB3's DummyVecEnv of single envs,
same run, plus the training env alone (seeded random actions, no learning).

    python benchmarks/bench_train_modes.py                    # configs/torque.yaml, 2 PPO updates per path
    python benchmarks/bench_train_modes.py --quick            # 1 short update per path (~1 min)
    python benchmarks/bench_train_modes.py --config configs/target_torque.yaml --n-envs 8 32

Both paths run the same option layers (``planetnav_agents.batch_wrappers``: the torque recipe's
``pd_torque`` feature and pointing shaping included), which ``tests/test_vec_training.py`` holds equal:
the native path steps all rows in one compiled loop with the options on arrays; the DummyVecEnv path
(``vec_env: dummy``, what torque modes trained on before: a Python env object per row, options computed
one row at a time) runs them with N = 1 per env. Issue 18 asks for >= 20,000 env steps/s of torque-mode PPO
training on the native path. The rate counts environment steps (decisions x ``action_repeat``).
"""

from __future__ import annotations

import argparse
import time

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
    return steps * venv.num_envs * tc.action_repeat / elapsed


def config(path: str, n_envs: int | None, quick: bool) -> TrainConfig:
    """The training config of ``path`` with ``n_envs`` rows (None: the file's); ``quick``: 128-step
    rollouts."""
    tc = load_config(path)
    if n_envs is not None:
        tc.n_envs = n_envs
    if quick:
        tc.hyperparams["n_steps"] = 128
        tc.hyperparams["batch_size"] = min(int(tc.hyperparams.get("batch_size", 64)), 128 * tc.n_envs)
    return tc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/torque.yaml")
    ap.add_argument("--updates", type=int, default=2, help="PPO rollouts + updates timed per path")
    ap.add_argument("--n-envs", type=int, nargs="*", default=[None], help="rows (default: the config's)")
    ap.add_argument("--quick", action="store_true", help="one 128-step rollout + update per path")
    args = ap.parse_args()
    updates = 1 if args.quick else args.updates
    print("| config | env rows | training env | PPO env steps/s (env + learning) | env alone | ratio |")
    print("|---|---|---|---|---|---|")
    for n_envs in args.n_envs:
        tc = config(args.config, n_envs, args.quick)
        per_update = int(tc.hyperparams.get("n_steps", 2048)) * tc.n_envs
        decisions = updates * per_update
        # Warm-up: compile the kernels and build torch's caches outside the timing.
        rate(config(args.config, n_envs, args.quick), "native", per_update)
        results = {}
        for path in ("native", "dummy"):
            ppo = rate(config(args.config, n_envs, args.quick), path, decisions)
            alone = env_rate(config(args.config, n_envs, args.quick), path, decisions)
            results[path] = (ppo, alone)
        base = results["dummy"][0]
        names = {"native": "native vector env", "dummy": "DummyVecEnv of single envs"}
        for path in ("dummy", "native"):
            ppo, alone = results[path]
            row = f"| {args.config} | {tc.n_envs} | {names[path]} | {ppo:,.0f} | {alone:,.0f} |"
            print(f"{row} {ppo / base:.2f}x |")
    print(
        f"{updates} PPO update(s) of n_steps x n_envs decisions per path, action_repeat {tc.action_repeat}. "
        "Target (issue 18): native torque-mode PPO training >= 20,000 env steps/s."
    )


if __name__ == "__main__":
    main()
