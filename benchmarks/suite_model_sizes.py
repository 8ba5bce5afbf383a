"""Bytes of a saved model per suite algorithm and task (docs/suite.md, "Publishing"): which algorithms' models
can ship as a baseline (under 1 MB, ``planetnav_train.shipped.MAX_BASELINE_BYTES``). Each model is built
with the suite's settings of its raw-track cell (policy and hyper-parameters of ``suite.cell_config``),
updated once (so its optimizers hold their state), and saved by SB3 as training saves it (networks, target
networks and optimizer state; no replay buffer). More training changes the weights, not the size.

    python benchmarks/suite_model_sizes.py
    python benchmarks/suite_model_sizes.py --tasks Cruise-Target-v0 --algos ppo dqn
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import Any

from planetnav_env.env import PlanetNavEnv
from planetnav_env.errors import ConfigError
from planetnav_train import suite
from planetnav_train.sb3 import algorithm_class
from planetnav_train.shipped import MAX_BASELINE_BYTES


def save_cell_model(task: suite.Task, algo: str, env: PlanetNavEnv, tc: Any, folder: Path) -> Path:
    """Build ``algo`` with the suite cell's settings ``tc`` on ``env``, update it once (so its optimizers
    hold their state, Adam's moments: 2x the weights, as after training; an untrained model saves empty
    optimizer state) and save it as training does; the zip's path."""
    hp = dict(tc.hyperparams)
    if "train_freq" in hp or algo == "dqn":
        hp["buffer_size"] = 1_000  # not saved; the default 10^6 rows would only take memory
        hp["learning_starts"] = 0  # an update within the few steps below
    model = algorithm_class(algo)(tc.policy, env, seed=0, **hp)
    model.learn(getattr(model, "n_steps", 8) * model.n_envs)
    path = folder / f"{task.id}__{algo}.zip"
    model.save(path)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=["Cruise-Target-v0", "Cruise-Torque-v0"], help="task ids")
    ap.add_argument("--algos", nargs="+", help="algorithms (default: the tasks' SB3 ones)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        settings = suite.Settings(out=Path(tmp))
        print("| task | algorithm | bytes | ships (< 1 MB) |\n|---|---|---|---|")
        for name in args.tasks:
            task = suite.get_task(name)
            env = PlanetNavEnv(task.env_config(episode_steps=10))
            for algo in args.algos or suite.ALGOS_BY_KIND[task.action_kind]:
                try:
                    tc, _ = suite.cell_config(suite.Cell(task.id, algo, "raw", 0), settings)
                except ConfigError as exc:  # reported, so one bad cell does not hide the others' sizes
                    print(f"| {task.id} | {algo} | - | config error: {exc} |")
                    continue
                path = save_cell_model(task, algo, env, tc, Path(tmp))
                size = path.stat().st_size
                print(f"| {task.id} | {algo} | {size:,} | {'yes' if size < MAX_BASELINE_BYTES else 'no'} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
