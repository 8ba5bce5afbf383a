"""``optimum`` on planetnav/ThrustArc-TCM-v0 (research/operations_log.md §3.5, §7.3): per held-out seed, its
predicted J (the covariance model's, at reset) beside the env's realised ``info["objective"]``
(``reward: covariance``, per-step noise streams), the relative difference, the sessions it played
(start step, planet index, steps), the schedule evaluations and the search's CPU time.

    NUMBA_CACHE_DIR=/tmp/nb_opt nice -n 10 .venv/bin/python research/operations/check_optimum.py --episodes 5
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from planetnav_agents import make_agent
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_train.config import load_config
from planetnav_train.evaluate import evaluation_env

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--agent", default="optimum", help="an optimum spec, e.g. optimum:session=12,grid=6")
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--seed", type=int, default=10000, help="first held-out seed")
    args = ap.parse_args()
    cfg = load_config(ROOT / "configs" / "operations" / "thrust_arc_tcm.yaml")
    env = PlanetNavEnv(evaluation_env(cfg.env_config(), None, "per_step"))
    worst = 0.0
    for seed in range(args.seed, args.seed + args.episodes):
        agent = make_agent(args.agent, env)
        agent.reset(seed=seed)
        obs, info = env.reset(seed=seed)
        t0 = time.process_time()
        action = agent.act(obs, info)  # the search runs at the first decision
        cpu = time.process_time() - t0
        done = False
        while not done:
            obs, _, term, trunc, info = env.step(action)
            done = term or trunc
            if not done:
                action = agent.act(obs, info)
        pred, real = agent.predicted_objective_km, float(info["objective"])
        rel = (pred - real) / real
        worst = max(worst, abs(rel))
        print(
            f"seed {seed}  predicted J {pred:9.2f} km  env J {real:9.2f} km  rel {rel:+.1e}  "
            f"evaluations {agent.evaluations}  search cpu {cpu:4.1f} s  sessions {agent.sessions}",
            flush=True,
        )
    print(f"largest |relative difference| {worst:.1e}")


if __name__ == "__main__":
    main()
