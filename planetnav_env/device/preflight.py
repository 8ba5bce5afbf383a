"""The device check's first minute: does this machine's CUDA stack run the device env at all?

    python -m planetnav_env.device.preflight            # JSON lines, one a check; the last line a summary

Each check proves one link of the chain a device benchmark stands on, in the order they are needed, and
the first that fails stops the run with one line naming it (exit status 1), so that a lent machine's minutes
are not spent on a benchmark whose figures would not mean anything:

1. ``card``: the GPU's name, driver and MIG state (``nvidia-smi``), what torch sees;
2. ``toolchain``: numba-cuda's version, the NVVM and libdevice it finds and where from, loaded for real;
   if that fails, the fallbacks it tries (``CUDA_HOME`` set to each candidate toolkit: the one in
   ``$CUDA_HOME``, a carried one in ``./.cuda``, ``/usr/local/cuda*``), each in a fresh process;
3. ``torch_stream``: a numba-cuda kernel writes a torch tensor (no copy: ``as_cuda_array``) on the default
   stream, a torch operation then reads it, and the host reads the result back: equal to the expected
   values only if the two libraries' work ran in order;
4. ``large_parameters``: a kernel with more than 4 KB of parameters (the step kernel's are 5,480 B) is
   compiled (its PTX's parameter block measured) and launched, and its sum read back;
5. ``libdevice_math``: an ``@njit`` function using ``math.sin`` and ``math.atan2``, called from a kernel,
   against the CPU's, to one ulp (libdevice's and glibc's functions may differ in the last bit);
6. ``kernels``: the device env's real kernels at 256 rows: the compile and first-step time, and the
   registers per thread of each kernel;
7. ``parity``: 32 rows on the device against the host mode (the CPU build of the same thread functions),
   within :data:`~planetnav_env.device.parity.PARITY_TOLERANCE`.

Without a GPU the host mode stands in where it can: ``toolchain`` loads NVVM and libdevice, the two kernel
checks compile to PTX (the parameter block measured, libdevice linked), ``kernels`` runs the host mode at
256 rows, ``parity`` compares the host mode with the CPU vector env (bit for bit); the checks that need a
device (``card``, ``torch_stream`` and the launches) are named as skipped in the summary.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: The id the kernel and parity checks run (target choice, 10 physics steps a decision).
PREFLIGHT_ID = "planetnav/Cruise-Target-v1"
#: Rows of the real-kernel check and of the parity check.
KERNEL_ROWS, PARITY_ROWS = 256, 32
#: Decisions of the parity check.
PARITY_DECISIONS = 12
#: One-element float64 arrays the large-parameter kernel takes, as a tuple: numba passes each array as
#: 7 words (56 B), so 96 of them make 5,432 B of parameters, past the 4 KB that CUDA allowed before 12.1
#: (and Volta), as the step kernel's records of arrays make 5,480 B.
LARGE_ARRAYS = 96
#: The old limit on a kernel's parameters [B].
OLD_PARAM_LIMIT = 4096


class CheckFailed(Exception):
    """A check's finding that the device stack cannot run the benchmark (its message names why)."""


class Skipped(Exception):
    """A check that needs a device, on a machine without one (its message says what it would do)."""


@dataclass
class Result:
    """One check's outcome: ``status`` ``"ok"``, ``"skipped"`` or ``"failed"``; what it found."""

    name: str
    status: str
    seconds: float
    found: dict[str, Any] = field(default_factory=dict)
    reason: str = ""

    def line(self) -> str:
        return json.dumps({"check": self.name, "status": self.status, "seconds": round(self.seconds, 2),
                           **({"reason": self.reason} if self.reason else {}), **self.found})  # fmt: skip


