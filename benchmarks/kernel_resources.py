"""The device kernels' resources on an H100/H200 (compute capability 9.0), without a GPU: JSON on stdout.

    python benchmarks/kernel_resources.py                        # step and autoreset; no register cap
    python benchmarks/kernel_resources.py --max-registers 168 128 --kernels step

For each kernel the device env launches (the step of every registered id, and the autoreset) it
compiles the PTX numba-cuda would (:func:`planetnav_env.numerics.cuda_target.compile_ptx`), assembles it
with ``ptxas`` (:mod:`planetnav_env.device.kernel_resources`) and prints the registers per thread, the stack
frame and spills, and the occupancy they allow (:mod:`planetnav_env.device.occupancy`): resident warps per
SM at the device env's block size and at the best one, and the register counts at which the next
occupancy step starts. ``--max-registers R`` assembles again with the registers capped at ``R`` (what
``cuda.jit(max_registers=R)`` does), to show what a higher occupancy would cost in spills. It also counts
the PTX's fused multiply-adds (``fma.rn.f64``): NVVM contracts a multiply and an add into one rounding
where the CPU build rounds twice, one reason the GPU's rows are not the CPU's bit for bit; and its loads and
stores by state space, in the whole kernel and in its largest innermost loops (the step's are the attitude
sub-step loop at its two call sites: what a sub-step moves, the memory-bound estimate of
docs/performance.md).

The registered ids share their numba types, hence one PTX per entry point; the script checks that and
names the ids of each PTX. These are compiler figures (numba-cuda, NVVM and ptxas of the ``[gpu]`` extra's
releases, printed), the same on any machine with those releases; they are not speeds.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numba

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core.cuda_entry import ENTRY_POINTS, entry_argtypes
from planetnav_env.device import occupancy as O
from planetnav_env.device.cuda_kernels import autoreset_argtypes, autoreset_kernel
from planetnav_env.device.kernel_resources import assemble, find_ptxas, innermost_loops, memory_ops
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.numerics.cuda_target import DEFAULT_CC, compile_ptx

KERNELS = {"step": ENTRY_POINTS["step"], "autoreset": autoreset_kernel}


def _types_by_kernel() -> dict[str, dict[tuple, list[str]]]:
    """Per kernel: its argument types, with the ids that have them."""
    out: dict[str, dict[tuple, list[str]]] = {k: {} for k in KERNELS}
    for env_id, kw in ENV_IDS.items():
        core = BatchCore(EnvConfig.from_dict(kw), 2)
        types = {**entry_argtypes(core), "autoreset": autoreset_argtypes(core)}
        for k in KERNELS:
            out[k].setdefault(types[k], []).append(env_id)
    return out


def _occupancy(regs: int, limits: O.SmLimits) -> dict:
    best = O.best_threads_per_block(regs, limits)
    at_best = O.warps_per_sm(regs, best, limits)
    more = [(r, w) for r, w in O.register_steps(limits) if w > at_best]
    return {
        "threads_per_block": O.THREADS_PER_BLOCK,
        "warps_per_sm": O.warps_per_sm(regs, O.THREADS_PER_BLOCK, limits),
        "occupancy": O.occupancy(regs, O.THREADS_PER_BLOCK, limits),
        "best_threads_per_block": best,
        "warps_per_sm_at_best": at_best,
        "next_step": {"registers_at_most": more[0][0], "warps_per_sm": more[0][1]} if more else None,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--kernels", nargs="+", choices=list(KERNELS), default=list(KERNELS))
    p.add_argument("--max-registers", type=int, nargs="*", default=[], help="also assemble with these caps")
    args = p.parse_args(argv)
    limits = O.limits_for(DEFAULT_CC)
    ptxas = find_ptxas()
    from importlib.metadata import version

    out: dict = {
        "compute_capability": f"{DEFAULT_CC[0]}.{DEFAULT_CC[1]}", "limits": limits.name,
        "numba": numba.__version__, "numba_cuda": version("numba-cuda"), "ptxas": ptxas, "kernels": {},
    }  # fmt: skip
    for kernel, by_types in _types_by_kernel().items():
        if kernel not in args.kernels:
            continue
        for types, ids in by_types.items():
            t = time.perf_counter()
            ptx = compile_ptx(KERNELS[kernel], types, DEFAULT_CC)
            compile_s = time.perf_counter() - t
            rows = []
            for cap in [None, *args.max_registers]:
                t = time.perf_counter()
                (res,) = assemble(ptx, DEFAULT_CC, cap, ptxas).values()
                rows.append({
                    "max_registers": cap, "registers": res.registers, "stack_bytes": res.stack_bytes,
                    "spill_store_bytes": res.spill_store_bytes, "spill_load_bytes": res.spill_load_bytes,
                    **_occupancy(res.registers, limits), "ptxas_s": round(time.perf_counter() - t, 1),
                })  # fmt: skip
            entry = {"ids": len(ids) if len(by_types) == 1 else ids, "ptx_chars": len(ptx),
                     "ptx_fma_f64": ptx.count("fma.rn.f64"), "memory_ops": memory_ops(ptx),
                     "largest_innermost_loops": innermost_loops(ptx), "nvvm_compile_s": round(compile_s, 1),
                     "assembled": rows}  # fmt: skip
            out["kernels"].setdefault(kernel, []).append(entry)
            print(json.dumps({kernel: entry}), file=sys.stderr, flush=True)
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
