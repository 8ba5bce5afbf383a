"""Compile the row kernels for CUDA without a GPU: numba-cuda's PTX with the compute capability supplied.

numba-cuda (the ``[gpu]`` extra: ``pip install -e ".[gpu]"``) compiles a kernel to PTX on a machine without a
GPU (``numba.cuda.compile_ptx(..., cc=...)``), except that its dispatcher asks the CUDA driver for the
current device's compute capability whenever the kernel calls a device function that is not inlined:
``CUDADispatcher.compile_device`` calls ``get_current_device().compute_capability`` (numba-cuda 0.30,
``numba/cuda/dispatcher.py``), and without a driver that fails with ``CudaSupportError: Error at driver
init``. An ``@njit`` function called from a kernel takes the same path (the CUDA typing context wraps it in
a ``CUDADispatcher`` of its Python source), so every row kernel does.

:func:`supplied_compute_capability` replaces that one lookup, inside numba-cuda's dispatcher module only
and for the duration of a ``with`` block, by a device that reports the capability given; :func:`compile_ptx`
compiles a kernel under it. Nothing runs on a device and nothing else is patched; numba-cuda's own
``compile_ptx`` keeps its ``cc`` for the kernel itself.

Caveat: numba-cuda caches a device function per argument types, not per capability, in the process: a
second capability in the same process reuses the device functions typed and lowered for the first (NVVM
still generates the PTX for the kernel's capability). Use one capability per process.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

#: The capability the checks compile for: 9.0, the H100 and H200 this project's devices are.
DEFAULT_CC: tuple[int, int] = (9, 0)


def require_numba_cuda() -> Any:
    """``numba.cuda`` from numba-cuda (NVIDIA's target), or ImportError saying how to install it (numba
    0.68 still ships a deprecated built-in ``numba.cuda``: not the target these kernels are written for)."""
    from numba import cuda

    if getattr(cuda, "implementation", None) != "NVIDIA":
        raise ImportError(
            "the CUDA target needs numba-cuda (NVIDIA's numba.cuda, not numba's built-in one): "
            'pip install -e ".[gpu]"'
        )
    return cuda


class _SuppliedDevice:
    """What ``compile_device`` reads of the current device: its compute capability."""

    def __init__(self, cc: tuple[int, int]) -> None:
        self.compute_capability = tuple(cc)
        self.name = f"supplied compute capability {cc[0]}.{cc[1]} (no device)"


@contextlib.contextmanager
def supplied_compute_capability(cc: tuple[int, int] = DEFAULT_CC) -> Iterator[None]:
    """While active, numba-cuda's dispatcher compiles device functions for ``cc`` instead of asking the
    driver for the current device (which needs a GPU). Holds numba's compiler lock, so no other thread
    compiles meanwhile."""
    require_numba_cuda()
    from numba.core.compiler_lock import global_compiler_lock
    from numba.cuda import dispatcher

    device = _SuppliedDevice(cc)
    with global_compiler_lock:
        saved = dispatcher.get_current_device
        dispatcher.get_current_device = lambda: device
        try:
            yield
        finally:
            dispatcher.get_current_device = saved


def compile_ptx(kernel: Callable, argtypes: tuple, cc: tuple[int, int] = DEFAULT_CC) -> str:
    """PTX of the Python function ``kernel`` as a CUDA kernel (``device=False``) for the numba types
    ``argtypes``, compute capability ``cc``, on any machine (no GPU needed)."""
    cuda = require_numba_cuda()
    with supplied_compute_capability(cc):
        ptx, _ = cuda.compile_ptx(kernel, argtypes, cc=cc, device=False)
    return ptx


def device_typeof(value: Any) -> Any:
    """The numba type a kernel launch gives ``value`` once its numpy arrays are device arrays (the device
    env's records: numpy arrays uploaded, nested named tuples kept).

    numba-cuda types a device array as a writable array of its dtype, dimensions and layout, whatever the
    host array it mirrors (``DeviceNDArray._numba_type_``). ``numba.typeof`` of the host value types a
    read-only array (the star catalogue's) as read-only: a specialization the launch never compiles. So
    the PTX checks and the register report compile these types, the ones the launch compiles."""
    import numba

    return _writable(numba.typeof(value))


def _writable(t: Any) -> Any:
    from numba.core import types

    if isinstance(t, types.Array):
        return t.copy(readonly=False)
    if isinstance(t, types.NamedUniTuple):
        return types.NamedUniTuple(_writable(t.dtype), t.count, t.instance_class)
    if isinstance(t, types.NamedTuple):
        return types.NamedTuple([_writable(x) for x in t.types], t.instance_class)
    if isinstance(t, types.UniTuple):
        return types.UniTuple(_writable(t.dtype), t.count)
    if isinstance(t, types.Tuple):
        return types.Tuple([_writable(x) for x in t.types])
    return t