# --- the checks ------------------------------------------------------------------------------------
def check_card(on_device: bool) -> dict:
    """The card, driver and MIG state from ``nvidia-smi``, and the device torch sees."""
    if not on_device:
        raise Skipped("no CUDA device: no card to report")
    import torch

    cc = torch.cuda.get_device_capability(0)
    found: dict[str, Any] = {
        "torch": torch.__version__, "torch_cuda": torch.version.cuda,
        "torch_device": torch.cuda.get_device_name(0), "capability": f"{cc[0]}.{cc[1]}",
    }  # fmt: skip
    smi = shutil.which("nvidia-smi")
    if smi is None:
        found["nvidia_smi"] = "absent"
        return found
    query = "name,driver_version,mig.mode.current,memory.total,compute_mode"
    proc = subprocess.run([smi, f"--query-gpu={query}", "--format=csv,noheader"], capture_output=True,
                          text=True, timeout=20, check=False)  # fmt: skip
    if proc.returncode != 0:
        raise CheckFailed(f"nvidia-smi failed: {(proc.stderr or proc.stdout).strip()[-300:]}")
    first = proc.stdout.strip().splitlines()[0]
    name, driver, mig, memory, mode = (s.strip() for s in first.split(","))
    found.update(name=name, driver=driver, mig=mig, memory=memory, compute_mode=mode)
    if mig.lower() == "enabled":
        found["mig_note"] = "MIG is on: the process sees one instance, not the whole card"
    return found


_NVVM_PROBE = r"""
import json
from numba.cuda.cudadrv import libs, nvvm
paths = libs.get_cuda_paths()
out = {k: {"by": paths[k].by, "path": str(paths[k].info)} for k in ("nvvm", "libdevice")}
out["nvvm_version"] = ".".join(map(str, nvvm.NVVM().get_version()))
out["nvvm_ir_version"] = ".".join(map(str, nvvm.NVVM().get_ir_version()))
with open(paths["libdevice"].info, "rb") as f:
    out["libdevice_bytes"] = len(f.read())
print(json.dumps(out))
"""


def _probe_nvvm(env: dict[str, str]) -> tuple[dict | None, str]:
    proc = subprocess.run([sys.executable, "-c", _NVVM_PROBE], capture_output=True, text=True, env=env,
                          timeout=60, check=False)  # fmt: skip
    if proc.returncode == 0:
        return json.loads(proc.stdout.strip().splitlines()[-1]), ""
    lines = (proc.stderr or proc.stdout).strip().splitlines()
    return None, lines[-1] if lines else f"exit status {proc.returncode}"


def fallback_homes() -> list[str]:
    """Toolkits to try as ``CUDA_HOME`` when numba-cuda finds no NVVM by itself: ``$CUDA_HOME``, a carried
    one in ``./.cuda`` (the CUDA_HOME layout: ``nvvm/lib64``, ``nvvm/libdevice``), ``/usr/local/cuda*``."""
    homes = [os.environ.get("CUDA_HOME", ""), str(Path.cwd() / ".cuda"), "/usr/local/cuda",
             *sorted(str(p) for p in Path("/usr/local").glob("cuda-*"))]  # fmt: skip
    return [h for i, h in enumerate(homes) if h and Path(h).is_dir() and h not in homes[:i]]


def check_toolchain(on_device: bool) -> dict:
    """numba-cuda's version, the NVVM and libdevice it finds (and loads, in a fresh process), with the
    fallbacks tried if it finds none."""
    from importlib.metadata import version

    found: dict[str, Any] = {"numba": version("numba"), "numba_cuda": version("numba-cuda")}
    for dist in ("cuda-bindings", "cuda-core", "cuda-pathfinder"):
        try:
            found[dist] = version(dist)
        except Exception:  # not every numba-cuda release depends on it
            found[dist] = "absent"
    found["CUDA_HOME"] = os.environ.get("CUDA_HOME", "unset")
    probe, why = _probe_nvvm(dict(os.environ))
    if probe is not None:
        found.update(probe)
        found["fallback"] = "not needed"
        return found
    tried = []
    for home in fallback_homes():
        probe, why_home = _probe_nvvm({**os.environ, "CUDA_HOME": home})
        tried.append({"CUDA_HOME": home, "result": "found" if probe else why_home})
        if probe is not None:
            found.update(probe)
            found["fallback"] = {"used": home, "tried": tried, "default_search": why}
            found["export"] = f"CUDA_HOME={home}"
            return found
    raise CheckFailed(f"numba-cuda finds no NVVM/libdevice ({why}); fallbacks tried: {tried or 'none found'}")


