"""How much of a sampled learner's J on the evaluation seeds is its own action draws: one saved SB3 model,
rolled out on the same evaluation seeds (the env's noise fixed by them) under ``--draws`` generator seeds
of its sampled actions, beside its argmax.

    python research/tasks_v3/sampling_spread.py --task MarsApproach-Tasking-v3 --model M.zip --draws 10

Per model (``--model`` repeats): J [km] per draw seed, their mean, standard deviation and range, and per
evaluation seed the largest J any draw gave (where the spread comes from).
"""

from __future__ import annotations

import argparse

import numpy as np

from planetnav_train.suite import v3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", required=True)
    ap.add_argument(
        "--model", required=True, action="append", help="SB3 zip from `learners --save-model` (repeatable)"
    )
    ap.add_argument("--algo", default="ppo", choices=sorted(v3.LEARNERS))
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--draws", type=int, default=10)
    args = ap.parse_args()
    import stable_baselines3

    cfg = v3.eval_config(f"planetnav/{args.task}")
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + args.episodes)
    cls = getattr(stable_baselines3, v3.LEARNERS[args.algo][0])
    summary = []
    for path in args.model:
        print(f"## {path}")
        summary.append((path, *_spread(cfg, cls.load(path, device="cpu"), seeds, args.draws)))
    if len(summary) > 1:
        print("## J over the draws, per model: mean (SD of one draw's J)")
        for path, m, sd in summary:
            print(f"  {path}: {m:.1f} ({sd:.1f})")


def _spread(cfg, model, seeds: range, draws: int) -> tuple[float, float]:
    """Print one model's J under ``draws`` draw seeds; return their mean and SD [km]."""
    per_draw = np.stack([v3.roll_out(cfg, v3._policy_fn(model, [], seed=k), seeds).objective
                         for k in range(draws)])  # fmt: skip
    means = per_draw.mean(axis=1)
    for k, m in enumerate(means):
        print(f"draw seed {k}: J {m:.1f} km")
    print(f"{draws} draws on {len(seeds)} evaluation seeds: J mean {means.mean():.1f}, "
          f"SD {means.std(ddof=1):.1f}, range {means.min():.1f}..{means.max():.1f} km")  # fmt: skip
    argmax = v3.roll_out(cfg, v3._policy_fn(model, [], deterministic=True), seeds).objective
    print(f"argmax: J {argmax.mean():.1f} km")
    worst = per_draw.max(axis=0)
    order = np.argsort(worst)[::-1][:5]
    tops = [f"{seeds[i]} {worst[i]:.0f} (median {np.median(per_draw[:, i]):.0f})" for i in order]
    print("largest J of any draw, by evaluation seed: " + ", ".join(tops))
    # Without the five seeds that spread most: how much of the draw SD they carry.
    keep = np.setdiff1d(np.arange(len(seeds)), order)
    rest = per_draw[:, keep].mean(axis=1)
    print(f"without those five seeds: J mean {rest.mean():.1f}, SD over draws {rest.std(ddof=1):.1f} km")
    return float(means.mean()), float(means.std(ddof=1))


if __name__ == "__main__":
    main()
