"""An event's strength swept from 0 (the v1 physics) upward:
``python research/commands/regime_map.py --task ID --event NAME --strengths S ... --agents A ...
--candidates C ... [--json J] [--plot P]``.

At each strength, the best blind schedule of the candidates (two-stage search), the agents (nominal,
adaptive and oracle rules, any trained agent) with 95 % intervals of the mean J [km]
(:func:`planetnav_train.suite.blind.regime_map`); JSON and one figure
(:func:`planetnav_train.suite.blind.plot_regime_map`). The maps of docs/tasks_v2.md were made with it.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import option_pair, run

from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_train.cli import write_json
from planetnav_train.provenance import provenance
from planetnav_train.suite import blind as B

#: The events swept: the options at a strength (0 = the v1 physics), the axis label. The centroid bias
#: and the pulsar timing error are effects of the world (``world.<name>``).
REGIME_EVENTS: dict[str, tuple[Callable[[float], dict], str]] = {
    "image_success_min": (
        lambda s: {"image_success_min": 1.0 - s}, "1 - image_success_min (largest failure probability)"
    ),
    "centroid_bias_max": (
        lambda s: {"world": {"centroid_bias_max": s}}, "world.centroid_bias_max (largest bias scale)"
    ),
    "pulsar_frequency_error_max": (
        lambda s: {"world": {"pulsar_frequency_error_max": s}},
        "world.pulsar_frequency_error_max (largest delta nu / nu)",
    ),
}


def regime_map(args: argparse.Namespace) -> int:
    from planetnav_env.envs.registration import ENV_IDS

    env_id = args.task if args.task.startswith("planetnav/") else f"planetnav/{args.task}"
    if env_id not in ENV_IDS:
        raise ConfigError(f"regime-map: unknown task {args.task!r}; the ids are {sorted(ENV_IDS)}")
    if args.event not in REGIME_EVENTS:
        raise ConfigError(f"regime-map: --event must be one of {sorted(REGIME_EVENTS)}, got {args.event!r}")
    options_of, xlabel = REGIME_EVENTS[args.event]

    def cfg_for(strength: float) -> EnvConfig:
        return EnvConfig.from_dict(
            {**ENV_IDS[env_id], **dict(args.option or []), **options_of(strength)},
            noise_streams="per_step",
        )

    evaluate = B.evaluate_objective
    t0 = time.perf_counter()
    data = B.regime_map(
        cfg_for, args.strengths, args.agents, args.candidates, evaluate, args.search_seed,
        args.search_episodes, args.seed, args.episodes, args.finalists, args.final_episodes,
    )  # fmt: skip
    wall_s = time.perf_counter() - t0
    data.update(task=env_id, event=args.event, options=dict(args.option or []), wall_s=wall_s,
                provenance=provenance(wall_s=wall_s))  # fmt: skip
    for p in data["points"]:
        print(f"strength {p['strength']:.3g}: blind {p['blind']}")
        for spec, row in p["agents"].items():
            print(f"  {spec:40s} {row['mean']:9.2f} [{row['lo']:.2f}, {row['hi']:.2f}] km")
    if args.json:
        write_json(args.json, data)
    if args.plot:
        B.plot_regime_map(data, f"{env_id.split('/')[1]}: {args.event}", xlabel, args.plot)
        print(f"wrote {args.plot}")
    return 0


def parser() -> argparse.ArgumentParser:
    rm = argparse.ArgumentParser(
        prog="regime-map",
        description="an event's strength swept: the best blind schedule and the rules at each point",
    )
    rm.add_argument("--task", required=True, help="task id, e.g. Cruise-Target-v2")
    rm.add_argument("--event", default="image_success_min", help=", ".join(REGIME_EVENTS))
    rm.add_argument("--strengths", nargs="+", type=float, default=[0.0, 0.25, 0.5, 0.75, 1.0],
                    help="0 = the v1 physics; image failures: 1 - image_success_min")  # fmt: skip
    rm.add_argument("--agents", nargs="+", required=True, help="agents to score at every point")
    rm.add_argument("--candidates", nargs="+", required=True, help="blind schedules searched at every point")
    rm.add_argument("--search-seed", type=int, default=B.BLIND_SEARCH_SEED)
    rm.add_argument("--search-episodes", type=int, default=20)
    rm.add_argument("--finalists", type=int, default=3)
    rm.add_argument("--final-episodes", type=int, default=60, help="second-stage seeds (0: one stage)")
    rm.add_argument("--seed", type=int, default=50_000)
    rm.add_argument("--episodes", type=int, default=30)
    rm.add_argument("--option", action="append", type=option_pair, metavar="KEY=VALUE")
    rm.add_argument("--json", help="write the points here")
    rm.add_argument("--plot", help="write the figure here (PNG)")
    return rm


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), regime_map, argv)


if __name__ == "__main__":
    sys.exit(main())
