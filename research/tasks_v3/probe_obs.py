"""Probe: per-column range of the raw observation of the v2 tasks in the flight world (uniform random
actions, 16 seeds from 70,000): which columns a learner sees far from order 1."""

from __future__ import annotations

import sys

import numpy as np

from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.tasks import get_version

IDS = sys.argv[1:] or [
    "Cruise-Target-v2",
    "RandomCruise-Target-v2",
    "MarsApproach-Tasking-v2",
    "ThrustArc-TCM-v2",
    "Cruise-Torque-v2",
]
for env_id in IDS:
    cfg = get_version(env_id).config(world="flight")
    env = PlanetNavVectorEnv(16, cfg, autoreset_mode="disabled")
    obs, _ = env.reset(seed=70_000)
    rng = np.random.default_rng(0)
    rows = [obs]
    done = np.zeros(16, bool)
    while not done.all():
        a = (
            env.action_space.sample()
            if cfg.action_mode != "target"
            else rng.integers(0, env.single_action_space.n, 16)
        )
        r, term, trunc = env.step_rows(a, ~done)
        done |= term | trunc
        rows.append(env.observations())
    o = np.concatenate(rows)
    print(env_id, o.shape)
    for name, a, b, _ in env.layout.blocks:
        seg = o[:, a:b]
        print(f"  {name:22s} min {seg.min(0).round(2)} max {seg.max(0).round(2)} std {seg.std(0).round(2)}")
    env.close()
