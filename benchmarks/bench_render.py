"""Render speed: rgb_array frames per second beside env steps per second, in the same run.

For each id: the env's step rate (scripted targets, no rendering), then the frame rate of ``env.render()``
with a step between frames (the figure is reused, so the first frame, which builds it, is left out), and the
share of a frame spent building the :class:`~planetnav_env.envs.render.FrameData` versus drawing it.

    python benchmarks/bench_render.py [--frames N] [--steps N] [--id ID ...]

A frame costs as much as thousands of steps: record videos every few hundred steps or episodes, not every
step (gymnasium's ``RecordVideo`` takes an ``episode_trigger``/``step_trigger``).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.envs.render import render_frame, scripted_action

DEFAULT_IDS = ("planetnav/Cruise-Target-v0", "planetnav/MarsApproach-Tasking-v0")


def _step_rate(env_id: str, steps: int) -> float:
    """Env steps per second with the CLI's scripted targets (no rendering)."""
    env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for s in range(50):  # JIT warm-up
        env.step(scripted_action(env.action_space, s, rng))
    t0 = time.perf_counter()
    for s in range(steps):
        _, _, term, trunc, _ = env.step(scripted_action(env.action_space, s, rng))
        if term or trunc:
            env.reset()
    return steps / (time.perf_counter() - t0)


def _frame_rate(env_id: str, frames: int) -> tuple[float, float]:
    """Frames per second of ``env.render()`` (one step between frames, not timed) and the fraction of a
    frame spent in building its FrameData."""
    env = gym.make(env_id, render_mode="rgb_array").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    env.render()  # builds the figure for this beacon layout (once per process)
    t_render = t_data = 0.0
    for s in range(frames):
        _, _, term, trunc, _ = env.step(scripted_action(env.action_space, s, rng, hold=10))
        if term or trunc:
            env.reset()
        t0 = time.perf_counter()
        data = env._frame_data()
        t1 = time.perf_counter()
        render_frame(data)
        t2 = time.perf_counter()
        t_data += t1 - t0
        t_render += t2 - t0
    return frames / t_render, t_data / t_render


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--id", nargs="+", default=list(DEFAULT_IDS))
    args = parser.parse_args()
    print(f"{'id':38s} {'steps/s':>10s} {'frames/s':>9s} {'steps per frame':>16s} {'FrameData share':>16s}")
    for env_id in args.id:
        steps_s = _step_rate(env_id, args.steps)
        frames_s, data_share = _frame_rate(env_id, args.frames)
        print(f"{env_id:38s} {steps_s:10,.0f} {frames_s:9.1f} {steps_s / frames_s:16,.0f} {data_share:16.1%}")


if __name__ == "__main__":
    main()
