"""What the paired benchmarks of two or more commits share (``bench_ceiling_pair.py``,
``bench_info_pair.py``, ``bench_core_pair.py``): each commit's tree extracted once with ``git archive``
(``<root>/wt_<short sha>``, its numba cache beside it in ``<root>/nb_<short sha>``), a measuring child
process run on a tree with that tree's ``planetnav_env`` on the path, and the rounds of the commits in
turn with the best figure of each kept.

Alternating processes, each timed by CPU time, is what makes figures taken on a shared, loaded machine
comparable: waits for a core are not counted, and a slow spell hits both commits' rounds alike.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]  # research/commit_pair/ -> the repository

#: The start of a child that measures with a tree's own ``benchmarks/bench_vec.py`` (``bv``), the tree's
#: root as ``sys.argv[1]``; it stops if ``planetnav_env`` came from anywhere else.
BENCH_VEC_CHILD = r"""
import importlib.util, sys, time, types
root = sys.argv[1]
spec = importlib.util.spec_from_file_location("bench_vec", root + "/benchmarks/bench_vec.py")
bv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bv)
import planetnav_env
if not planetnav_env.__file__.startswith(root):
    raise SystemExit(f"planetnav_env imported from {planetnav_env.__file__}, not from {root}")
"""


def pair_parser(description: str, rounds: int) -> argparse.ArgumentParser:
    """The options every paired benchmark of two commits takes: ``a``, ``b``, ``--rounds``, ``--root``."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("a", help="first commit (the reference)")
    ap.add_argument("b", help="second commit")
    ap.add_argument("--rounds", type=int, default=rounds, help="alternating A, B rounds")
    ap.add_argument(
        "--root", type=Path, default=Path(tempfile.gettempdir()), help="where trees and caches go"
    )
    return ap


def short(rev: str, who: str) -> str:
    """The 7-character sha of ``rev``; exits naming ``rev`` when git does not know it."""
    out = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short=7", f"{rev}^{{commit}}"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if out.returncode != 0:
        raise SystemExit(f"{who}: unknown commit {rev!r}: {out.stderr.strip()}")
    return out.stdout.strip()


def extract(sha: str, root: Path) -> Path:
    """The commit's tree under ``root`` (extracted once; a complete tree already there is reused)."""
    tree = root / f"wt_{sha}"
    if not (tree / "benchmarks" / "bench_vec.py").exists():
        tree.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", sha], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive.stdout, check=True)
    return tree


def run_child(tree: Path, code: str, args: list[str], who: str) -> str:
    """Run ``python -c code *args`` in ``tree`` with the tree's package and numba cache; its stdout."""
    cache = tree.parent / f"nb_{tree.name.removeprefix('wt_')}"
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=str(tree),
        check=False,
    )
    if out.returncode != 0:
        raise SystemExit(f"{who}: {tree} failed:\n{out.stderr[-3000:]}")
    return out.stdout


def key_values(stdout: str) -> dict[str, float]:
    """The ``name=value`` pairs of the child's last output line."""
    line = stdout.strip().splitlines()[-1]
    return {k: float(v) for k, v in (item.split("=") for item in line.split())}


def alternate(
    revs: list[str], measure: Callable[[str], dict[str, float]], rounds: int, better: Callable = max
) -> dict[str, dict[str, float]]:
    """``rounds`` rounds of ``measure(sha)`` for each commit in turn, each round printed; per commit and
    figure, the best over the rounds (``better``: max for rates, min for times)."""
    best: dict[str, dict[str, float]] = {sha: {} for sha in revs}
    for k in range(rounds):
        for sha in revs:
            figures = measure(sha)
            print(
                f"round {k + 1} {sha}: " + ", ".join(f"{c} {v:,.2f}" for c, v in figures.items()), flush=True
            )
            for c, v in figures.items():
                best[sha][c] = better(best[sha][c], v) if c in best[sha] else v
    return best


def ratio_table(best: dict[str, dict[str, float]], head: str, fmt: str = ",.0f") -> None:
    """Print the markdown table of the best figures per commit and each later commit over the first."""
    revs = list(best)
    ref = revs[0]
    print()
    print(f"| {head} | " + " | ".join(revs) + " | " + " | ".join(f"{b} / {ref}" for b in revs[1:]) + " |")
    print("|---" * (2 * len(revs)) + "|")
    for c in best[ref]:
        row = [format(best[sha][c], fmt) for sha in revs] + [
            f"{best[b][c] / best[ref][c]:.3f}" for b in revs[1:]
        ]
        print(f"| {c} | " + " | ".join(row) + " |")
