"""What the v1 decision interval costs the best rule: greedy choosing only at the interface's decision
times (every ``decision_steps`` physics steps, holding its choice in between) against greedy choosing at
every physics step (the suite's reference), on the suite's 100 held-out seeds with per-step noise streams.

A learner in the v1 interface cannot do better than the best schedule that interface can express; greedy
held over the decision is one such schedule, so its score is a measured point below that ceiling (not the
ceiling itself: another held schedule may beat it).

    python research/tasks_v1/greedy_at_interface.py --tasks RandomCruise-Target-v1 MarsApproach-Tasking-v1
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from planetnav_agents import make_agent
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_train.stats import mean_ci
from planetnav_train.suite.tasks import get_task


def held_greedy_episode(env: PlanetNavEnv, agent, seed: int, hold: int) -> float:
    """One episode's mean true position error [km]; greedy's choice is taken every ``hold`` steps."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    errors, action, step = [], None, 0
    while True:
        choice = agent.act(obs, info)
        if step % hold == 0:
            action = choice
        obs, _, terminated, truncated, info = env.step(action)
        errors.append(info["pos_err_km"])
        step += 1
        if terminated or truncated:
            return float(np.mean(errors))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", nargs="+", default=["RandomCruise-Target-v1", "MarsApproach-Tasking-v1"])
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--references", default="runs/suite/references", help="the suite's reference JSONs")
    args = ap.parse_args()
    for name in args.tasks:
        task = get_task(name)
        v1 = task.eval_config()
        env = PlanetNavEnv(v1.at_physics_step())
        agent = make_agent("greedy", env)
        seeds = task.eval_seeds[: args.episodes]
        ref_path = Path(args.references) / f"{task.id}.json"
        ref = json.loads(ref_path.read_text()) if ref_path.exists() else None
        for hold in sorted({1, v1.decision_steps}):
            per = np.array([held_greedy_episode(env, agent, s, hold) for s in seeds])
            ci = mean_ci(per)
            m = ci.mean
            line = f"{task.id} | greedy, choosing every {hold} physics step(s) | {ci.format('{:.2f}')} km"
            if ref is not None and len(seeds) == task.eval_episodes:
                score = (ref["J_zero"] - m) / (ref["J_zero"] - ref["J_best"])
                line += f" | score {score:.3f} (zero {ref['J_zero']:.2f}, best {ref['J_best']:.2f} km)"
            print(line, flush=True)


if __name__ == "__main__":
    main()
