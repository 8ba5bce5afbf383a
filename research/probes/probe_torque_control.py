"""Short PPO probes of the issue-18 pure-RL torque task, with the measured fraction of every 4 rollouts.

``train.py train`` logs the training episodes' measured fraction only when an episode ends (every
3,600 env steps x 256 rows = 0.92 M env steps at the shipped setting); this driver builds the same
training env and algorithm from a config (``planetnav_train.envs.make_training_env``,
``planetnav_train.algorithms.algo_kwargs``) and prints, every 4 rollouts, the fraction of the rollouts'
decisions whose last env step measured, the policy's mean std and decisions/s. Runs H7-H17, H19-H21 of
research/training_log.md (issue 18) were made with it::

    python research/probes/probe_torque_control.py configs/torque_control.yaml --steps 3e6 \\
        --set env.decision_steps=4 hyperparams.n_epochs=10 "shaping={}" --dense 0.2

``--set KEY=YAML`` overrides a config entry (dotted keys: ``env.reward_scale_km=1e5``). Two
probe-only rewards, both NOT potential-based (reported as shaping): ``--bonus B`` adds B [reward units]
per decision whose last env step measured; ``--dense C`` adds C x max cos(boresight, observable planet)
of each decision's new observation (the shipped ``shaping: {pointing_bonus: W}`` adds it every env
step, so C = W x decision_steps). ``--dense-final C1`` anneals C linearly to C1 over the run.
``--save DIR`` keeps the model and its config for ``train.py compare --agents DIR``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import yaml


def _override(tc: Any, key: str, value: Any) -> None:
    """Set ``tc.a.b = value`` for ``key = "a.b"`` (attributes, then dict entries)."""
    obj, parts = tc, key.split(".")
    for p in parts[:-1]:
        obj = obj[p] if isinstance(obj, dict) else getattr(obj, p)
        if obj is None:
            raise SystemExit(f"--set {key}: {p} is not set in the config")
    if isinstance(obj, dict):
        obj[parts[-1]] = value
    else:
        setattr(obj, parts[-1], value)


class InfoWeightedPotential:
    """``weight * max_p w_p cos_p`` over the observable planets, ``w_p = (s_p / max s) ** power`` with
    ``s_p`` the planet's position 1-sigma across its line of sight [km] from the observation (column
    ``TF_LOG_SIGMA``: log10(km) / 4): probe only, a designed reward (reported as shaping)."""

    def __init__(self, cfg: Any, weight: float, power: float) -> None:
        from planetnav_env.core import layout as L

        self.weight, self.power, self.L = weight, power, L
        self.start, self.n = L.ObservationLayout.for_config(cfg).planets_start, cfg.n_planets

    def __call__(self, obs: Any) -> np.ndarray:
        L = self.L
        x = np.asarray(obs, dtype=float)
        p = x[:, self.start : self.start + self.n * L.TARGET_FEATURES].reshape(len(x), self.n, -1)
        vis = p[:, :, L.TF_OBSERVABLE] > 0.5
        log_s = np.where(vis, 4.0 * p[:, :, L.TF_LOG_SIGMA], -np.inf)
        w = 10.0 ** (self.power * (log_s - np.max(log_s, axis=1, keepdims=True, initial=-np.inf)))
        score = np.where(vis, w * p[:, :, L.TF_DIR], -np.inf)
        return np.where(vis.any(axis=1), self.weight * np.max(score, axis=1, initial=-np.inf), 0.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config")
    ap.add_argument("--steps", type=float, default=3e6, help="decisions (SB3 timesteps)")
    ap.add_argument("--set", nargs="*", default=[], help="KEY=YAML overrides, dotted keys")
    ap.add_argument("--bonus", type=float, default=0.0, help="reward per measured decision")
    ap.add_argument("--dense", type=float, default=0.0, help="x max cos of the new observation, per decision")
    ap.add_argument(
        "--info",
        type=float,
        help="weight the --dense bonus per planet by (its 1-sigma across the line of sight / the largest "
        "of the observable planets') ** INFO: a designed reward toward the planet a measurement helps most",
    )
    ap.add_argument("--dense-final", type=float, help="anneal --dense linearly to this by the last step")
    ap.add_argument("--save", help="save the model (model.zip) and its config.yaml into this directory")
    a = ap.parse_args()

    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecEnvWrapper

    from planetnav_train.algorithms import algo_kwargs, policy_class
    from planetnav_train.config import load_config
    from planetnav_train.envs import make_training_env
    from planetnav_train.sb3 import algorithm_class
    from planetnav_train.shaping import PointingPotential

    tc = load_config(a.config)
    for kv in a.set:
        key, value = kv.split("=", 1)
        _override(tc, key, yaml.safe_load(value))
    torch.set_num_threads(tc.torch_threads)
    venv = make_training_env(tc, None)
    potential = PointingPotential(tc.env_config(), a.dense) if a.dense else None
    if potential is not None and a.info is not None:
        potential = InfoWeightedPotential(tc.env_config(), a.dense, a.info)

    class Probe(VecEnvWrapper):
        """The probe-only rewards (module docstring)."""

        def reset(self) -> Any:
            return self.venv.reset()

        def step_wait(self) -> Any:
            obs, reward, done, infos = self.venv.step_wait()
            if a.bonus:
                reward = reward + a.bonus * np.array([bool(i.get("measured", False)) for i in infos])
            if potential is not None:  # the new state: the terminal observation where a row ended
                if a.dense_final is not None:  # linear anneal over the run (a curriculum on the bonus)
                    done_frac = min(1.0, log.num_timesteps / a.steps) if log.model is not None else 0.0
                    potential.weight = a.dense + (a.dense_final - a.dense) * done_frac
                new = np.array([i.get("terminal_observation", obs[k]) for k, i in enumerate(infos)])
                reward = reward + potential(new)
            return obs, reward.astype(np.float32), done, infos

    if a.bonus or a.dense:
        venv = Probe(venv)

    class Log(BaseCallback):
        def _on_training_start(self) -> None:
            self.measured = self.seen = self.rollouts = 0
            self.t0 = time.perf_counter()

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                self.measured += bool(info.get("measured", False))
                self.seen += 1
            return True

        def _on_rollout_end(self) -> None:
            self.rollouts += 1
            if self.rollouts % 4 == 0:
                std = float(torch.exp(self.model.policy.log_std.detach()).mean())
                rate = self.num_timesteps / (time.perf_counter() - self.t0)
                frac = self.measured / max(self.seen, 1)
                print(f"{self.num_timesteps:>9d} meas {frac:.4f} std {std:.3f} {rate:.0f} sps", flush=True)
                self.measured = self.seen = 0

    log = Log()
    log.model = None
    model = algorithm_class(tc.algo)(
        policy_class(tc), venv, seed=tc.seed, device="cpu", verbose=0, **algo_kwargs(tc)
    )
    t0 = time.perf_counter()
    model.learn(int(a.steps), callback=log)
    print(f"done {time.perf_counter() - t0:.0f} s")
    if a.save:
        from pathlib import Path

        out = Path(a.save)
        out.mkdir(parents=True, exist_ok=True)
        model.save(out / "model.zip")
        with open(out / "config.yaml", "w") as fh:  # SB3Agent reads the run's env and features from it
            yaml.safe_dump(tc.to_dict(), fh, sort_keys=False)


if __name__ == "__main__":
    main()
