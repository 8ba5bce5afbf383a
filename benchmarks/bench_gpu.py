"""GPU throughput: the device env's env-only steps/s at N = 2^10 .. 2^20 on three ids, the device PPO's
end-to-end rate, and the parity of the GPU's rows with the CPU's; JSON on stdout.

    python benchmarks/bench_gpu.py                  # everything (a few minutes on one H100)
    python benchmarks/bench_gpu.py --sizes 10 14 18 --skip-ppo

Ids: planetnav/Cruise-Target-v1 (target choice, 10 physics steps a decision),
planetnav/Cruise-TorqueControl-v1 (1-s torque control), planetnav/MarsApproach-Tasking-v1 (the Mars
approach). A rate is physics steps (row x decision x ``decision_steps``) per second and decisions per
second, best of ``--repeats`` timed blocks after ``--warmup`` decisions, as a user steps the env but with
the bank's refill off (its host thread would hold the interpreter lock the launches need), in two
regimes (:data:`REGIMES`): ``held`` (every row keeps its target: after the first slew the attitude
settles and takes the coarse sub-steps) and ``slewing`` (every row changes target every decision: each
decision starts with a slew on the fine sub-steps), each with the fraction of rows settled after its
last decision; ``setup_s`` holds the
bank's drawing, its upload and, for the process's first env, the kernels' compilation (every env of a
process shares it). The CPU's native vector env at ``--cpu-n`` rows is measured in the same run, right
after the first id's rates, with the same regimes, as the reference ratio (its rate is this machine's
CPUs'). Parity, on every registered id
(``--parity-ids``): the device env on CUDA against its host mode (the CPU build of the same thread
functions) over ``--parity-steps`` decisions of ``--parity-rows`` rows with the same episodes and actions:
the largest differences of the observations, rewards and final state, and whether they are equal bit for
bit. Bank: the host's drawing rate of the refill (episodes/s, one thread, measured with or without
a device) and the decisions/s it feeds (episodes/s x decisions per episode: above that rate a thread
refill substitutes), and at each size the bank's statistics after the timed blocks (substitutes among
the episodes started). Kernels: each kernel's registers and local memory on the device, and the blocks
per SM that the occupancy rule (:mod:`planetnav_env.device.occupancy`) and the driver each give;
``--max-registers R ...`` times the target-choice id at the largest size again with the registers capped.
PPO: baselines/ppo_device.py in this process (the compiled kernels reused), its updates' own rate, the
first update's apart. The stages run in the order of what a short loan must not miss (the target-choice
rates, the CPU reference, the parity on the timed ids, the PPO, the other ids' rates, then the rest);
each one's result goes to stderr as it finishes and, with ``--out``, the JSON so far to that file (a kill
keeps what finished); a failing stage records its error in the JSON instead of ending the run, and a
stage that would start past ``--deadline-s`` is recorded as skipped. The last line on stderr, and
``--summarize FILE`` of a recorded run, is a one-line summary.
Without a CUDA device it prints ``{"measured": false, "reason": ..., "bank_draw": ...}`` and exits 0: no
device figure is claimed.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import time
import traceback
from pathlib import Path

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.batch import BatchCore
from planetnav_env.device.bank import EpisodeBank
from planetnav_env.device.draw_pool import DrawPool
from planetnav_env.device.parity import compare_runs, record_run, run_actions
from planetnav_env.device.vector_env import THREADS_PER_BLOCK, DeviceVectorEnv, cuda_unavailable_reason
from planetnav_env.envs.env import resolve_config
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.provenance import cpu_model

IDS = ("planetnav/Cruise-Target-v1", "planetnav/Cruise-TorqueControl-v1", "planetnav/MarsApproach-Tasking-v1")
ROOT = Path(__file__).resolve().parents[1]


#: The two attitude regimes a rate is reported for. ``held``: every row keeps its target (relative target
#: actions 0, absolute ones the first target; Box actions zero), so after the first slew the rows settle
#: and take the coarse attitude sub-steps; ``slewing``: every row changes target every decision (relative
#: 1, absolute alternating between two targets; Box actions fixed random ones), so each decision starts
#: with a slew on the fine sub-steps, until the attitude settles again (a decision's later physics steps
#: hold its target).
REGIMES = ("held", "slewing")


def regime_actions(cfg, space, n: int, regime: str) -> list[np.ndarray]:
    """The actions of ``regime`` (:data:`REGIMES`) for ``n`` rows, one array per decision of its cycle."""
    if isinstance(space, gym.spaces.Discrete):
        if regime == "held":
            return [np.zeros(n, np.int64)]
        if cfg.target_actions == "relative":
            return [np.ones(n, np.int64)]
        return [np.zeros(n, np.int64), np.ones(n, np.int64)]
    if regime == "held":
        return [np.zeros((n, *space.shape), np.float32)]
    return [run_actions(space, n, np.random.default_rng(0))]


def _settled_fraction(i) -> float:
    from planetnav_env.core.layout import I_SETTLED

    return float((np.asarray(i)[:, I_SETTLED] == 1).mean())


def device_rate(env_id: str, n: int, args, max_registers: int | None = None) -> dict:
    """Env-only rate of the device env with ``n`` rows in each regime (:data:`REGIMES`), as a user steps it
    but with the bank's refill off (no host thread takes the interpreter lock the launches need; the
    timed blocks are shorter than an episode, so no row starts a substitute), its kernels' registers
    capped at ``max_registers`` if given. Per regime: ``--warmup`` decisions, then the best of
    ``--repeats`` blocks of ``--decisions``, and the fraction of rows settled (coarse sub-steps) at the
    end."""
    import torch

    decisions, repeats = args.decisions, args.repeats
    t0 = time.perf_counter()
    env = DeviceVectorEnv(env_id, n, device="cuda", bank_size=min(args.bank, n), refill="off",
                          bank_workers=0, max_registers=max_registers)  # fmt: skip
    env.reset(seed=0)
    torch.cuda.synchronize()
    out: dict = {"n": n, "setup_s": time.perf_counter() - t0, "refill": "off"}
    k = env.config.decision_steps
    for regime in REGIMES:
        cycle = [torch.as_tensor(a).to(env.device) for a in
                 regime_actions(env.config, env.single_action_space, n, regime)]  # fmt: skip
        for j in range(args.warmup):
            env.step(cycle[j % len(cycle)])
        torch.cuda.synchronize()
        best = 0.0
        for _ in range(repeats):
            t = time.perf_counter()
            for j in range(decisions):
                env.step(cycle[j % len(cycle)])
            torch.cuda.synchronize()
            best = max(best, n * decisions / (time.perf_counter() - t))
        out[regime] = {"decisions_per_s": best, "physics_steps_per_s": best * k,
                       "settled_fraction": _settled_fraction(env.i.cpu().numpy())}  # fmt: skip
    out.update(bytes_per_row=env.bytes_per_row(), bank=env.bank_stats(),
               registers=env.backend.kernel_registers())  # fmt: skip
    env.close()
    del env
    torch.cuda.empty_cache()
    return out


def bank_draw_rate(env_id: str, workers: int, episodes: int, repeats: int = 3) -> dict:
    """The host's drawing rate of ``env_id``'s episodes (best of ``repeats`` banks of ``episodes``) in this
    process (``workers`` 1) or a pool of ``workers`` processes, and the decisions/s it feeds."""
    cfg = resolve_config(env_id, {})
    core = BatchCore(cfg, 1)
    pool = DrawPool(cfg, workers) if workers > 1 else None
    try:
        EpisodeBank.for_vector_env(core, 64, 64, 0, pool)  # warm the table caches and the compiled code
        rate = 0.0
        for r in range(repeats):
            t = time.perf_counter()
            EpisodeBank.for_vector_env(core, 4096, episodes, 1 + 10_000 * r, pool)
            rate = max(rate, episodes / (time.perf_counter() - t))
    finally:
        if pool is not None:
            pool.close()
    decisions = cfg.episode_decisions
    return {"workers": workers, "episodes_per_s": rate, "decisions_per_episode": decisions,
            "feeds_decisions_per_s": rate * decisions}  # fmt: skip


def cpu_rate(env_id: str, n: int, args) -> dict:
    """The native CPU vector env's rate at ``n`` rows in each regime (the reference ratio; the device
    rate's actions, warm-up and blocks)."""
    env = gym.make_vec(env_id, num_envs=n)
    env.reset(seed=0)
    cfg = env.unwrapped.config
    out: dict = {"n": n, "cpu": cpu_model()}
    for regime in REGIMES:
        cycle = regime_actions(cfg, env.single_action_space, n, regime)
        for j in range(args.warmup):
            env.step(cycle[j % len(cycle)])
        best = 0.0
        for _ in range(args.repeats):
            t = time.perf_counter()
            for j in range(args.decisions):
                env.step(cycle[j % len(cycle)])
            best = max(best, n * args.decisions / (time.perf_counter() - t))
        out[regime] = {"decisions_per_s": best, "physics_steps_per_s": best * cfg.decision_steps,
                       "settled_fraction": _settled_fraction(env.unwrapped.core.i)}  # fmt: skip
    env.close()
    return out


