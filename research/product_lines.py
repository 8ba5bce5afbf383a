"""Lines of Python in each package at a git revision: ``python research/product_lines.py [REV ...]``.

Counts every line (blank and comment lines included) of the ``.py`` files tracked under each package's
folder at REV (default ``HEAD``), read from git, so a revision can be counted without checking it out.
``planetnav_env`` is also split by subpackage. The product is planetnav_env, the agents (installed as
planetnav_agents from ``agents/``), planetnav_train and planetnav_rl; planetnav_validation (the paper
reproductions, harnesses and test oracles) is counted apart, as is ``research/``.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter

PRODUCT = ("planetnav_env", "agents", "planetnav_train", "planetnav_rl")
OTHER = ("planetnav_validation", "research", "tests")


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], check=True, capture_output=True, text=True).stdout


def count(rev: str) -> Counter[str]:
    """Lines of ``.py`` files at ``rev`` per package and of planetnav_env ("planetnav_env/x")."""
    lines: Counter[str] = Counter()
    paths = [p for p in _git("ls-tree", "-r", "--name-only", rev).splitlines() if p.endswith(".py")]
    for path in paths:
        top = path.split("/", 1)[0]
        if top not in PRODUCT + OTHER:
            continue
        n = _git("show", f"{rev}:{path}").count("\n")
        lines[top] += n
        if top == "planetnav_env":
            parts = path.split("/")
            lines["planetnav_env/" + (parts[1] if len(parts) > 2 else "(top)")] += n
    return lines


def main(argv: list[str]) -> int:
    revs = argv or ["HEAD"]
    counts = [count(r) for r in revs]
    keys = sorted({k for c in counts for k in c}, key=lambda k: (k.split("/")[0] not in PRODUCT, k))
    print(f"{'package':<28}" + "".join(f"{r[:12]:>14}" for r in revs))
    for k in keys:
        print(f"{k:<28}" + "".join(f"{c[k]:>14}" for c in counts))
    print(f"{'product total':<28}" + "".join(f"{sum(c[p] for p in PRODUCT):>14}" for c in counts))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
