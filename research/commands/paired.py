"""Paired difference of two evaluations on the same seeds: ``python research/commands/paired.py --a FILE:AGENT
--b FILE:AGENT [--metric pos_err|objective]``.

The evaluations may come from two environments (the same policy in target and target+torque mode) or
two runs of the ``compare`` or ``evaluate --json`` command. Prints the two means [km], the paired
difference (first - second) with its 95 % t-interval (:func:`planetnav_train.stats.paired_difference`), the
per-seed 5 %, 50 % and 95 % quantiles, and the same for the filter's 1-sigma when both files hold it.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import run

from planetnav_env.errors import ConfigError
from planetnav_train.stats import paired_difference


def evaluation_entry(given: str) -> tuple[str, dict[str, Any]]:
    """``FILE:AGENT`` (an ``eval.json`` or a ``--json`` output and one of its agents) -> (agent, metrics)."""
    # Agent names hold colons (ppo:run, periodic:period=10): the file is the shortest prefix that exists.
    cuts = [i for i, ch in enumerate(given) if ch == ":" and Path(given[:i]).is_file()]
    if not cuts or cuts[0] == len(given) - 1:
        raise ConfigError(f"paired: expected FILE:AGENT with an existing evaluation file, got {given!r}")
    path, agent = given[: cuts[0]], given[cuts[0] + 1 :]
    try:
        agents = json.loads(Path(path).read_text())["agents"]
    except (ValueError, KeyError, TypeError):
        raise ConfigError(f"paired: {path!r} is not an evaluation JSON (no 'agents')") from None
    if agent not in agents:
        raise ConfigError(f"paired: no agent {agent!r} in {path}; it has {sorted(agents)}")
    return agent, agents[agent]


def paired(args: argparse.Namespace) -> int:
    (name_a, a), (name_b, b) = evaluation_entry(args.a), evaluation_entry(args.b)
    if (a["seed"], a["episodes"]) != (b["seed"], b["episodes"]):
        raise ConfigError(
            f"paired: the evaluations ran on different seeds: {args.a} on {a['episodes']} from {a['seed']}, "
            f"{args.b} on {b['episodes']} from {b['seed']}"
        )
    # --metric objective: the scenario objective J [km] per episode (evaluate.episode_objective).
    per_key, mean_key, label = (
        ("per_episode_objective", "objective_mean", "objective J")
        if args.metric == "objective"
        else ("per_episode_mean_pos_err_km", "mean_pos_err_km", "mean position error")
    )
    for given, entry in ((args.a, a), (args.b, b)):
        if per_key not in entry:
            raise ConfigError(f"paired: {given} has no {per_key!r} (written before that key existed)")
    diff = paired_difference(a[per_key], b[per_key])
    print(
        f"{label}: {name_a}: {a[mean_key]:.1f} km, {name_b}: {b[mean_key]:.1f} km; paired "
        f"difference (first - second) {diff.format('{:+.1f}')} km on {a['episodes']} seeds from {a['seed']}"
    )
    # Files written before the key existed used the sequential stream.
    streams = (a.get("noise_streams", "sequential"), b.get("noise_streams", "sequential"))
    if streams[0] != streams[1]:
        print(
            f"note: {args.a} drew {streams[0]} noise, {args.b} {streams[1]}: the two share no sensor noise, "
            "so the pairing is by seed only (common random numbers need the same noise streams)"
        )
    per_seed = np.subtract(a[per_key], b[per_key])
    q05, q50, q95 = np.percentile(per_seed, [5, 50, 95])
    print(f"per seed: 5 % quantile {q05:+.1f} km, median {q50:+.1f} km, 95 % quantile {q95:+.1f} km")
    key = "per_episode_mean_pos_sigma_km"
    if key in a and key in b:  # evaluation files written before this key have the error only
        sig = paired_difference(a[key], b[key])
        print(
            f"filter 1-sigma (mean over the day): {a['mean_pos_sigma_km']:.1f} km vs "
            f"{b['mean_pos_sigma_km']:.1f} km; paired difference {sig.format('{:+.1f}')} km"
        )
    return 0


def parser() -> argparse.ArgumentParser:
    pr = argparse.ArgumentParser(
        prog="paired", description="paired difference of two evaluation JSONs on the same seeds"
    )
    pr.add_argument("--a", required=True, help="FILE:AGENT, e.g. runs/x/eval.json:ppo:x")
    pr.add_argument("--b", required=True, help="FILE:AGENT, subtracted from --a")
    pr.add_argument(
        "--metric",
        choices=("pos_err", "objective"),
        default="pos_err",
        help="per-episode value paired: the mean position error (default) or the scenario objective J [km]",
    )
    return pr


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), paired, argv)


if __name__ == "__main__":
    sys.exit(main())
