"""The best blind policy of each task, then the closed-loop gap and the blind-zero scores:
``python research/commands/blind_search.py --tasks ID ... [--json J] [--option KEY=VALUE ...]``.

For each task: the two-stage search over blind (open-loop) policies on the search seeds
(:func:`planetnav_train.suite.blind.search_blind`), then the winner beside the references and any other
agents on the evaluation seeds (:func:`planetnav_train.suite.blind.measure_task`): each mean J [km] with
its 95 % interval, the closed-loop gap and each agent's blind-zero score. ``--json`` writes (or adds to)
the file; the suite's blind zeros are ``docs/tasks_v2_blind.json``, written by this command (docs/suite.md
"Score and aggregation", docs/tasks_v2.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import option_pair, run

from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_train.cli import write_json
from planetnav_train.provenance import provenance
from planetnav_train.suite import blind as B


def blind_search(args: argparse.Namespace) -> int:
    from planetnav_env.envs.registration import ENV_IDS

    evaluate = B.evaluate_objective
    out: dict[str, Any] = {"search_seed": args.search_seed, "eval_seed": args.seed, "tasks": {}}
    if args.json and Path(args.json).exists():
        out = json.loads(Path(args.json).read_text())  # add to an earlier run's tasks
    for name in args.tasks:
        env_id = name if name.startswith("planetnav/") else f"planetnav/{name}"
        if env_id not in ENV_IDS:
            raise ConfigError(f"blind-search: unknown task {name!r}; the ids are {sorted(ENV_IDS)}")
        cfg = EnvConfig.from_dict({**ENV_IDS[env_id], **dict(args.option or [])}, noise_streams="per_step")
        t0 = time.perf_counter()
        res = B.search_blind(
            cfg, evaluate, args.search_seed, args.search_episodes,
            progress=None if args.no_progress else lambda s, j: print(f"  {s:48s} {j:10.2f}", flush=True),
            finalists=args.finalists, final_episodes=args.final_episodes,
        )  # fmt: skip
        refs, privileged = B.default_references(cfg)
        refs = tuple(args.references) if args.references is not None else refs
        privileged = tuple(args.privileged) if args.privileged is not None else privileged
        rec = B.measure_task(cfg, res, refs, privileged, evaluate, args.seed, args.episodes, args.agents)
        rec["options"] = dict(args.option or [])
        rec["wall_s"] = time.perf_counter() - t0
        rec["provenance"] = provenance(wall_s=rec["wall_s"])
        g = rec["closed_loop_gap"]
        print(f"{env_id}: blind {rec['blind_winner']} {rec['J_blind']:.2f} km "
              f"(search {res.winner_mean:.2f}), "
              f"best {rec['best_reference']} {rec['J_best']:.2f} km; closed-loop gap {100 * g['gap']:.1f} % "
              f"[{100 * g['gap_lo']:.1f}, {100 * g['gap_hi']:.1f}]")  # fmt: skip
        for spec, row in rec["agents"].items():
            print(f"  {row['role']:10s} {spec:48s} {row['mean']:9.2f} [{row['lo']:.2f}, {row['hi']:.2f}] km  "
                  f"score {row['score']:+.2f} [{row['score_lo']:+.2f}, {row['score_hi']:+.2f}]")  # fmt: skip
        key = env_id.split("/", 1)[1] + "".join(f" {k}={v}" for k, v in sorted(rec["options"].items()))
        out["tasks"][key] = rec
        if args.json:
            write_json(args.json, out)
    return 0


def parser() -> argparse.ArgumentParser:
    bs = argparse.ArgumentParser(
        prog="blind-search",
        description=f"the best blind policy of each task (search seeds {B.BLIND_SEARCH_SEED}..), then the "
        "closed-loop gap and blind-zero scores on the evaluation seeds",
    )
    bs.add_argument("--tasks", nargs="+", required=True, help="task ids, e.g. Cruise-Target-v2")
    bs.add_argument("--search-seed", type=int, default=B.BLIND_SEARCH_SEED)
    bs.add_argument("--search-episodes", type=int, default=B.BLIND_SEARCH_EPISODES)
    bs.add_argument("--finalists", type=int, default=B.FINALISTS)
    bs.add_argument("--final-episodes", type=int, default=B.FINAL_EPISODES,
                    help="second-stage seeds for the finalists (0: one stage)")  # fmt: skip
    bs.add_argument("--seed", type=int, default=50_000, help="first evaluation seed (the suite's)")
    bs.add_argument("--episodes", type=int, default=100, help="evaluation episodes")
    bs.add_argument("--references", nargs="+",
                    help="non-privileged references (the best is the score's 1); default: the task's "
                    "(nominal and adaptive greedy where an event is drawn, the suite's references on the "
                    "torque and operations tasks)")  # fmt: skip
    bs.add_argument("--privileged", nargs="*", help="oracles (reported only); default: the event's oracle")
    bs.add_argument("--agents", nargs="*", default=[], help="more agents to score (e.g. a trained model)")
    bs.add_argument("--option", action="append", type=option_pair, metavar="KEY=VALUE",
                    help="an option over the id's (image_success_min=0.5), repeatable")  # fmt: skip
    bs.add_argument("--json", help="write (or add to) this JSON")
    bs.add_argument("--no-progress", action="store_true")
    return bs


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), blind_search, argv)


if __name__ == "__main__":
    sys.exit(main())