def parity(env_id: str, n: int, steps: int) -> dict:
    """The device env on CUDA against its host mode (the CPU build of the same thread functions), the same
    episodes and actions over ``steps`` decisions of ``n`` rows
    (:func:`planetnav_env.device.parity.compare_runs`)."""
    gpu, cpu = (record_run(env_id, n, steps, d) for d in ("cuda", "cpu"))
    return {"steps": steps, "rows": n, **compare_runs(gpu, cpu)}


def ppo_rate(args, device: str = "cuda") -> dict:
    """End-to-end rate of baselines/ppo_device.py on the target-choice task (no evaluation), in this process
    so that it launches the kernels the env-only stage compiled. The rate is the updates' own (the first
    update, which may compile, left out), decisions and physics steps per second."""
    sys.path.insert(0, str(ROOT / "baselines"))
    import ppo_device

    argv = ["--device", device, "--env-id", IDS[0], "--num-envs", str(args.ppo_n), "--num-steps", "16",
            "--num-minibatches", "4", "--update-epochs", "4",
            "--total-timesteps", str(args.ppo_n * 16 * args.ppo_updates), "--eval-episodes", "0",
            "--bank-workers", str(args.bank_workers)]  # fmt: skip
    t = time.perf_counter()
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        hist = ppo_device.main(argv)["history"]
    steady = [h["update_sps"] for h in hist[1:]] or [h["update_sps"] for h in hist]
    k = resolve_config(IDS[0], {}).decision_steps
    bank = [ln for ln in printed.getvalue().splitlines() if ln.startswith("bank:")]
    return {"n": args.ppo_n, "updates": len(hist), "decisions_per_s_median": float(np.median(steady)),
            "decisions_per_s_first_update": hist[0]["update_sps"],
            "physics_steps_per_s_median": float(np.median(steady)) * k, "wall_s": time.perf_counter() - t,
            "bank": bank[-1] if bank else None}  # fmt: skip


