"""Mean true position error [km] and its 95 % half-width of agents on a task with extra options, per-step
noise, on N seeds from SEED: the probe behind docs/tasks_v2.md's centroid-bias paragraph.

    python research/tasks_v2/probe_events.py planetnav/Cruise-Target-v1 12 60000 \
        '{"world": {"centroid_bias_max": 1.0}, "observe_residual_log": true}' \
        greedy greedy:bias=expected greedy:bias=oracle schedule:targets=1-2,steps=20 \
        schedule:targets=0-1-2,steps=30 schedule:targets=0-2,steps=20
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.evaluate import evaluate_agent


def main(env_id: str, episodes: int, seed: int, options: dict, specs: list[str]) -> None:
    cfg = EnvConfig.from_dict({**ENV_IDS[env_id], "noise_streams": "per_step", **options})
    for spec in specs:
        t = time.time()
        v = np.asarray(evaluate_agent(spec, cfg, episodes, seed, progress=False).metrics[
            "per_episode_mean_pos_err_km"])  # fmt: skip
        half = 1.96 * v.std(ddof=1) / np.sqrt(v.size)
        print(f"{spec:48s} {v.mean():9.2f} +- {half:7.2f}  ({time.time() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), json.loads(sys.argv[4]), sys.argv[5:])
