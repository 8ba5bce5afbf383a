"""How often a trained policy picks another planet than a teacher on the policy's own states:
``python research/commands/agreement.py --student RUN --teacher SPEC [--episodes N] [--seed S] [--json J]``.

Plays the student (a training run directory or model .zip) and asks the teacher (an agent spec or another
run) at every decision (:func:`planetnav_train.pretrain.agreement`); prints the share of decisions where the
planets differ and, in target+torque mode, the mean absolute residual torque (fraction of the action range).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import run

from planetnav_env.errors import ConfigError
from planetnav_train.cli import add_evaluation_arguments, eval_env_config, write_json
from planetnav_train.provenance import provenance


def agreement_command(args: argparse.Namespace) -> int:
    from planetnav_train.pretrain import agreement

    env_cfg, ev = eval_env_config(args, [args.student])
    episodes = args.episodes or 5
    seed = ev.seed if args.seed is None else args.seed
    t0 = time.perf_counter()
    try:
        got = agreement(args.student, env_cfg, args.teacher, episodes, seed)
    except ValueError as exc:
        raise ConfigError(f"agreement: {exc}") from None
    residual = got["mean_abs_residual"]
    print(
        f"{args.student} vs {args.teacher} on {episodes} episodes from seed {seed}: another planet at "
        f"{100 * got['different']:.1f} % of {got['decisions']} decisions"
        + (f"; mean |residual torque| {residual:.4f} of the action range" if math.isfinite(residual) else "")
    )
    if args.json:
        if not math.isfinite(residual):
            got["mean_abs_residual"] = None  # target mode: no residual torque (JSON has no NaN)
        write_json(args.json, {"student": args.student, "teacher": args.teacher, "episodes": episodes,
                               "seed": seed, **got,
                               "provenance": provenance(wall_s=time.perf_counter() - t0)})  # fmt: skip
    return 0


def parser() -> argparse.ArgumentParser:
    ag = argparse.ArgumentParser(
        prog="agreement", description="how often a trained policy picks another planet than a teacher"
    )
    ag.add_argument("--student", required=True, help="a training run directory or model .zip")
    ag.add_argument("--teacher", required=True, help="an agent spec or another run (it labels the states)")
    add_evaluation_arguments(ag)
    return ag


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), agreement_command, argv)


if __name__ == "__main__":
    sys.exit(main())
