"""Whether the GPU's rows equal the CPU's: the comparison and its stated tolerance.

The GPU runs the same row functions as the CPU build, but rounds differently in two places: NVVM fuses a
multiply and an add into one FMA (one rounding where the CPU build rounds twice; the step's PTX holds about
3,000 of them), and libdevice's ``sin``, ``atan2`` ... differ from glibc's in the last bit. So the rows are
compared bit for bit and, failing that, against :data:`PARITY_TOLERANCE`. The filter damps what such
roundings seed rather than growing it: FMA contraction alone, measured on the CPU
(``python research/probes/fma_contraction_probe.py``), stays far inside the tolerance, and the discrete
state (status codes, counters, targets) stays equal. ``benchmarks/bench_gpu.py`` applies it to the device
env on CUDA against its host mode on every registered id.
"""

from __future__ import annotations

import numpy as np

#: The tolerance: room for an FMA's and a libdevice function's last-bit differences and what the step
#: makes of them, far above what contraction alone does on the CPU (the module docstring).
PARITY_TOLERANCE = {
    "observation": 1e-6,  # |d| <= tol * max(|value|, 1): 16 float32 ulps of an O(1) feature
    "reward": 1e-9,  # |d| <= tol * the largest |reward| of the run
    "covariance": 1e-9,  # |dP_ij| <= tol * sqrt(P_ii P_jj), per row: the entry's own scale
}


def row_differences(gpu: np.ndarray, cpu: np.ndarray, rows_axes: int = 1) -> dict:
    """How far ``gpu`` is from ``cpu`` (the same shape; the first ``rows_axes`` axes count rows or steps,
    the others name a quantity): over the entries finite in both, the largest absolute difference, the
    largest difference relative to the quantity's scale (its largest ``|cpu|`` over the rows: a value
    near zero does not inflate it), the largest and 99th-percentile difference relative to the entry's own
    ``|cpu|``, how many entries differ, and whether the same entries are finite."""
    a, b = np.asarray(gpu, float), np.asarray(cpu, float)
    both = np.isfinite(a) & np.isfinite(b)
    axes = tuple(range(rows_axes))
    scale = np.broadcast_to(np.nanmax(np.where(both, np.abs(b), 0.0), axis=axes, keepdims=True), b.shape)
    d = np.abs(a - b)[both]
    rel = d / np.maximum(np.abs(b[both]), 1e-300)
    return {"max_abs": float(d.max(initial=0.0)),
            "max_scaled": float((d / np.maximum(scale[both], 1e-300)).max(initial=0.0)),
            "max_rel": float(rel.max(initial=0.0)),
            "rel_p99": float(np.quantile(rel, 0.99)) if rel.size else 0.0,
            "entries_differing": f"{int((d > 0).sum())} of {d.size}",
            "finite_pattern_equal": bool(np.array_equal(np.isfinite(a), np.isfinite(b)))}  # fmt: skip


