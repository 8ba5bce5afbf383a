"""What the flight world measures, against the matched world:
``python research/commands/flight_world_study.py {agents,shares,claims,inflation} [--seeds N] [--json FILE]``.

* ``agents``: per scenario (the four v2 scenarios) and per rule agent (baseline, greedy, planner,
  periodic), the same held-out seeds in the matched and the flight world, with per-step noise streams
  (common random numbers between the worlds): the true position error at the end and over the episode
  [km], the filter's 1-sigma at the end [km], the mean NEES over the episode's second half (6 is
  consistent: the 6-state error), and the mean NIS per degree of freedom of the camera fixes and of the
  pulsar fixes (1 is consistent). Each a mean over the seeds with its 95 % t-interval.
* ``shares``: each effect's share of the flight world's error: the flight world with that one effect
  switched off (set to its matched value), one at a time, for one agent (``--agent``, default baseline);
  the same seeds and noise streams.
* ``claims``: the source documents' claims that the environment can pose (docs/angular_size.md,
  docs/optical_pulsar.md), each a paired comparison of two agents or two settings on the same seeds, in
  the matched and the flight world, with the verdict in each: the claim holds where the paired 95 %
  interval of the difference lies wholly on the claimed side.
* ``inflation``: the filter's process noise that restores consistency in the flight world: the
  white-acceleration PSD ``filter.accel_psd`` swept over decades with ``world.process_noise: filter``
  (the tuned rule's q beside it), reporting NEES and error per value.

The seeds start at :data:`EVAL_SEED`, apart from every seed the project tunes on. ``--json`` writes every
per-episode value beside the summaries.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from research_cli import run

#: The first held-out seed of the study (disjoint from the suite's search, zero and evaluation seeds).
EVAL_SEED = 60_000

#: The scenarios: one v2 id each (the id's options; ``world`` and ``noise_streams`` set by the study).
SCENARIOS = {
    "cruise": "planetnav/Cruise-Target-v2",
    "random-cruise": "planetnav/RandomCruise-Target-v2",
    "mars-approach": "planetnav/MarsApproach-Tasking-v2",
    "thrust-arc": "planetnav/ThrustArc-TCM-v2",
}
AGENTS = ("baseline", "greedy", "planner", "periodic")

#: The NEES of a consistent 6-state filter (its chi-square mean).
NEES_CONSISTENT = 6.0


@dataclass(frozen=True)
class Case:
    """One episode to run: scenario, agent spec, world (a preset name or a mapping), seed, overrides."""

    scenario: str
    agent: str
    world: Any
    seed: int
    extra: tuple[tuple[str, Any], ...] = ()


def _config(case: Case) -> Any:
    from planetnav_env.envs.env import resolve_config

    overrides = {"world": case.world, "noise_streams": "per_step", **dict(case.extra)}

    return resolve_config(SCENARIOS[case.scenario], overrides)


def not_applicable(case: Case) -> str | None:
    """Why ``case.agent`` cannot act in ``case``'s scenario, or None."""
    from planetnav_agents import make_agent
    from planetnav_agents import not_applicable as reason_of
    from planetnav_env.envs.env import PlanetNavEnv

    cfg = _config(case)
    reason = reason_of(case.agent, cfg)
    if reason:
        return reason
    try:
        make_agent(case.agent, PlanetNavEnv(cfg.at_physics_step()))
    except ValueError as exc:  # e.g. a periodic cycle over planets the scenario does not have
        return str(exc)
    return None


