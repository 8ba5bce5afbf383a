"""GPU throughput: the device env's env-only steps/s at N = 2^10 .. 2^20 on three ids, the device PPO's
end-to-end rate, and the parity of the GPU's rows with the CPU's; JSON on stdout.

    python benchmarks/bench_gpu.py                  # everything (a few minutes on one H100)
    python benchmarks/bench_gpu.py --sizes 10 14 18 --skip-ppo

Ids: planetnav/Cruise-Target-v1 (target choice, 10 physics steps a decision),
planetnav/Cruise-TorqueControl-v1 (1-s torque control), planetnav/MarsApproach-Tasking-v1 (the Mars
approach). A rate is physics steps (row x decision x ``decision_steps``) per second and decisions per
second, best of ``--repeats`` timed blocks after a warm-up step; ``setup_s`` holds the bank's drawing,
its upload and the kernels' compilation. The CPU's native vector env at ``--cpu-n`` rows is measured in
the same run as the reference ratio (its rate is this machine's CPUs'). Parity: the device env on CUDA
against its host mode (the CPU build of the same thread functions) over ``--parity-steps`` decisions with
the same actions: the largest differences of the state and the observation, and whether they are equal
bit for bit. Bank: the host's drawing rate of the refill (episodes/s, one thread, measured with or without
a device) and the decisions/s it feeds (episodes/s x decisions per episode: above that rate a thread
refill substitutes), and at each size the bank's statistics after the timed blocks (substitutes among
the episodes started). Without a CUDA device it prints ``{"measured": false, "reason": ..., "bank_draw":
...}`` and exits 0: no device figure is claimed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401
from planetnav_env.core.batch import BatchCore
from planetnav_env.device.bank import EpisodeBank
from planetnav_env.device.draw_pool import DrawPool
from planetnav_env.device.vector_env import DeviceVectorEnv, cuda_unavailable_reason
from planetnav_env.envs.env import resolve_config
from planetnav_train.provenance import cpu_model

IDS = ("planetnav/Cruise-Target-v1", "planetnav/Cruise-TorqueControl-v1", "planetnav/MarsApproach-Tasking-v1")
ROOT = Path(__file__).resolve().parents[1]


def _torch_actions(env, rng: np.random.Generator, torch):
    n, space = env.num_envs, env.single_action_space
    if isinstance(space, gym.spaces.Discrete):
        a = torch.as_tensor(rng.integers(0, space.n, n))
    else:
        a = torch.as_tensor(rng.uniform(-1, 1, (n, *space.shape)).astype(np.float32))
    return a.to(env.device)


def device_rate(env_id: str, n: int, args) -> dict:
    """Env-only rate of the device env with ``n`` rows (fixed random actions; the timed blocks are shorter
    than an episode, so the bank's refill does not enter: the PPO run's does)."""
    import torch

    decisions, repeats = args.decisions, args.repeats
    t0 = time.perf_counter()
    env = DeviceVectorEnv(env_id, n, device="cuda", bank_size=min(args.bank, n), bank_workers=0)
    env.reset(seed=0)
    torch.cuda.synchronize()
    setup = time.perf_counter() - t0
    a = _torch_actions(env, np.random.default_rng(0), torch)
    env.step(a)
    torch.cuda.synchronize()
    best = 0.0
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(decisions):
            env.step(a)
        torch.cuda.synchronize()
        best = max(best, n * decisions / (time.perf_counter() - t))
    k = env.config.decision_steps
    out = {"n": n, "decisions_per_s": best, "physics_steps_per_s": best * k, "setup_s": setup,
           "bytes_per_row": env.bytes_per_row(), "bank": env.bank_stats()}  # fmt: skip
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
    decisions = -(-cfg.episode_steps // cfg.decision_steps)
    return {"workers": workers, "episodes_per_s": rate, "decisions_per_episode": decisions,
            "feeds_decisions_per_s": rate * decisions}  # fmt: skip


def cpu_rate(env_id: str, n: int, decisions: int, repeats: int) -> dict:
    """The native CPU vector env's rate at ``n`` rows (the reference ratio)."""
    env = gym.make_vec(env_id, num_envs=n)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    a = env.action_space.sample() if not isinstance(env.single_action_space, gym.spaces.Discrete) else None
    a = rng.integers(0, env.single_action_space.n, n) if a is None else a
    env.step(a)
    best = 0.0
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(decisions):
            env.step(a)
        best = max(best, n * decisions / (time.perf_counter() - t))
    k = env.unwrapped.config.decision_steps
    return {"n": n, "decisions_per_s": best, "physics_steps_per_s": best * k}


