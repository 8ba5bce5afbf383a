"""CUDA entry points of the batch core: one thread per row (numba-cuda, the ``[gpu]`` extra).

No physics is written here. The step kernel is one thread's index arithmetic around a row function of
:mod:`planetnav_env.core.kernels` (:func:`~planetnav_env.core.kernels.step_thread`), and numba-cuda
compiles it, and everything it calls, as device functions from the same source as the CPU build (an
``@njit`` function called from a CUDA kernel is compiled from its Python source for the device). The rules
the row kernels follow so that they compile for both targets are in :mod:`planetnav_env.numerics.jit`.

The arguments are the CPU's records (:class:`~planetnav_env.core.records.CoreParams`,
:class:`~planetnav_env.core.records.RowState`, :class:`~planetnav_env.core.records.Actions`) with device
arrays in place of the numpy ones, and a :class:`~planetnav_env.core.records.Scratch` of one row per
state row (:func:`~planetnav_env.core.records.scratch_rows`: a thread cannot allocate). The per-row arrays
(state, actions, scratch) are laid out with the rows innermost in memory
(:func:`~planetnav_env.core.records.rows_innermost`), so that a warp's 32 threads, reading the same column
of 32 adjacent rows, read adjacent addresses; the kernels index them ``a[n, ...]`` as the CPU's, by
strides.

What is built and checked without a GPU: the PTX of the entry point for every registered id
(``tests/env/test_cuda_ptx.py``, :func:`entry_ptx`), and the thread functions on the CPU, bit for bit
against the chunked step. The device-resident environment that launches this kernel, and its autoreset
kernel (a bank row copied in, then the compiled reset), are in :mod:`planetnav_env.device`.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from planetnav_env.core.decoding import raw_action_size
from planetnav_env.core.kernels import step_thread
from planetnav_env.core.records import (
    Actions,
    CoreParams,
    RowState,
    rows_innermost,
    rows_innermost_like,
    scratch_rows,
)
from planetnav_env.numerics.cuda_target import DEFAULT_CC, compile_ptx, device_typeof, require_numba_cuda

__all__ = ["ENTRY_POINTS", "compile_ptx", "entry_argtypes", "entry_ptx", "step_kernel"]

cuda = require_numba_cuda()


def step_kernel(prm, st, act, rows) -> None:  # pragma: no cover - compiled
    """Thread ``n`` steps and observes row ``n`` (if ``act`` marks it active)."""
    n = cuda.grid(1)
    if n < st.f.shape[0]:
        step_thread(prm, st, act, rows, n)


#: The entry points, by name. The reset on a device is the device env's autoreset, which first copies a
#: row of its episode bank in (:func:`planetnav_env.device.cuda_kernels.autoreset_kernel`).
ENTRY_POINTS: dict[str, Any] = {"step": step_kernel}


class RowBatch(Protocol):
    """What the entry points' types are read from: the kernels' parameters and state of ``num_rows`` rows
    (:class:`planetnav_env.batch.BatchCore` is one, built above the core from a configuration)."""

    num_rows: int

    @property
    def params(self) -> CoreParams: ...

    @property
    def state(self) -> RowState: ...


def entry_argtypes(core: RowBatch) -> dict[str, tuple]:
    """The numba argument types of each entry point for the batch ``core``, as a launch with the records'
    arrays on the device types them (:func:`~planetnav_env.numerics.cuda_target.device_typeof`): the
    parameters as the CPU holds them, the state, actions and scratch rows innermost
    (:func:`~planetnav_env.core.records.rows_innermost`, the device env's layout)."""
    n = core.num_rows
    ps = core.params.scalars[0]
    act = Actions(
        raw=rows_innermost((n, raw_action_size(int(ps["mode"]), int(ps["n_planets"]))), np.float64),
        targets=np.zeros(n, np.int64),
        torques=rows_innermost((n, 3), np.float64),
        active=np.ones(n, np.bool_),
    )
    prm = device_typeof(core.params)
    st = device_typeof(rows_innermost_like(core.state))
    rows = device_typeof(scratch_rows(core.params, n))
    return {"step": (prm, st, device_typeof(act), rows)}


def entry_ptx(core: RowBatch, names: tuple[str, ...] = ("step",), cc=DEFAULT_CC) -> dict[str, str]:
    """PTX of the entry points ``names`` for ``core``'s types and compute capability ``cc`` (no GPU needed:
    :func:`~planetnav_env.numerics.cuda_target.compile_ptx`)."""
    types = entry_argtypes(core)
    return {name: compile_ptx(ENTRY_POINTS[name], types[name], cc) for name in names}
