"""The same numbers on every machine: the golden hashes hold under every BLAS kernel and SIMD setting.

The environment's numbers must not depend on the CPU they run on (``planetnav_env.numerics.portable_math``
says how the reset and step paths ensure it). One machine can play several CPUs: OpenBLAS takes its kernels
from ``OPENBLAS_CORETYPE`` (Prescott: SSE3; Haswell: AVX2 and FMA; SkylakeX: AVX-512, only where the CPU has
it), numpy's run-time SIMD dispatch is limited to its baseline by ``NPY_DISABLE_CPU_FEATURES``, and
numba compiles for a generic x86-64 with ``NUMBA_CPU_NAME=generic``. Each setting runs the golden tests
(``tests/env/test_golden.py``, ``tests/train/test_training_golden.py``) in a fresh process: each must find the
stored hashes, so all give the same numbers.

Slow (the golden tests once per setting, two settings at a time), so it runs in ``make test`` (CI) but not
in the [ray] environment's second pass.
"""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GOLDEN_TESTS = ["tests/env/test_golden.py", "tests/train/test_training_golden.py"]


def _cpu_flags() -> set[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    for line in text.splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    return set()


def _numpy_dispatch_features() -> list[str]:
    """The SIMD targets numpy would dispatch to on this CPU beyond its compiled baseline."""
    from numpy._core import _multiarray_umath as mu

    return [f for f in mu.__cpu_dispatch__ if mu.__cpu_features__.get(f)]


def _settings() -> list:
    flags = _cpu_flags()
    skylake = pytest.mark.skipif("avx512f" not in flags, reason="the CPU has no AVX-512 (SkylakeX kernels)")
    return [
        pytest.param({"OPENBLAS_CORETYPE": "Prescott"}, id="openblas-prescott"),
        pytest.param({"OPENBLAS_CORETYPE": "Haswell"}, id="openblas-haswell"),
        pytest.param({"OPENBLAS_CORETYPE": "SkylakeX"}, id="openblas-skylakex", marks=skylake),
        pytest.param(
            {"NPY_DISABLE_CPU_FEATURES": " ".join(_numpy_dispatch_features()), "NUMBA_CPU_NAME": "generic"},
            id="numpy-baseline-numba-generic",
        ),
    ]


def _run_golden(setting: dict[str, str]) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PLANETNAV_UPDATE_GOLDEN"}
    env.pop("OPENBLAS_L2_SIZE", None)  # set beside OPENBLAS_CORETYPE on some machines; goes with it
    env.update(setting)
    return subprocess.run(
        [sys.executable, "-m", "pytest", *GOLDEN_TESTS, "-q", "-p", "no:cacheprovider"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800, check=False,
    )  # fmt: skip


@pytest.fixture(scope="module")
def golden_runs() -> dict[str, Future]:
    """The golden tests under every setting, two processes at a time (each is single-threaded)."""
    pool = ThreadPoolExecutor(max_workers=2)
    runs = {}
    for param in _settings():
        if not any(m.name == "skipif" and m.args and m.args[0] for m in param.marks):
            runs[param.id] = pool.submit(_run_golden, param.values[0])
    yield runs
    pool.shutdown(wait=True)


@pytest.mark.cpu_settings
@pytest.mark.parametrize("setting", _settings())
def test_golden_hashes_hold_under_cpu_setting(
    setting: dict[str, str], golden_runs: dict[str, Future], request: pytest.FixtureRequest
) -> None:
    proc = golden_runs[request.node.callspec.id].result()
    failed = [line for line in proc.stdout.splitlines() if "FAILED" in line or "changed" in line]
    assert proc.returncode == 0, f"golden hashes under {setting}:\n" + "\n".join(
        failed[:20] or [proc.stdout[-3000:]]
    )