def parity(env_id: str, n: int, steps: int) -> dict:
    """The device env on CUDA against its host mode, the same actions: largest differences."""
    import torch

    # A bank as deep as the run: both play the CPU env's episodes, no refill needed.
    deep = {"bank_size": n * (steps + 2), "refill": "off", "bank_workers": 0}
    envs = {d: DeviceVectorEnv(env_id, n, device=d, **deep) for d in ("cuda", "cpu")}
    for e in envs.values():
        e.reset(seed=1)
    rng = np.random.default_rng(2)
    worst = {"obs_abs": 0.0, "obs_rel": 0.0}
    for _ in range(steps):
        a = _torch_actions(envs["cpu"], rng, torch)
        o = {d: e.step(a.to(e.device))[0].cpu().numpy() for d, e in envs.items()}
        diff = np.abs(o["cuda"].astype(float) - o["cpu"])
        worst["obs_abs"] = max(worst["obs_abs"], float(np.nanmax(diff)))
        worst["obs_rel"] = max(worst["obs_rel"], float(np.nanmax(diff / np.maximum(np.abs(o["cpu"]), 1e-30))))
    sg, sc = envs["cuda"].state_arrays(), envs["cpu"].state_arrays()
    out = {"steps": steps, "rows": n, **worst}
    for k in ("f", "p", "obs"):
        d = np.abs(sg[k] - sc[k])
        out[f"{k}_max_abs"] = float(np.nanmax(d))
        out[f"{k}_max_rel"] = float(np.nanmax(d / np.maximum(np.abs(sc[k]), 1e-30)))
    out["i_equal"] = bool(np.array_equal(sg["i"], sc["i"]))
    out["bit_for_bit"] = all(sg[k].tobytes() == sc[k].tobytes() for k in sg)
    return out


def ppo_rate(args) -> dict:
    """End-to-end env steps/s of baselines/ppo_device.py on the target-choice task (no evaluation)."""
    cmd = [sys.executable, str(ROOT / "baselines" / "ppo_device.py"), "--device", "cuda",
           "--env-id", IDS[0], "--num-envs", str(args.ppo_n), "--num-steps", "16", "--num-minibatches", "4",
           "--update-epochs", "4", "--total-timesteps", str(args.ppo_n * 16 * args.ppo_updates),
           "--eval-episodes", "0", "--bank-workers", str(args.bank_workers)]  # fmt: skip
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("iter")]
    bank = [ln for ln in proc.stdout.splitlines() if ln.startswith("bank:")]
    sps = [float(ln.rsplit("SPS", 1)[1]) for ln in lines]
    return {"n": args.ppo_n, "updates": len(lines), "decisions_per_s_last": sps[-1] if sps else None,
            "physics_steps_per_s_last": sps[-1] * 10 if sps else None, "wall_s": time.perf_counter() - t,
            "bank": bank[-1] if bank else None, "returncode": proc.returncode,
            "stderr_tail": proc.stderr[-2000:] if proc.returncode else ""}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10, 12, 14, 16, 18, 20], help="log2 of N")
    p.add_argument("--decisions", type=int, default=5, help="timed decisions per block")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--bank", type=int, default=1 << 14, help="bank size (at most N)")
    p.add_argument("--cpu-n", type=int, default=1024, help="rows of the CPU reference (0: none)")
    p.add_argument("--parity-steps", type=int, default=200, help="decisions of the parity check (0: none)")
    p.add_argument("--skip-ppo", action="store_true")
    p.add_argument("--ppo-n", type=int, default=1 << 14)
    p.add_argument("--ppo-updates", type=int, default=5)
    p.add_argument("--bank-workers", type=int, default=os.cpu_count() or 1,
                   help="processes that draw the bank (default: the CPUs)")  # fmt: skip
    args = p.parse_args(argv)
    workers = sorted({1, args.bank_workers})
    bank_draw = {env_id: [bank_draw_rate(env_id, w, 256 * w) for w in workers] for env_id in IDS}
    why = cuda_unavailable_reason()
    if why is not None:
        print(json.dumps({"measured": False, "reason": f"not measured: no CUDA device ({why})",
                          "cpu": cpu_model(), "bank_draw": bank_draw}, indent=1))  # fmt: skip
        return 0
    import torch

    out: dict = {"measured": True, "device": torch.cuda.get_device_name(0), "cpu": cpu_model(),
                 "torch": torch.__version__, "env_only": {}, "cpu_reference": {}, "parity": {},
                 "bank_draw": bank_draw}  # fmt: skip
    for env_id in IDS:
        if args.parity_steps:
            out["parity"][env_id] = parity(env_id, 64, args.parity_steps)
        out["env_only"][env_id] = [device_rate(env_id, 1 << s, args) for s in args.sizes]
        if args.cpu_n:
            out["cpu_reference"][env_id] = cpu_rate(env_id, args.cpu_n, args.decisions, args.repeats)
        print(json.dumps({env_id: out["env_only"][env_id]}), file=sys.stderr, flush=True)
    if not args.skip_ppo:
        out["ppo"] = ppo_rate(args)
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
