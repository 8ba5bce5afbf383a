"""The paired J table of research/operations_log.md §7.3 from ``train.py compare --json`` files of
consecutive seed
blocks (the 100 held-out seeds were run as two 50-seed commands side by side on the shared machine; each
episode's seed is the block's first seed + its index, so the blocks joined are the 100-seed run).

For every agent: J [km] mean and 95 % interval; ΔJ paired against the first agent (the reference) and
against the best rule (the lower mean J among agents whose names begin with ``periodic`` or ``greedy``),
as km and as % of the best rule's mean J, with the paired t-interval; the mean position error [km]; for
all seeds also the imaging fraction and the wall seconds per episode. Printed for the first ``--first``
seeds and for all.

    .venv/bin/python research/operations/paired_table.py /tmp/opt/cmp_a.json /tmp/opt/cmp_b.json

A block may be several files joined by commas (``a.json,c.json``: runs of the same seeds, e.g. a trained
policy run later beside the stored rules and references); an agent present in more than one of them must
have the same per-episode J in each (the check that the seeds and noise streams are the same), else the
script stops naming it. For every agent that is neither a rule nor a reference (a trained policy), and
for every reference (names beginning with ``optimum`` or ``planner``), it also prints the fraction of the
gap from the best rule to that reference that the agent closes, ``(J_rule - J_agent) / (J_rule - J_ref)``,
and the paired interval of ``J_agent - (J_rule + J_ref) / 2`` (negative: more than half the gap closed).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from planetnav_train.stats import mean_ci, paired_difference


def _block(spec: str) -> dict:
    """One seed block: the ``compare --json`` file(s) of ``spec`` (comma-separated), agents merged."""
    paths = spec.split(",")
    merged: dict = {"agents": {}}
    for path in paths:
        for name, a in json.load(open(path))["agents"].items():
            old = merged["agents"].get(name)
            if old is not None and (
                old["seed"] != a["seed"]
                or not np.array_equal(old["per_episode_objective"], a["per_episode_objective"])
            ):
                raise SystemExit(f"{spec}: agent {name!r} differs between the joined files (other seeds?)")
            merged["agents"].setdefault(name, a)
    firsts = {(a["seed"], a["episodes"]) for a in merged["agents"].values()}
    if len(firsts) != 1:
        raise SystemExit(f"{spec}: the joined files cover different seeds {sorted(firsts)}")
    return merged


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+", help="compare --json files in seed order (a,b: one block's files)")
    ap.add_argument("--first", type=int, default=20, help="also the table of the first N seeds")
    args = ap.parse_args()
    parts = [_block(spec) for spec in args.files]
    names = list(parts[0]["agents"])
    seed = parts[0]["agents"][names[0]]["seed"]
    for p in parts:
        a = p["agents"][names[0]]
        if a["seed"] != seed:
            raise SystemExit(f"{args.files}: seed blocks not consecutive (expected {seed}, got {a['seed']})")
        seed += a["episodes"]

    def cat(name: str, key: str) -> np.ndarray:
        return np.concatenate([np.asarray(p["agents"][name][key], float) for p in parts])

    j = {n: cat(n, "per_episode_objective") for n in names}
    err = {n: cat(n, "per_episode_mean_pos_err_km") for n in names}
    eps = [p["agents"][names[0]]["episodes"] for p in parts]
    imaging = {
        n: np.average([p["agents"][n]["measured_fraction"] for p in parts], weights=eps) for n in names
    }
    sec = {n: np.average([p["agents"][n]["seconds_per_episode"] for p in parts], weights=eps) for n in names}
    first_seed = parts[0]["agents"][names[0]]["seed"]
    for n_seeds in sorted({min(args.first, len(j[names[0]])), len(j[names[0]])}):
        rules = [n for n in names if n.startswith(("periodic", "greedy"))]
        best = min(rules, key=lambda n: j[n][:n_seeds].mean())
        m_best = j[best][:n_seeds].mean()
        print(f"--- {n_seeds} seeds ({first_seed}..{first_seed + n_seeds - 1}); best rule: {best}")
        for n in names:
            x = j[n][:n_seeds]
            c = mean_ci(x)
            line = f"{n:54s} J {c.mean:7.1f} [{c.low:7.1f}, {c.high:7.1f}]"
            if n != names[0]:
                d = paired_difference(x, j[names[0]][:n_seeds])
                line += f"  dJ vs ref {d.mean:+7.1f} [{d.low:+7.1f}, {d.high:+7.1f}]"
            if n != best:
                d = paired_difference(x, j[best][:n_seeds])
                line += f"  vs best rule {100 * d.mean / m_best:+.1f} % [{100 * d.low / m_best:+.1f}, "
                line += f"{100 * d.high / m_best:+.1f}]"
            line += f"  pos err {err[n][:n_seeds].mean():7.1f}"
            if n_seeds == len(j[names[0]]):  # the blocks' own means: all seeds only
                line += f"  imaging {imaging[n]:.3f}  s/ep {sec[n]:.1f}"
            print(line)
        others = [n for n in names if not n.startswith(("periodic", "greedy", "optimum", "planner"))]
        for ref in (n for n in names if n.startswith(("optimum", "planner"))):
            gap = m_best - j[ref][:n_seeds].mean()
            for n in others:
                closed = (m_best - j[n][:n_seeds].mean()) / gap
                d = paired_difference(j[n][:n_seeds], 0.5 * (j[best][:n_seeds] + j[ref][:n_seeds]))
                print(
                    f"{n} closes {100 * closed:.1f} % of the gap {best} -> {ref} ({gap:.1f} km); "
                    f"J - (J_rule + J_ref)/2 = {d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}] km"
                )


if __name__ == "__main__":
    main()
