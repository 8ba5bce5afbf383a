"""Is the learned Mars policy's lead closed-loop, or a better open-loop time profile the zero search missed?

    python research/tasks_v3/mars_blind_distill.py --model M.zip [--episodes 300]

The DQN policy of ``mars_regime_map.py`` picks Mars less as the approach ends. A blind policy can do that
too: a time-indexed distribution over the targets is in the blind family (the suite's search has the
cross-entropy method over such distributions, at a small budget). This distills the model into blind
policies and scores them beside it:

- ``distilled, sampled``: at decision d, a target drawn from the model's own action frequencies at d,
  measured on 200 search seeds (110,000..; none is an evaluation seed), smoothed over ``--window``
  decisions;
- ``distilled, fixed``: the same frequencies played as a fixed schedule (at each decision the target whose
  running count lags its frequency most);
- ``thirds``: the frequencies averaged per third of the episode, sampled.

Each is scored with the model, the published zero and the best finalist on evaluation seeds from 130,100
(the model was picked on 130,000..130,099), paired. If a distilled blind policy matches the model, its
lead is a time profile and the published zero is not the best blind policy; if the model stays ahead,
the lead needs the observation.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mars_regime_map import blind_policies  # a sibling research script

TASK = "MarsApproach-Tasking-v3"
ENV_ID = f"planetnav/{TASK}"


def frequencies(actions: np.ndarray, n_actions: int, window: int) -> np.ndarray:
    """Per-decision action frequencies (D, A) of ``actions`` (D, N), a centred moving average over
    ``window`` decisions (odd; 1: none)."""
    counts = np.stack([(actions == a).mean(axis=1) for a in range(n_actions)], axis=1)
    if window <= 1:
        return counts
    k = np.ones(window) / window
    pad = window // 2
    padded = np.pad(counts, ((pad, pad), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(padded[:, a], k, mode="valid") for a in range(n_actions)], axis=1)
    return smooth / smooth.sum(axis=1, keepdims=True)


def fixed_schedule(freq: np.ndarray) -> np.ndarray:
    """One-hot rows (D, A): at each decision the target whose count lags its cumulative share most."""
    d_n, n_a = freq.shape
    share = np.cumsum(freq, axis=0)
    count = np.zeros(n_a)
    out = np.zeros_like(freq)
    for d in range(d_n):
        a = int(np.argmax(share[d] - count))
        count[a] += 1.0
        out[d, a] = 1.0
    return out


def thirds(freq: np.ndarray) -> np.ndarray:
    out = np.empty_like(freq)
    for part in np.array_split(np.arange(len(freq)), 3):
        out[part] = freq[part].mean(axis=0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--episodes", type=int, default=300)
    ap.add_argument("--search-episodes", type=int, default=200)
    ap.add_argument("--window", type=int, default=9)
    args = ap.parse_args()
    from stable_baselines3 import DQN

    t0 = time.time()
    cfg = v3.eval_config(ENV_ID)
    act = v3._policy_fn(DQN.load(args.model, device="cpu"), [], deterministic=True)
    search = v3.roll_out(cfg, act, range(v3.SEARCH_SEED, v3.SEARCH_SEED + args.search_episodes), actions=True)
    freq = frequencies(np.asarray(search.actions), cfg.n_target_actions, args.window)
    policies = {
        "distilled, sampled": v3.BlindTargets("distilled, sampled", freq),
        "distilled, fixed": v3.BlindTargets("distilled, fixed", fixed_schedule(freq)),
        "thirds": v3.BlindTargets("thirds", thirds(freq)),
    }
    finalists = blind_policies(TASK)
    policies.update({f"blind {name}": p for name, p in finalists.items()})
    seeds = range(v3.EVAL_SEED + 100, v3.EVAL_SEED + 100 + args.episodes)
    print(f"{TASK}: {args.model}; frequencies from {args.search_episodes} search seeds (window "
          f"{args.window}); scored on {seeds.start}..{seeds.stop - 1}")  # fmt: skip
    per_third = thirds(freq)[[0, len(freq) // 2, -1]]
    rows = "; ".join(" ".join(f"{x:.2f}" for x in row) for row in per_third)
    print(f"  the model's frequencies per third (Mars, B0531+21, B1937+21): {rows}")
    jm = v3.roll_out(cfg, act, seeds).objective
    js = {name: v3.roll_out(cfg, policy, seeds).objective for name, policy in policies.items()}
    zero = js[f"blind {next(iter(finalists))}"]
    print(f"  model: J {mean_ci(jm).format('{:.1f}')}")
    for name, j in js.items():
        dm, dz = paired_difference(jm, j), paired_difference(j, zero)
        print(f"  {name}: J {mean_ci(j).format('{:.1f}')}; model - it {dm.mean:+.1f} [{dm.low:+.1f}, "
              f"{dm.high:+.1f}]; it - zero {dz.mean:+.1f} [{dz.low:+.1f}, {dz.high:+.1f}]")  # fmt: skip
    print(f"({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