def episode(case: Case) -> dict[str, float]:
    """One episode of ``case``: its per-episode values (module docstring)."""
    from planetnav_agents import acts_at_physics_step, make_agent
    from planetnav_env.core import layout as L
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_env.estimation.ekf_kernels import KIND_CODES

    cfg = _config(case)
    if acts_at_physics_step(case.agent):
        cfg = cfg.at_physics_step()
    env = PlanetNavEnv(cfg)
    agent = make_agent(case.agent, env)
    agent.reset(seed=case.seed)
    obs, info = env.reset(seed=case.seed)
    camera_dof = 3 if KIND_CODES[cfg.measurement_model] in (1, 3) else 2
    core = env.unwrapped.core
    err, nees, nis_cam, nis_psr = [], [], [], []
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        err.append(info["pos_err_km"])
        nees.append(info["nees"])
        if info["measured"]:
            nis = float(core.f[0, L.F_NIS])
            (nis_cam if info["sensor"] == "camera" else nis_psr).append(nis)
        if terminated or truncated:
            break
    env.close()
    half = len(nees) // 2
    return {
        "final_err_km": float(err[-1]),
        "mean_err_km": float(np.mean(err)),
        "final_sigma_km": float(info["pos_sigma_km"]),
        "nees": float(np.mean(nees[half:])),
        "nis_camera": float(np.mean(nis_cam) / camera_dof) if nis_cam else math.nan,
        "nis_pulsar": float(np.mean(nis_psr)) if nis_psr else math.nan,
        "objective": float(info["objective"]) if "objective" in info else float(np.mean(err)),
        "diverged": float(terminated),
    }


