"""What one kernel launch of the device env costs on the host in numba-cuda, measured without a GPU.

The device env launches its step kernel once a decision (each thread runs the decision's
``decision_steps`` physics steps, the compiled decision rule) and its autoreset kernel once a decision.
Each launch, numba-cuda 0.30 types the arguments
(``numba.cuda.typing.typeof``: the dispatcher picks the compiled overload), flattens them into the
kernel's parameters (``_Kernel._prepare_args``: each array becomes meminfo, parent, size, itemsize,
pointer, shape and strides) and packs those for the driver (cuda.core's ``ParamHolder``); only then does it
call ``cuLaunchKernel``. The records are named tuples of some hundred arrays, so this is Python work per
launch whatever the number of rows. This probe times those three parts on numba-cuda's own code, with
``DeviceNDArray`` stand-ins for the device env's arrays (same shapes, strides and dtypes; the memory a
stand-in: nothing reads it), and prints the bound they put on the env's rate: a decision of N rows takes
one step launch and one autoreset launch, so decisions/s <= N / (the two launches' time). Not timed
here: the C part of the dispatch, the driver's call and the
torch operations between launches. Those are counted instead: the torch operations of a decision other
than views (each one a kernel launch on a GPU, a few microseconds of the host's time), profiled in the host
mode (``device="cpu"``, the same Python as on CUDA) over 15 decisions of random target actions.

    python research/probes/launch_overhead_probe.py [--rounds 5]

The kernel parameters' total size is printed too: above the 4,096 bytes CUDA allowed before 12.1, under
the 32,764 bytes it allows since (Volta and later); ptxas checks it (tests/env/test_cuda_ptx.py
assembles every entry point).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core.records import Actions, map_arrays, scratch_rows
from planetnav_env.device.bank import BankRows
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.envs.spaces import action_size, action_space
from planetnav_env.numerics.cuda_target import device_typeof, require_numba_cuda

#: The benchmark's three ids, and the device PPO's task.
IDS = (
    "planetnav/Cruise-Target-v1", "planetnav/Cruise-TorqueControl-v1", "planetnav/MarsApproach-Tasking-v1",
    "planetnav/Cruise-Target-v2",
)  # fmt: skip
ROWS = (2**10, 2**14, 2**18)


class _StandInMemory:
    """What a DeviceNDArray reads of its memory when it is passed to a kernel: a device pointer."""

    def __init__(self) -> None:
        self.device_ctypes_pointer = ctypes.c_void_p(0x10000)


def _stand_in(value: Any) -> Any:
    """``value`` with each numpy array replaced by a DeviceNDArray of its shape, strides and dtype (an empty
    one by a one-element one: numba-cuda makes an empty device array only with a CUDA context)."""
    from numba.cuda.cudadrv.devicearray import DeviceNDArray

    def device(a: np.ndarray) -> DeviceNDArray:
        a = a if a.size else np.zeros(tuple(max(d, 1) for d in a.shape), a.dtype)
        return DeviceNDArray(a.shape, a.strides, a.dtype, gpu_data=_StandInMemory())

    return map_arrays(device, value)


def _median_time(f: Callable[[], Any], rounds: int, reps: int = 100) -> float:
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(reps):
            f()
        times.append((time.perf_counter() - t) / reps)
    return statistics.median(times)


def launch_costs(host_args: tuple, rounds: int) -> dict:
    """Median seconds per launch of typing, flattening and packing ``host_args`` (host records)."""
    from cuda.core.cu12._kernel_arg_handler import ParamHolder
    from numba.cuda.dispatcher import _Kernel
    from numba.cuda.typing.typeof import Purpose, typeof

    class Flattener:  # the one method of a compiled kernel this needs, on numba-cuda's own code
        extensions = ()
        _prepare_args = _Kernel._prepare_args

    flattener = Flattener()
    args = tuple(_stand_in(a) for a in host_args)
    types = tuple(device_typeof(a) for a in host_args)

    def flatten() -> list:
        params: list = []
        for t, v in zip(types, args, strict=True):
            flattener._prepare_args(t, v, 0, [], params)
        return params

    params = flatten()
    parts = {
        "typeof_s": _median_time(lambda: [typeof(a, Purpose.argument) for a in args], rounds),
        "flatten_s": _median_time(flatten, rounds),
        "pack_s": _median_time(lambda: ParamHolder(params), rounds),
    }
    return {"parameters": len(params), "parameter_bytes": 8 * len(params), **parts,
            "per_launch_s": sum(parts.values())}  # fmt: skip


#: Operations that make a view (no kernel on a GPU).
VIEW_OPS = frozenset(
    f"aten::{name}"
    for name in ("select", "slice", "unsqueeze", "view", "reshape", "expand", "as_strided", "alias",
                 "diagonal", "transpose", "t", "detach", "_reshape_alias", "lift_fresh", "result_type")
)  # fmt: skip


def torch_ops_per_decision(env_id: str, decisions: int = 15, rows: int = 64) -> float:
    """Top-level torch operations other than views per decision of the device env in host mode."""
    import torch
    from torch.profiler import ProfilerActivity, profile

    from planetnav_env.device.vector_env import DeviceVectorEnv

    env = DeviceVectorEnv(env_id, num_envs=rows, device="cpu", refill="off")
    env.reset(seed=0)
    gen = torch.Generator().manual_seed(0)
    n = getattr(env.single_action_space, "n", None)

    def action() -> torch.Tensor:
        if n is not None:
            return torch.randint(0, int(n), (rows,), generator=gen)
        return torch.rand((rows, *env.single_action_space.shape), generator=gen) * 2 - 1

    for _ in range(5):
        env.step(action())
    actions = [action() for _ in range(decisions)]
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for a in actions:
            env.step(a)
    env.close()
    top = [e for e in prof.events() if e.cpu_parent is None and e.name not in VIEW_OPS]
    return len(top) / decisions


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="timed rounds of 100 launches' work (median)")
    args = ap.parse_args(argv)
    require_numba_cuda()
    out = {}
    for env_id in IDS:
        cfg = EnvConfig.from_dict(ENV_IDS[env_id])
        core = BatchCore(cfg, 4)
        n = core.num_rows
        rows = scratch_rows(core.params, n)
        act = Actions(
            raw=np.zeros((n, action_size(action_space(cfg)))), targets=np.zeros(n, np.int64),
            torques=np.zeros((n, 3)), active=np.ones(n, np.bool_),
        )  # fmt: skip
        bank = BankRows(f=core.f, p=core.p, rng=core.rng, eph=core.eph)
        slots, mask = np.zeros(n, np.int64), np.zeros(n, np.bool_)
        kernels = {
            "step": launch_costs((core.params, core.state, act, rows), args.rounds),
            "autoreset": launch_costs((core.params, core.state, bank, slots, mask, rows), args.rounds),
        }
        k_steps = cfg.decision_steps
        per_decision = kernels["step"]["per_launch_s"] + kernels["autoreset"]["per_launch_s"]
        ops = torch_ops_per_decision(env_id)
        out[env_id] = {
            "decision_steps": k_steps,
            "torch_ops_per_decision": ops,
            "kernels": kernels,
            "host_s_per_decision": per_decision,
            "decisions_per_s_at_most": {f"2^{int(np.log2(r))}": r / per_decision for r in ROWS},
        }
        s = kernels["step"]
        print(
            f"{env_id}: step {s['parameters']} parameters ({s['parameter_bytes']} bytes), "
            f"{s['per_launch_s'] * 1e6:.0f} us a launch (typeof {s['typeof_s'] * 1e6:.0f}, flatten "
            f"{s['flatten_s'] * 1e6:.0f}, pack {s['pack_s'] * 1e6:.0f}); autoreset "
            f"{kernels['autoreset']['per_launch_s'] * 1e6:.0f} us; 1 + 1 launches a decision: "
            + ", ".join(f"N={r}: <= {r / per_decision / 1e6:.2f}M decisions/s" for r in ROWS)
            + f"; and {ops:.0f} torch operations a decision",
            flush=True,
        )
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