def compare_runs(gpu: dict, cpu: dict) -> dict:
    """Two runs of the same episodes and actions: ``obs`` (decisions, rows, D), ``reward`` (decisions,
    rows), and the final state ``f``, ``p`` (rows, 6, 6), ``i``. Their :func:`row_differences`, whether
    each is within :data:`PARITY_TOLERANCE` (and the discrete state ``i`` equal, the same entries finite),
    and whether they are equal bit for bit."""
    out = {"observation": row_differences(gpu["obs"], cpu["obs"], 2),
           "reward": row_differences(gpu["reward"], cpu["reward"], 2),
           "state_f": row_differences(gpu["f"], cpu["f"]),
           "state_p": row_differences(gpu["p"], cpu["p"])}  # fmt: skip
    tol = PARITY_TOLERANCE
    o_g, o_c = np.asarray(gpu["obs"], float), np.asarray(cpu["obs"], float)
    both = np.isfinite(o_g) & np.isfinite(o_c)
    obs_ok = bool(np.all(np.abs(o_g - o_c)[both] <= tol["observation"] * np.maximum(np.abs(o_c[both]), 1.0)))
    diag = np.abs(np.diagonal(cpu["p"], axis1=1, axis2=2))
    p_scale = np.sqrt(diag[:, :, None] * diag[:, None, :])
    p_off = np.nan_to_num(np.abs(gpu["p"] - cpu["p"]), nan=np.inf) / np.maximum(p_scale, 1e-300)
    # the covariance's largest difference in the tolerance's own terms
    out["state_p"]["max_of_sqrt_pii_pjj"] = float(p_off.max(initial=0.0))
    p_ok = bool(np.all(p_off <= tol["covariance"]))
    out["within_tolerance"] = {
        "observation": obs_ok and out["observation"]["finite_pattern_equal"],
        "reward": out["reward"]["max_scaled"] <= tol["reward"] and out["reward"]["finite_pattern_equal"],
        "covariance": p_ok,
        "discrete_state_equal": bool(np.array_equal(gpu["i"], cpu["i"])),
    }
    out["all_within_tolerance"] = all(out["within_tolerance"].values())
    out["bit_for_bit"] = all(np.asarray(gpu[k]).tobytes() == np.asarray(cpu[k]).tobytes() for k in gpu)
    return out


def run_actions(space, n: int, rng: np.random.Generator) -> np.ndarray:
    """A decision's random actions of ``n`` rows for the single-row action ``space`` (targets uniform over
    a Discrete space, Box entries uniform in [-1, 1] as float32)."""
    import gymnasium as gym

    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, space.n, n)
    return rng.uniform(-1, 1, (n, *space.shape)).astype(np.float32)


def record_run(env_id: str, n: int, steps: int, device: str) -> dict:
    """The device env on ``device`` for ``steps`` decisions of ``n`` rows, random actions from a fixed
    seed (:func:`run_actions`): the observations and rewards of every decision and the final state
    (``f``, ``p``, ``i``), as :func:`compare_runs` takes them. The same arguments give the same episodes
    and actions on any device."""
    import torch

    from planetnav_env.device.vector_env import DeviceVectorEnv

    # 4 N episodes cycled without a refill: the same sequence whatever the episodes' lengths.
    env = DeviceVectorEnv(env_id, n, device=device, bank_size=4 * n, refill="off", bank_workers=0)
    env.reset(seed=1)
    rng = np.random.default_rng(2)
    obs, reward = [], []
    for _ in range(steps):
        a = torch.as_tensor(run_actions(env.single_action_space, n, rng)).to(env.device)
        o, r = env.step(a)[:2]
        obs.append(o.cpu().numpy().copy())
        reward.append(r.cpu().numpy().copy())
    state = env.state_arrays()
    env.close()
    return {"obs": np.stack(obs), "reward": np.stack(reward), **{k: state[k] for k in ("f", "p", "i")}}


def record_cpu_vector_run(env_id: str, n: int, steps: int) -> dict:
    """:func:`record_run`'s run on the CPU vector env (``gym.make_vec``): the same episodes (seed 1, row
    ``n`` seeded ``1 + n``) and actions, as long as no row starts a fifth episode (``record_run``'s bank
    then replays one)."""
    import gymnasium as gym

    env = gym.make_vec(env_id, num_envs=n)
    env.reset(seed=1)
    rng = np.random.default_rng(2)
    obs, reward = [], []
    for _ in range(steps):
        o, r = env.step(run_actions(env.single_action_space, n, rng))[:2]
        obs.append(np.asarray(o, np.float32).copy())
        reward.append(np.asarray(r).copy())
    core = env.unwrapped.core
    out = {"obs": np.stack(obs), "reward": np.stack(reward), **{k: getattr(core, k).copy() for k in "fpi"}}
    env.close()
    return out


__all__ = [
    "PARITY_TOLERANCE", "compare_runs", "record_cpu_vector_run", "record_run", "row_differences",
    "run_actions",
]  # fmt: skip
