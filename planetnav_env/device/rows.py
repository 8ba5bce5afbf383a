"""The device env's thread functions, and the loops that run them on the CPU.

:func:`autoreset_thread` is what thread ``n`` of the autoreset kernel runs
(:mod:`planetnav_env.device.cuda_kernels`): if ``mask[n]``, copy bank row ``slots[n]``
(:class:`~planetnav_env.device.bank.BankRows`) into state row ``n``, then the compiled part of the reset
(``kernels.reset_row``, the CPU reset's own). It is a row kernel (:mod:`planetnav_env.numerics.jit`'s
rules: no allocation, no numpy function, no exception), compiled for the CPU by numba and for the device
by numba-cuda from this source.

:func:`step_rows` and :func:`autoreset_rows` run the thread functions row by row on the CPU, each row with
its own scratch (the device's layout): the device env's host mode, which the tests hold to the CPU vector
env bit for bit. :func:`reset_rows` runs the compiled part of the reset (``kernels.reset_thread``) the same
way, for the tests that hold it to the CPU reset. All three are cached, so every process (a test run's
several, ``python -m planetnav_env.precompile --host-mode``) shares one compilation.
"""

from __future__ import annotations

from numba import njit

from planetnav_env.core.kernels import reset_row, reset_thread, step_thread
from planetnav_env.core.records import scratch_row
from planetnav_env.numerics.jit import row_kernel


@row_kernel
def autoreset_thread(prm, st, bank, slots, mask, rows, n) -> None:  # pragma: no cover - compiled
    """Row ``n`` (if ``mask[n]``) starts bank episode ``slots[n]``: its host-drawn float state,
    covariance, noise-stream seed and ephemeris table are copied in, then :func:`reset_row` runs with
    row ``n``'s scratch (``rows``' slices ``n``)."""
    if not mask[n]:
        return
    k = slots[n]
    for c in range(st.f.shape[1]):
        st.f[n, c] = bank.f[k, c]
    for a in range(6):
        for b in range(6):
            st.p[n, a, b] = bank.p[k, a, b]
    for w in range(st.rng.shape[1]):
        st.rng[n, w] = bank.rng[k, w]
    e = st.eph
    for s0 in range(e.shape[1]):
        for s1 in range(e.shape[2]):
            for s2 in range(e.shape[3]):
                for s3 in range(e.shape[4]):
                    e[n, s0, s1, s2, s3] = bank.eph[k, s0, s1, s2, s3]
    reset_row(prm, st, n, scratch_row(rows, n))


@njit(cache=True, nogil=True)
def step_rows(prm, st, act, rows) -> None:  # pragma: no cover - compiled
    """What the step kernel's threads run, row by row on the CPU (``cuda_entry.step_kernel``)."""
    for n in range(st.f.shape[0]):
        step_thread(prm, st, act, rows, n)


@njit(cache=True, nogil=True)
def autoreset_rows(prm, st, bank, slots, mask, rows) -> None:  # pragma: no cover - compiled
    """What the autoreset kernel's threads run, row by row on the CPU."""
    for n in range(st.f.shape[0]):
        autoreset_thread(prm, st, bank, slots, mask, rows, n)


@njit(cache=True, nogil=True)
def reset_rows(prm, st, reset, rows) -> None:  # pragma: no cover - compiled
    """The compiled part of the reset of rows ``reset``, as reset threads run it, row by row on the CPU."""
    for j in range(reset.shape[0]):
        reset_thread(prm, st, reset, rows, j)
