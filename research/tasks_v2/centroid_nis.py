"""Does the residual log find a centroid-biased planet? Four episodes of Cruise-Target-v1 with
``world: {centroid_bias_max: 1}`` and a blind Venus-Mars-Earth schedule (30 steps each): per planet the
drawn bias scale, the mean offset of its images [arcsec], the residual log's mean normalized NIS at the
end, and the final true error and filter 1-sigma [km].

    python research/tasks_v2/centroid_nis.py
"""

from __future__ import annotations

import numpy as np

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS

ARCSEC = np.pi / 180.0 / 3600.0


def main() -> None:
    options = {
        **ENV_IDS["planetnav/Cruise-Target-v1"], "world": {"centroid_bias_max": 1.0},
        "observe_residual_log": True,
    }  # fmt: skip
    env = PlanetNavEnv(EnvConfig.from_dict(options).at_physics_step())
    for seed in range(60_000, 60_004):
        obs, info = env.reset(seed=seed)
        offsets: dict[int, list[float]] = {0: [], 1: [], 2: []}
        for k in range(1440):
            obs, _, _, _, info = env.step((k // 30) % 3)
            if info["sensor"] == "camera":
                offsets[info["target_index"]].append(env.core.f[0, L.F_COB_LAST] / ARCSEC)
        nis = env.decode_observation(obs)["residual_log"] * 10.0
        print(
            f"seed {seed}: scale {np.round(env.core.true_centroid_bias()[0], 2)}, mean offset [arcsec] "
            f"{[round(float(np.mean(v)), 2) for v in offsets.values()]}, "
            f"mean normalized NIS {np.round(nis, 2)}, "
            f"error {info['pos_err_km']:.0f} km, 1-sigma {info['pos_sigma_km']:.0f} km"
        )


if __name__ == "__main__":
    main()
