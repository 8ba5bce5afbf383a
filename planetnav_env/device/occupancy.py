"""How many of a kernel's threads a GPU keeps resident per multiprocessor (SM), from its registers per
thread and its block size: the occupancy that bounds a register-heavy kernel such as the row step.

The rule is CUDA's occupancy calculation for compute capability 7.0 and later (``cuda_occupancy.h``,
``cudaOccMaxActiveBlocksPerMultiprocessor``), restricted to what these kernels use (no shared memory):

* a warp's registers are ``registers per thread x 32`` rounded up to the allocation unit (256);
* an SM's register file is split into sub-partitions (4), each holding whole warps, so the warps an SM
  holds are ``4 x floor(registers per sub-partition / registers per warp)``;
* a block launches at all only if its warps, rounded up to the sub-partitions, fit the per-block register
  limit (the hardware's check), and if it has at most ``max_threads_per_block`` threads;
* the resident blocks are the smallest of the register limit, the warp limit (``max_threads_per_sm / 32``
  warps) and the block limit (``max_blocks_per_sm``).

A device's driver answers the same question for a compiled kernel
(``cuOccupancyMaxActiveBlocksPerMultiprocessor``): ``benchmarks/bench_gpu.py`` prints both on a device. Here
the register count comes from ``ptxas`` (:mod:`planetnav_env.device.kernel_resources`) or, on a device,
from the compiled kernel.
"""

from __future__ import annotations

from dataclasses import dataclass

from planetnav_env.errors import InvalidParameterError, require_count


@dataclass(frozen=True)
class SmLimits:
    """The per-SM resources of a compute capability that decide occupancy (CUDA C++ Programming Guide,
    "Technical Specifications per Compute Capability"). Registers are 32-bit."""

    name: str
    regs_per_sm: int = 65536
    regs_per_block: int = 65536
    max_regs_per_thread: int = 255
    #: Registers are allocated to a warp in units of this many.
    reg_alloc_unit: int = 256
    #: Register-file partitions of an SM; each holds whole warps.
    sub_partitions: int = 4
    max_threads_per_sm: int = 2048
    max_blocks_per_sm: int = 32
    max_threads_per_block: int = 1024
    warp_size: int = 32

    @property
    def max_warps_per_sm(self) -> int:
        return self.max_threads_per_sm // self.warp_size


#: Compute capability 9.0: the H100 and H200 this project's devices are.
SM_90 = SmLimits(name="compute capability 9.0 (H100, H200)")
#: Compute capability 8.0: the A100.
SM_80 = SmLimits(name="compute capability 8.0 (A100)")
#: The limits by compute capability.
SM_LIMITS: dict[tuple[int, int], SmLimits] = {(9, 0): SM_90, (8, 0): SM_80}

#: Threads per block of the device env's kernels. The step's 200 registers per thread leave 8 warps per SM
#: at any block size that fits (``python benchmarks/kernel_resources.py``); 128 holds them in 2 blocks.
THREADS_PER_BLOCK = 128


def limits_for(cc: tuple[int, int]) -> SmLimits:
    """The :class:`SmLimits` of compute capability ``cc``, or an error naming the ones known."""
    try:
        return SM_LIMITS[tuple(cc)]
    except KeyError:
        known = ", ".join(f"{a}.{b}" for a, b in SM_LIMITS)
        raise InvalidParameterError(
            f"no occupancy limits for compute capability {cc!r} (known: {known}); pass an SmLimits"
        ) from None


