"""Arithmetic whose bits do not depend on the CPU: the reset and step paths compute with these.

Two things in numpy give other last bits on other x86-64 CPUs:

* products that go through BLAS (``@``, ``np.dot``, ``np.linalg.*``, a vector's ``np.linalg.norm``, and
  everything built on them, such as scipy's ODE solvers and ``Generator.multivariate_normal``): OpenBLAS
  picks its kernels for the CPU it runs on (``OPENBLAS_CORETYPE`` overrides), and the kernels sum in
  other orders and fuse multiply-adds differently;
* numpy's transcendental ufuncs (``np.sin``, ``np.exp``, ``np.log1p``, ``np.arctan2`` ...): numpy
  dispatches them at run time to SIMD implementations for the CPU's features (AVX-512 ones differ from
  the C library's; ``NPY_DISABLE_CPU_FEATURES`` limits the choice).

So the environment's path uses elementwise numpy arithmetic (``+ - * /`` and ``sqrt`` are correctly
rounded IEEE operations, the same on every CPU), the products below written out as sums in a fixed
order, and transcendental functions compiled by numba, which call the C library's ``libm`` scalar by
scalar. glibc picks its own ``libm`` kernels by CPU too, but the same one (its FMA variant) on every
x86-64 CPU with AVX2 and FMA: that is the promise's scope (``docs/architecture.md``, "Same numbers on
every machine"). Numba itself compiles for the host CPU, but without fast-math it neither reorders nor
fuses floating-point operations.

Shapes broadcast like numpy's; the 3-vectors are the last axis.

The scalar functions at the end (:func:`remainder`, :func:`rint`) are for the compiled row kernels: numpy
ufuncs on scalars compile for the CPU but not for CUDA (numba-cuda's ufunc table has no ``np.sqrt``,
``np.remainder`` or ``np.rint``), so the row kernels call ``math.*`` (which numba lowers to the same
instruction or ``libm`` call as the ufunc: the same bits) or these, which give numba's ufunc results bit
for bit on the CPU and compile for both targets (:mod:`planetnav_env.numerics.jit`, "Two targets").
"""

from __future__ import annotations

import math

import numpy as np
from numba import vectorize

from planetnav_env.numerics.jit import row_kernel

__all__ = [
    "arccos",
    "arctan",
    "arctan2",
    "cos",
    "cross3",
    "dot3",
    "log1p",
    "matvec3",
    "norm3",
    "remainder",
    "rint",
    "sin",
    "tan",
    "unit3",
]


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a . b`` over the last axis (length 3), summed left to right."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm3(v: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis (length 3)."""
    return np.sqrt(dot3(v, v))


def unit3(v: np.ndarray) -> np.ndarray:
    """``v / |v|`` over the last axis (length 3)."""
    v = np.asarray(v, dtype=float)
    return v / norm3(v)[..., None]


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis (length 3)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def matvec3(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``m @ v`` for 3x3 matrices ``m`` (..., 3, 3) and vectors ``v`` (..., 3), each row summed left to
    right (the numbers ``m @ v`` gives depend on the BLAS kernel)."""
    m = np.asarray(m, dtype=float)
    v = np.asarray(v, dtype=float)[..., None, :]
    return m[..., 0] * v[..., 0] + m[..., 1] * v[..., 1] + m[..., 2] * v[..., 2]


# libm through numba: one scalar call per element, whatever SIMD the CPU has.
@vectorize(["float64(float64)"], cache=True)
def sin(x):  # pragma: no cover - compiled
    """sin [rad] from the C library."""
    return math.sin(x)


@vectorize(["float64(float64)"], cache=True)
def cos(x):  # pragma: no cover - compiled
    """cos [rad] from the C library."""
    return math.cos(x)


@vectorize(["float64(float64)"], cache=True)
def tan(x):  # pragma: no cover - compiled
    """tan [rad] from the C library."""
    return math.tan(x)


@vectorize(["float64(float64)"], cache=True)
def arctan(x):  # pragma: no cover - compiled
    """atan [rad] from the C library."""
    return math.atan(x)


@vectorize(["float64(float64)"], cache=True)
def arccos(x):  # pragma: no cover - compiled
    """acos [rad] from the C library (NaN outside [-1, 1])."""
    return math.acos(x) if -1.0 <= x <= 1.0 else math.nan


@vectorize(["float64(float64, float64)"], cache=True)
def arctan2(y, x):  # pragma: no cover - compiled
    """atan2 [rad] from the C library."""
    return math.atan2(y, x)


@vectorize(["float64(float64)"], cache=True)
def log1p(x):  # pragma: no cover - compiled
    """log(1 + x) from the C library (NaN below -1)."""
    return math.log1p(x) if x >= -1.0 else math.nan


# Scalars for the row kernels (both targets): numpy's ufunc semantics, bit for bit, without a ufunc.
_TWO52 = 4503599627370496.0  # 2**52: from here on every float64 is an integer


@row_kernel
def remainder(x: float, y: float) -> float:  # pragma: no cover - compiled
    """``np.remainder(x, y)`` of two floats as numba compiles it: ``fmod(x, y)``, plus ``y`` where that is
    nonzero and its sign differs from ``y``'s (the result takes the divisor's sign); a zero result is
    ``+0.0``; NaN where ``y`` is zero or ``x`` infinite (or either is NaN). Python's ``%`` gives the same
    numbers for ``y != 0`` (the same fmod and the same correction) except that its zero takes ``y``'s sign,
    and it raises on ``y == 0``: both handled before and after it here."""
    if y == 0.0:
        return math.nan
    r = x % y
    if r == 0.0:
        return 0.0
    return r


@row_kernel
def rint(x: float) -> float:  # pragma: no cover - compiled
    """``np.rint(x)``: the nearest integer, halves to even, the sign kept (``-0.3`` gives ``-0.0``).
    Below 2**52, adding and subtracting 2**52 rounds in the FPU's default mode, round-half-even, exactly;
    from 2**52 on (and for infinities and NaN) ``x`` is its own value."""
    ax = abs(x)
    if ax < _TWO52:
        return math.copysign((ax + _TWO52) - _TWO52, x)
    return x
