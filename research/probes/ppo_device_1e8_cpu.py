"""What do the device PPO's 10^8-decision configurations score? Trained on the CPU, where the same loop
runs on the native vector env (no device has been lent to this work).

    python research/probes/ppo_device_1e8_cpu.py --config CONFIG --train MODEL.pt   # 1.5-2 h, 2-core CPU
    python research/probes/ppo_device_1e8_cpu.py --config CONFIG --from-model MODEL.pt [--against OTHER.pt]

Two configurations, both 10^8 decisions of planetnav/Cruise-Target-v2 from ``baselines/ppo_device.py
--device cpu`` (4 epochs, two torch threads, training seed 0 unless ``--seed``), 16 decisions per row an
update:

- ``large-updates``: 65,536 rows, 8 minibatches (96 updates of 1,048,576 decisions, 3,072 gradient
  steps); weights ``research/probes/ppo_device_1e8_cpu.pt``.
- ``small-updates``: 16,384 rows, 64 minibatches (382 updates of 262,144 decisions, 97,792 gradient
  steps); weights ``research/probes/ppo_device_1e8_cpu_small.pt`` (seed 0) and
  ``research/probes/ppo_device_1e8_cpu_small_s1.pt`` (``--seed 1``).

``--stagger-starts`` trains with each row's first episode cut at a random decision (``ppo_device.py
--stagger-starts``); weights ``research/probes/ppo_device_1e8_cpu_small_staggered.pt`` (small-updates,
seed 0). ``--against OTHER.pt`` adds, under each draw, the paired difference of mean error between the
weights and OTHER's on the same seeds and draws.

``--train`` trains one and saves the weights. Both modes then score the weights as the suite scores them
(sampled actions on seeds 50,000..50,099, per-step noise streams, blind-zero scale): with the suite's
draws, and with three other draws of the same policy (one sampled score depends on its draw; see
docs/performance.md, "GPU"). Beside them: the suite's PPO runs at the suite's budget (3M physics steps,
300,000 decisions), their interquartile mean and where this run falls among them. Training is not the
same on every CPU (torch picks its kernels for the CPU), and a GPU run differs in its last bits, so another
run of a configuration lands elsewhere within the spread of training seeds; scoring saved weights gives the
same numbers on any CPU.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "baselines"))  # ppo_device and ppo_single_file, imported where used
sys.path.insert(0, str(Path(__file__).resolve().parent))  # the equal-budget probe's task and reference
from ppo_device_equal_budget import EVAL_SEEDS, TASK, suite_ppo_scores  # noqa: E402

#: Other draws of the same policy: each episode's generator is seeded with the stream plus its seed.
OTHER_STREAMS = (1_000_000, 2_000_000, 3_000_000)
COMMON_ARGV = ["--device", "cpu", "--env-id", f"planetnav/{TASK}", "--num-steps", "16",
               "--update-epochs", "4", "--total-timesteps", "100000000", "--torch-threads", "2"]  # fmt: skip
#: Name -> (rows, minibatches an update).
CONFIGS = {"large-updates": (65_536, 8), "small-updates": (16_384, 64)}


def train_argv(config: str, seed: int, stagger_starts: bool = False) -> list[str]:
    rows, minibatches = CONFIGS[config]
    argv = [*COMMON_ARGV, "--seed", str(seed), "--num-envs", str(rows), "--num-minibatches", str(minibatches)]
    return [*argv, "--stagger-starts"] if stagger_starts else argv


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--train", type=Path, metavar="MODEL", help="train and save the weights here")
    mode.add_argument("--from-model", type=Path, metavar="MODEL", help="score saved weights")
    p.add_argument("--suite-json", type=Path, nargs="+",
                   default=[ROOT / "docs" / "benchmark.json",
                            ROOT / "research" / "probes" / "suite_ppo_cruise_target_v2_s5-19.json"],
                   help="suite JSONs whose PPO runs on the task are the reference")  # fmt: skip
    p.add_argument("--config", choices=sorted(CONFIGS), required=True, help="the configuration (see above)")
    p.add_argument("--seed", type=int, default=0, help="the training seed (scoring does not depend on it)")
    p.add_argument("--stagger-starts", action="store_true",
                   help="train with staggered first episodes (scoring does not depend on it)")  # fmt: skip
    p.add_argument("--against", type=Path, metavar="MODEL",
                   help="also print the paired difference of mean error against these weights")  # fmt: skip
    args = p.parse_args(argv)

    import ppo_device
    import ppo_single_file as single

    from planetnav_train.stats import paired_difference
    from planetnav_train.suite.blind import paired_ratio_ci
    from planetnav_train.suite.scoring import iqm_intervals

    run_argv = train_argv(args.config, args.seed, args.stagger_starts)
    if args.train:
        ppo_device.main([*run_argv, "--eval-episodes", "0", "--save-model", str(args.train)])
    model = args.train or args.from_model
    run = ppo_device.parse_args([*run_argv, "--eval-episodes", str(len(EVAL_SEEDS))])
    cfg = single.eval_config(run)
    ref = single.references(run, cfg, EVAL_SEEDS[0], len(EVAL_SEEDS))
    assert ref is not None, f"{run.blind_json}: no blind-search record of {TASK}"
    _, j_blind, _, j_best, _ = ref
    agent = single.load_agent(model)
    other = single.load_agent(args.against) if args.against else None

    def errors(policy_agent, stream: int) -> np.ndarray:  # per-seed mean error (km), sampled actions
        policy = single.sampled_policy(policy_agent, EVAL_SEEDS, stream=stream)
        return single.evaluate(policy, cfg, EVAL_SEEDS)

    print(f"{TASK}, {model.name}: the 10^8-decision configuration {args.config}, blind-zero score on seeds "
          f"{EVAL_SEEDS[0]}..{EVAL_SEEDS[-1]} [95 % paired bootstrap]")  # fmt: skip
    scores = {}
    for stream in (0, *OTHER_STREAMS):
        j = errors(agent, stream)
        s = paired_ratio_ci(j_blind, j_best, j)
        scores[stream] = s["score"]
        name = "the suite's draws" if stream == 0 else f"draws of stream {stream:,}"
        print(f"  {name:27s} {s['score']:+.3f} [{s['score_lo']:+.3f}, {s['score_hi']:+.3f}]  "
              f"(mean error {j.mean():.2f} km)")  # fmt: skip
        if other is not None:
            d = paired_difference(j, errors(other, stream))
            print(f"  {'':27s} minus {args.against.name}: {d.format('{:+.2f}')} km (paired t, 95 %)")
    suite = suite_ppo_scores(args.suite_json)
    v = iqm_intervals({"suite": np.asarray(suite)[:, None]})["suite"]
    below = sum(x < scores[0] for x in suite)
    print(
        f"suite PPO at its budget (300,000 decisions), {len(suite)} runs, suite's draws: IQM "
        f"{v['iqm']:+.3f} [{v['low']:+.3f}, {v['high']:+.3f}]; this run is above {below} of them"
    )


if __name__ == "__main__":
    main()
