"""Bytes of a saved model and of its policy-only export per suite algorithm and task (docs/suite.md,
"Shipped baselines"): which algorithms' best policies can ship as a baseline (under 1 MB,
``planetnav_train.shipped.MAX_BASELINE_BYTES``), as the full model or as the export
(:func:`planetnav_train.export.export_policy`, which also checks the export acts as the model).

Each model is built as ``benchmarks/suite_model_sizes.py`` builds it: the suite's settings of its raw-track
cell (policy and hyper-parameters of ``suite.cell_config``), updated once (so its optimizers hold their
state, as after training), saved by SB3 as training saves it. More training changes the weights, not the
size (the export is deflated float32: trained weights compress no better than these).

    python benchmarks/suite_export_sizes.py
    python benchmarks/suite_export_sizes.py --tasks Cruise-Torque-v0 --algos sac td3 tqc
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from suite_model_sizes import save_cell_model  # the same model build as the full-size table

from planetnav_env.env import PlanetNavEnv
from planetnav_env.errors import ConfigError
from planetnav_train import suite
from planetnav_train.export import export_policy
from planetnav_train.shipped import MAX_BASELINE_BYTES


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=[t.id for t in suite.TASKS], help="task ids (default: all)")
    ap.add_argument("--algos", nargs="+", help="algorithms (default: the tasks' SB3 ones)")
    args = ap.parse_args(argv)
    limit = MAX_BASELINE_BYTES
    with tempfile.TemporaryDirectory() as tmp:
        settings = suite.Settings(out=Path(tmp))
        print("| task | algorithm | obs | full bytes | policy-only bytes | ships as |")
        print("|---|---|---|---|---|---|")
        for name in args.tasks:
            task = suite.get_task(name)
            env = PlanetNavEnv(task.env_config(episode_steps=10))
            for algo in args.algos or suite.ALGOS_BY_KIND[task.action_kind]:
                try:
                    tc, _ = suite.cell_config(suite.Cell(task.id, algo, "raw", 0), settings)
                except ConfigError as exc:  # reported, so one bad cell does not hide the others' sizes
                    print(f"| {task.id} | {algo} | - | - | - | config error: {exc} |")
                    continue
                path = save_cell_model(task, algo, env, tc, Path(tmp))
                full = path.stat().st_size
                small = export_policy(path, path.with_suffix(".policy.zip"), algo).stat().st_size
                form = "full" if full < limit else "policy-only" if small < limit else "none (refused)"
                obs = env.observation_space.shape[0]
                print(f"| {task.id} | {algo} | {obs} | {full:,} | {small:,} | {form} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