def run_cases(cases: Sequence[Case], workers: int) -> list[dict[str, float]]:
    """``episode`` of every case, in order, on ``workers`` processes (1: this one)."""
    if workers <= 1:
        return [episode(c) for c in cases]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(episode, cases, chunksize=max(1, len(cases) // (4 * workers))))


def summarize(values: Sequence[dict[str, float]]) -> dict[str, dict[str, float]]:
    """Per key: the mean over the seeds with its 95 % t-interval (NaN entries, e.g. no pulsar fix, left
    out)."""
    from planetnav_train.stats import mean_ci

    out = {}
    for key in values[0]:
        v = np.array([x[key] for x in values], float)
        v = v[np.isfinite(v)]
        if v.size >= 2:
            ci = mean_ci(v)
            out[key] = {"mean": ci.mean, "low": ci.low, "high": ci.high, "n": int(v.size)}
        else:
            out[key] = {"mean": float(v[0]) if v.size else math.nan, "low": math.nan, "high": math.nan,
                        "n": int(v.size)}  # fmt: skip
    return out


def _fmt(s: dict[str, float], digits: int = 1) -> str:
    if not math.isfinite(s["mean"]):
        return "-"
    if not math.isfinite(s["low"]):
        return f"{s['mean']:.{digits}f}"
    return f"{s['mean']:.{digits}f} [{s['low']:.{digits}f}, {s['high']:.{digits}f}]"


def _seeds(args: argparse.Namespace) -> list[int]:
    return list(range(args.seed, args.seed + args.seeds))


def _cases(
    args: argparse.Namespace,
    scenario: str,
    agent: str,
    world: Any,
    extra: tuple = (),
    seeds: int | None = None,
) -> list[Case]:
    """The cases of one cell: ``seeds`` (default ``--seeds``) seeds, with ``--episode-steps`` if given."""
    if args.episode_steps:
        extra = (*extra, ("episode_steps", args.episode_steps))
    return [Case(scenario, agent, world, s, extra) for s in _seeds(args)[:seeds]]


def agents_table(args: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {}
    print("| scenario | agent | world | final error [km] | mean error [km] | final 1-sigma [km] | NEES "
          "| camera NIS / dof | pulsar NIS |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for scenario in args.scenarios:
        for agent in args.agents:
            reason = not_applicable(Case(scenario, agent, "matched", 0))
            if reason:
                print(f"| {scenario} | {agent} | - | not applicable: {reason.splitlines()[0][:60]} |")
                continue
            seeds = args.planner_seeds if agent == "planner" else args.seeds
            for world in ("matched", "flight"):
                t0 = time.perf_counter()
                vals = run_cases(_cases(args, scenario, agent, world, seeds=seeds), args.workers)
                s = summarize(vals)
                out.setdefault(scenario, {}).setdefault(agent, {})[world] = {"summary": s, "episodes": vals}
                print(
                    f"| {scenario} | {agent} | {world} | {_fmt(s['final_err_km'])} "
                    f"| {_fmt(s['mean_err_km'])} | {_fmt(s['final_sigma_km'])} | {_fmt(s['nees'], 2)} "
                    f"| {_fmt(s['nis_camera'], 2)} "
                    f"| {_fmt(s['nis_pulsar'], 2)} |",
                    flush=True,
                )
                print(f"<!-- {len(vals)} seeds in {time.perf_counter() - t0:.0f} s -->", file=sys.stderr)
    return out


def effects_off(scenario: str) -> dict[str, dict[str, Any]]:
    """Each effect of the flight world on ``scenario``, named by its option, as the world mapping that
    switches that effect alone off (:func:`planetnav_env.world.flight_effects`: those the scenario's
    thrust and pulsars concern)."""
    from planetnav_env.world import flight_effects

    cfg = _config(Case(scenario, "baseline", "flight", 0))
    effects = flight_effects(thrust=cfg.operations is not None, pulsars=bool(cfg.pulsars))
    return {name: {"preset": "flight", **off} for name, off in effects.items()}


def shares_table(args: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {}
    print(f"agent: {args.agent}; the flight world with one effect off (paired with the full flight world)\n")
    print("| scenario | world | mean error [km] | final error [km] | NEES | paired change of the mean "
          "error [km] |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    from planetnav_train.stats import paired_difference

    for scenario in args.scenarios:
        variants = {"flight": "flight", **{f"flight, no {k}": w for k, w in effects_off(scenario).items()},
                    "matched": "matched"}  # fmt: skip
        full = None
        for name, world in variants.items():
            vals = run_cases(_cases(args, scenario, args.agent, world), args.workers)
            s = summarize(vals)
            out.setdefault(scenario, {})[name] = {"summary": s, "episodes": vals}
            per = np.array([v["mean_err_km"] for v in vals])
            if full is None:
                full, change = per, "-"
            else:
                change = paired_difference(per, full).format("{:+.1f}")
            print(
                f"| {scenario} | {name} | {_fmt(s['mean_err_km'])} | {_fmt(s['final_err_km'])} "
                f"| {_fmt(s['nees'], 2)} | {change} |",
                flush=True,
            )
    return out


@dataclass(frozen=True)
class Claim:
    """A source's claim as a paired comparison on ``scenario``: agent ``a`` with options ``a_extra`` ends the
    episode with a lower position error than agent ``b`` with ``b_extra`` (the sources compare the error
    after convergence, not the initial transient that dominates a one-day mean)."""

    source: str
    text: str
    scenario: str
    a: str
    b: str
    a_extra: tuple[tuple[str, Any], ...] = ()
    b_extra: tuple[tuple[str, Any], ...] = ()


CLAIMS = (
    Claim("thesis", "direction and size beat direction alone (nearest planet)", "cruise", "baseline",
          "baseline", (("measurement_model", "los+size"),), (("measurement_model", "los"),)),
    Claim("thesis", "switching to the nearest planet beats holding Venus", "random-cruise", "baseline",
          "schedule:targets=venus"),
    Claim("thesis", "switching to the nearest planet beats holding Mars", "random-cruise", "baseline",
          "schedule:targets=mars"),
    Claim("patent", "hybrid (Mars and the pulsars, greedy) beats optical only (Mars held)", "mars-approach",
          "greedy", "schedule:targets=mars"),
    Claim("patent", "hybrid (greedy) beats pulsar only (B1937+21 held)", "mars-approach", "greedy",
          "schedule:targets=B1937+21"),
)  # fmt: skip


def claims_table(args: argparse.Namespace) -> dict[str, Any]:
    from planetnav_train.stats import paired_difference

    out: dict[str, Any] = {}
    print("| source | claim | world | final error, first [km] | final error, second [km] | paired difference "
          "[km] | holds? |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for claim in CLAIMS:
        for world in ("matched", "flight"):
            per = []
            for agent, extra in ((claim.a, claim.a_extra), (claim.b, claim.b_extra)):
                cells = _cases(args, claim.scenario, agent, world, extra)
                per.append(np.array([v["final_err_km"] for v in run_cases(cells, args.workers)]))
            diff = paired_difference(per[0], per[1])
            holds = (
                "yes"
                if diff.high < 0.0
                else ("no: the reverse" if diff.low > 0.0 else "no: within the noise")
            )
            out.setdefault(claim.text, {})[world] = {"first": per[0].tolist(), "second": per[1].tolist()}
            print(
                f"| {claim.source} | {claim.text} | {world} | {per[0].mean():.1f} | {per[1].mean():.1f} "
                f"| {diff.format('{:+.1f}')} | {holds} |",
                flush=True,
            )
    return out


def inflation_table(args: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {}
    print(f"agent: {args.agent}; flight world, world.process_noise: filter, filter.accel_psd swept\n")
    print("| scenario | process noise | mean error [km] | final 1-sigma [km] | NEES |")
    print("|---|---|---|---|---|")
    for scenario in args.scenarios:
        cases = {"tuned (the flight default)": ("flight", ())}
        for q in args.psd:
            cases[f"accel_psd = {q:g} km^2/s^3"] = (
                {"preset": "flight", "process_noise": "filter"},
                (("filter", {"accel_psd": q}),),
            )
        for name, (world, extra) in cases.items():
            vals = run_cases(_cases(args, scenario, args.agent, world, extra), args.workers)
            s = summarize(vals)
            out.setdefault(scenario, {})[name] = {"summary": s, "episodes": vals}
            print(
                f"| {scenario} | {name} | {_fmt(s['mean_err_km'])} | {_fmt(s['final_sigma_km'])} "
                f"| {_fmt(s['nees'], 2)} |",
                flush=True,
            )
    return out


def _check_agents(names: Sequence[str]) -> None:
    """A ConfigError naming an agent spec that names no registered rule agent."""
    from planetnav_agents import AGENTS, OPERATIONS_AGENTS, parse_spec
    from planetnav_env.errors import ConfigError

    known = {*AGENTS, *OPERATIONS_AGENTS}
    for spec in names:
        if parse_spec(spec)[0] not in known:
            raise ConfigError(
                f"flight_world_study: unknown agent {spec!r}; the rule agents are {sorted(known)}"
            )


def study(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    _check_agents([*args.agents, args.agent])
    tables = {
        "agents": agents_table,
        "shares": shares_table,
        "claims": claims_table,
        "inflation": inflation_table,
    }
    table = tables[args.table]
    out = table(args)
    print(f"\n{args.seeds} seeds from {args.seed}, per-step noise streams; {time.perf_counter() - t0:.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps({"table": args.table, "seed": args.seed, "results": out}))
    return 0


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("table", choices=("agents", "shares", "claims", "inflation"))
    ap.add_argument("--seeds", type=int, default=100, help="held-out seeds per cell (default 100)")
    ap.add_argument("--seed", type=int, default=EVAL_SEED, help=f"first seed (default {EVAL_SEED})")
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=list(SCENARIOS))
    ap.add_argument("--agents", nargs="+", default=list(AGENTS), help="agents of the agents table")
    ap.add_argument("--agent", default="baseline", help="the agent of the shares and inflation tables")
    ap.add_argument(
        "--planner-seeds", type=int, default=100, help="seeds of the planner, the slowest agent (default 100)"
    )
    ap.add_argument(
        "--psd",
        type=float,
        nargs="+",
        default=[1e-16, 1e-14, 1e-12, 1e-10, 1e-9, 1e-8],
        help="accel_psd values swept",
    )
    ap.add_argument("--episode-steps", type=int, help="shorter episodes (a smoke run); default: the ids' own")
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--json", help="write every per-episode value here")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    return run(parser(), study, argv)


if __name__ == "__main__":
    raise SystemExit(main())
