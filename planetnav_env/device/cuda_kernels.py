"""The device env's CUDA kernels (numba-cuda, the ``[gpu]`` extra): the step and reset entry points of
:mod:`planetnav_env.core.cuda_entry`, and the autoreset kernel, one thread per row around
:func:`planetnav_env.device.rows.autoreset_thread`. No physics here either.

:func:`autoreset_ptx` compiles the autoreset kernel to PTX without a GPU (the compute capability supplied,
:mod:`planetnav_env.numerics.cuda_target`), as ``tests/env/test_device_env.py`` does for every id.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from planetnav_env.batch import BatchCore
from planetnav_env.core.cuda_entry import entry_argtypes
from planetnav_env.core.records import rows_innermost_like, scratch_rows
from planetnav_env.device.bank import BankRows
from planetnav_env.device.rows import autoreset_thread
from planetnav_env.numerics.cuda_target import DEFAULT_CC, compile_ptx, device_typeof, require_numba_cuda

cuda = require_numba_cuda()


def autoreset_kernel(prm, st, bank, slots, mask, rows) -> None:  # pragma: no cover - compiled
    """Thread ``n``: if ``mask[n]``, row ``n`` starts bank episode ``slots[n]`` (copy, then the compiled
    reset)."""
    n = cuda.grid(1)
    if n < st.f.shape[0]:
        autoreset_thread(prm, st, bank, slots, mask, rows, n)


def autoreset_argtypes(core: BatchCore) -> tuple:
    """The numba argument types of :func:`autoreset_kernel` for ``core``'s configuration, as the launch types
    them (:func:`~planetnav_env.numerics.cuda_target.device_typeof`): the state and scratch rows innermost
    (the device env's layout), the bank rows outermost (the host writes it a range of slots at a time)."""
    n = core.num_rows
    bank = BankRows(f=core.f, p=core.p, rng=core.rng, eph=core.eph)
    return tuple(
        device_typeof(v)
        for v in (core.params, rows_innermost_like(core.state), bank, np.zeros(n, np.int64),
                  np.zeros(n, np.bool_), scratch_rows(core.params, n))
    )  # fmt: skip


def autoreset_ptx(core: BatchCore, cc: tuple[int, int] = DEFAULT_CC) -> str:
    """PTX of :func:`autoreset_kernel` for ``core``'s types at compute capability ``cc`` (no GPU needed)."""
    return compile_ptx(autoreset_kernel, autoreset_argtypes(core), cc)


class Dispatchers(NamedTuple):
    """The device env's kernels as numba-cuda dispatchers (compiled at their first launch)."""

    step: Any
    autoreset: Any


def dispatchers(max_registers: int | None = None) -> Dispatchers:
    """The step and autoreset kernels, one dispatcher each per ``max_registers`` for the whole process.

    A dispatcher compiles a kernel once per argument types and keeps it, and every id has the same types;
    so every device env of a process shares one compilation (tens of seconds: NVVM, then the driver's
    assembly of a PTX of several MB) instead of repeating it for each env it creates. ``max_registers``
    caps the registers per thread (``cuda.jit(max_registers=...)``): more resident warps, paid in spills
    (``python benchmarks/kernel_resources.py --max-registers ...`` prints both)."""
    return _dispatchers(None if max_registers is None else int(max_registers))


@functools.cache
def _dispatchers(max_registers: int | None) -> Dispatchers:
    from planetnav_env.core.cuda_entry import step_kernel

    options = {} if max_registers is None else {"max_registers": max_registers}
    return Dispatchers(step=cuda.jit(**options)(step_kernel), autoreset=cuda.jit(**options)(autoreset_kernel))


__all__ = [
    "Dispatchers", "autoreset_argtypes", "autoreset_kernel", "autoreset_ptx", "dispatchers", "entry_argtypes",
]  # fmt: skip
