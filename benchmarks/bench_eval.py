"""Evaluation throughput: a saved SB3 policy on a suite task's evaluation seeds, one episode at a time (single
envs, ``evaluate_agent(..., batched=False)``) against the seeds as rows of the native vector env
(``batched=True``, one ``model.predict`` per decision for all rows), in the same run.

The policy is a randomly initialised PPO ``MlpPolicy`` (SB3's default 64x64 network; the rate does not
depend on what it learned), saved as ``train.py`` saves a run. Each task runs at the suite's evaluation
configuration (``Task.eval_config``: full episodes, per-step noise streams, the suite's seeds). The single
path runs the first ``--single`` seeds, the batched paths ``--batched`` seeds (the suite's 100): ``batched``
is the default (``exact_actions=True``: a continuous policy predicts row by row), and for a continuous
policy ``batched-fast`` predicts all rows in one call (``exact_actions=False``). ``single-sampled`` and
``batched-sampled`` score the sampled actions (``PATH@sampled``, the protocol's mode for PPO), the speed-up
of the latter against the former, and ``fast-sampled`` a continuous policy's with ``exact_actions=False``.
On the seeds every path ran it prints each batched path's largest relative difference of the per-episode
objective J from its single path's (0 expected for ``batched`` and ``batched-sampled``; float rounding
amplified by the episode for ``batched-fast``: ``planetnav_train.evaluate``).

    nice -n 10 .venv/bin/python benchmarks/bench_eval.py [--tasks Cruise-Target-v0 Cruise-TorqueControl-v0]
        [--single 3] [--batched 100]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_train.evaluate import evaluate_agent
from planetnav_train.sb3 import algorithm_class
from planetnav_train.suite import get_task
from planetnav_train.vec_training import NavTrainingVecEnv


def save_policy(run: Path, env_cfg: object) -> Path:
    """A randomly initialised PPO on ``env_cfg`` saved as ``run/model.zip`` with its ``config.yaml``."""
    model = algorithm_class("ppo")("MlpPolicy", NavTrainingVecEnv(2, env_cfg, seed=0), seed=0, device="cpu")
    run.mkdir(parents=True)
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo"}))
    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=["Cruise-Target-v0", "Cruise-TorqueControl-v0"])
    ap.add_argument("--single", type=int, default=3, help="episodes one at a time (the slow path)")
    ap.add_argument("--batched", type=int, default=100, help="episodes as vector-env rows (the suite's 100)")
    args = ap.parse_args()
    if args.single < 1 or args.batched < args.single:
        raise SystemExit(f"need 1 <= --single <= --batched, got {args.single} and {args.batched}")
    print(
        f"{'task':26s} {'path':15s} {'episodes':>8s} {'steps/s':>9s} {'episodes/s':>10s} {'speed-up':>8s} "
        f"{'diverged':>8s}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.tasks:
            task = get_task(name)
            cfg = task.eval_config()
            run = save_policy(Path(tmp) / name, cfg)
            evaluate_agent(str(run), cfg, 1, task.eval_seed, progress=False)  # compile / load once
            rates = {}
            res = {}
            # (path, episodes, batched, exact_actions, agent spec, the single path it is compared with)
            argmax, sampled = str(run), f"{run}@sampled"
            paths = [("single", args.single, False, True, argmax, "single"),
                     ("batched", args.batched, True, True, argmax, "single")]  # fmt: skip
            if cfg.action_mode != "target":  # a continuous policy (Box actions)
                paths.append(("batched-fast", args.batched, True, False, argmax, "single"))
            # Sampled actions (the protocol's mode for PPO): each row draws from its own generator state.
            paths += [("single-sampled", args.single, False, True, sampled, "single-sampled"),
                      ("batched-sampled", args.batched, True, True, sampled, "single-sampled")]  # fmt: skip
            if cfg.action_mode != "target":
                paths.append(("fast-sampled", args.batched, True, False, sampled, "single-sampled"))
            for path, n, batched, exact, spec, ref in paths:
                t0 = time.perf_counter()
                res[path] = evaluate_agent(
                    spec, cfg, n, task.eval_seed, progress=False, batched=batched, exact_actions=exact
                )
                wall = time.perf_counter() - t0
                # Nominal steps: a diverged episode ends early (the last column counts them).
                steps = n * cfg.episode_steps
                rates[path] = steps / wall
                speed = f"{rates[path] / rates[ref]:7.1f}x"
                print(
                    f"{name:26s} {path:15s} {n:8d} {steps / wall:9.0f} {n / wall:10.3f} {speed:>8s} "
                    f"{res[path].metrics['diverged']:8d}"
                )
            for path, *_, ref in paths:
                if path == ref:
                    continue
                one = np.asarray(res[ref].metrics["per_episode_objective"])
                many = np.asarray(res[path].metrics["per_episode_objective"][: args.single])
                diff = float(np.max(np.abs(many - one) / np.abs(one)))
                print(
                    f"{name:26s} {path} vs {ref}: largest relative J difference, first {args.single} "
                    f"seeds: {diff:.2e}"
                )


if __name__ == "__main__":
    main()
