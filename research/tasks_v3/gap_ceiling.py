"""How large can a v3 target task's closed-loop gap be if the onboard filter modelled the world better?

    python research/tasks_v3/gap_ceiling.py [--tasks T ...] [--worlds W ...] [--episodes 300]

The target tasks' gap is negative in the flight world: the covariance-driven references lose to a blind
cycle (docs/tasks_v3.md, "Normalization"). A filter that carried the flight world's unmodelled effects
(the boresight drift as augmented states, a photometric centre-of-brightness model, oblate limbs, the
image's own error model) would at best see the world those effects are absent from. This scores each
task's references and every published blind finalist in three worlds, on the same evaluation seeds with
per-step noise streams:

- ``flight``: the task's own world;
- ``camera-exact``: the flight world with every camera effect the filter does not model off (the drift,
  the Lambertian centre of brightness, oblate planets, the image's errors: a filter that modelled the
  camera exactly); the dynamics' and light's departures stay;
- ``matched``: the truth is the filter's own model (a filter that modelled everything).

In each world it prints the J of each policy [km] and the closed-loop gap ``(J_zero - J_best) / J_zero``
with its paired bootstrap interval (``planetnav_train.suite.blind.paired_ratio_ci``) against two zeros:
the published one (the flight world's search winner) and the best finalist in that world. The second is
the tighter of the two: a better blind policy in that world lowers J_zero and the gap with it. Neither
is a bound on every rule: the references are the task's (v2's), as the published J_best is.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from planetnav_train.stats import mean_ci
from planetnav_train.suite import v3
from planetnav_train.suite.blind import paired_ratio_ci

TASKS = ("Cruise-Target-v3", "RandomCruise-Target-v3", "MarsApproach-Tasking-v3")
CAMERA_EXACT = {"boresight_drift": False, "lambert_cob": False, "oblate_planets": False,
                "image_errors": False}  # fmt: skip
WORLDS = {"flight": {}, "camera-exact": CAMERA_EXACT, "matched": {"preset": "matched"}}


def _gap(jz: np.ndarray, jb: np.ndarray) -> str:
    g = paired_ratio_ci(jz, jb)
    return f"{g['gap']:+.1%} [{g['gap_lo']:+.1%}, {g['gap_hi']:+.1%}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    ap.add_argument("--worlds", nargs="+", default=list(WORLDS), choices=list(WORLDS))
    ap.add_argument("--episodes", type=int, default=300)
    args = ap.parse_args()
    blind_file = v3.read_json(v3.BLIND_FILE)["tasks"]
    print(f"{args.episodes} evaluation seeds from {v3.EVAL_SEED}, per-step noise streams\n")
    for task in args.tasks:
        blind = blind_file[task]
        zero = blind["winner"]
        blind_specs = [zero, *(s for s in blind["finalists"] if s != zero)]
        print(f"## {task}: published zero {zero}; references {', '.join(v3.V3_TASKS[task])}")
        for world in args.worlds:
            t0 = time.time()
            cfg = v3.eval_config(f"planetnav/{task}", world=WORLDS[world])
            j = {s: v3.policy_objective(cfg, v3.policy_from_record(s, blind["policies"][s]), v3.EVAL_SEED,
                                        args.episodes) for s in blind_specs}  # fmt: skip
            refs = {s: v3.policy_objective(cfg, s, v3.EVAL_SEED, args.episodes) for s in v3.V3_TASKS[task]}
            best_blind = min(blind_specs, key=lambda s: j[s].mean())
            best_ref = min(refs, key=lambda s: refs[s].mean())
            print(f"### {world}  ({time.time() - t0:.0f} s)")
            for s in blind_specs:
                print(f"  blind {s}: {mean_ci(j[s]).format('{:.1f}')}")
            for s, v in refs.items():
                print(f"  reference {s}: {mean_ci(v).format('{:.1f}')}")
            print(f"  gap of {best_ref} against the published zero: {_gap(j[zero], refs[best_ref])}")
            print(f"  gap of {best_ref} against the best finalist here ({best_blind}): "
                  f"{_gap(j[best_blind], refs[best_ref])}", flush=True)  # fmt: skip
        print()


if __name__ == "__main__":
    main()
