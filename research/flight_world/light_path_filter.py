"""The filter in the flight world's light path: light time and stellar aberration in truth, with and without
the onboard corrections, against the matched world.

    python research/flight_world/light_path_filter.py            # 16 seeds per case
    python research/flight_world/light_path_filter.py --seeds 4

Per scenario, a held-target schedule (the cruise: each planet in turn for 80 steps; the Mars approach:
Mars throughout) over one whole episode of the v2 id, on the vector env (row r seeded ``seed + r``). Printed
per world: the true position error at the end [km] (mean over the rows), the filter's 1-sigma there [km],
the mean NEES over the last half of the episode (3 is consistent), the mean NIS of the camera fixes (2 or 3
is consistent, by the measurement model) and the median star-tracker error ["]. A small pilot, not the
issue's 100-seed study with intervals.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.core import layout as L

CASES = {
    "matched": "matched",
    "flight (corrected from the estimate)": "flight",
    "flight, no onboard corrections": {"preset": "flight", "onboard_corrections": False},
    "light time alone, uncorrected": {"light_time": True, "onboard_corrections": False},
    "aberration alone, uncorrected": {"aberration": True, "onboard_corrections": False},
}
SCENARIOS = {"cruise": "planetnav/Cruise-Target-v2", "mars-approach": "planetnav/MarsApproach-Tasking-v2"}


def run(env_id: str, world, seeds: int) -> dict[str, float]:
    venv = gym.make_vec(env_id, num_envs=seeds, world=world)
    steps = venv.unwrapped.config.episode_steps
    venv.reset(seed=100)
    core = venv.unwrapped.core
    approach = "MarsApproach" in env_id
    nees, nis, att = [], [], []
    for k in range(steps - 1):
        target = 0 if approach else (k // 80) % 3
        _, _, _, _, info = venv.step(np.full(seeds, target))
        if k >= steps // 2:
            nees.append(info["nees"])
        att.append(info["attitude_err_arcsec"])
        nis.extend(core.f[np.asarray(info["measured"], bool), L.F_NIS])  # camera fixes: planets targeted
    out = {
        "pos_err_km": float(np.mean(info["pos_err_km"])),
        "sigma_km": float(np.mean(info["pos_sigma_km"])),
        "nees": float(np.nanmean(nees)),
        "nis": float(np.nanmean(nis)) if nis else float("nan"),
        "att_arcsec": float(np.nanmedian(att)),
    }
    venv.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=16)
    args = ap.parse_args()
    for scenario, env_id in SCENARIOS.items():
        print(f"\n{scenario} ({env_id}, {args.seeds} seeds, one episode)\n")
        print(
            "| world | position error [km] | filter 1-sigma [km] | NEES (last half) | NIS of fixes "
            "| star fix [arcsec] |"
        )
        print("|---|---|---|---|---|---|")
        for name, world in CASES.items():
            r = run(env_id, world, args.seeds)
            print(
                f"| {name} | {r['pos_err_km']:.1f} | {r['sigma_km']:.1f} | {r['nees']:.2f} "
                f"| {r['nis']:.2f} | {r['att_arcsec']:.2f} |"
            )


if __name__ == "__main__":
    main()
