"""The spread of a trained policy's figure over training runs: a 95 % prediction interval for a new run.

Training with torch is not bit-reproducible across CPUs (its kernels, like BLAS, are chosen for the CPU),
so a fresh clone's ``make run`` on another machine trains another policy, even with the same seed. A
trained figure is therefore quoted with the spread of independent runs: the configuration is trained with
``n >= 5`` seeds, each policy is evaluated on the configuration's held-out seeds (argmax and sampled
actions), and a new run's figure is expected in

    mean +- t(0.975, n - 1) * sd * sqrt(1 + 1 / n)

19 times in 20 (the prediction interval of one more draw from a normal sample; ``sd`` the runs' sample
standard deviation). ``python train.py spread --config CONFIG --seeds 0 1 2 3 4`` prints it; runs already
trained in ``--out`` are reused, so a killed spread continues where it stopped.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scipy import stats as sps

#: The two evaluation modes of a trained policy and the suffix of its agent spec.
MODES = {"argmax": "", "sampled": "@sampled"}


@dataclass(frozen=True)
class PredictionInterval:
    """Mean, sample standard deviation and the 95 % prediction interval [lo, hi] of one more run."""

    n: int
    mean: float
    sd: float
    lo: float
    hi: float


def prediction_interval(values: Sequence[float], level: float = 0.95) -> PredictionInterval:
    """The ``level`` prediction interval of one more draw from the normal sample ``values`` (n >= 2)."""
    x = [float(v) for v in values]
    n = len(x)
    if n < 2 or not all(math.isfinite(v) for v in x):
        raise ValueError(f"a prediction interval needs at least 2 finite values, got {x}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    mean = sum(x) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in x) / (n - 1))
    half = float(sps.t.ppf(0.5 + level / 2.0, n - 1)) * sd * math.sqrt(1.0 + 1.0 / n)
    return PredictionInterval(n=n, mean=mean, sd=sd, lo=mean - half, hi=mean + half)


def run_spread(
    config: str | Path, seeds: Sequence[int], out: Path, episodes: int | None = None, progress: bool = True
) -> dict[str, Any]:
    """Train ``config`` once per seed into ``out/seed<S>/`` (kept if its model exists), evaluate each policy
    in both modes on the configuration's held-out seeds, and return the per-run figures with their
    prediction intervals; also written to ``out/spread.json``."""
    from planetnav_train.config import load_config
    from planetnav_train.evaluate import evaluate_agent, evaluation_env
    from planetnav_train.provenance import provenance
    from planetnav_train.training import train

    if len(set(seeds)) < 2 or any(s < 0 for s in seeds):
        raise ValueError(f"--seeds needs at least 2 distinct seeds >= 0, got {list(seeds)}")
    base = load_config(config)
    env_cfg = evaluation_env(base.env_config(), base.eval.episode_steps, base.eval.noise_streams)
    n_episodes = episodes or base.eval.episodes
    t0 = time.perf_counter()
    runs = []
    for seed in seeds:
        tc = load_config(config)
        tc.seed = int(seed)
        run_dir = out / f"seed{seed}"
        model = run_dir / "model.zip"
        if not model.exists():
            train(tc, run_dir, progress=progress)
        row: dict[str, Any] = {"seed": int(seed), "model": str(model)}
        for mode, suffix in MODES.items():
            res = evaluate_agent(f"{model}{suffix}", env_cfg, n_episodes, base.eval.seed, progress)
            row[mode] = float(res.metrics["mean_pos_err_km"])
        runs.append(row)
        print(f"seed {seed}: argmax {row['argmax']:.1f} km, sampled {row['sampled']:.1f} km")
    result = {
        "config": str(config),
        "eval_seed": base.eval.seed,
        "eval_episodes": n_episodes,
        "runs": runs,
        "intervals": {m: prediction_interval([r[m] for r in runs]).__dict__ for m in MODES},
        # this invocation's: runs trained by an earlier one (their model kept) were evaluated here only
        "provenance": provenance(wall_s=time.perf_counter() - t0),
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "spread.json").write_text(json.dumps(result, indent=2))
    return result


def format_spread(result: dict[str, Any]) -> str:
    """The table ``train.py spread`` prints: one line per mode with mean, sd and the interval."""
    lines = [
        f"{result['config']}: {len(result['runs'])} training runs, each on {result['eval_episodes']} "
        f"held-out seeds from {result['eval_seed']} (mean position error, km)",
        "| mode | per run | mean | sd | 95 % prediction interval for a new run |",
        "|---|---|---|---|---|",
    ]
    for mode, pi in result["intervals"].items():
        per_run = ", ".join(f"{r[mode]:.1f}" for r in result["runs"])
        interval = f"[{pi['lo']:.1f}, {pi['hi']:.1f}]"
        lines.append(f"| {mode} | {per_run} | {pi['mean']:.1f} | {pi['sd']:.1f} | {interval} |")
    return "\n".join(lines)
