"""The flight world's attitude loop, measured: per scenario, in the flight and the matched world, over N
seeds with 95 % intervals of the mean (Student t):

    python research/commands/attitude_tables.py                 # 100 seeds, every scenario
    python research/commands/attitude_tables.py --seeds 20 --scenarios cruise
    python research/commands/attitude_tables.py --references --seeds 20   # the torque tasks' references

Columns: momentum dumps per day and the delta-v they spent [m/s per day] (the nominal impulses), the
share of the episode a wheel spent at 99 % of its momentum capacity (and, on the thrust arc, the share the
engine was off for dumps, printed below the table), the camera's true pointing error
against the PD law's direction (each seed's median over the steps the PD law points; arcsec), and the
navigation error that follows (the true position error at the episode's end [km]). Each scenario runs its
v2 id under a fixed schedule (the same actions in both worlds): the targets in turn, each held 60 physics
steps; on the thrust arc one imaging decision in 12, else the mission attitude. Rows are the seeds
``seed0 .. seed0 + N - 1`` of one vector env per world. ``--references``: the wheel-torque tasks' rule
references (greedy executed by the PD law on ``Cruise-TorqueControl-v1``, the planner on
``Cruise-Torque-v2``) in both worlds, the mean position error over the episode [km]
(``planetnav_train.evaluate.evaluate_agent``, the same seeds).
"""

from __future__ import annotations

import argparse

import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.core import layout as L
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_train.stats import mean_ci

#: scenario -> the v2 id it runs.
SCENARIOS = {
    "cruise": "Cruise-Target-v2",
    "random-cruise": "RandomCruise-Target-v2",
    "mars-approach": "MarsApproach-Tasking-v2",
    "thrust-arc": "ThrustArc-TCM-v2",
}
WORLDS = ("flight", "matched")


def _id_options(name: str) -> dict:
    from planetnav_env.envs.registration import ENV_IDS

    return dict(ENV_IDS[f"planetnav/{name}"])


def run(scenario: str, world: str, seeds: int, seed0: int) -> dict[str, np.ndarray]:
    """Per-seed figures of ``scenario`` in ``world`` (arrays of ``seeds``)."""
    opts = _id_options(SCENARIOS[scenario])
    # Absolute targets, one physics step per decision: the schedule is then written in physics steps.
    opts.update(decision_steps=1, target_actions="absolute", world=world)
    env = PlanetNavVectorEnv(seeds, info_keys="all", **opts)
    cfg = env.core.config
    env.reset(seed=seed0)
    n_t = cfg.n_targets
    ops = cfg.operations is not None
    errs: list[np.ndarray] = []
    pos_err = np.full(seeds, np.nan)
    for k in range(cfg.episode_steps):
        if ops:
            a = np.full(seeds, n_t if (k // 60) % 12 else (k // 60 // 12) % n_t)  # n_t: the mission attitude
        else:
            a = np.full(seeds, (k // 60) % n_t)
        _, _, term, trunc, info = env.step(a)
        errs.append(env.core.f[:, L.F_POINT_ERR].copy())
        done = term | trunc
        if np.any(done):
            pos_err = np.where(done & np.isnan(pos_err), info["pos_err_km"], pos_err)
            break
    f = env.core.f
    span_s = cfg.episode_steps * cfg.step_s
    days = span_s / 86400.0
    e = np.array(errs)
    point = np.array(
        [np.nanmedian(e[:, r]) if np.any(np.isfinite(e[:, r])) else np.nan for r in range(seeds)]
    )
    return {
        "dumps_per_day": f[:, L.F_DUMPS] / days,
        "dump_dv_per_day": f[:, L.F_DUMP_DV] / days,
        "saturated_pct": 100.0 * f[:, L.F_SAT_S] / span_s,
        # The engine stays off for dump_duration_s after each dump on the thrust arc: time the arc loses.
        "dump_engine_off_pct": 100.0 * f[:, L.F_DUMPS] * cfg.world.dump_duration_s / span_s * ops,
        "pointing_arcsec": np.degrees(point) * 3600.0,
        "pos_err_km": pos_err,
    }


#: The torque tasks' references: (agent, id).
REFERENCES = (("greedy-pd", "Cruise-TorqueControl-v1"), ("planner", "Cruise-Torque-v2"))


def references(seeds: int, seed0: int) -> None:
    """Print the torque tasks' references in both worlds (mean episode position error, 95 % interval)."""
    import dataclasses

    from planetnav_env.tasks import get_version
    from planetnav_train.evaluate import evaluate_agent

    print("| reference | id | world | mean position error [km] |")
    print("|---|---|---|---|")
    for agent, name in REFERENCES:
        base = get_version(f"planetnav/{name}").config()
        for w in WORLDS:
            cfg = dataclasses.replace(base, world=w)
            res = evaluate_agent(agent, cfg, seeds, seed0, progress=False)
            print(
                f"| {agent} | {name} | {w} | {mean_ci(res.episode_mean_err).format('{:.1f}')} |", flush=True
            )


def _cell(x: np.ndarray, fmt: str) -> str:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return "-"
    if np.all(x == x[0]):
        return fmt.format(x[0])
    return mean_ci(x).format(fmt)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--seed0", type=int, default=1000)
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=list(SCENARIOS))
    ap.add_argument("--references", action="store_true", help="the torque tasks' references instead")
    args = ap.parse_args()
    if args.references:
        references(args.seeds, args.seed0)
        return
    print(f"{args.seeds} seeds from {args.seed0}; mean [95 % interval]")
    print()
    print(
        "| scenario | world | dumps / day | dump delta-v [m/s / day] | wheel saturated [% of time] | "
        'pointing error ["] | position error at the end [km] |'
    )
    print("|---|---|---|---|---|---|---|")
    off: list[str] = []
    for sc in args.scenarios:
        for w in WORLDS:
            r = run(sc, w, args.seeds, args.seed0)
            cells = [
                _cell(r["dumps_per_day"], "{:.2f}"),
                _cell(r["dump_dv_per_day"], "{:.4f}"),
                _cell(r["saturated_pct"], "{:.2f}"),
                _cell(r["pointing_arcsec"], "{:.1f}"),
                _cell(r["pos_err_km"], "{:.1f}"),
            ]
            print(f"| {sc} | {w} | " + " | ".join(cells) + " |", flush=True)
            if SCENARIOS[sc].startswith("ThrustArc"):
                off.append(f"{sc}, {w}: {_cell(r['dump_engine_off_pct'], '{:.2f}')} % of the arc")
    if off:
        print()
        print("Engine off for momentum dumps (dumps x dump_duration_s over the episode):", "; ".join(off))


if __name__ == "__main__":
    main()
