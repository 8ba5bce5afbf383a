"""How much of a sampled learner's J on the evaluation seeds is its own action draws: one saved SB3 model,
rolled out on the same evaluation seeds (the env's noise fixed by them) under ``--draws`` generator seeds
of its sampled actions, beside its argmax.

    python research/tasks_v3/sampling_spread.py --task MarsApproach-Tasking-v3 --model M.zip --draws 10

Per model (``--model`` repeats): J [km] per draw seed, their mean, standard deviation and range, and per
evaluation seed the largest J any draw gave (where the spread comes from); on a normalized task, each
model paired with the published zero and best reference on the same seeds, and its blind-zero score.
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
        summary.append((path, _spread(cfg, cls.load(path, device="cpu"), seeds, args.draws)))
    if len(summary) > 1:
        print("## J over the draws, per model: mean (SD of one draw's J)")
        for path, per_draw in summary:
            means = per_draw.mean(axis=1)
            print(f"  {path}: {means.mean():.1f} ({means.std(ddof=1):.1f})")
    _against_published(args.task, cfg, seeds, summary)


def _against_published(task: str, cfg, seeds: range, summary: list[tuple[str, np.ndarray]]) -> None:
    """Each model's J (mean over its draws, per evaluation seed) minus the published zero's and best
    reference's per-seed J on the same seeds, and its blind-zero score against the published constants
    (a bootstrap over the draws' runs and the seeds); then all models pooled. Only where the seeds are the
    normalization record's."""
    try:
        rec = v3.normalization(task)
    except v3.ConfigError:  # not normalized
        return
    recorded = v3._recorded_per_seed(rec, cfg, task, seeds)
    if recorded is None:
        return
    jz, jb = rec["J_zero"]["mean"], rec["J_best"]["mean"]
    zero, best = recorded["zero"], recorded["best"]
    print(f"## against the published constants (J_zero {jz:.1f}, J_best {jb:.1f} on 1,000 seeds; on these "
          f"seeds the zero {zero.mean():.1f}, {rec['best_reference']} {best.mean():.1f})")  # fmt: skip
    for path, per_draw in summary:
        j = per_draw.mean(axis=0)
        dz, db = v3.paired_difference(j, zero), v3.paired_difference(j, best)
        line = f"  {path}: minus zero {_fmt(dz)}, minus best {_fmt(db)}"
        if jb < jz:
            sc = v3.run_score(list(per_draw), jz, jb)
            line += f", score {sc['score']:+.2f} [{sc['lo']:+.2f}, {sc['hi']:+.2f}]"
        print(line)
    if len(summary) > 1:
        from planetnav_train.stats import mean_ci

        for name, other in (("zero", zero), ("best", best)):
            d = mean_ci([per_draw.mean() - other.mean() for _, per_draw in summary])
            print(f"  minus {name} over the {d.n} models: {d.format('{:+.1f}')} km (Student t)")
    if len(summary) > 1 and jb < jz:
        sc = v3.run_score([row for _, per_draw in summary for row in per_draw], jz, jb)
        print(f"  pooled: score {sc['score']:+.2f} [{sc['lo']:+.2f}, {sc['hi']:+.2f}]")


def _fmt(d: dict) -> str:
    return f"{d['mean']:+.1f} [{d['lo']:+.1f}, {d['hi']:+.1f}]"


def _spread(cfg, model, seeds: range, draws: int) -> np.ndarray:
    """Print one model's J under ``draws`` draw seeds; return its J per draw and seed, (draws, seeds) [km]."""
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
    return per_draw


if __name__ == "__main__":
    main()
