"""What each of the flight world's ephemeris, force and pulsar effects does to the baseline agent's error.

Question: the flight world's truth follows DE440 (the onboard model DE421), feels SRP on the Mars approach
too, flies the thrust arc's execution error as its Gauss-Markov process, and its pulsar phases hold the
Sun's Shapiro delay (corrected on board from the estimate). How much of the baseline agent's flight-world
error does each one make, on the scenario it touches?

Command:

    python research/flight_world/ephemeris_forces_pulsar_probe.py            # 20 seeds per case
    python research/flight_world/ephemeris_forces_pulsar_probe.py --seeds 8 --ids ThrustArc-TCM-v2

Per case: the baseline rule agent (nearest planet by the estimate; the patent's hybrid schedule with a
pulsar detector) over whole episodes of the v2 id, seeds 5000.. (``planetnav_train.evaluate``); on the
thrust arc, where the baseline never leaves the planets and so never thrusts, the benchmark's periodic
schedule (a 2-h imaging session every 3 days, thrusting between them) instead. Printed: the mean
position error over the episode [km] with its 95 % interval, the final error [km], the final 1-sigma
[km] and, on the thrust arc, the objective J [km]. Each "flight without X" switches one effect off in
the flight preset. A magnitude probe, not the 100-seed study with intervals per agent.
"""

from __future__ import annotations

import argparse

from planetnav_env.tasks import get_version
from planetnav_train.evaluate import evaluate_agent

CASES = {
    "planetnav/Cruise-Target-v2": {
        "matched": "matched",
        "flight": "flight",
        "flight without DE440 (truth on DE421)": {"preset": "flight", "truth_ephemeris": "de421"},
    },
    "planetnav/MarsApproach-Tasking-v2": {
        "matched": "matched",
        "flight": "flight",
        "flight without DE440 (truth on DE421)": {"preset": "flight", "truth_ephemeris": "de421"},
        "flight without SRP": {"preset": "flight", "srp": False},
        "flight without the Shapiro delay": {"preset": "flight", "pulsar_shapiro": False},
        "matched + Shapiro delay, uncorrected": {"pulsar_shapiro": True, "onboard_corrections": False},
    },
    "planetnav/ThrustArc-TCM-v2": {
        "matched": "matched",
        "flight": "flight",
        "flight with white thrust errors": {"preset": "flight", "thrust_gauss_markov": False},
    },
}


#: The rule agent per id (the baseline, but on the thrust arc a schedule that thrusts).
AGENTS = {"planetnav/ThrustArc-TCM-v2": "periodic:period=432,session=12,phase=108,cycle=0-1-2"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seed", type=int, default=5000)
    ap.add_argument("--ids", nargs="*", default=None, help="only these ids (e.g. ThrustArc-TCM-v2)")
    args = ap.parse_args()
    for env_id, cases in CASES.items():
        if args.ids and env_id.split("/")[-1] not in args.ids:
            continue
        agent = AGENTS.get(env_id, "baseline")
        print(f"\n{env_id}, {agent}, {args.seeds} seeds from {args.seed}\n")
        print("| world | mean error [km] (95 %) | final error [km] | final 1-sigma [km] | J [km] |")
        print("|---|---|---|---|---|")
        for name, world in cases.items():
            cfg = get_version(env_id).config(world=world)
            m = evaluate_agent(agent, cfg, args.seeds, args.seed, progress=False).metrics
            lo, hi = m["mean_pos_err_ci95_km"]
            j = m["objective_mean"] if cfg.operations is not None else float("nan")
            print(
                f"| {name} | {m['mean_pos_err_km']:.2f} [{lo:.2f}, {hi:.2f}] | {m['final_pos_err_km']:.2f} "
                f"| {m['final_pos_sigma_km']:.2f} | {j:.1f} |"
            )


if __name__ == "__main__":
    main()
