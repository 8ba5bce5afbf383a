"""The same numbers on every machine: the golden hashes hold under every BLAS kernel and SIMD setting.

The environment's numbers must not depend on the CPU they run on (``planetnav_env.numerics.portable_math``
says how the reset and step paths ensure it). One machine can play several CPUs: OpenBLAS takes its kernels
from ``OPENBLAS_CORETYPE`` (Prescott: SSE3; Haswell: AVX2 and FMA; SkylakeX: AVX-512, only where the CPU has
it), numpy's run-time SIMD dispatch is limited to its baseline by ``NPY_DISABLE_CPU_FEATURES``, and
numba compiles for a generic x86-64 with ``NUMBA_CPU_NAME=generic``. Each setting runs the golden tests
(``tests/env/test_golden.py``, ``tests/train/test_training_golden.py``) in a fresh process: each must find the
stored hashes, so all give the same numbers.

Slow: each setting reruns the golden tests in a fresh process, and the generic numba target compiles every
kernel afresh (minutes). So the settings that compile for another numba target start in the background as
soon as the session knows it has these tests (``tests/conftest.py``), one at a time on the second core beside
the rest of the suite, with a numba cache of their own outside the source tree, keyed on the source
(:func:`numba_cache_dir`): numba's cache index is not safe against two concurrent writers, and the generic
kernels never mix with the host's. These tests come last; then the host-target settings (OpenBLAS kernels)
run one after the other on the suite's own cache, which the suite has filled by then and no other process
writes meanwhile. They run in ``make test`` (CI) but not in the [ray] environment's second pass.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest

from planetnav_env.numerics.numba_cache import source_digest

ROOT = Path(__file__).resolve().parents[2]
GOLDEN_TESTS = ["tests/env/test_golden.py", "tests/train/test_training_golden.py"]
#: The packages whose source the golden tests' compiled kernels come from (a change to any makes a cache
#: of them stale).
KERNEL_SOURCES = ["planetnav_env", "agents", "planetnav_train", "planetnav_rl"]
TIMEOUT_S = 1800


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


def numba_cache_dir(target: str) -> Path:
    """The numba cache of the settings that compile for ``target`` (a ``NUMBA_CPU_NAME``): in the
    system's temporary folder, one per checkout, under the digest of the kernels' source (a cache of
    another source is deleted: numba itself only checks a kernel's own file, see
    ``planetnav_env.numerics.numba_cache``)."""
    checkout = hashlib.sha256(str(ROOT).encode()).hexdigest()[:12]
    base = Path(tempfile.gettempdir()) / f"planetnav-cpu-settings-numba-{checkout}"
    digest = source_digest([ROOT / p for p in KERNEL_SOURCES if (ROOT / p).is_dir()])[:16]
    if base.is_dir():
        for old in base.iterdir():
            if old.name != digest:
                shutil.rmtree(old, ignore_errors=True)
    path = base / digest / target
    path.mkdir(parents=True, exist_ok=True)
    return path


def _own_target(setting: dict[str, str]) -> bool:
    return "NUMBA_CPU_NAME" in setting


class GoldenRuns:
    """The golden tests under every setting that this CPU can play, each in a process of its own, one at a
    time per pool: :meth:`start_host` starts the host-target ones; :meth:`stop` kills what still runs (the
    session ended early)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._procs: list[subprocess.Popen] = []
        self._stopped = False
        self._pools = [ThreadPoolExecutor(max_workers=1, thread_name_prefix="cpu-settings") for _ in range(2)]
        self._params = [
            p for p in _settings() if not any(m.name == "skipif" and m.args and m.args[0] for m in p.marks)
        ]
        self.futures: dict[str, Future] = {}
        self._submit(own_target=True)

    def _submit(self, own_target: bool) -> None:
        for param in self._params:
            if _own_target(param.values[0]) == own_target and param.id not in self.futures:
                self.futures[param.id] = self._pools[own_target].submit(self._run, param.values[0])

    def start_host(self) -> None:
        """The settings that compile for this CPU: on the suite's cache, once the suite has filled it."""
        self._submit(own_target=False)

    def _run(self, setting: dict[str, str]) -> subprocess.CompletedProcess:
        env = {k: v for k, v in os.environ.items() if k != "PLANETNAV_UPDATE_GOLDEN"}
        env.pop("OPENBLAS_L2_SIZE", None)  # set beside OPENBLAS_CORETYPE on some machines; goes with it
        env.update(setting)
        if _own_target(setting):
            env["NUMBA_CACHE_DIR"] = str(numba_cache_dir(setting["NUMBA_CPU_NAME"]))
        cmd = [sys.executable, "-m", "pytest", *GOLDEN_TESTS, "-q", "-p", "no:cacheprovider"]
        with self._lock:
            if self._stopped:
                raise RuntimeError("the session ended before this setting ran")
            proc = subprocess.Popen(
                cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            self._procs.append(proc)
        try:
            out, err = proc.communicate(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            err += f"\n(killed after {TIMEOUT_S} s)"
        return subprocess.CompletedProcess(cmd, proc.returncode, out, err)

    def stop(self) -> None:
        with self._lock:
            self._stopped = True
            for proc in self._procs:
                if proc.poll() is None:
                    proc.kill()
        for pool in self._pools:
            pool.shutdown(wait=True, cancel_futures=True)


_RUNS: GoldenRuns | None = None


def start_golden_runs() -> GoldenRuns:
    """Start the runs (once per session)."""
    global _RUNS
    if _RUNS is None:
        _RUNS = GoldenRuns()
    return _RUNS


def stop_golden_runs() -> None:
    if _RUNS is not None:
        _RUNS.stop()


@pytest.fixture(scope="module")
def golden_runs() -> dict[str, Future]:
    """The runs' results by setting id (the other-target ones started at collection when the conftest did,
    else here; the host-target ones start here, after the rest of the suite)."""
    runs = start_golden_runs()
    runs.start_host()
    yield runs.futures
    stop_golden_runs()


@pytest.mark.cpu_settings
@pytest.mark.parametrize("setting", _settings())
def test_golden_hashes_hold_under_cpu_setting(
    setting: dict[str, str], golden_runs: dict[str, Future], request: pytest.FixtureRequest
) -> None:
    proc = golden_runs[request.node.callspec.id].result()
    failed = [line for line in proc.stdout.splitlines() if "FAILED" in line or "changed" in line]
    assert proc.returncode == 0, f"golden hashes under {setting}:\n" + "\n".join(
        failed[:20] or [proc.stdout[-3000:] + proc.stderr[-2000:]]
    )
