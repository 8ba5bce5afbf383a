"""Does the critic's loss jump when the rows' episodes wrap together, and does staggering the starts stop it?

    python research/probes/ppo_value_loss_wraps.py LOG [LOG ...] [--num-steps 16] [--episode-decisions 144]
        [--updates K]

Reads the update lines of ``baselines/ppo_device.py`` training logs (``iter k/K ... v LOSS ...``). With
every row starting on decision 0, an episode of L decisions and T decisions per row an update, update k
begins a new episode on every row when ``(k - 1) T mod L < T``: its batch holds the first decisions of the
episode after the critic was last fitted to its last ones. The script prints, per log, the value loss on
those *wrap* updates (the first update excluded) against the other updates, over the first ``--updates``
updates of each log (so logs of different lengths compare over the same span). Without staggering the
wrap updates' loss stands far above the rest; with ``--stagger-starts`` the rows' phases are spread and
no update is a wrap for all rows, so the two groups should look alike.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

LINE = re.compile(r"^iter\s+(\d+)/\d+\s.*?\sv\s+([0-9.]+)\s")


def read_log(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(update index, value loss) of every update line of a training log."""
    rows = [tuple(map(float, m.groups())) for m in map(LINE.match, path.read_text().splitlines()) if m]
    if not rows:
        raise SystemExit(f"{path}: no update lines ('iter k/K ... v LOSS ...')")
    k, v = (np.asarray(c) for c in zip(*rows, strict=True))
    return k.astype(int), v


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("logs", type=Path, nargs="+")
    p.add_argument("--num-steps", type=int, default=16, help="T: decisions per row an update")
    p.add_argument("--episode-decisions", type=int, default=144, help="L: decisions an episode")
    p.add_argument("--updates", type=int, default=None, help="read the first K updates of each log")
    args = p.parse_args(argv)
    logs = {path: read_log(path) for path in args.logs}
    span = args.updates or min(len(k) for k, _ in logs.values())
    print(f"value loss over updates 2..{span}; wrap: (k-1) T mod {args.episode_decisions} < T")
    t = args.num_steps
    for path, (k, v) in logs.items():
        k, v = k[:span], v[:span]
        wrap = (((k - 1) * t) % args.episode_decisions < t) & (k > 1)
        rest = ~wrap & (k > 1)
        print(
            f"  {path.name}: wrap updates {int(wrap.sum())}, value loss median {np.median(v[wrap]):.2f} "
            f"(max {v[wrap].max():.2f}); other updates {int(rest.sum())}, median {np.median(v[rest]):.2f} "
            f"(max {v[rest].max():.2f}); ratio of medians {np.median(v[wrap]) / np.median(v[rest]):.1f}"
        )


if __name__ == "__main__":
    main()
