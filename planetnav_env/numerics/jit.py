"""Compilation options of the compiled row kernels (one place for them).

The simulation core calls many small kernels per row and step, passing arrays and tuples of arrays
(:class:`~planetnav_env.core.records.CoreParams`, ``Scratch``: ~60 arrays). With numba's reference
counting (NRT) every such call increments and decrements the count of every array it receives: atomic
operations that cost more than the arithmetic of a small kernel, and that two threads stepping their
chunks contend on (the parameter arrays are shared). Kernels that neither allocate nor return an
array need no reference counting, because their caller holds every array for the duration of the call:
:data:`ROW_KERNEL` compiles them without it (the arithmetic, hence every result, is unchanged).

Rules for a kernel compiled with these options: no allocation (numba refuses to compile one), no array
(or tuple holding an array) returned or stored, and no call of a function that returns a new array.
Entry points that allocate their scratch (``step_range``, the ``*_batch`` kernels) keep the default.

Two targets. The same row kernels compile as CUDA device functions (numba-cuda, the ``[gpu]`` extra):
a CUDA kernel that calls an ``@njit`` function compiles that function's Python source for the device,
and so on down its calls, so there is one source and no decorator of a second kind
(:mod:`planetnav_env.core.cuda_entry` holds the kernels, one thread per row; ``inline="always"`` is
honoured on both targets). For that, a row kernel also follows these rules:

* Math on scalars is ``math.*`` or :mod:`planetnav_env.numerics.portable_math`'s scalar functions
  (``remainder``, ``rint``), never a numpy function: numba-cuda's ufunc table lacks most of them
  (``np.sqrt``, ``np.remainder``, ``np.rint``, ``np.floor`` fail to lower with ``KeyError: <ufunc ...>``).
  For a float, numba lowers ``np.sqrt``/``np.arcsin``/``np.cos``... and ``math.sqrt``/``math.asin``/
  ``math.cos``... to the same instruction or ``libm`` call, so the change keeps every bit on the CPU.
  numpy constants (``np.nan``, ``np.pi``) are fine.
* No ``@vectorize`` ufunc called on scalars: give the ufunc a scalar row kernel that it wraps and call
  that (``sensors/pulsar.py``: ``resolve_cycle`` / ``resolve_cycle_kernel``).
* No allocation anywhere below a thread (a device thread cannot allocate; this is already the CPU rule
  above): scratch is a record of arrays its caller allocated, (chunk, ...) reused on the CPU, (N, ...)
  with one row per thread on the device (``core/records.py``: ``scratch_rows``, ``scratch_row``).
* No exceptions and no Python objects (strings, lists, dicts, objects' attributes other than records'
  fields): report a status code in the row's integers (``I_STATUS``), as the kernels do. Division by zero
  raises ``ZeroDivisionError`` on the CPU under numba's default error model but gives inf/NaN on the
  device, so a row kernel guards its divisors rather than rely on either.
* Arguments are scalars, arrays, records (named tuples) of them and one-element structured arrays
  (``CoreParams.scalars``); the device passes device arrays of the same types.

The check: ``tests/env/test_cuda_ptx.py`` reads the rules it can from the source (no ``np.<function>``,
no ``raise`` in a row kernel), runs the device's thread functions on the CPU against the chunked step bit
for bit, and, with numba-cuda installed (the ``[dev]`` extra includes ``[gpu]``), compiles every entry
point to PTX for every registered id with the compute capability supplied
(:mod:`planetnav_env.numerics.cuda_target`: no GPU needed).
"""

from __future__ import annotations

from numba import njit

#: ``numba.njit`` options of a row kernel: cached, releases the GIL, no reference counting (``_nrt`` is
#: numba's switch for its runtime's reference counting and allocation).
ROW_KERNEL_OPTIONS: dict = {"cache": True, "nogil": True, "_nrt": False}

#: Decorator compiling a row kernel with :data:`ROW_KERNEL_OPTIONS`.
row_kernel = njit(**ROW_KERNEL_OPTIONS)
