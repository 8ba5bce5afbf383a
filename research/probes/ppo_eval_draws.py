"""How much of a sampled-action score is the evaluation's draws? The suite's PPO and the single-file PPO on
Cruise-Target-v2 at the suite's budget, each trained policy scored under several draws of its actions.

    python research/probes/ppo_eval_draws.py [--seeds 0 1 ... 9] [--out DIR] [--json F | --from-json F]

The suite scores a stochastic policy on its sampled actions, each evaluation episode's sampling seeded
with the episode's seed: every run of every seed draws from the same generators. The single file's
evaluation draws the same (``ppo_single_file.sampled_policy``, stream 0). Each policy is scored here, on
the suite's seeds 50,000..50,099 with per-step noise streams on the blind-zero scale, under

- ``suite``: the suite's draws (stream 0; equal to the suite record's score for a suite run);
- ``alt1``..``alt3``: three other draws that, like the suite's, every run shares (streams k x 10^8);
- ``own``: draws of the run's own, independent across runs (stream 10^6 x (seed + 1), plus 5 x 10^5 for
  the single file).
- ``onegen``: the single file's earlier evaluation, one generator seeded 50,000 drawing for all rows at
  every decision (another draw that every run shares).

Policies: ``suite``, the suite's cell, learning curve included (what the suite command trains with
``--tasks Cruise-Target-v2 --algos ppo --seeds S``), trained here by the suite runner into ``DIR/suite``;
its record's score must equal its score under the suite's draws here. ``single``, ``python
baselines/ppo_single_file.py --seed S`` (``DIR/single``). A model already in ``DIR`` is reused, so a rerun
only scores. It prints each run's scores, the interquartile mean of each population under each draw with
its stratified-bootstrap interval, P(single > suite) under the suite's draws and under own draws, and the
mean over runs of (suite's draws - mean of the other shared draws): what the suite's draws add to a run's
score. Training differs across CPUs (torch's kernels); the scoring of a given model does not.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "baselines"))  # ppo_single_file, imported where used
TASK = "Cruise-Target-v2"
EVAL_SEEDS = list(range(50_000, 50_100))
SHARED = {"suite": 0, "alt1": 10**8, "alt2": 2 * 10**8, "alt3": 3 * 10**8}
DRAWS = (*SHARED, "own", "onegen")
#: Own draws: stream OWN * (seed + 1) + the population's offset.
OWN, OFFSET = 10**6, {"suite": 0, "single": 5 * 10**5}


def suite_model(out: Path, seed: int) -> tuple[Path, float]:
    """The suite cell's model (trained here unless ``out`` holds it) and its record's score (kept beside
    the model in ``score.json``)."""
    from planetnav_train.suite import runner
    from planetnav_train.suite.cells import Cell, Settings
    from planetnav_train.suite.tasks import get_task

    settings = Settings(out=out)
    cell = Cell(TASK, "ppo", "raw", seed)
    path = out / "models" / cell.key / "model.zip"
    if not path.exists():
        rec = runner.run_cell(cell, settings, runner.task_references(get_task(TASK), settings))
        (path.parent / "score.json").write_text(json.dumps({"normalized_score": rec["normalized_score"]}))
    return path, json.loads((path.parent / "score.json").read_text())["normalized_score"]


def single_model(out: Path, seed: int) -> Path:
    """The single file's agent for ``seed`` (trained here unless ``out`` holds it)."""
    import ppo_single_file

    path = out / f"seed_{seed}.pt"
    if not path.exists():
        out.mkdir(parents=True, exist_ok=True)
        ppo_single_file.main(["--seed", str(seed), "--eval-episodes", "0", "--save-model", str(path)])
    return path


def load_agent(path: Path):
    """A single-file Agent holding the policy saved at ``path`` (an SB3 zip or a state_dict)."""
    import ppo_single_file

    if path.suffix == ".zip":
        from stable_baselines3 import PPO

        return ppo_single_file.agent_from_sb3(PPO.load(path, device="cpu").policy.state_dict())
    return ppo_single_file.load_agent(path)


