"""Scores of the benchmark suite: the normalized score of one run (:func:`normalized_score`) and the
aggregation over runs the way the field reports it, with ``rliable`` (Agarwal et al. 2021): the
interquartile mean with stratified-bootstrap 95 % intervals (:func:`iqm_intervals`), performance profiles
(:func:`performance_profiles`) and the probability of improvement between algorithms
(:func:`improvement_probabilities`), and their plots (:func:`write_plots`).

A score matrix is ``(runs, tasks)``: column ``m`` holds one algorithm's training seeds on task ``m``. The
stratified bootstrap resamples runs within each task (rliable's default, ``task_bootstrap=False``): the
interval is the uncertainty of re-running the same tasks with other seeds.

``rliable`` is the ``bench`` extra; it is imported inside the functions that need it, so the formula and
the suite's bookkeeping work without it.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.errors import ConfigError
from planetnav_train.suite.tasks import TRACKS

#: Bootstrap resamples of the published aggregates (rliable's own default for intervals is 50,000; 10,000
#: keeps the 95 % endpoints to ~0.01 of a score on matrices of this size and takes seconds).
BOOTSTRAP_REPS = 10_000
#: Seed of the bootstrap (the same records give the same intervals).
BOOTSTRAP_SEED = 0
#: Thresholds of the performance profiles, in normalized score.
PROFILE_TAUS = tuple(float(t) for t in np.round(np.linspace(-0.5, 2.0, 51), 3))


def normalized_score(j: float, j_random: float, j_best: float) -> float:
    """``(J_random - J) / (J_random - J_best)`` for an objective ``J`` where lower is better: 0 is the random
    agent, 1 the best non-learned reference, above 1 beats it, below 0 is worse than random.

    Raises :class:`ConfigError` naming the values when the references coincide (no scale) or are not
    finite.
    """
    values = {"J": j, "J_random": j_random, "J_best": j_best}
    bad = {k: v for k, v in values.items() if not math.isfinite(float(v))}
    if bad:
        raise ConfigError(f"normalized score: non-finite objective value(s) {bad}")
    span = float(j_random) - float(j_best)
    if span == 0.0:
        raise ConfigError(
            f"normalized score: the random and the best reference have the same objective ({j_random!r}), "
            "so the score has no scale"
        )
    return (float(j_random) - float(j)) / span


def require_rliable() -> None:
    """Raise :class:`ConfigError` naming the ``bench`` extra when rliable is not installed."""
    import importlib.util

    if importlib.util.find_spec("rliable") is None:
        raise ConfigError(
            'the suite\'s aggregation needs rliable, which is not installed: pip install -e ".[bench]"'
        )


@contextlib.contextmanager
def _rliable_draws(seed: int) -> Iterator[None]:
    """rliable's bootstrap, seeded: rliable 1.2's stratified bootstrap draws its resamples from numpy's
    legacy global generator (the ``random_state`` it hands to arch is never used for them), so the global
    generator is seeded for the call and restored after it. Also silences arch's FutureWarning about that
    ``random_state``."""
    state = np.random.get_state()  # noqa: NPY002 - rliable reads the legacy global generator
    np.random.seed(seed)  # noqa: NPY002
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=FutureWarning, module="arch")
            yield
    finally:
        np.random.set_state(state)  # noqa: NPY002


def iqm(scores: np.ndarray) -> float:
    """The interquartile mean of all entries (rliable's ``aggregate_iqm``: the 25 % trimmed mean)."""
    from rliable import metrics

    return float(metrics.aggregate_iqm(np.asarray(scores, dtype=float)))


def _check_matrices(score_dict: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    out = {}
    for name, m in score_dict.items():
        arr = np.asarray(m, dtype=float)
        if arr.ndim != 2 or arr.size == 0:
            raise ValueError(
                f"scores of {name!r}: expected a non-empty (runs, tasks) matrix, got {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"scores of {name!r}: non-finite values")
        out[name] = arr
    return out


def iqm_intervals(
    score_dict: Mapping[str, np.ndarray], reps: int = BOOTSTRAP_REPS, seed: int = BOOTSTRAP_SEED
) -> dict[str, dict[str, float]]:
    """``{algorithm: {"iqm", "low", "high"}}``: the IQM of each ``(runs, tasks)`` matrix with its
    stratified-bootstrap 95 % percentile interval (``reps`` resamples, seeded)."""
    require_rliable()
    from rliable import library as rly
    from rliable import metrics

    scores = _check_matrices(score_dict)
    with _rliable_draws(seed):
        point, ci = rly.get_interval_estimates(
            scores,
            lambda x: np.array([metrics.aggregate_iqm(x)]),
            reps=int(reps),
            random_state=np.random.RandomState(seed),
        )
    return {
        k: {"iqm": float(point[k][0]), "low": float(ci[k][0, 0]), "high": float(ci[k][1, 0])} for k in scores
    }


def performance_profiles(
    score_dict: Mapping[str, np.ndarray],
    taus: Sequence[float] = PROFILE_TAUS,
    reps: int = 2_000,
    seed: int = BOOTSTRAP_SEED,
) -> dict[str, dict[str, list[float]]]:
    """``{algorithm: {"tau", "fraction", "low", "high"}}``: the fraction of runs whose score exceeds each
    ``tau`` (score distribution), with stratified-bootstrap 95 % bands."""
    require_rliable()
    from rliable import library as rly

    scores = _check_matrices(score_dict)
    with _rliable_draws(seed):
        prof, cis = rly.create_performance_profile(scores, np.asarray(taus, dtype=float), reps=int(reps))
    return {
        k: {
            "tau": [float(t) for t in taus],
            "fraction": [float(v) for v in prof[k]],
            "low": [float(v) for v in cis[k][0]],
            "high": [float(v) for v in cis[k][1]],
        }
        for k in scores
    }


def improvement_probabilities(
    pairs: Mapping[tuple[str, str], tuple[np.ndarray, np.ndarray]],
    reps: int = 2_000,
    seed: int = BOOTSTRAP_SEED,
) -> list[dict[str, Any]]:
    """For each ``(X, Y)``: P(X > Y), the probability that a run of X beats a run of Y on a task drawn at
    random (Mann-Whitney, ties count half, averaged over tasks), with its stratified-bootstrap 95 %
    interval. The two matrices must cover the same tasks (columns) in the same order."""
    require_rliable()
    from rliable import library as rly
    from rliable import metrics

    out = []
    for (x, y), (sx, sy) in pairs.items():
        mx, my = (_check_matrices({x: sx})[x], _check_matrices({y: sy})[y])
        if mx.shape[1] != my.shape[1]:
            raise ValueError(f"P({x} > {y}): the score matrices cover {mx.shape[1]} and {my.shape[1]} tasks")
        with _rliable_draws(seed):
            point, ci = rly.get_interval_estimates(
                {"pair": (mx, my)},
                metrics.probability_of_improvement,
                reps=int(reps),
                random_state=np.random.RandomState(seed),
            )
        out.append(
            {
                "x": x,
                "y": y,
                "probability": float(point["pair"]),
                "low": float(np.ravel(ci["pair"])[0]),
                "high": float(np.ravel(ci["pair"])[1]),
            }
        )
    return out


def write_plots(
    intervals: Mapping[str, Mapping[str, float]],
    profiles: Mapping[str, Mapping[str, list[float]]],
    improvements: Sequence[Mapping[str, Any]],
    out_dir: Path,
    prefix: str = "",
) -> list[Path]:
    """PNG plots: ``{prefix}iqm.png`` (IQM with intervals per algorithm), ``{prefix}profiles.png``
    (performance profiles) and, when there are pairs, ``{prefix}improvement.png``. Returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    names = sorted(intervals, key=lambda k: intervals[k]["iqm"])
    fig, ax = plt.subplots(figsize=(5.5, 0.45 * len(names) + 1.2))
    for i, k in enumerate(names):
        v = intervals[k]
        ax.plot([v["low"], v["high"]], [i, i], lw=6, alpha=0.5, solid_capstyle="butt")
        ax.plot([v["iqm"]], [i], "k|", ms=14)
    ax.set_yticks(range(len(names)), names)
    ax.axvline(0.0, color="grey", lw=0.8, ls=":")
    ax.axvline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("normalized score: IQM, 95 % stratified-bootstrap interval (0 random, 1 best rule)")
    fig.tight_layout()
    paths.append(out_dir / f"{prefix}iqm.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4))
    for k in sorted(profiles):
        p = profiles[k]
        ax.plot(p["tau"], p["fraction"], label=k)
        ax.fill_between(p["tau"], p["low"], p["high"], alpha=0.15)
    ax.axvline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("normalized score τ")
    ax.set_ylabel("fraction of runs with score > τ")
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(out_dir / f"{prefix}profiles.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    if improvements:
        fig, ax = plt.subplots(figsize=(5.5, 0.45 * len(improvements) + 1.2))
        for i, row in enumerate(improvements):
            ax.plot([row["low"], row["high"]], [i, i], lw=6, alpha=0.5, solid_capstyle="butt")
            ax.plot([row["probability"]], [i], "k|", ms=14)
        ax.set_yticks(range(len(improvements)), [f"P({r['x']} > {r['y']})" for r in improvements])
        ax.axvline(0.5, color="grey", lw=0.8, ls=":")
        ax.set_xlim(0, 1)
        ax.set_xlabel("probability of improvement, 95 % interval")
        fig.tight_layout()
        paths.append(out_dir / f"{prefix}improvement.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


Scores = dict[str, dict[str, dict[int, float]]]


def scores_by_seed(records: Iterable[Mapping[str, Any]], track: str) -> Scores:
    """``{algorithm: {task: {seed: normalized score}}}`` of ``track``'s records."""
    by: Scores = {}
    for r in records:
        if r["track"] == track:
            seeds = by.setdefault(r["algorithm"], {}).setdefault(r["task"], {})
            seeds[int(r["seed"])] = r["normalized_score"]
    return by


def score_matrices(
    records: Iterable[Mapping[str, Any]], track: str
) -> dict[str, tuple[list[str], np.ndarray]]:
    """Per algorithm of ``track``: its tasks and the ``(runs, tasks)`` score matrix, runs by seed order.
    Tasks with fewer seeds than the others of the algorithm are cut to the common count (rliable needs a
    full matrix): the aggregate over tasks uses the cut (its table gives the runs per task), the per-task
    intervals of :func:`aggregate` every seed."""
    out = {}
    for algo, tasks in scores_by_seed(records, track).items():
        names = sorted(tasks)
        n = min(len(tasks[t]) for t in names)
        cols = [[tasks[t][s] for s in sorted(tasks[t])[:n]] for t in names]
        out[algo] = (names, np.array(cols, dtype=float).T)
    return out


def learning_curves(
    records: Iterable[Mapping[str, Any]], track: str, reps: int = 2_000
) -> dict[str, dict[str, dict[str, list[float]]]]:
    """IQM learning curves of ``track`` with stratified-bootstrap 95 % bands: ``{task: {algorithm: {"steps",
    "iqm", "low", "high"}}}`` over the seeds' ``learning_curve`` points (aligned by index, cut to the
    shortest), and under the task ``"all"`` per algorithm over its tasks, the x axis as the fraction of
    each run's budget."""
    by: dict[str, dict[str, list[list[list[float]]]]] = {}
    for r in records:
        if r["track"] == track and r.get("learning_curve"):
            by.setdefault(r["task"], {}).setdefault(r["algorithm"], []).append(r["learning_curve"])
    out: dict[str, dict[str, dict[str, list[float]]]] = {}
    pooled: dict[str, list[np.ndarray]] = {}
    for task, algos in sorted(by.items()):
        for algo, curves in sorted(algos.items()):
            n = min(len(c) for c in curves)
            pts = np.array([c[:n] for c in curves], dtype=float)  # (runs, points, 2)
            scores = pts[:, :, 1]
            band = [iqm_intervals({algo: scores[:, [k]]}, reps)[algo] for k in range(n)]
            out.setdefault(task, {})[algo] = {
                "steps": pts[0, :, 0].tolist(),
                "iqm": [b["iqm"] for b in band],
                "low": [b["low"] for b in band],
                "high": [b["high"] for b in band],
            }
            pooled.setdefault(algo, []).append(scores)
    for algo, mats in sorted(pooled.items()):
        n = min(m.shape[1] for m in mats)
        runs = min(m.shape[0] for m in mats)
        band = [iqm_intervals({algo: np.stack([m[:runs, k] for m in mats], axis=1)}, reps)[algo]
                for k in range(n)]  # fmt: skip
        out.setdefault("all", {})[algo] = {
            "steps": [(k + 1) / n for k in range(n)],
            "iqm": [b["iqm"] for b in band],
            "low": [b["low"] for b in band],
            "high": [b["high"] for b in band],
        }
    return out


def write_curve_plot(
    curves: Mapping[str, Mapping[str, Mapping[str, list[float]]]], path: Path
) -> Path | None:
    """One panel per task (and the aggregate ``all``): each algorithm's IQM learning curve and its 95 %
    band; None when there are no curves."""
    if not curves:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [t for t in curves if t != "all"] + (["all"] if "all" in curves else [])
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.2), squeeze=False)
    for ax, task in zip(axes[0], names, strict=True):
        for algo, c in curves[task].items():
            x = np.asarray(c["steps"], dtype=float) / (1.0 if task == "all" else 1e6)
            ax.plot(x, c["iqm"], label=algo)
            ax.fill_between(x, c["low"], c["high"], alpha=0.25)
        ax.axhline(1.0, color="grey", lw=0.8, ls=":")
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.set_title("all tasks" if task == "all" else task, fontsize=9)
        ax.set_xlabel("fraction of the budget" if task == "all" else "physics steps (millions)")
        ax.set_ylabel("normalized score (IQM, 95 % band)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def aggregate(records: Sequence[Mapping[str, Any]], reps: int | None = None) -> dict[str, Any]:
    """Per track: per-task and overall IQM with stratified-bootstrap 95 % intervals per algorithm,
    performance profiles, and the probability of improvement between every two algorithms that ran on the
    same tasks (this module)."""
    reps = reps or BOOTSTRAP_REPS
    out: dict[str, Any] = {}
    for track in TRACKS:
        mats = score_matrices(records, track)
        if not mats:
            continue
        # Per task every seed counts; only the aggregate over tasks needs the common count (rliable).
        per_task: dict[str, Any] = {}
        for algo, tasks in scores_by_seed(records, track).items():
            for task, seeds in tasks.items():
                column = np.array([seeds[s] for s in sorted(seeds)], dtype=float)[:, None]
                per_task.setdefault(task, {}).update(iqm_intervals({algo: column}, reps))
        overall = iqm_intervals({a: m for a, (_, m) in mats.items()}, reps)
        profiles = performance_profiles({a: m for a, (_, m) in mats.items()}, reps=min(reps, 2_000))
        pairs = {
            (x, y): (mats[x][1], mats[y][1])
            for x in sorted(mats)
            for y in sorted(mats)
            if x < y and mats[x][0] == mats[y][0] and mats[x][1].shape == mats[y][1].shape
        }
        improvements = improvement_probabilities(pairs, reps=min(reps, 2_000))
        out[track] = {
            "tasks": {a: names for a, (names, _) in mats.items()},
            "runs": {a: int(m.shape[0]) for a, (_, m) in mats.items()},
            "per_task": per_task,
            "overall": overall,
            "profiles": profiles,
            "improvement": improvements,
            "curves": learning_curves(records, track, reps=min(reps, 2_000)),
        }
    return out
