"""A learned policy on the drift regime map of Cruise-Target-v3: SB3's PPO trained and scored at each drift.

    python research/tasks_v3/drift_regime_learners.py run --sigma 0 --seed 0 \
        --out research/tasks_v3/regime/drift-0-seed0.json
    python research/tasks_v3/drift_regime_learners.py table research/tasks_v3/regime/*.json

``run`` is the suite's ``learners`` row (SB3's PPO with every default through ``make_vec_env``, the
suite's budget of 300,000 decisions) in the flight world with the planet camera's boresight drift at
``--sigma`` arcsec per axis (0: the drift off; 1, the flight value; ``drift_regime_map.world_for``), trained
and scored in that world on the same evaluation seeds as ``drift_regime_map.py`` (300 from 130,000), beside
the blind zero of the task and its best reference (greedy with observed success rates) in the same world.
The task's reward constants stay the published ones (measured at the flight value): a time-only baseline,
so the reward's optimum is still the objective's at every drift.

``table`` pools the runs of each drift: PPO's J, and its paired difference from the zero, from the
reference and from uniform random [km, negative is better], the mean over runs with a 95 % interval
from a two-level bootstrap (pick a training run, then resample its evaluation seeds), so both spreads
are in it; each run's own difference from the reference beside. A row whose interval lies below 0
against the reference is a learned policy beating the best non-privileged rule at that drift.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from drift_regime_map import world_for

from planetnav_train.suite import v3

TASK = "Cruise-Target-v3"
PPO = "SB3 PPO (defaults, make_vec_env)"
UNIFORM = "uniform random"


def run(args: argparse.Namespace) -> None:
    rows = v3.learner_rows(TASK, args.budget, args.seed, args.episodes, world=world_for(args.sigma))
    rows["drift_sigma_arcsec"] = args.sigma
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    v3.write_json(Path(args.out), rows)
    for r in rows["rows"]:
        extra = "".join(
            f"  {k} {r[k]['mean']:+.1f} [{r[k]['lo']:+.1f}, {r[k]['hi']:+.1f}]"
            for k in ("minus_zero", "minus_best_reference")
            if k in r
        )
        print(f"{r['policy']:<45} J {r['J']['mean']:7.1f}{extra}")


def table(paths: list[str]) -> None:
    by_sigma: dict[float, list[dict]] = defaultdict(list)
    for p in paths:
        d = json.loads(Path(p).read_text())
        by_sigma[float(d["drift_sigma_arcsec"])].append(d)
    head = ["drift sigma [arcsec]", "runs", "J zero", "J reference", "J uniform", "PPO J (runs)",
            "PPO - zero", "PPO - reference", "PPO - uniform", "per run: PPO - reference"]  # fmt: skip
    print("| " + " | ".join(head) + " |")
    print("|---" * len(head) + "|")
    for sigma, runs in sorted(by_sigma.items()):
        if len({tuple(r["per_seed"]["zero"]) for r in runs}) != 1:
            raise SystemExit(f"drift {sigma}: the runs' zero rows differ (other seeds or world)")
        ps = [{k: np.asarray(v, float) for k, v in r["per_seed"].items()} for r in runs]
        jp = [p[PPO].mean() for p in ps]
        cells = [f"{sigma:g}", str(len(runs))]
        cells += [f"{ps[0][k].mean():.1f}" for k in ("zero", "best_reference", UNIFORM)]
        cells.append(f"{np.mean(jp):.1f} ({min(jp):.1f}..{max(jp):.1f})")
        for other in ("zero", "best_reference", UNIFORM):
            d = v3.pooled_mean_interval([p[PPO] - p[other] for p in ps])
            cells.append(f"{d['mean']:+.1f} [{d['lo']:+.1f}, {d['hi']:+.1f}]")
        d_ref_run = [next(x for x in r["rows"] if x["policy"] == PPO)["minus_best_reference"] for r in runs]
        cells.append(", ".join(f"{d['mean']:+.1f} [{d['lo']:+.1f}, {d['hi']:+.1f}]" for d in d_ref_run))
        print("| " + " | ".join(cells) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--sigma", type=float, required=True)
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--episodes", type=int, default=300)
    r.add_argument("--budget", type=int, default=300_000)
    r.add_argument("--out", required=True)
    t = sub.add_parser("table")
    t.add_argument("paths", nargs="+")
    args = ap.parse_args()
    run(args) if args.cmd == "run" else table(args.paths)


if __name__ == "__main__":
    main()
