"""Training throughput: environment steps per second of the training loop of ``train.py`` (environment and
learning together), on the native vector env against SB3's DummyVecEnv of wrapped single envs, same run.

    python benchmarks/bench_train.py                          # the default config, 2 PPO updates each
    python benchmarks/bench_train.py --config configs/random_cruise_ppo.yaml --updates 1

Both paths train the same MDP (``tests/train/test_vec_training.py``) with the same hyperparameters and seed;
each is timed over whole PPO rollouts + updates (``model.learn``), after a warm-up that compiles the
kernels. The figure that matters is the ratio native / dummy of the default run.
"""

from __future__ import annotations

import argparse
import time

from planetnav_train.algorithms import algo_kwargs
from planetnav_train.config import TrainConfig, load_config
from planetnav_train.envs import make_training_env
from planetnav_train.sb3 import algorithm_class


def rate(tc: TrainConfig, vec_env: str, decisions: int) -> float:
    """Environment steps/s of ``decisions`` policy decisions of training on the ``vec_env`` path."""
    import torch

    tc.vec_env = vec_env
    torch.set_num_threads(tc.torch_threads)
    venv = make_training_env(tc, None)
    model = algorithm_class(tc.algo)(
        tc.policy, venv, seed=tc.seed, device="cpu", verbose=0, **algo_kwargs(tc)
    )
    t = time.perf_counter()
    model.learn(total_timesteps=decisions)
    elapsed = time.perf_counter() - t
    venv.close()
    return model.num_timesteps * tc.env_config().decision_steps / elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/cruise_ppo.yaml")
    ap.add_argument("--updates", type=int, default=2, help="PPO rollouts + updates timed per path")
    args = ap.parse_args()
    tc = load_config(args.config)
    per_update = int(tc.hyperparams.get("n_steps", 2048)) * tc.n_envs
    decisions = args.updates * per_update
    k = tc.env_config().decision_steps
    # Warm-up: compile the kernels and build torch's graph caches outside the timing.
    rate(load_config(args.config), "native", per_update)
    native = rate(load_config(args.config), "native", decisions)
    dummy = rate(load_config(args.config), "dummy", decisions)
    print(
        f"{args.config}: {tc.n_envs} envs, decision_steps {k}, {decisions} decisions "
        f"({decisions * k} physics steps) per path"
    )
    print("| training env | env steps/s (env + learning) | ratio |")
    print("|---|---|---|")
    print(f"| DummyVecEnv of wrapped single envs | {dummy:,.0f} | 1.00x |")
    print(f"| native vector env (planetnav_train.vec_training) | {native:,.0f} | {native / dummy:.2f}x |")
    print("Target: native >= 2x the DummyVecEnv path of the default run.")


if __name__ == "__main__":
    main()
