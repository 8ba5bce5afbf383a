"""Every periodic schedule of a grid on the sweep seeds, best first:
``python research/commands/sweep_periodic.py [--periods 10 30 60 ...] [--cycles 0-1 0-1-2 ...] [--episodes N]
[--seed S] [--config X.yaml] [--json J]``.

Runs :func:`planetnav_train.evaluate.sweep_periodic` (target mode only) on seeds from
:data:`planetnav_train.evaluate.SWEEP_SEED` (not the evaluation seeds) and prints the table, paired with the
best setting. The periodic agent's defaults (``agents/periodic.py``, docs/agents.md) are its best setting on
the default cruise.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import run

from planetnav_env.errors import ConfigError
from planetnav_train.cli import add_evaluation_arguments, eval_env_config, write_json
from planetnav_train.config import EVAL_EPISODES
from planetnav_train.evaluate import (
    DEFAULT_SWEEP_CYCLES,
    DEFAULT_SWEEP_PERIODS,
    SWEEP_SEED,
    results_json,
    sweep_periodic,
)
from planetnav_train.provenance import provenance
from planetnav_train.report import print_table


def sweep_command(args: argparse.Namespace) -> int:
    env_cfg, _ = eval_env_config(args, [])
    if env_cfg.action_mode != "target":
        raise ConfigError("sweep-periodic runs in action_mode 'target' (use a target-mode --config)")
    episodes = args.episodes or EVAL_EPISODES
    seed = SWEEP_SEED if args.seed is None else args.seed
    t0 = time.perf_counter()
    results = sweep_periodic(env_cfg, args.periods, args.cycles, episodes, seed, not args.no_progress)
    print_table(
        results,
        title=f"periodic schedules: {episodes} seeds ({seed}..{seed + episodes - 1}), paired with the best",
    )
    best = results[0]
    wall_s = time.perf_counter() - t0
    print(f"best: {best.name} (mean err {best.metrics['mean_pos_err_km']:.1f} km); "
          f"{len(results)} settings in {wall_s:.0f} s")  # fmt: skip
    if args.json:
        write_json(args.json, {**results_json(results), "best": best.name,
                               "provenance": provenance(wall_s=wall_s)})  # fmt: skip
    return 0


def parser() -> argparse.ArgumentParser:
    w = argparse.ArgumentParser(
        prog="sweep-periodic",
        description=f"every periodic schedule of a grid on seeds {SWEEP_SEED}.. (not the evaluation seeds)",
    )
    w.add_argument(
        "--periods", nargs="+", type=int, default=list(DEFAULT_SWEEP_PERIODS), help="steps per planet"
    )
    w.add_argument(
        "--cycles", nargs="+", default=list(DEFAULT_SWEEP_CYCLES), help="planet cycles, e.g. 0-1-2"
    )
    add_evaluation_arguments(w)
    w.add_argument("--no-progress", action="store_true", help="no progress bars")
    return w


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), sweep_command, argv)


if __name__ == "__main__":
    sys.exit(main())
