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
"""

from __future__ import annotations

from numba import njit

#: ``numba.njit`` options of a row kernel: cached, releases the GIL, no reference counting (``_nrt`` is
#: numba's switch for its runtime's reference counting and allocation).
ROW_KERNEL_OPTIONS: dict = {"cache": True, "nogil": True, "_nrt": False}

#: Decorator compiling a row kernel with :data:`ROW_KERNEL_OPTIONS`.
row_kernel = njit(**ROW_KERNEL_OPTIONS)
