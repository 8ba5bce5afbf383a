"""Paired comparison of the compiled ceiling of two commits: each commit's own
``benchmarks/bench_vec.py`` ``ceiling_per_core`` (the compiled step alone, one thread, N = 1024), run in
alternating processes.

    python benchmarks/bench_ceiling_pair.py cf84ce8 HEAD          # 2 rounds of A then B, 4 cases
    python benchmarks/bench_ceiling_pair.py A B --rounds 3 --cases target/random,torque/random

Each commit's tree is extracted with ``git archive`` into ``--root`` (default: the system's temporary
folder) as ``wt_<short sha>``, with its numba cache beside it (``nb_<short sha>``); both are kept, so only
the first run of a commit compiles (minutes). A timed block is measured with ``time.thread_time``, the CPU
time of the stepping thread: on a shared machine the time the thread waits for a core is not counted,
so paired figures stay comparable under load (wall-clock rates fall with the load; cache sharing with
other processes still costs a little). Every process prints the best of ``--repeats`` blocks per case;
the summary gives, per case, the best over the rounds of each commit and the ratio B / A.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: Run in a fresh interpreter whose ``planetnav_env`` is the extracted commit's (PYTHONPATH).
_CHILD = r"""
import importlib.util, sys, time, types
root, repeats, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
spec = importlib.util.spec_from_file_location("bench_vec", root + "/benchmarks/bench_vec.py")
bv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bv)
import planetnav_env
if not planetnav_env.__file__.startswith(root):
    raise SystemExit(f"planetnav_env imported from {planetnav_env.__file__}, not from {root}")
bv.REPEATS = repeats
bv.time = types.SimpleNamespace(perf_counter=time.thread_time)  # CPU time of this thread
rates = []
for case in cases:
    mode, stream = case.split("/")
    rates.append(f"{case}={bv.ceiling_per_core(1024, mode, stream, 20000):.0f}")
print(" ".join(rates), flush=True)
"""


def _short(rev: str) -> str:
    out = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short=7", f"{rev}^{{commit}}"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if out.returncode != 0:
        raise SystemExit(f"bench_ceiling_pair: unknown commit {rev!r}: {out.stderr.strip()}")
    return out.stdout.strip()


def _extract(sha: str, root: Path) -> Path:
    """The commit's tree under root (extracted once; a folder already there is reused)."""
    tree = root / f"wt_{sha}"
    if not (tree / "benchmarks" / "bench_vec.py").exists():
        tree.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", sha], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive.stdout, check=True)
    return tree


def _run(tree: Path, cache: Path, repeats: int, cases: str) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(tree), str(repeats), cases],
        capture_output=True, text=True, env=env, cwd=str(tree), check=False,
    )  # fmt: skip
    if out.returncode != 0:
        raise SystemExit(f"bench_ceiling_pair: {tree} failed:\n{out.stderr[-3000:]}")
    line = out.stdout.strip().splitlines()[-1]
    return {k: float(v) for k, v in (item.split("=") for item in line.split())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", help="first commit (the reference)")
    ap.add_argument("b", help="second commit")
    ap.add_argument("--rounds", type=int, default=2, help="alternating A, B rounds")
    ap.add_argument("--repeats", type=int, default=5, help="timed blocks per case and process (best kept)")
    ap.add_argument("--cases", default="target/random,torque/random,torque/held,target/held")
    ap.add_argument(
        "--root", type=Path, default=Path(tempfile.gettempdir()), help="where trees and caches go"
    )
    args = ap.parse_args()
    if args.rounds < 1 or args.repeats < 1:
        raise SystemExit(
            f"bench_ceiling_pair: --rounds and --repeats must be >= 1, got {args.rounds}, {args.repeats}"
        )
    revs = [_short(args.a), _short(args.b)]
    trees = {sha: _extract(sha, args.root) for sha in revs}
    cases = args.cases.split(",")
    best: dict[str, dict[str, float]] = {sha: dict.fromkeys(cases, 0.0) for sha in revs}
    print(f"compiled ceiling, row-steps/s per core (CPU time, best of {args.repeats} blocks per process)")
    for k in range(args.rounds):
        for sha in revs:
            rates = _run(trees[sha], args.root / f"nb_{sha}", args.repeats, args.cases)
            print(f"round {k + 1} {sha}: " + ", ".join(f"{c} {rates[c]:,.0f}" for c in cases), flush=True)
            for c in cases:
                best[sha][c] = max(best[sha][c], rates[c])
    a, b = revs
    print()
    print(f"| case | {a} | {b} | {b} / {a} |")
    print("|---|---|---|---|")
    for c in cases:
        print(f"| {c} | {best[a][c]:,.0f} | {best[b][c]:,.0f} | {best[b][c] / best[a][c]:.3f} |")


if __name__ == "__main__":
    main()
