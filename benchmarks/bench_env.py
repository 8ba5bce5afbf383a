"""Environment speed: steps per second per action mode, beside CartPole-v1 in the same run.

Each mode is driven by the baseline agent (nearest planet by the estimate; PD torques in torque
mode). The agent acts online, as in training; its time is measured apart so that the
environment's own rate is visible beside the rate with the agent.

    python benchmarks/bench_env.py [--steps N]

Target: >= 7,000 steps/s in target mode on this machine, i.e. within 20x of CartPole.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401  (registers the ids)


def _cartpole_rate(steps: int) -> float:
    env = gym.make("CartPole-v1").unwrapped  # no wrappers: the bare simulator, like ours below
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 2, steps)
    t0 = time.perf_counter()
    for a in actions:
        _, _, term, trunc, _ = env.step(int(a))
        if term or trunc:
            env.reset()
    return steps / (time.perf_counter() - t0)


def _planetnav_rate(env_id: str, steps: int) -> tuple[float, float]:
    from planetnav_agents import make_agent

    env = gym.make(env_id).unwrapped
    agent = make_agent("baseline", env)
    obs, info = env.reset(seed=0)
    agent.reset(seed=0)
    for _ in range(50):  # JIT warm-up and the first slew
        obs, _, _, _, info = env.step(agent.act(obs, info))
    t_env = t_agent = 0.0
    for _ in range(steps):
        t0 = time.perf_counter()
        action = agent.act(obs, info)
        t1 = time.perf_counter()
        obs, _, term, trunc, info = env.step(action)
        t2 = time.perf_counter()
        t_agent += t1 - t0
        t_env += t2 - t1
        if term or trunc:
            obs, info = env.reset()
            agent.reset()
    return steps / t_env, steps / (t_env + t_agent)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=5000)
    args = ap.parse_args()
    cart = _cartpole_rate(20 * args.steps)
    print(f"CartPole-v1 (unwrapped): {cart:12,.0f} steps/s")
    print(f"{'environment':<36}{'env steps/s':>14}{'with agent':>14}{'CartPole / env':>16}")
    modes = ("planetnav/Cruise-Target-v0", "planetnav/Cruise-Torque-v0", "planetnav/Cruise-TargetTorque-v0")
    for env_id in modes:
        rate, with_agent = _planetnav_rate(env_id, args.steps)
        print(f"{env_id:<36}{rate:>14,.0f}{with_agent:>14,.0f}{cart / rate:>15.1f}x")
    print("target: >= 7,000 env steps/s in target mode (within 20x of CartPole)")


if __name__ == "__main__":
    main()