def _round_up(x: int, unit: int) -> int:
    return -(-x // unit) * unit


def _check(regs_per_thread: int, threads_per_block: int, limits: SmLimits) -> None:
    require_count("regs_per_thread", regs_per_thread)
    require_count("threads_per_block", threads_per_block)
    if regs_per_thread > limits.max_regs_per_thread:
        raise InvalidParameterError(
            f"regs_per_thread must be at most {limits.max_regs_per_thread} on {limits.name}, "
            f"got {regs_per_thread}"
        )


def blocks_per_sm(regs_per_thread: int, threads_per_block: int, limits: SmLimits = SM_90) -> int:
    """Blocks of ``threads_per_block`` threads, each using ``regs_per_thread`` registers, resident on one SM
    at once; 0 when such a block cannot launch (too many threads, or too many registers for a block)."""
    _check(regs_per_thread, threads_per_block, limits)
    if threads_per_block > limits.max_threads_per_block:
        return 0
    warps_per_block = -(-threads_per_block // limits.warp_size)
    regs_per_warp = _round_up(regs_per_thread * limits.warp_size, limits.reg_alloc_unit)
    # The hardware's launch check assumes the block's warps are spread over every sub-partition.
    if regs_per_warp * _round_up(warps_per_block, limits.sub_partitions) > limits.regs_per_block:
        return 0
    warps_by_regs = (limits.regs_per_sm // limits.sub_partitions // regs_per_warp) * limits.sub_partitions
    return min(
        warps_by_regs // warps_per_block,
        limits.max_warps_per_sm // warps_per_block,
        limits.max_blocks_per_sm,
    )


def warps_per_sm(regs_per_thread: int, threads_per_block: int, limits: SmLimits = SM_90) -> int:
    """Warps resident on one SM (see :func:`blocks_per_sm`)."""
    blocks = blocks_per_sm(regs_per_thread, threads_per_block, limits)
    return blocks * -(-threads_per_block // limits.warp_size)


def occupancy(regs_per_thread: int, threads_per_block: int, limits: SmLimits = SM_90) -> float:
    """Resident warps over the SM's maximum (0 to 1)."""
    return warps_per_sm(regs_per_thread, threads_per_block, limits) / limits.max_warps_per_sm


def best_threads_per_block(regs_per_thread: int, limits: SmLimits = SM_90) -> int:
    """The block size (a multiple of the warp size) with the most resident threads per SM; among equals the
    largest, as ``cudaOccMaxPotentialOccupancyBlockSize`` chooses."""
    best, best_threads = 0, 0
    for tpb in range(limits.max_threads_per_block, 0, -limits.warp_size):
        threads = blocks_per_sm(regs_per_thread, tpb, limits) * tpb
        if threads > best_threads:
            best, best_threads = tpb, threads
    return best


def register_steps(limits: SmLimits = SM_90) -> list[tuple[int, int]]:
    """The occupancy steps: ``(most registers per thread, warps per SM)`` for each warp count the register
    file allows, from the fewest warps up (blocks of a multiple of 4 warps reach them). A kernel gains
    resident warps only by going below one of these register counts."""
    steps: dict[int, int] = {}
    for regs in range(limits.max_regs_per_thread, 0, -1):
        regs_per_warp = _round_up(regs * limits.warp_size, limits.reg_alloc_unit)
        warps = (limits.regs_per_sm // limits.sub_partitions // regs_per_warp) * limits.sub_partitions
        warps = min(warps, limits.max_warps_per_sm)
        steps.setdefault(warps, regs)
    return sorted(((r, w) for w, r in steps.items()), key=lambda rw: rw[1])


def require_launchable(kernel: str, regs_per_thread: int, threads_per_block: int, limits: SmLimits) -> None:
    """Raise :class:`InvalidParameterError` naming ``threads_per_block`` when a block of that size of
    ``kernel`` (``regs_per_thread`` registers) cannot launch, with the largest size that can."""
    if blocks_per_sm(regs_per_thread, threads_per_block, limits) == 0:
        fits = max(
            (t for t in range(limits.warp_size, limits.max_threads_per_block + 1, limits.warp_size)
             if blocks_per_sm(regs_per_thread, t, limits) > 0),
            default=0,
        )  # fmt: skip
        raise InvalidParameterError(
            f"threads_per_block={threads_per_block} cannot launch {kernel}: it uses {regs_per_thread} "
            f"registers per thread, so on {limits.name} a block holds at most {fits} threads"
        )


__all__ = [
    "SM_80", "SM_90", "SM_LIMITS", "SmLimits", "best_threads_per_block", "blocks_per_sm", "limits_for",
    "occupancy", "register_steps", "require_launchable", "warps_per_sm",
]  # fmt: skip
