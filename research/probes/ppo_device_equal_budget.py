"""Does the device PPO's loop score like the suite's PPO at the suite's budget? Measured on the CPU, where
the loop runs on the device env's host mode (its bank, autoreset and torch views, the thread functions the
GPU runs compiled for the CPU) and on the native vector env.

    python research/probes/ppo_device_equal_budget.py [--seeds 0 1 2 3 4] [--envs host native]
        [--suite-json docs/benchmark.json MORE.json] [--json RUNS.json | --from-json RUNS.json]

Each run is ``baselines/ppo_device.py --device cpu`` with the suite's PPO settings for
planetnav/Cruise-Target-v2 (64 envs x 64 decisions an update, 4 minibatches, 5 epochs, 300,000 decisions:
the suite's 3M physics steps; one torch thread), trained from scratch and scored as the suite scores it
(sampled actions on seeds 50,000..50,099, per-step noise streams, blind-zero scale): once with the suite's
draws (each evaluation episode's sampling seeded with its seed, as the suite's evaluator seeds it, so every
run here and every suite run shares them), and once with the run's own draws, independent across runs.
It prints each run's scores, whether the
host mode trained the same policy as the native env (the same J on every evaluation seed: the host mode's
rows equal the native env's, so with no substitute from the bank they should), and the interquartile mean
of the training seeds with its stratified-bootstrap interval beside the suite's PPO (Stable-Baselines3's
PPO, the same settings: its runs in the suite JSONs given), with P(device loop > suite PPO). Training is
not the same on every CPU (torch picks its kernels for the CPU), so a rerun elsewhere gives other scores
within the seeds' spread.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "baselines"))  # ppo_device and ppo_single_file, imported where used
TASK = "Cruise-Target-v2"
#: The suite's evaluation seeds (the single file's: 50,000..50,099).
EVAL_SEEDS = list(range(50_000, 50_100))
#: A run's own draws: stream ``OWN_STREAM * (training seed + 1)`` (each episode's generator is seeded with
#: the stream plus its evaluation seed; the suite's draws are stream 0).
OWN_STREAM = 1_000_000


def suite_ppo_scores(paths: list[Path]) -> list[float]:
    """The suite's PPO runs on :data:`TASK` in the suite JSONs ``paths`` (docs/benchmark.json, or what
    the suite command's ``--json`` writes), their scores in the suite's evaluation mode; a training seed found
    in two files counts once."""
    by_seed: dict[int, float] = {}
    for path in paths:
        for r in json.loads(path.read_text())["runs"]:
            if r["task"] == TASK and r["algorithm"] == "ppo" and r["track"] == "raw":
                by_seed.setdefault(r["seed"], r["normalized_score"])
    if not by_seed:
        raise SystemExit(f"{', '.join(map(str, paths))}: no PPO run on {TASK}")
    return [by_seed[s] for s in sorted(by_seed)]


def train_and_score(env: str, seed: int, total: int) -> dict:
    """One training run and its scores: with the suite's draws (the single file's evaluation: shared by
    every run) and with the run's own draws (:data:`OWN_STREAM`: independent across runs)."""
    import ppo_device
    import ppo_single_file as single

    from planetnav_train.suite.blind import paired_ratio_ci

    argv = ["--device", "cpu", "--env", env, "--env-id", f"planetnav/{TASK}", "--num-envs", "64",
            "--num-steps", "64", "--num-minibatches", "4", "--update-epochs", "5",
            "--total-timesteps", str(total), "--seed", str(seed), "--eval-episodes", "100",
            "--torch-threads", "1"]  # fmt: skip
    out = ppo_device.main(argv)
    args = ppo_device.parse_args(argv)
    sampled = single.sampled_policy(out["agent"], EVAL_SEEDS, stream=OWN_STREAM * (seed + 1))
    j_own = single.evaluate(sampled, single.eval_config(args), EVAL_SEEDS)
    own = paired_ratio_ci(out["J_blind"], out["J_best"], j_own)
    keep = ("score", "score_lo", "score_hi", "train_seconds")
    return {"env": env, "seed": seed, "J": out["J"].tolist(), **{k: out[k] for k in keep},
            "J_own_stream": j_own.tolist(), "score_own_stream": own["score"]}  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    p.add_argument("--envs", nargs="+", choices=("host", "native"), default=["host", "native"])
    p.add_argument("--total-timesteps", type=int, default=300_000)
    p.add_argument("--suite-json", type=Path, nargs="+", default=[ROOT / "docs" / "benchmark.json"],
                   help="suite JSONs whose PPO runs on the task are the reference (more seeds: the suite "
                   "command with --tasks Cruise-Target-v2 --algos ppo --seeds 5 6 ... --json F)")  # fmt: skip
    p.add_argument("--json", type=Path, default=None, help="write the runs here")
    p.add_argument("--from-json", type=Path, default=None,
                   help="train nothing: compare the runs that a previous --json wrote")  # fmt: skip
    args = p.parse_args(argv)

    from planetnav_train.suite.scoring import improvement_probabilities, iqm_intervals

    if args.from_json:
        runs = json.loads(args.from_json.read_text())
        args.envs = list(dict.fromkeys(r["env"] for r in runs))
        args.seeds = sorted({r["seed"] for r in runs})
    else:
        runs = [train_and_score(env, s, args.total_timesteps) for env in args.envs for s in args.seeds]
    if args.json:
        args.json.write_text(json.dumps(runs, indent=1))
    suite = suite_ppo_scores(args.suite_json)

    print(f"\n{TASK}, {args.total_timesteps} decisions, blind-zero score [95 % paired bootstrap]:")
    for r in runs:
        own = f", own draws {r['score_own_stream']:+.3f}" if "score_own_stream" in r else ""
        print(f"  device loop, {r['env']:6s} env, seed {r['seed']}: {r['score']:+.3f} [{r['score_lo']:+.3f}, "
              f"{r['score_hi']:+.3f}]{own}  ({r['train_seconds']:.0f} s)")  # fmt: skip
    print(f"  suite PPO, {len(suite)} runs: " + ", ".join(f"{s:+.3f}" for s in suite))
    if {"host", "native"} <= set(args.envs):
        by = {(r["env"], r["seed"]): np.asarray(r["J"]) for r in runs}
        both = [s for s in args.seeds if ("host", s) in by and ("native", s) in by]
        same = [s for s in both if np.array_equal(by["host", s], by["native", s])]
        print(f"host mode and native env trained the same policy (equal J on all 100 seeds) for "
              f"{len(same)} of {len(both)} training seeds")  # fmt: skip

    matrices = {"suite PPO": np.asarray(suite)[:, None]}
    for env in args.envs:
        matrices[f"device loop ({env})"] = np.asarray([r["score"] for r in runs if r["env"] == env])[:, None]
    if all("score_own_stream" in r for r in runs):
        for env in args.envs:
            own = [r["score_own_stream"] for r in runs if r["env"] == env]
            matrices[f"device loop ({env}), own draws"] = np.asarray(own)[:, None]
    for name, v in iqm_intervals(matrices).items():
        print(f"IQM {name:35s} {v['iqm']:+.3f} [{v['low']:+.3f}, {v['high']:+.3f}]")
    pairs = {(n, "suite PPO"): (m, matrices["suite PPO"]) for n, m in matrices.items() if n != "suite PPO"}
    for v in improvement_probabilities(pairs):
        print(f"P({v['x']} > {v['y']}) = {v['probability']:.2f} [{v['low']:.2f}, {v['high']:.2f}]")


if __name__ == "__main__":
    main()
