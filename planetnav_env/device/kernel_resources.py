"""What a CUDA kernel costs a multiprocessor, read without a GPU from NVIDIA's PTX assembler.

numba-cuda compiles a kernel to PTX (:func:`planetnav_env.numerics.cuda_target.compile_ptx`); on a device the
driver assembles that PTX into machine code when the kernel first launches. ``ptxas`` does the same
assembly on any machine, and with ``-v`` reports per kernel the registers per thread, the stack frame and
the bytes spilled to local memory. Those numbers decide occupancy (:mod:`planetnav_env.device.occupancy`),
and assembling catches PTX the driver would reject before a device is ever lent.

``ptxas`` comes with the ``[gpu]`` extra (numba-cuda for CUDA 12 installs NVIDIA's ``nvidia-cuda-nvcc-cu12``
wheel, which holds it; CUDA 13's is ``nvidia-cuda-nvcc`` 13.x); :func:`find_ptxas` looks there first, so the
assembler is the release of the NVVM that wrote the PTX, then where ``cuda.pathfinder`` finds one
(``CUDA_HOME``), then on ``PATH``.

    python benchmarks/kernel_resources.py      # every entry point's resources and occupancy, JSON
"""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from planetnav_env.errors import require_count
from planetnav_env.numerics.cuda_target import DEFAULT_CC


@dataclass(frozen=True)
class KernelResources:
    """One kernel's resources as ``ptxas -v`` reports them, for one compute capability.

    ``registers``: 32-bit registers per thread; ``stack_bytes``: the kernel's stack frame per thread (local
    memory); ``spill_store_bytes`` / ``spill_load_bytes``: registers spilled to local memory and reloaded,
    bytes per thread, the kernel's own (functions it calls report theirs)."""

    function: str
    registers: int
    stack_bytes: int
    spill_store_bytes: int
    spill_load_bytes: int


#: Where NVIDIA's compiler wheel puts ``ptxas`` under the ``nvidia`` namespace package: the CUDA 12 wheel
#: (``nvidia-cuda-nvcc-cu12``) in ``nvidia/cuda_nvcc/bin``, the CUDA 13 one (``nvidia-cuda-nvcc`` 13.x) in
#: ``nvidia/cu13/bin`` (as the wheels' file lists have them).
PTXAS_WHEEL_PATHS: tuple[str, ...] = ("cu13/bin/ptxas", "cuda_nvcc/bin/ptxas")


def _nvidia_roots() -> list[str]:
    """The folders of the installed ``nvidia`` namespace package (none without NVIDIA's wheels)."""
    spec = importlib.util.find_spec("nvidia")
    return list(spec.submodule_search_locations or []) if spec else []


def ptxas_in_wheels(roots: list[str]) -> str | None:
    """The first ``ptxas`` of :data:`PTXAS_WHEEL_PATHS` under the ``nvidia`` package folders ``roots``."""
    for root in roots:
        for rel in PTXAS_WHEEL_PATHS:
            candidate = Path(root) / rel
            if candidate.is_file():
                return str(candidate)
    return None


def find_ptxas() -> str:
    """The path of ``ptxas``: NVIDIA's compiler wheel first, CUDA 13's layout or CUDA 12's (the release
    numba-cuda's NVVM comes with), then what ``cuda.pathfinder`` finds (the wheels again, a conda
    environment, ``CUDA_HOME`` / ``CUDA_PATH``; numba-cuda's own search for NVVM), then ``PATH``;
    FileNotFoundError saying how to get it otherwise."""
    found = ptxas_in_wheels(_nvidia_roots())
    if found is None:
        try:
            from cuda.pathfinder import find_nvidia_binary_utility
        except ImportError:  # numba-cuda without cuda-pathfinder (older releases)
            pass
        else:
            found = find_nvidia_binary_utility("ptxas")
    found = found or shutil.which("ptxas")
    if found:
        return found
    raise FileNotFoundError(
        'ptxas not found: it comes with the [gpu] extra (pip install -e ".[gpu]" installs '
        "nvidia-cuda-nvcc-cu12; for CUDA 13, nvidia-cuda-nvcc), with CUDA_HOME set to a CUDA toolkit, or "
        "with one on PATH"
    )