def kernel_report() -> dict:
    """The kernels the env-only stage compiled (no register cap): their registers on this device, the
    occupancy they allow by the rule of :mod:`planetnav_env.device.occupancy`, and the driver's own
    occupancy figure beside it."""
    from numba import cuda

    from planetnav_env.device.cuda_kernels import dispatchers
    from planetnav_env.device.occupancy import SM_LIMITS, blocks_per_sm

    cc = tuple(cuda.get_current_device().compute_capability)
    limits, tpb, kernels = SM_LIMITS.get(cc), THREADS_PER_BLOCK, dispatchers()
    out: dict = {"compute_capability": list(cc), "threads_per_block": tpb}
    for name in kernels._fields:
        for overload in getattr(kernels, name).overloads.values():
            regs = int(overload.regs_per_thread)
            row: dict = {"registers": regs, "local_bytes": int(overload.local_mem_per_thread)}
            if limits is not None:
                row["blocks_per_sm_rule"] = blocks_per_sm(regs, tpb, limits)
            try:  # the driver's answer (numba-cuda's internal handle of the compiled function)
                ctx = cuda.current_context()
                func = overload._codelibrary.get_cufunc()
                row["blocks_per_sm_driver"] = int(ctx.get_active_blocks_per_multiprocessor(func, tpb, 0))
            except Exception as exc:  # a report, not a check
                row["blocks_per_sm_driver"] = f"unavailable: {exc!r}"[:200]
            out[name] = row
    return out


