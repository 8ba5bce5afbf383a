"""Paired comparison of ``benchmarks/bench_core.py`` between two commits (its compiled rows).

Each commit's tree is extracted with ``git archive`` into ``--root`` (with its own numba cache), and the two
trees' ``bench_core.py`` run in alternating processes, ``rounds`` times each, timing by the CPU time of the
calling thread (``time.perf_counter`` replaced by ``time.thread_time``), so that waits on a loaded machine
are not counted. Prints each round and the best per row, with the ratio new / reference. The threaded row
is left out (its other threads' CPU time is not counted).

    python benchmarks/bench_core_pair.py 57bef49 HEAD --rounds 3
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

_CODE = (
    "import time, runpy, sys; time.perf_counter = time.thread_time; "
    "sys.argv = ['bench_core', '--repeat', sys.argv[1]]; "
    "runpy.run_path('benchmarks/bench_core.py', run_name='__main__')"
)


def _tree(sha: str, root: Path) -> Path:
    """The commit's tree under ``root`` (extracted once)."""
    full = subprocess.run(["git", "rev-parse", "--short", sha], capture_output=True, text=True, check=True)
    tree = root / f"core_{full.stdout.strip()}"
    if not tree.exists():
        tree.mkdir(parents=True)
        subprocess.run(f"git archive {full.stdout.strip()} | tar -x -C {tree}", shell=True, check=True)
    return tree


def _run(tree: Path, repeat: int) -> dict[str, float]:
    """bench_core's compiled single-thread rows [us] in one process of ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(tree / ".nb"))
    out = subprocess.run(
        [sys.executable, "-c", _CODE, str(repeat)], cwd=tree, env=env, capture_output=True, text=True
    )
    if out.returncode:
        raise SystemExit(f"bench_core failed in {tree}:\n{out.stderr[-2000:]}")
    rows = {}
    for line in out.stdout.splitlines():
        m = re.match(r"(.*\S)\s+([0-9.]+)$", line)
        if m and ("(compiled)" in m[1] or ("numba" in m[1] and "threads" not in m[1])):
            rows[m[1]] = float(m[2])
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", help="reference commit")
    ap.add_argument("b", help="second commit")
    ap.add_argument("--rounds", type=int, default=3, help="alternating A, B rounds")
    ap.add_argument("--repeat", type=int, default=200, help="bench_core --repeat")
    ap.add_argument("--root", default=str(Path(tempfile.gettempdir()) / "planetnav_bench"))
    args = ap.parse_args()
    trees = {sha: _tree(sha, Path(args.root)) for sha in (args.a, args.b)}
    for tree in trees.values():
        _run(tree, 2)  # compile into the tree's cache
    best: dict[str, dict[str, float]] = {args.a: {}, args.b: {}}
    for r in range(args.rounds):
        for sha, tree in trees.items():
            rows = _run(tree, args.repeat)
            print(f"round {r + 1} {sha}: " + "; ".join(f"{k} {v:.2f}" for k, v in rows.items()), flush=True)
            for k, v in rows.items():
                best[sha][k] = min(best[sha].get(k, float("inf")), v)
    a, b = args.a, args.b
    print(f"\n| operation (us, CPU time, best of {args.rounds}) | {a} | {b} | {b} / {a} |\n|---|---|---|---|")
    for k in best[a]:
        print(f"| {k} | {best[a][k]:.2f} | {best[b][k]:.2f} | {best[b][k] / best[a][k]:.3f} |")


if __name__ == "__main__":
    main()
