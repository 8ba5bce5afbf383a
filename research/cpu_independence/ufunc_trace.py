"""pytest plugin: log the planetnav call sites of numpy's transcendental ufuncs, products and linalg.

numpy's SIMD versions of ``sin``, ``exp``, ``log1p``, ``arctan2`` ... differ from the C library's on some
CPUs, so the environment's path must not call them. Each ``np.<name>`` is wrapped (after numba has
registered the real ufuncs) and logs its caller's planetnav frames once per call site to stderr::

    PYTHONPATH=research/cpu_independence python -m pytest -p ufunc_trace -s \\
        tests/env/test_golden.py tests/train/test_training_golden.py
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Callable
from typing import Any

import numba.np.npyimpl
import numba.np.ufunc.decorators  # noqa: F401
import numpy as np
import numpy.linalg as la

UFUNCS = (
    "sin cos tan arcsin arccos arctan arctan2 exp log log10 log2 expm1 log1p power tanh sinh cosh cbrt hypot "
    "exp2 float_power arcsinh arccosh arctanh matmul dot inner vdot tensordot"
).split()
LINALG = "norm inv solve cholesky eigh eig svd det lstsq qr eigvalsh pinv".split()
_seen: set[tuple] = set()


def _wrap(name: str, f: Callable[..., Any]) -> Callable[..., Any]:
    def logged(*args: Any, **kwargs: Any) -> Any:
        frames = [
            x for x in traceback.extract_stack()[:-1] if "planetnav" in x.filename or "/agents/" in x.filename
        ]
        key = (name, tuple((x.filename, x.lineno) for x in frames[-3:]))
        if frames and key not in _seen:
            _seen.add(key)
            where = " <- ".join(f"{x.filename}:{x.lineno} {x.name}" for x in reversed(frames[-5:]))
            sys.__stderr__.write(f"NUMPY {name} {where}\n")
        return f(*args, **kwargs)

    return logged


for _name in UFUNCS:
    setattr(np, _name, _wrap(_name, getattr(np, _name)))
for _name in LINALG:
    setattr(la, _name, _wrap("linalg." + _name, getattr(la, _name)))