class Stages:
    """The run's stages against its deadline: each result goes into the JSON record (rewritten to
    ``--out`` after every stage, so a kill keeps what finished) and to stderr as it comes; a stage that
    would start past ``--deadline-s`` is recorded as skipped, so the run ends in time with its JSON."""

    def __init__(self, record: dict, deadline_s: float, path: str | None) -> None:
        self.record, self.deadline_s, self.path = record, deadline_s, path
        self.start = time.perf_counter()

    def run(self, out: dict, key: str, fn, *args) -> None:
        """Run one stage into ``out[key]``; its error is recorded, not raised, so that one failing stage of
        a device's few minutes does not lose the others."""
        t = time.perf_counter()
        if self.deadline_s and t - self.start > self.deadline_s:
            out[key] = {"skipped": f"past the run's deadline of {self.deadline_s:.0f} s"}
        else:
            try:
                out[key] = fn(*args)
            except (Exception, SystemExit) as exc:  # recorded in the JSON with its traceback
                out[key] = {"error": repr(exc), "traceback": traceback.format_exc()[-3000:]}
        print(json.dumps({key: out[key], "stage_s": round(time.perf_counter() - t, 1)}, default=str),
              file=sys.stderr, flush=True)  # fmt: skip
        self.save()

    def save(self) -> None:
        if self.path:
            tmp = Path(self.path + ".tmp")
            tmp.write_text(json.dumps(self.record, indent=1, default=str))
            tmp.replace(self.path)