_ENTRY = re.compile(r"Compiling entry function '([^']+)'")
_PROPS = re.compile(r"Function properties for (\S+)")
_FRAME = re.compile(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads")
_USED = re.compile(r"Used (\d+) registers")


def parse_ptxas_verbose(text: str) -> dict[str, KernelResources]:
    """The entry functions' :class:`KernelResources` from ``ptxas -v``'s report, by mangled name."""
    frames: dict[str, tuple[int, int, int]] = {}
    registers: dict[str, int] = {}
    entry = props_for = None
    for line in text.splitlines():
        if m := _ENTRY.search(line):
            entry = m.group(1)
        elif m := _PROPS.search(line):
            props_for = m.group(1)
        elif (m := _FRAME.search(line)) and props_for is not None:
            frames[props_for] = (int(m.group(1)), int(m.group(2)), int(m.group(3)))
            props_for = None
        elif (m := _USED.search(line)) and entry is not None:
            registers[entry] = int(m.group(1))
    return {
        name: KernelResources(name, regs, *frames.get(name, (0, 0, 0))) for name, regs in registers.items()
    }


def assemble(
    ptx: str, cc: tuple[int, int] = DEFAULT_CC, max_registers: int | None = None, ptxas: str | None = None
) -> dict[str, KernelResources]:
    """Assemble ``ptx`` for compute capability ``cc`` with ``ptxas`` (optionally capped at
    ``max_registers`` per thread, as ``cuda.jit(max_registers=...)`` caps them) and return its entry
    functions' resources. RuntimeError with ptxas's message if it rejects the PTX."""
    cmd = [ptxas or find_ptxas(), f"-arch=sm_{cc[0]}{cc[1]}", "-v"]
    if max_registers is not None:
        cmd += ["--maxrregcount", str(require_count("max_registers", max_registers))]
    with tempfile.TemporaryDirectory(prefix="planetnav_ptxas_") as tmp:
        src = Path(tmp) / "kernel.ptx"
        src.write_text(ptx)
        proc = subprocess.run(
            [*cmd, str(src), "-o", str(Path(tmp) / "kernel.cubin")],
            capture_output=True,
            text=True,
            check=False,
        )
    if proc.returncode != 0:
        raise RuntimeError(
            f"ptxas rejected the PTX for sm_{cc[0]}{cc[1]}: {(proc.stderr or proc.stdout)[-2000:]}"
        )
    found = parse_ptxas_verbose(proc.stderr + proc.stdout)
    if not found:
        raise RuntimeError(f"ptxas reported no entry function: {(proc.stderr + proc.stdout)[-2000:]}")
    return found


_MEMORY_OP = re.compile(r"^\s*(?:@!?%p\d+\s+)?(ld|st)((?:\.(?:global|local|param|const|shared|nc))*)\.", re.M)
_LABEL = re.compile(r"^(\$L__BB\d+_\d+):", re.M)
_BRANCH = re.compile(r"\bbra(?:\.uni)?\s+(\$L__BB\d+_\d+);")


def memory_ops(ptx: str) -> dict[str, int]:
    """The loads and stores of a PTX text by state space, static counts: ``ld.global``, ``ld.generic``
    (no space named: the address resolves at run time, to global memory for the device env's arrays),
    ``ld.local``, ``ld.param``, ... and the same for ``st``."""
    counts: dict[str, int] = {}
    for m in _MEMORY_OP.finditer(ptx):
        spaces = [s for s in m.group(2).split(".") if s and s != "nc"] or ["generic"]
        key = f"{m.group(1)}.{spaces[0]}"
        counts[key] = counts.get(key, 0) + 1
    return dict(sorted(counts.items()))


def innermost_loops(ptx: str, top: int = 4) -> list[dict]:
    """The ``top`` largest innermost loops of a PTX text (a label and a later branch back to it, with no
    such loop inside): their instruction counts, loads and stores (:func:`memory_ops`) and float64
    fused multiply-adds. A loop's body runs once per trip, so its counts times the trips are what the
    loop moves; the step kernel's largest are the attitude sub-step loop (its two call sites)."""
    lines = ptx.splitlines()
    offsets, pos = [], 0
    for line in lines:
        offsets.append(pos)
        pos += len(line) + 1
    label_line = {m.group(1): ptx.count("\n", 0, m.start()) for m in _LABEL.finditer(ptx)}
    spans = []
    for i, line in enumerate(lines):
        m = _BRANCH.search(line)
        if m and label_line.get(m.group(1), i + 1) < i:
            spans.append((label_line[m.group(1)], i))
    inner = [(a, b) for a, b in spans if not any(a <= c and d <= b and (c, d) != (a, b) for c, d in spans)]
    out = []
    for a, b in inner:
        body = "\n".join(lines[a : b + 1])
        skip = ("$", "//", "{", "}", ".")
        n = sum(1 for x in lines[a : b + 1] if x.strip() and not x.strip().startswith(skip))
        out.append({"lines": [a + 1, b + 1], "instructions": n, **memory_ops(body),
                    "fma_f64": body.count("fma.rn.f64")})  # fmt: skip
    return sorted(out, key=lambda r: -r["instructions"])[:top]


__all__ = [
    "PTXAS_WHEEL_PATHS", "KernelResources", "assemble", "find_ptxas", "innermost_loops", "memory_ops",
    "parse_ptxas_verbose", "ptxas_in_wheels",
]  # fmt: skip
