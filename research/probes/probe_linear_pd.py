"""A linear law on the torque task's observation (issue 18): is the pointing loop representable, and
does the policy's exploration noise swamp it?

``a = kp * (x_body x d) - kd * rates`` with ``d`` the estimated body-frame direction of the observable
planet nearest the boresight and ``rates`` the observation's reported rates [deg/s] (kp = 2, kd = 1.75:
the env's PD gains k_a = 0.02 N m, k_w = 1 N m s in units of the 0.01 N m wheel limit), plus Gaussian
noise of std ``--noise`` [wheel limits] per step, as a PPO policy's. Not a shipped agent: a check that
an MLP on these inputs can express the loop (it stares at the nearest planet: no switching)::

    python research/probes/probe_linear_pd.py --rows 64 --steps 900
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=64)
    ap.add_argument("--steps", type=int, default=900, help="1-s env steps from the reset")
    a = ap.parse_args()

    from planetnav_env.core import layout as L
    from planetnav_train.config import load_config
    from planetnav_train.vec_training import NavTrainingVecEnv

    cfg = load_config(Path(__file__).resolve().parents[2] / "configs" / "torque_control.yaml").env_config()
    lay = L.ObservationLayout.for_config(cfg)
    p0, n_p, n = lay.planets_start, cfg.n_planets, a.rows

    def run(kp: float, kd: float, noise: float) -> tuple[float, float]:
        env = NavTrainingVecEnv(n, cfg, seed=0)
        obs, rng, measured, cos_sum = env.reset(), np.random.default_rng(1), 0.0, 0.0
        for _ in range(a.steps):
            planets = obs[:, p0 : p0 + n_p * L.TARGET_FEATURES].reshape(n, n_p, L.TARGET_FEATURES)
            cos = np.where(planets[:, :, L.TF_OBSERVABLE] > 0.5, planets[:, :, L.TF_DIR], -9.0)
            d = planets[np.arange(n), cos.argmax(1), L.TF_DIR : L.TF_DIR + 3]
            axis = np.stack([np.zeros(n), -d[:, 2], d[:, 1]], axis=1)  # body +x cross d
            rates = obs[:, L.SC_RATES : L.SC_RATES + 3]
            action = kp * axis - kd * rates + rng.normal(0.0, noise, (n, 3))
            obs, _, _, infos = env.step(np.clip(action, -1.0, 1.0))
            measured += np.mean([i["measured"] for i in infos])
            cos_sum += cos.max(1).mean()
        return measured / a.steps, cos_sum / a.steps

    print(f"{a.rows} rows x {a.steps} s from the reset: measured fraction, mean best cos")
    for kp, kd, noise in ((0, 0, 0.22), (2, 1.75, 0), (2, 1.75, 0.05), (2, 1.75, 0.22), (2, 0, 0)):
        m, c = run(kp, kd, noise)
        print(f"kp {kp} kd {kd} noise {noise:.2f}: measured {m:.3f}, mean best cos {c:.3f}")


if __name__ == "__main__":
    main()
