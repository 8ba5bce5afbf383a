"""The flight world's camera truth, a magnitude probe: the baseline agent (nearest planet by the estimate)
over whole episodes with and without the camera effects (image-driven errors, the Lambertian centre of
brightness with its onboard correction, oblate planets, the boresight drift), and with each of them off
in turn.

    python research/flight_world/camera_probe.py               # 20 seeds, cruise and Mars approach
    python research/flight_world/camera_probe.py --seeds 8 --scenario cruise

Per world: the true position error at the end [km] (mean over the seeds, with a 95 % bootstrap interval),
the filter's 1-sigma there [km], and the mean NEES over the last half of the episode (3 is consistent).
Seeds 0..N-1, the single env. A probe of the magnitudes, not the issue's 100-seed study.
"""

from __future__ import annotations

import argparse

import numpy as np

from planetnav_agents import make_agent
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS

CAMERA = ("image_errors", "lambert_cob", "oblate_planets", "boresight_drift")
NO_CAMERA = {"preset": "flight", **{k: False for k in CAMERA}}
WORLDS = {
    "matched": "matched",
    "flight without the camera effects": NO_CAMERA,
    "flight": "flight",
    **{f"flight, {k} off": {"preset": "flight", k: False} for k in CAMERA},
    # The centre of brightness uncorrected (onboard corrections off; the light path off too, whose
    # uncorrected bias would swamp it).
    "flight without the light path, no onboard corrections": {
        "preset": "flight", "onboard_corrections": False, "light_time": False, "aberration": False},
}  # fmt: skip
SCENARIOS = {"cruise": "planetnav/Cruise-Target-v2", "mars-approach": "planetnav/MarsApproach-Tasking-v2"}


def episode(env_id: str, world, seed: int) -> tuple[float, float, float]:
    cfg = EnvConfig.from_dict({**ENV_IDS[env_id], "world": world}).at_physics_step()
    env = PlanetNavEnv(cfg)  # the rule agents' interface: one physics step per decision
    agent = make_agent("baseline", env)
    obs, info = env.reset(seed=seed)
    agent.reset(seed=seed)
    nees = []
    done = False
    k = 0
    n = cfg.episode_steps
    while not done:
        obs, _, term, trunc, info = env.step(agent.act(obs, info))
        done = term or trunc
        k += 1
        if k >= n // 2:
            nees.append(info["nees"])
    env.close()
    return float(info["pos_err_km"]), float(info["pos_sigma_km"]), float(np.nanmean(nees))


def interval(x: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    means = rng.choice(x, size=(4000, x.size)).mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--scenario", choices=[*SCENARIOS, "all"], default="all")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    for scenario, env_id in SCENARIOS.items():
        if args.scenario not in ("all", scenario):
            continue
        print(f"\n{scenario} ({env_id}, baseline agent, {args.seeds} seeds)\n")
        print("| world | position error [km] (95 % CI) | filter 1-sigma [km] | NEES (last half) (95 % CI) |")
        print("|---|---|---|---|")
        for name, world in WORLDS.items():
            r = np.array([episode(env_id, world, s) for s in range(args.seeds)])
            lo, hi = interval(r[:, 0], rng)
            nlo, nhi = interval(r[:, 2], rng)
            print(
                f"| {name} | {r[:, 0].mean():.1f} [{lo:.1f}, {hi:.1f}] | {r[:, 1].mean():.1f} "
                f"| {r[:, 2].mean():.2f} [{nlo:.2f}, {nhi:.2f}] |",
                flush=True,
            )


if __name__ == "__main__":
    main()