def check_torch_stream(on_device: bool) -> dict:
    """A numba-cuda kernel writes a torch tensor on the default stream; torch then adds 1 on its own
    stream (the same legacy default stream); the host reads back 2 i + 1 only if they ran in order."""
    if not on_device:
        raise Skipped("needs a device: a numba-cuda kernel and a torch operation on one stream")
    import torch
    from numba import cuda

    @cuda.jit
    def write(out):  # pragma: no cover - device code
        i = cuda.grid(1)
        if i < out.shape[0]:
            out[i] = 2.0 * i

    n = 1 << 20
    t = torch.full((n,), -1.0, dtype=torch.float64, device="cuda")
    write[(n + 255) // 256, 256](cuda.as_cuda_array(t))
    got = (t + 1.0).cpu().numpy()  # no synchronize between: the stream's order must hold
    want = 2.0 * np.arange(n) + 1.0
    if not np.array_equal(got, want):
        bad = int(np.flatnonzero(got != want)[0])
        raise CheckFailed(f"torch read the kernel's tensor out of order: element {bad} is {got[bad]}, not "
                          f"{want[bad]} (numba-cuda's and torch's default streams differ?)")  # fmt: skip
    torch_stream = torch.cuda.current_stream().cuda_stream
    return {"elements": n, "torch_stream_handle": int(torch_stream), "in_order": True}


def _large_kernel(arrays, out) -> None:  # pragma: no cover - compiled
    """Writes the weighted sum of the first elements of a tuple of arrays (each array's fields flattened
    into the kernel's parameter block)."""
    s = 0.0
    for j in range(len(arrays)):
        s += arrays[j][0] * (j + 1)
    out[0] = s


def check_large_parameters(on_device: bool) -> dict:
    """A kernel whose parameters exceed 4 KB: its PTX's parameter block measured; on a device launched
    and its result checked."""
    from numba import types

    from planetnav_env.numerics.cuda_target import compile_ptx

    argtypes = (types.UniTuple(types.float64[::1], LARGE_ARRAYS), types.float64[::1])
    t0 = time.perf_counter()
    ptx = compile_ptx(_large_kernel, argtypes)
    found: dict[str, Any] = {"ptx_param_bytes": ptx_param_bytes(ptx), "compile_s": time.perf_counter() - t0}
    if found["ptx_param_bytes"] <= OLD_PARAM_LIMIT:
        raise CheckFailed(f"the test kernel's parameters are {found['ptx_param_bytes']} B, not above 4 KB")
    if not on_device:
        raise Skipped(f"compiled to PTX with {found['ptx_param_bytes']} B of parameters; the launch needs a "
                      "device")  # fmt: skip
    from numba import cuda

    values = [float(j % 7) - 3.0 for j in range(LARGE_ARRAYS)]
    arrays = tuple(cuda.to_device(np.array([v])) for v in values)
    out = cuda.device_array(1)
    cuda.jit(_large_kernel)[1, 1](arrays, out)
    got = float(out.copy_to_host()[0])
    want = float(sum(v * (j + 1) for j, v in enumerate(values)))
    if got != want:
        raise CheckFailed(f"a {found['ptx_param_bytes']}-byte parameter launch summed {got}, not {want}")
    found["launched"] = True
    return found


def ptx_param_bytes(ptx: str) -> int:
    """Bytes of the ``.param`` declarations of a PTX's entry (each ``.param .b64 name`` or ``.param .align
    A .b8 name[S]``)."""
    import re

    entry = ptx[ptx.index(".entry") :]
    head = entry[: entry.index(")")]
    total = 0
    decl = re.compile(r"\.param\s+(?:\.align\s+\d+\s+)?\.([busf])(\d+)\s+\S+?(?:\[(\d+)\])?\s*[,\n]")
    for m in decl.finditer(head):
        total += int(m.group(2)) // 8 * int(m.group(3) or 1)
    return total


def _math_inputs() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-10.0, 10.0, 4000), rng.uniform(-1e5, 1e5, 1000), [0.0, 1e-300, np.pi]])
    y = rng.uniform(-5.0, 5.0, x.size)
    return x, y


