"""How far fused multiply-adds alone move the device env's rows: a stand-in, before a device is lent, for
the GPU-against-CPU parity that benchmarks/bench_gpu.py measures on one.

    python research/probes/fma_contraction_probe.py [--rows 64 --decisions 200]

NVVM contracts ``a * b + c`` into one FMA (one rounding) by default; the CPU build never does. LLVM does
the same on the CPU when a function is compiled with ``fastmath={"contract"}`` and the host has FMA
instructions. This probe runs the device env's host mode (the thread functions the GPU runs, compiled for
the CPU) twice, in two processes: as shipped, and with every ``@njit`` function compiled with contraction
(``numba.njit`` wrapped before planetnav is imported; no cache). Both play the same episodes (the bank is
drawn by the shipped build and loaded by the contracted one, as a GPU gets its bank from the host) with
the same random actions, the bench's parity run: 64 rows, 200 decisions, the bench's three ids.

It prints, per id, the bench's comparison (``planetnav_env.device.parity.compare_runs``: the differences
of the observations and rewards over the run and of the final state, absolute, relative to the quantity's
scale and to the entry, and whether each is within the parity's tolerance), and the observation's and the
state's columns that differ most relative to their scale, with that scale. What it
does not measure: which multiply-adds NVVM fuses (LLVM on x86 may fuse others), and libdevice's ``sin``,
``atan2`` ... against glibc's (last-bit differences of their own).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def _contract_everything() -> None:
    """Wrap numba.njit so that every function planetnav compiles gets LLVM's contraction flag (and no
    cache, which would hand back the shipped build)."""
    import numba

    plain = numba.njit

    def njit(*args, **kw):
        kw = {**kw, "fastmath": {"contract"}, "cache": False}
        if args and callable(args[0]):
            return plain(**kw)(args[0])
        return plain(*args, **kw)

    numba.njit = njit


def _bench():
    """benchmarks/bench_gpu.py, imported (after the contraction's wrapper, if any: it imports planetnav)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import bench_gpu

    return bench_gpu


def run(mode: str, out: Path, rows: int, decisions: int) -> None:
    """One process: the bench's parity run (``bench_gpu.record_run``) of its three ids in host mode, saved
    to ``out`` (``.npz``). The shipped build saves its banks; the contracted one plays them."""
    if mode == "contract":
        _contract_everything()
    bench = _bench()
    from planetnav_env.device.bank import BankRows, EpisodeBank

    saved: dict[str, np.ndarray] = {}
    bank_file = out.with_name("bank.npz")
    loaded = dict(np.load(bank_file)) if mode == "contract" else None
    original = EpisodeBank.for_vector_env
    for env_id in bench.IDS:
        key = env_id.split("/")[1]

        def for_vector_env(*args, key=key, **kw):
            bank = original(*args, **kw)
            for name in BankRows._fields:
                if loaded is None:
                    saved[f"bank_{key}_{name}"] = getattr(bank.rows, name).copy()
                else:
                    getattr(bank.rows, name)[...] = loaded[f"bank_{key}_{name}"]
            return bank

        EpisodeBank.for_vector_env = for_vector_env
        try:
            recorded = bench.record_run(env_id, rows, decisions, "cpu")
        finally:
            EpisodeBank.for_vector_env = original
        saved.update({f"{name}_{key}": a for name, a in recorded.items()})
    if mode == "plain":
        np.savez(bank_file, **{k: v for k, v in saved.items() if k.startswith("bank_")})
    np.savez(out, **{k: v for k, v in saved.items() if not k.startswith("bank_")})


def _column_names(env_id: str) -> dict[str, list[str]]:
    """Names of the state's ``f`` columns and of the observation's, for the report."""
    from planetnav_env.batch import BatchCore
    from planetnav_env.core.layout import F_OFFSETS
    from planetnav_env.envs.env import resolve_config

    f = [""] * sum(w for _, w in F_OFFSETS.values())
    for name, (start, width) in F_OFFSETS.items():
        for k in range(width):
            f[start + k] = f"{name}[{k}]" if width > 1 else name
    obs: list[str] = []
    for block in BatchCore(resolve_config(env_id, {}), 1).layout.blocks:
        obs += [f"{block[0]}[{k}]" for k in range(block[2] - block[1])]
    return {"f": f, "obs": obs}


def _worst_columns(gpu: np.ndarray, cpu: np.ndarray, names: list[str], top: int = 3) -> list:
    """The ``top`` columns by their largest difference relative to the column's scale."""
    a, b = gpu.reshape(-1, gpu.shape[-1]).astype(float), cpu.reshape(-1, cpu.shape[-1]).astype(float)
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    worst = np.nan_to_num(np.nanmax(np.abs(a - b), axis=0) / scale)
    return [
        {"column": names[j], "max_scaled": float(worst[j]), "scale": float(scale[j])}
        for j in np.argsort(worst)[::-1][:top]
        if worst[j] > 0
    ]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rows", type=int, default=64)
    p.add_argument("--decisions", type=int, default=200)
    p.add_argument("--keep", type=Path, help="keep the runs' arrays in this folder")
    p.add_argument("--run", choices=("plain", "contract"), help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.run:
        run(args.run, args.out, args.rows, args.decisions)
        return 0
    import llvmlite.binding as llvm

    if "+fma" not in llvm.get_host_cpu_features().flatten():
        print("this CPU has no FMA instructions: contraction changes nothing here, nothing to measure")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        files = {m: folder / f"{m}.npz" for m in ("plain", "contract")}
        for mode, path in files.items():  # plain first: it draws the bank the contracted run loads
            cmd = [sys.executable, __file__, "--run", mode, "--out", str(path), "--rows", str(args.rows),
                   "--decisions", str(args.decisions)]  # fmt: skip
            subprocess.run(cmd, check=True)
        plain, contract = dict(np.load(files["plain"])), dict(np.load(files["contract"]))
    from planetnav_env.device.parity import compare_runs

    report: dict = {"rows": args.rows, "decisions": args.decisions}
    for env_id in _bench().IDS:
        key = env_id.split("/")[1]
        # contracted in the place of the GPU, shipped in the place of the CPU: the bench's comparison
        runs = {
            m: {k: d[f"{k}_{key}"] for k in ("obs", "reward", "f", "p", "i")}
            for m, d in (("contract", contract), ("plain", plain))
        }  # fmt: skip
        names = _column_names(env_id)
        report[env_id] = {
            **compare_runs(runs["contract"], runs["plain"]),
            "observation's worst columns": _worst_columns(
                runs["contract"]["obs"], runs["plain"]["obs"], names["obs"]
            ),
            "state f's worst columns": _worst_columns(runs["contract"]["f"], runs["plain"]["f"], names["f"]),
        }
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
