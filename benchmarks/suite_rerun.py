"""Re-run published suite cells with the command their record holds, and compare with the record.

The suite's protocol asks that re-running any cell with its recorded command gives its objective within
the cell's spread. For each cell key this copies the suite's cached references into the record's ``--out``
(so only the cell trains and evaluates), runs the record's ``command`` with this interpreter (plus
``--no-progress``, and ``--no-ray`` unless the cell is an RLlib one), and prints the published and the
re-run objective, their difference against the published 95 % half-width, and whether the per-episode
errors are equal::

    NUMBA_CACHE_DIR=/tmp/nb_rr nice -n 10 python benchmarks/suite_rerun.py \\
        Cruise-Target-v0__ppo__assisted__s4 Cruise-TorqueControl-v0__sac__raw__s0

Exit status 1 if any re-run objective falls outside its cell's published 95 % interval.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _record(path: Path) -> dict:
    if not path.is_file():
        raise SystemExit(f"no record {path}")
    return json.loads(path.read_text())


def rerun(key: str, published: Path) -> bool:
    """Re-run cell ``key`` from the records under ``published``; True if inside the published interval."""
    rec = _record(published / "runs" / f"{key}.json")
    argv = shlex.split(rec["command"])
    if argv[:2] != ["python", "train.py"]:
        raise SystemExit(f"{key}: unexpected recorded command {rec['command']!r}")
    out = ROOT / argv[argv.index("--out") + 1]
    if (out / "runs" / f"{key}.json").exists():
        raise SystemExit(f"{key}: {out} already holds a re-run; remove it first")
    shutil.copytree(published / "references", out / "references", dirs_exist_ok=True)
    extra = ["--no-progress"] + ([] if rec["algorithm"].startswith("rllib") else ["--no-ray"])
    subprocess.run([sys.executable, *argv[1:], *extra], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    new = _record(out / "runs" / f"{key}.json")
    lo, hi = rec["objective_ci95"]
    inside = lo <= new["objective"] <= hi
    same = new.get("per_episode") == rec.get("per_episode")
    print(f"{key}: published {rec['objective']!r}, re-run {new['objective']!r}, "
          f"diff {new['objective'] - rec['objective']:+.3g} (95 % half-width {(hi - lo) / 2:.1f}), "
          f"per-episode equal: {same}, inside: {inside}")  # fmt: skip
    return inside


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("cells", nargs="+", help="cell keys, e.g. Cruise-Target-v0__ppo__raw__s1")
    p.add_argument("--published", default="runs/suite", help="the suite's --out (default %(default)s)")
    a = p.parse_args()
    ok = [rerun(k, ROOT / a.published) for k in a.cells]
    return 0 if all(ok) else 1


if __name__ == "__main__":
    raise SystemExit(main())
