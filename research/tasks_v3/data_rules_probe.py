"""Probe: do simple rules that read the spacecraft's own logs (image successes, time since a fix, the
residual log) beat the blind zero (a fast cycle) on the v3 target tasks?

Each rule is a callable in the task's decision interface (``v3.roll_out``), scored paired against the
published zero on the blind search's second-stage seeds (115,000.., apart from the evaluation seeds).

    python research/tasks_v3/data_rules_probe.py [--task Cruise-Target-v3] [--episodes 100]
"""

from __future__ import annotations

import argparse

import numpy as np

from planetnav_env.core.layout import SINCE_SCALE_STEPS, ObservationLayout
from planetnav_train.suite import v3


class LogRule:
    """Cycle through the targets, skipping a planet whose success estimate is below
    ``theta`` once it has had ``n_min`` images; or, with ``stalest``, point at the planet whose last fix
    is oldest, weighted by its success estimate to the power ``w``; ``nis`` > 0 skips a planet whose
    mean normalized NIS exceeds it."""

    def __init__(self, cfg, theta=0.0, n_min=3, stalest=False, w=1.0, nis=0.0, dwell=1):
        lay = ObservationLayout.for_config(cfg)
        self.p = cfg.n_planets
        self.t = cfg.n_targets  # the cycle visits every target; success and NIS skips apply to planets
        self.img = lay.start("image_log")
        self.since = lay.start("since_measured")
        self.res = lay.start("residual_log") if lay.has("residual_log") else None
        self.theta, self.n_min, self.stalest, self.w, self.nis, self.dwell = (
            theta,
            n_min,
            stalest,
            w,
            nis,
            dwell,
        )
        self.ptr = None
        self.name = (
            (f"stalest:w={w:g}" if stalest else f"skip:theta={theta:g},n_min={n_min}")
            + (f",nis={nis:g}" if nis else "")
            + (f",dwell={dwell}" if dwell > 1 else "")
        )

    def __call__(self, d, obs):
        n, p, t = obs.shape[0], self.p, self.t
        ok = np.ones((n, t), bool)
        rate = np.ones((n, t))
        rate[:, :p] = obs[:, self.img : self.img + p]
        images = np.expm1(obs[:, self.img + p : self.img + 2 * p] * np.log1p(SINCE_SCALE_STEPS))
        ok[:, :p] = (rate[:, :p] >= self.theta) | (images < self.n_min)
        if self.nis and self.res is not None:
            ok[:, :p] &= obs[:, self.res : self.res + p] * 10.0 <= self.nis
        if d == 0 or self.ptr is None:
            self.ptr = np.full(n, -1)
            self.last = np.zeros(n, np.int64)
        if d % self.dwell:
            return self.last
        if self.stalest:
            since = obs[:, self.since : self.since + t]
            score = since * np.maximum(rate, 1e-3) ** self.w
            score = np.where(ok, score, -1.0)
            act = np.argmax(score, axis=1)
        else:
            act = np.empty(n, np.int64)
            for r in range(n):
                for k in range(1, t + 1):
                    c = (self.ptr[r] + k) % t
                    if ok[r, c]:
                        break
                else:
                    c = (self.ptr[r] + 1) % t
                act[r] = c
            self.ptr = act.copy()
        self.last = act
        return act


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--task", default="Cruise-Target-v3")
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--seed", type=int, default=v3.FINAL_SEED)
    args = ap.parse_args()
    env_id = f"planetnav/{args.task}"
    cfg = v3.eval_config(env_id)
    seeds = range(args.seed, args.seed + args.episodes)
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][args.task]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    jz = v3.roll_out(cfg, zero, seeds).objective
    print(
        f"{args.task}: zero {blind['winner']} J {jz.mean():.1f} km on seeds {args.seed}.. ({args.episodes})"
    )
    rules = [LogRule(cfg, theta=t, n_min=n) for t in (0.2, 0.35, 0.5) for n in (3, 10)]
    rules += [LogRule(cfg, stalest=True, w=w) for w in (0.0, 1.0, 2.0)]
    rules += [LogRule(cfg, theta=0.35, n_min=3, nis=x) for x in (3.0, 6.0)]
    for rule in rules:
        j = v3.roll_out(cfg, rule, seeds).objective
        d = v3.paired_difference(j, jz)
        print(
            f"  {rule.name:32s} J {j.mean():7.1f} minus zero {d['mean']:+7.1f} "
            f"[{d['lo']:+.1f}, {d['hi']:+.1f}]",
            flush=True,
        )


if __name__ == "__main__":
    main()
