"""Paired step rates at small N (where the Python side, the info above all, is a large part of a step) of
two or more commits: each commit's own ``benchmarks/bench_vec.py`` ``vector_rate`` (native vector env) and
``single_rate`` (single env), run in alternating processes.

    python research/commit_pair/bench_info_pair.py cf84ce8 HEAD        # 3 rounds, N = 1 and the single env
    python research/commit_pair/bench_info_pair.py cf84ce8 2ba1b11 HEAD \\
        --cases vec1/target/held,vec16/target/held

Cases are ``vec<N>/<mode>/<stream>`` or ``single/<mode>/<stream>`` (``mode``: target or torque;
``stream``: held or random, as in bench_vec.py). Trees come from ``git archive`` into ``--root`` as
``wt_<short sha>`` with their numba caches beside them (``nb_<short sha>``), shared with
``bench_ceiling_pair.py``, so only a commit's first run compiles. A timed block is measured with
``time.process_time`` (the CPU time of the process): on a shared, loaded machine the time the process
waits for a core is not counted, so paired figures stay comparable (wall-clock rates fall with the load).
Every process prints the best of ``--repeats`` blocks per case; the summary gives, per case, the best
over the rounds of each commit and the ratio to the first commit.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from commit_pair import BENCH_VEC_CHILD, alternate, extract, key_values, ratio_table, run_child, short

#: Run in a fresh interpreter whose ``planetnav_env`` is the extracted commit's (PYTHONPATH).
_CHILD = (
    BENCH_VEC_CHILD
    + r"""
repeats, steps, cases = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4].split(",")
bv.REPEATS = repeats
bv.time = types.SimpleNamespace(perf_counter=time.process_time)  # CPU time of this process
rates = []
for case in cases:
    kind, mode, stream = case.split("/")
    if kind == "single":
        rate = bv.single_rate(mode, stream, steps)
    else:
        n = int(kind[3:])
        rate = bv.vector_rate(n, mode, stream, steps * n)
    rates.append(f"{case}={rate:.1f}")
print(" ".join(rates), flush=True)
"""
)


def _check_case(case: str) -> None:
    parts = case.split("/")
    ok = len(parts) == 3 and parts[1] in ("target", "torque") and parts[2] in ("held", "random")
    kind = parts[0]
    ok = ok and (kind == "single" or (kind.startswith("vec") and kind[3:].isdigit() and int(kind[3:]) >= 1))
    if not ok:
        raise SystemExit(
            f"bench_info_pair: bad case {case!r}; expected vec<N>/<target|torque>/<held|random> "
            "or single/<target|torque>/<held|random>"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("commits", nargs="+", help="two or more commits; the first is the reference")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the commits in turn")
    ap.add_argument("--repeats", type=int, default=5, help="timed blocks per case and process (best kept)")
    ap.add_argument("--steps", type=int, default=3000, help="env steps per timed block (each row's)")
    ap.add_argument(
        "--cases", default="vec1/target/held,vec1/target/random,single/target/held,single/target/random"
    )
    ap.add_argument(
        "--root", type=Path, default=Path(tempfile.gettempdir()), help="where trees and caches go"
    )
    args = ap.parse_args()
    if len(args.commits) < 2:
        raise SystemExit(f"bench_info_pair: give at least two commits, got {args.commits}")
    if args.rounds < 1 or args.repeats < 1 or args.steps < 1:
        raise SystemExit(
            "bench_info_pair: --rounds, --repeats and --steps must be >= 1, got "
            f"{args.rounds}, {args.repeats}, {args.steps}"
        )
    cases = args.cases.split(",")
    for c in cases:
        _check_case(c)
    revs = list(dict.fromkeys(short(c, "bench_info_pair") for c in args.commits))
    if len(revs) < 2:
        raise SystemExit(f"bench_info_pair: the commits {args.commits} are one commit")
    trees = {sha: extract(sha, args.root) for sha in revs}
    print(f"env steps/s (CPU time of the process, best of {args.repeats} blocks of {args.steps} steps)")

    def measure(sha: str) -> dict[str, float]:
        argv = [str(trees[sha]), str(args.repeats), str(args.steps), args.cases]
        return key_values(run_child(trees[sha], _CHILD, argv, "bench_info_pair"))

    ratio_table(alternate(revs, measure, args.rounds), "case")


if __name__ == "__main__":
    main()