def check_libdevice_math(on_device: bool) -> dict:
    """``math.sin`` and ``math.atan2`` in an ``@njit`` function called from a kernel, against the CPU's
    numba build of the same function, to one ulp."""
    from numba import njit, types

    from planetnav_env.numerics.cuda_target import compile_ptx, require_numba_cuda

    cuda = require_numba_cuda()

    @njit
    def f(x, y):  # pragma: no cover - compiled
        return math.sin(x), math.atan2(y, x)

    def kernel(x, y, s, a):  # pragma: no cover - compiled
        i = cuda.grid(1)
        if i < x.shape[0]:
            s[i], a[i] = f(x[i], y[i])

    arr = types.float64[::1]
    ptx = compile_ptx(kernel, (arr, arr, arr, arr))
    if ".extern" in ptx:
        raise CheckFailed("the math kernel's PTX leaves a function unresolved (libdevice not linked)")
    if not on_device:
        raise Skipped("compiled to PTX with libdevice linked; the comparison needs a device")
    x, y = _math_inputs()
    s, a = cuda.device_array_like(x), cuda.device_array_like(x)
    cuda.jit(kernel)[(x.size + 127) // 128, 128](cuda.to_device(x), cuda.to_device(y), s, a)
    s_cpu, a_cpu = np.array([f(p, q) for p, q in zip(x, y, strict=True)]).T
    ulps = {"sin": _ulps(s.copy_to_host(), s_cpu), "atan2": _ulps(a.copy_to_host(), a_cpu)}
    if max(ulps.values()) > 1:
        raise CheckFailed(f"libdevice differs from the CPU by more than 1 ulp: {ulps}")
    return {"inputs": int(x.size), "max_ulps": ulps}


def _ulps(a: np.ndarray, b: np.ndarray) -> int:
    """The largest distance in units in the last place between ``a`` and ``b`` (float64, same signs)."""
    ia, ib = a.view(np.int64), b.view(np.int64)
    ia = np.where(ia < 0, np.int64(-(2**63)) - ia, ia)  # order the negative floats as integers
    ib = np.where(ib < 0, np.int64(-(2**63)) - ib, ib)
    return int(np.abs(ia - ib).max(initial=0))


def check_kernels(on_device: bool) -> dict:
    """The real kernels at 256 rows: construction, reset and one decision (the first compiles), timed;
    the registers per thread of each (on a device)."""
    import torch

    from planetnav_env.device.vector_env import DeviceVectorEnv

    t0 = time.perf_counter()
    env = DeviceVectorEnv(PREFLIGHT_ID, KERNEL_ROWS, device="cuda" if on_device else "cpu",
                          bank_size=KERNEL_ROWS, refill="off", bank_workers=0)  # fmt: skip
    env.reset(seed=0)
    env.step(torch.zeros(KERNEL_ROWS, dtype=torch.int64, device=env.device))
    if on_device:
        torch.cuda.synchronize()
    first_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    env.step(torch.ones(KERNEL_ROWS, dtype=torch.int64, device=env.device))
    if on_device:
        torch.cuda.synchronize()
    env.check_status()
    found = {"rows": KERNEL_ROWS, "mode": env.backend.kind, "first_decision_s": first_s,
             "next_decision_s": time.perf_counter() - t1, "registers": env.backend.kernel_registers(),
             "bytes_per_row": env.bytes_per_row()}  # fmt: skip
    env.close()
    if on_device and not found["registers"]:
        raise CheckFailed("the kernels ran but report no registers (not compiled for this device?)")
    return found


def check_parity(on_device: bool) -> dict:
    """32 rows over 12 decisions: on a device, against the host mode, within the stated tolerance; without
    one, the host mode against the CPU vector env, bit for bit."""
    from planetnav_env.device.parity import compare_runs, record_cpu_vector_run, record_run

    if on_device:
        got = record_run(PREFLIGHT_ID, PARITY_ROWS, PARITY_DECISIONS, "cuda")
        ref = record_run(PREFLIGHT_ID, PARITY_ROWS, PARITY_DECISIONS, "cpu")
        out = compare_runs(got, ref)
        if not out["all_within_tolerance"]:
            raise CheckFailed(f"device rows beyond the tolerance: {out['within_tolerance']}")
        return {"against": "host mode", "bit_for_bit": out["bit_for_bit"],
                "observation_max_scaled": out["observation"]["max_scaled"]}  # fmt: skip
    got = record_run(PREFLIGHT_ID, PARITY_ROWS, PARITY_DECISIONS, "cpu")
    ref = record_cpu_vector_run(PREFLIGHT_ID, PARITY_ROWS, PARITY_DECISIONS)
    equal = {k: np.asarray(got[k]).tobytes() == np.asarray(ref[k]).tobytes() for k in ref}
    if not all(equal.values()):
        raise CheckFailed(f"host mode differs from the CPU vector env: {equal}")
    return {"against": "the CPU vector env (host mode standing in)", "bit_for_bit": True}


#: The checks, in the order the chain needs them.
CHECKS: tuple[tuple[str, Callable[[bool], dict]], ...] = (
    ("card", check_card),
    ("toolchain", check_toolchain),
    ("torch_stream", check_torch_stream),
    ("large_parameters", check_large_parameters),
    ("libdevice_math", check_libdevice_math),
    ("kernels", check_kernels),
    ("parity", check_parity),
)


def run(
    on_device: bool,
    emit: Callable[[str], None] = print,
    only: list[str] | None = None,
    started: Callable[[str], None] | None = None,
) -> list[Result]:
    """Run the checks (``only``: those names) in order, emitting each result's JSON line as it finishes
    (and ``started(name)`` before each, so that a run killed at its time limit shows which check it was
    in); stop at the first failure (its result is the last)."""
    results = []
    for name, check in CHECKS:
        if only and name not in only:
            continue
        if started is not None:
            started(name)
        t0 = time.perf_counter()
        try:
            res = Result(name, "ok", 0.0, check(on_device))
        except Skipped as why:
            res = Result(name, "skipped", 0.0, reason=str(why))
        except CheckFailed as why:
            res = Result(name, "failed", 0.0, reason=str(why))
        except Exception as exc:  # an error inside a check is that check's failure, named
            res = Result(name, "failed", 0.0, reason=f"{type(exc).__name__}: {exc}")
        res.seconds = time.perf_counter() - t0
        results.append(res)
        emit(res.line())
        if res.status == "failed":
            break
    return results


def summary(results: list[Result], on_device: bool, seconds: float) -> str:
    """The run's last line: ``PREFLIGHT OK ...`` or ``PREFLIGHT FAILED at <check>: <why>``."""
    failed = [r for r in results if r.status == "failed"]
    if failed:
        return f"PREFLIGHT FAILED at {failed[0].name}: {failed[0].reason}"
    skipped = [r.name for r in results if r.status == "skipped"]
    where = "on the device" if on_device else "on the CPU, host mode standing in"
    ok = sum(r.status == "ok" for r in results)
    return (f"PREFLIGHT OK {where}: {ok} passed in {seconds:.0f} s"
            + (f"; skipped (need a device): {', '.join(skipped)}" if skipped else ""))  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cpu", action="store_true", help="host mode even if a device is present")
    p.add_argument("--only", nargs="+", choices=[n for n, _ in CHECKS], help="run only these checks")
    p.add_argument("--env-file", help="write the exports a fallback needs (CUDA_HOME=...) here, for a shell")
    args = p.parse_args(argv)
    from planetnav_env.device.vector_env import cuda_unavailable_reason

    why = cuda_unavailable_reason()
    on_device = why is None and not args.cpu
    print(json.dumps({"preflight": "device" if on_device else "cpu", "no_device_reason": why}), flush=True)
    t0 = time.perf_counter()

    def started(name: str) -> None:
        print(json.dumps({"check": name, "status": "running"}), flush=True)

    results = run(on_device, lambda line: print(line, flush=True), args.only, started)
    if args.env_file:
        exports = [r.found["export"] for r in results if "export" in r.found]
        Path(args.env_file).write_text("".join(f"export {e}\n" for e in exports))
    print(summary(results, on_device, time.perf_counter() - t0), flush=True)
    return 1 if any(r.status == "failed" for r in results) else 0


if __name__ == "__main__":
    raise SystemExit(main())
