"""Probe: an elongated prior (sigma_long along a random direction per episode, sigma_short across) on a
target task, by patching the reset; mean true position error [km] per agent on N seeds from SEED.

    python research/tasks_v2/probe_prior_shape.py planetnav/Cruise-Target-v1 12 60000 3000 100 \
        greedy schedule:targets=0-1-2,steps=20

``search`` as the first agent runs the suite's blind search (smaller: 20 + 30 seeds) and scores its winner.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.config import EnvConfig
from planetnav_env.core import kernels as K
from planetnav_env.core import layout as L
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.evaluate import evaluate_agent

_ORIG = K.reset_rows


def patched(s_long: float, s_short: float):
    def reset_rows(prm, st, rows):
        for r in rows:
            x = st.f[r, L.F_X : L.F_X + 3]
            g = np.random.default_rng(np.frombuffer(x.tobytes(), dtype=np.uint32).tolist())
            u = g.normal(size=3)
            u /= np.linalg.norm(u)
            prr = s_short**2 * np.eye(3) + (s_long**2 - s_short**2) * np.outer(u, u)
            st.f[r, L.F_XE : L.F_XE + 3] = x + np.linalg.cholesky(prr) @ g.normal(size=3)
            st.p[r, :3, :3] = prr
        _ORIG(prm, st, rows)

    return reset_rows


def main(env_id, episodes, seed, s_long, s_short, specs):
    K.reset_rows = patched(s_long, s_short)
    cfg = EnvConfig.from_dict({**ENV_IDS[env_id], "noise_streams": "per_step"})
    if specs[:1] == ["search"]:
        # The two-stage blind search of the suite (20 seeds from 40,000, the best 3 on 30 more) first.
        from planetnav_train.suite import blind as B

        res = B.search_blind(cfg, B.evaluate_objective, 40_000, 20, finalists=3, final_episodes=30)
        print(f"blind search winner {res.winner} ({res.winner_mean:.2f} km on its second-stage seeds)")
        specs = [res.winner, *specs[1:]]
    for spec in specs:
        t = time.time()
        res = evaluate_agent(spec, cfg, episodes, seed, progress=False)
        v = np.asarray(res.metrics["per_episode_mean_pos_err_km"])
        half = 1.96 * v.std(ddof=1) / np.sqrt(v.size)
        print(f"{spec:48s} {v.mean():9.2f} +- {half:7.2f}  ({time.time() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    a = sys.argv
    main(a[1], int(a[2]), int(a[3]), float(a[4]), float(a[5]), a[6:])