def summary_line(record: dict) -> str:
    """One line of a run's JSON record: the target-choice id's rates by size and regime, the parity, the
    PPO rate, and how many stages failed or were skipped."""
    if not record.get("measured"):
        return f"bench_gpu: {record.get('reason', 'not measured')}"
    parts = [f"bench_gpu on {record.get('device')}"]
    for size, r in record.get("env_only", {}).get(IDS[0], {}).items():
        if "held" in r:
            parts.append(f"{size} held {r['held']['physics_steps_per_s'] / 1e6:.2f}M / slewing "
                         f"{r['slewing']['physics_steps_per_s'] / 1e6:.2f}M steps/s")  # fmt: skip
    cpu = record.get("cpu_reference", {}).get(IDS[0], {})
    if "held" in cpu:
        parts.append(f"CPU {cpu['n']} rows held {cpu['held']['physics_steps_per_s'] / 1e6:.2f}M")
    par = record.get("parity", {})
    if par:
        ok = sum(bool(p.get("all_within_tolerance")) for p in par.values())
        parts.append(f"parity {ok}/{len(par)} within tolerance")
    if "decisions_per_s_median" in record.get("ppo", {}):
        parts.append(f"PPO {record['ppo']['physics_steps_per_s_median'] / 1e6:.2f}M steps/s")
    flat = json.dumps(record, default=str)
    failed, skipped = flat.count('"error":'), flat.count('"skipped":')
    parts.append(f"{failed} failed, {skipped} skipped stages")
    return "; ".join(parts)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10, 12, 14, 16, 18, 20], help="log2 of N")
    p.add_argument("--decisions", type=int, default=5, help="timed decisions per block")
    p.add_argument("--warmup", type=int, default=3, help="decisions of each regime before its timing")
    p.add_argument("--deadline-s", type=float, default=0.0,
                   help="start no stage past this many seconds (0: none); the JSON is printed")  # fmt: skip
    p.add_argument("--out", help="rewrite the JSON record to this file after every stage")
    p.add_argument("--summarize", metavar="JSON", help="print the one-line summary of a recorded run, exit")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--bank", type=int, default=1 << 14, help="bank size (at most N)")
    p.add_argument("--cpu-n", type=int, default=1024, help="rows of the CPU reference (0: none)")
    p.add_argument("--parity-steps", type=int, default=200, help="decisions of the parity check (0: none)")
    p.add_argument("--parity-rows", type=int, default=32, help="rows of the parity check")
    p.add_argument("--parity-ids", choices=("all", "bench"), default="all",
                   help="parity on every registered id, or on the three timed ones")  # fmt: skip
    p.add_argument("--skip-ppo", action="store_true")
    p.add_argument("--ppo-n", type=int, default=1 << 14)
    p.add_argument("--ppo-updates", type=int, default=5)
    p.add_argument(
        "--max-registers",
        type=int,
        nargs="*",
        default=[],
        help="also time the target-choice id at the largest size with the registers capped",
    )
    p.add_argument("--bank-workers", type=int, default=os.cpu_count() or 1,
                   help="processes that draw the bank (default: the CPUs)")  # fmt: skip
    args = p.parse_args(argv)
    if args.summarize:
        print(summary_line(json.loads(Path(args.summarize).read_text())))
        return 0
    workers = sorted({1, args.bank_workers})
    why = cuda_unavailable_reason()
    if why is not None:
        bank_draw = {env_id: [bank_draw_rate(env_id, w, 256 * w) for w in workers] for env_id in IDS}
        record = {"measured": False, "reason": f"not measured: no CUDA device ({why})", "cpu": cpu_model(),
                  "bank_draw": bank_draw}  # fmt: skip
        Stages(record, 0.0, args.out).save()
        print(json.dumps(record, indent=1))
        print(summary_line(record), file=sys.stderr, flush=True)
        return 0
    import torch

    out: dict = {"measured": True, "device": torch.cuda.get_device_name(0), "cpu": cpu_model(),
                 "torch": torch.__version__, "env_only": {}, "cpu_reference": {}, "parity": {},
                 "bank_draw": {}}  # fmt: skip
    st = Stages(out, args.deadline_s, args.out)
    # In the order of what a short loan must not miss (each stage is in the log and the --out file when it
    # finishes): the target-choice rates (the first stage compiles the kernels and the CPU core), the CPU
    # reference beside them, the parity on the timed ids, the PPO's rate, the other timed ids, then what
    # can wait.
    for s in args.sizes:
        st.run(out["env_only"].setdefault(IDS[0], {}), f"2^{s}", device_rate, IDS[0], 1 << s, args)
    if args.cpu_n:
        st.run(out["cpu_reference"], IDS[0], cpu_rate, IDS[0], args.cpu_n, args)
    parity_ids = [i for i in IDS if args.parity_steps]
    parity_ids += [i for i in ENV_IDS if args.parity_ids == "all" and args.parity_steps and i not in IDS]
    for env_id in parity_ids[: len(IDS)]:
        st.run(out["parity"], env_id, parity, env_id, args.parity_rows, args.parity_steps)
    if not args.skip_ppo:
        st.run(out, "ppo", ppo_rate, args)
    for env_id in IDS[1:]:
        for s in args.sizes:
            st.run(out["env_only"].setdefault(env_id, {}), f"2^{s}", device_rate, env_id, 1 << s, args)
    for env_id in IDS[1:] if args.cpu_n else ():
        st.run(out["cpu_reference"], env_id, cpu_rate, env_id, args.cpu_n, args)
    st.run(out, "kernels", kernel_report)
    capped = out.setdefault("max_registers", {})
    for cap in args.max_registers:
        st.run(capped, str(cap), device_rate, IDS[0], 1 << max(args.sizes), args, cap)
    for env_id in IDS:
        st.run(out["bank_draw"], env_id, lambda e: [bank_draw_rate(e, w, 256 * w) for w in workers], env_id)
    for env_id in parity_ids[len(IDS) :]:
        st.run(out["parity"], env_id, parity, env_id, args.parity_rows, args.parity_steps)
    print(json.dumps(out, indent=1, default=str))
    print(summary_line(out), file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
