"""Paired comparison of the compiled ceiling of two commits: each commit's own
``benchmarks/bench_vec.py`` ``ceiling_per_core`` (the compiled step alone, one thread, N = 1024), run in
alternating processes.

    python research/commit_pair/bench_ceiling_pair.py cf84ce8 HEAD          # 2 rounds of A then B, 4 cases
    python research/commit_pair/bench_ceiling_pair.py A B --rounds 3 --cases target/random,torque/random

Each commit's tree is extracted with ``git archive`` into ``--root`` (default: the system's temporary
folder) as ``wt_<short sha>``, with its numba cache beside it (``nb_<short sha>``); both are kept, so only
the first run of a commit compiles (minutes). A timed block is measured with ``time.thread_time``, the CPU
time of the stepping thread: on a shared machine the time the thread waits for a core is not counted,
so paired figures stay comparable under load (wall-clock rates fall with the load; cache sharing with
other processes still costs a little). Every process prints the best of ``--repeats`` blocks per case;
the summary gives, per case, the best over the rounds of each commit and the ratio B / A.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from commit_pair import (
    BENCH_VEC_CHILD,
    alternate,
    extract,
    key_values,
    pair_parser,
    ratio_table,
    run_child,
    short,
)

#: Run in a fresh interpreter whose ``planetnav_env`` is the extracted commit's (PYTHONPATH).
_CHILD = (
    BENCH_VEC_CHILD
    + r"""
repeats, cases = int(sys.argv[2]), sys.argv[3].split(",")
bv.REPEATS = repeats
bv.time = types.SimpleNamespace(perf_counter=time.thread_time)  # CPU time of this thread
rates = []
for case in cases:
    mode, stream = case.split("/")
    rates.append(f"{case}={bv.ceiling_per_core(1024, mode, stream, 20000):.0f}")
print(" ".join(rates), flush=True)
"""
)


def main() -> None:
    ap = pair_parser(__doc__.split("\n\n")[0], rounds=2)
    ap.add_argument("--repeats", type=int, default=5, help="timed blocks per case and process (best kept)")
    ap.add_argument("--cases", default="target/random,torque/random,torque/held,target/held")
    args = ap.parse_args()
    if args.rounds < 1 or args.repeats < 1:
        raise SystemExit(
            f"bench_ceiling_pair: --rounds and --repeats must be >= 1, got {args.rounds}, {args.repeats}"
        )
    revs = [short(args.a, "bench_ceiling_pair"), short(args.b, "bench_ceiling_pair")]
    trees = {sha: extract(sha, args.root) for sha in revs}
    print(f"compiled ceiling, row-steps/s per core (CPU time, best of {args.repeats} blocks per process)")

    def measure(sha: str) -> dict[str, float]:
        out = run_child(
            trees[sha], _CHILD, [str(trees[sha]), str(args.repeats), args.cases], "bench_ceiling_pair"
        )
        return key_values(out)

    ratio_table(alternate(revs, measure, args.rounds), "case")


if __name__ == "__main__":
    main()