def one_generator(agent, seed: int = 50_000):
    """The single file's earlier draws: one generator seeded ``seed``, one multinomial over all rows."""
    import torch

    gen = torch.Generator().manual_seed(seed)

    def act(o: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            probs = torch.softmax(agent.actor(torch.as_tensor(o)), dim=-1)
        return torch.multinomial(probs, 1, generator=gen).flatten().numpy()

    return act


@functools.cache
def evaluation():
    """The evaluation's environment and the two references' per-seed J (the blind winner's, the best's)."""
    import ppo_single_file as single

    args = single.parse_args(["--env-id", f"planetnav/{TASK}"])
    cfg = single.eval_config(args)
    _, jb, _, jr, _ = single.references(args, cfg, EVAL_SEEDS[0], len(EVAL_SEEDS))
    return cfg, jb, jr


def score_draws(agent, own_stream: int) -> dict[str, float]:
    """The agent's blind-zero score under each shared draw and under its own."""
    import ppo_single_file as single

    from planetnav_train.suite.blind import paired_ratio_ci

    cfg, jb, jr = evaluation()
    out = {}
    for name, stream in {**SHARED, "own": own_stream}.items():
        j = single.evaluate(single.sampled_policy(agent, EVAL_SEEDS, stream), cfg, EVAL_SEEDS)
        out[name] = paired_ratio_ci(jb, jr, j)["score"]
    out["onegen"] = paired_ratio_ci(jb, jr, single.evaluate(one_generator(agent), cfg, EVAL_SEEDS))["score"]
    return out


def row_line(r: dict) -> str:
    """One run's scores under each draw."""
    return f"{r['population']:6s} seed {r['seed']:2d}: " + "  ".join(f"{k} {r[k]:+.3f}" for k in DRAWS)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    p.add_argument("--out", type=Path, default=Path("runs/ppo-eval-draws"))
    p.add_argument("--json", type=Path, default=None, help="write the runs' scores here")
    p.add_argument("--from-json", type=Path, default=None, help="train and score nothing: summarize these")
    args = p.parse_args(argv)

    import torch

    from planetnav_train.suite.scoring import improvement_probabilities, iqm_intervals

    torch.set_num_threads(1)
    if args.from_json:
        runs = json.loads(args.from_json.read_text())
    else:
        runs = []
        for seed in args.seeds:
            path, record = suite_model(args.out / "suite", seed)
            s = score_draws(load_agent(path), OWN * (seed + 1) + OFFSET["suite"])
            if abs(record - s["suite"]) > 1e-9:
                raise SystemExit(f"seed {seed}: its suite record scores {record}, here {s['suite']}")
            runs.append({"population": "suite", "seed": seed, **s})
            path = single_model(args.out / "single", seed)
            runs.append({"population": "single", "seed": seed,
                         **score_draws(load_agent(path), OWN * (seed + 1) + OFFSET["single"])})  # fmt: skip
            for r in runs[-2:]:
                print(row_line(r), flush=True)
    if args.json:
        args.json.write_text(json.dumps(runs, indent=1))

    print(f"\n{TASK}, 300,000 decisions, blind-zero score, {len({r['seed'] for r in runs})} training seeds "
          f"per population:")  # fmt: skip
    for r in runs:
        print(f"  {row_line(r)}")
    matrices = {f"{pop}, {d} draws": np.asarray([r[d] for r in runs if r["population"] == pop])[:, None]
                for pop in ("suite", "single") for d in DRAWS}  # fmt: skip
    print("IQM [95 % stratified bootstrap over runs]:")
    for name, v in iqm_intervals(matrices).items():
        print(f"  {name:25s} {v['iqm']:+.3f} [{v['low']:+.3f}, {v['high']:+.3f}]")
    for d in ("suite", "own"):
        pair = {(f"single, {d} draws", f"suite, {d} draws"):
                (matrices[f"single, {d} draws"], matrices[f"suite, {d} draws"])}  # fmt: skip
        for v in improvement_probabilities(pair):
            print(f"P({v['x']} > {v['y']}) = {v['probability']:.2f} [{v['low']:.2f}, {v['high']:.2f}]")
    for pop in ("suite", "single"):
        others = [a for a in SHARED if a != "suite"]
        gain = [r["suite"] - np.mean([r[a] for a in others]) for r in runs if r["population"] == pop]
        print(f"suite's draws minus the mean of alt1-alt3, {pop} runs: mean {np.mean(gain):+.3f}, "
              f"{sum(g > 0 for g in gain)} of {len(gain)} runs above")  # fmt: skip


if __name__ == "__main__":
    main()
