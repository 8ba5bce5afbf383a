"""Paired comparison of ``benchmarks/bench_core.py`` between two commits (its compiled rows).

Each commit's tree is extracted with ``git archive`` into ``--root`` (with its own numba cache), and the two
trees' ``bench_core.py`` run in alternating processes, ``rounds`` times each, timing by the CPU time of the
calling thread (``time.perf_counter`` replaced by ``time.thread_time``), so that waits on a loaded machine
are not counted. Prints each round and the best per row, with the ratio new / reference. The threaded row
is left out (its other threads' CPU time is not counted).

    python research/commit_pair/bench_core_pair.py 57bef49 HEAD --rounds 3
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from commit_pair import alternate, extract, pair_parser, ratio_table, run_child, short

_CODE = (
    "import time, runpy, sys; time.perf_counter = time.thread_time; "
    "sys.argv = ['bench_core', '--repeat', sys.argv[1]]; "
    "runpy.run_path('benchmarks/bench_core.py', run_name='__main__')"
)


def _run(tree: Path, repeat: int) -> dict[str, float]:
    """bench_core's compiled single-thread rows [us] in one process of ``tree``."""
    rows = {}
    for line in run_child(tree, _CODE, [str(repeat)], "bench_core_pair").splitlines():
        m = re.match(r"(.*\S)\s+([0-9.]+)$", line)
        if m and ("(compiled)" in m[1] or ("numba" in m[1] and "threads" not in m[1])):
            rows[m[1]] = float(m[2])
    return rows


def main() -> None:
    ap = pair_parser(__doc__.split("\n")[0], rounds=3)
    ap.add_argument("--repeat", type=int, default=200, help="bench_core --repeat")
    args = ap.parse_args()
    revs = [short(args.a, "bench_core_pair"), short(args.b, "bench_core_pair")]
    trees = {sha: extract(sha, Path(args.root)) for sha in revs}
    for tree in trees.values():
        _run(tree, 2)  # compile into the tree's cache
    best = alternate(revs, lambda sha: _run(trees[sha], args.repeat), args.rounds, better=min)
    ratio_table(best, f"operation (us, CPU time, best of {args.rounds})", fmt=".2f")


if __name__ == "__main__":
    main()
