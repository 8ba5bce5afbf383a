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
from planetnav_train.suite.tasks import ALGOS, TASKS_BY_ID, TRACKS

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


def algorithm_colours(names: Iterable[str]) -> dict[str, Any]:
    """One colour per algorithm, the same in every panel and every figure: the suite's algorithms in the
    order of :data:`~planetnav_train.suite.tasks.ALGOS`, then any other by name (tab10)."""
    import matplotlib

    cmap = matplotlib.colormaps["tab10"]
    wanted = set(names)
    order = [a for a in ALGOS if a in wanted] + sorted(wanted - set(ALGOS))
    return {
        name: cmap((list(ALGOS).index(name) if name in ALGOS else len(ALGOS) + order.index(name)) % 10)
        for name in wanted
    }


def _set_title(tasks: Sequence[str]) -> str:
    import textwrap

    return textwrap.fill(f"{len(tasks)} task(s): " + ", ".join(tasks), 90)


def write_plots(
    sets: Sequence[Mapping[str, Any]],
    improvements: Sequence[Mapping[str, Any]],
    out_dir: Path,
    prefix: str = "",
) -> list[Path]:
    """PNG plots: ``{prefix}iqm.png`` and ``{prefix}profiles.png`` (one panel per task set of
    :func:`task_set_rows`, named: the IQM with its interval, and the performance profiles, of each
    algorithm that ran on all of it) and, when there are pairs, ``{prefix}improvement.png`` (each pair on
    its tasks in common). One colour per algorithm throughout. Returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    colours = algorithm_colours([a for row in sets for a in row["algorithms"]])
    if sets:  # no ranked algorithm (every entry short-budget): no set panels
        height = sum(0.4 * len(row["algorithms"]) + 0.9 for row in sets) + 0.6
        fig, axes = plt.subplots(
            len(sets), 1, figsize=(6.4, height), squeeze=False, sharex=True,
            gridspec_kw={"height_ratios": [len(row["algorithms"]) + 1 for row in sets]},
        )  # fmt: skip
        for ax, row in zip(axes[:, 0], sets, strict=True):
            algos = row["algorithms"]
            names = sorted(algos, key=lambda k: algos[k]["iqm"])
            for i, k in enumerate(names):
                v = algos[k]
                ax.plot([v["low"], v["high"]], [i, i], lw=6, alpha=0.6, solid_capstyle="butt",
                        color=colours[k])  # fmt: skip
                ax.plot([v["iqm"]], [i], "k|", ms=14)
            ax.set_yticks(range(len(names)), names)
            ax.set_ylim(-0.7, len(names) - 0.3)
            ax.axvline(0.0, color="grey", lw=0.8, ls=":")
            ax.axvline(1.0, color="grey", lw=0.8, ls="--")
            ax.set_title(_set_title(row["tasks"]), fontsize=8)
        axes[-1, 0].set_xlabel("normalized score: IQM and 95 % interval\n(0 the zero point, 1 the best rule)")
        fig.tight_layout()
        paths.append(out_dir / f"{prefix}iqm.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)

        fig, axes = plt.subplots(len(sets), 1, figsize=(6, 3.2 * len(sets) + 0.4), squeeze=False, sharex=True)
        for ax, row in zip(axes[:, 0], sets, strict=True):
            for k, p in sorted(row["profiles"].items()):
                ax.plot(p["tau"], p["fraction"], label=k, color=colours[k])
                ax.fill_between(p["tau"], p["low"], p["high"], alpha=0.15, color=colours[k])
            ax.axvline(1.0, color="grey", lw=0.8, ls="--")
            ax.set_ylabel("fraction of runs with score > τ", fontsize=8)
            ax.set_title(_set_title(row["tasks"]), fontsize=8)
            ax.legend(fontsize=8)
        axes[-1, 0].set_xlabel("normalized score τ")
        fig.tight_layout()
        paths.append(out_dir / f"{prefix}profiles.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)

    if improvements:
        fig, ax = plt.subplots(figsize=(5.5, 0.45 * len(improvements) + 1.2))
        for i, row in enumerate(improvements):
            ax.plot(
                [row["low"], row["high"]], [i, i], lw=6, alpha=0.5, solid_capstyle="butt", color="tab:grey"
            )
            ax.plot([row["probability"]], [i], "k|", ms=14)
        labels = [f"P({r['x']} > {r['y']}), {len(r.get('tasks', []))} task(s)" for r in improvements]
        ax.set_yticks(range(len(improvements)), labels)
        ax.axvline(0.5, color="grey", lw=0.8, ls=":")
        ax.set_xlim(0, 1)
        ax.set_xlabel("probability of improvement, 95 % interval")
        fig.tight_layout()
        paths.append(out_dir / f"{prefix}improvement.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


Scores = dict[str, dict[str, dict[int, float]]]


#: The suffix of an entry that trained for fewer physics steps than its task's budget: shown, never ranked.
SHORT_BUDGET = " (short budget)"


def entry_name(record: Mapping[str, Any]) -> str:
    """The table's name for a run record: its algorithm; ``-tuned`` where the suite's settings of that
    algorithm on the task are its own (:attr:`Algo.task_hyperparams`, :attr:`Algo.task_reward_scale_km`),
    not the algorithm's standard set; and :data:`SHORT_BUDGET` where it trained for fewer physics steps than
    the task's budget (at the record's budget scale), so that it is kept out of every ranking."""
    algo, task = str(record["algorithm"]), str(record["task"])
    name = algo
    settings = ALGOS.get(algo)
    if settings is not None and (task in settings.task_hyperparams or task in settings.task_reward_scale_km):
        name += "-tuned"
    spec = TASKS_BY_ID.get(task)
    steps = record.get("env_steps")
    if spec is not None and steps is not None:
        budget = spec.budget * float(record.get("budget_scale") or 1.0)
        if float(steps) < 0.99 * budget:
            name += SHORT_BUDGET
    return name


def is_ranked(entry: str) -> bool:
    """Whether an entry (:func:`entry_name`) may be ranked: every one trained at its task's full budget."""
    return not entry.endswith(SHORT_BUDGET)


def best_ranked(per_task: Mapping[str, Mapping[str, float]]) -> str | None:
    """The best entry of one task: the ranked entry (:func:`is_ranked`) with the highest IQM of the
    normalized score, ties by name; None when no entry is ranked. ``per_task``: ``{entry: {"iqm", ...}}``.
    The page names it best, and it is what ships (:func:`planetnav_train.suite.publish.best_raw_runs`)."""
    ranked = {k: v for k, v in per_task.items() if is_ranked(k)}
    return min(ranked, key=lambda k: (-ranked[k]["iqm"], k)) if ranked else None


def scores_by_seed(records: Iterable[Mapping[str, Any]], track: str) -> Scores:
    """``{entry: {task: {seed: normalized score}}}`` of ``track``'s records, by :func:`entry_name`."""
    by: Scores = {}
    for r in records:
        if r["track"] == track:
            seeds = by.setdefault(entry_name(r), {}).setdefault(r["task"], {})
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


def _matrix_on(tasks: Mapping[str, Mapping[int, float]], names: Sequence[str]) -> np.ndarray:
    """The ``(runs, tasks)`` score matrix of one algorithm on the tasks ``names``, runs by seed order, cut to
    the seeds every one of those tasks has."""
    n = min(len(tasks[t]) for t in names)
    return np.array([[tasks[t][s] for s in sorted(tasks[t])[:n]] for t in names], dtype=float).T


def task_sets(records: Iterable[Mapping[str, Any]], track: str) -> list[tuple[str, ...]]:
    """The task sets an aggregate may rank algorithms over: each algorithm's own tasks and the tasks every
    two algorithms have in common (non-empty), largest first."""
    by = scores_by_seed(records, track)
    own = [frozenset(t) for a, t in by.items() if is_ranked(a)]
    sets = set(own) | {a & b for a in own for b in own if a & b}
    headline = frozenset(headline_tasks({t for tasks in by.values() for t in tasks}))
    if headline and any(headline <= t for t in own):
        sets.add(headline)
    return [tuple(sorted(s)) for s in sorted(sets, key=lambda s: (-len(s), sorted(s)))]


def headline_tasks(tasks: Iterable[str]) -> tuple[str, ...]:
    """The headline task set of the suite version of ``tasks`` (``Task.headline``: a closed-loop gap of
    25 % or more), whether or not ``tasks`` hold all of it; empty for version 1, which has none."""
    versions = {TASKS_BY_ID[t].suite_version for t in tasks if t in TASKS_BY_ID}
    return tuple(sorted(t.id for t in TASKS_BY_ID.values() if t.headline and t.suite_version in versions))


def task_set_rows(
    records: Iterable[Mapping[str, Any]], track: str, reps: int = BOOTSTRAP_REPS
) -> list[dict[str, Any]]:
    """One aggregate per task set of :func:`task_sets`, ranking only the algorithms that ran on every task
    of it, each over those tasks alone: ``{"tasks", "headline", "algorithms": {algorithm: {"iqm", "low",
    "high"}}, "runs": {algorithm: n}, "profiles": {algorithm: ...}, "curves": {algorithm: ...}}`` (the IQM
    by rliable over the ``(runs, tasks)`` matrix, the performance profiles of the same matrices, and the
    IQM learning curves pooled over the set's tasks: :func:`pooled_curves`). Every aggregate over more
    than one task lives here, so that none mixes task sets: each names its own."""
    records = list(records)
    by = scores_by_seed(records, track)
    rows = []
    for names in task_sets(records, track):
        mats = {
            a: _matrix_on(tasks, names)
            for a, tasks in sorted(by.items())
            if is_ranked(a) and set(names) <= set(tasks)
        }
        rows.append({
            "tasks": list(names),
            "headline": set(names) == set(headline_tasks(names)),
            "algorithms": iqm_intervals(mats, reps),
            "runs": {a: int(m.shape[0]) for a, m in mats.items()},
            "profiles": performance_profiles(mats, reps=min(reps, 2_000)),
            "curves": pooled_curves(records, track, names, sorted(mats), reps=min(reps, 2_000)),
        })  # fmt: skip
    return rows


def _curve_scores(records: Iterable[Mapping[str, Any]], track: str) -> dict[str, dict[str, np.ndarray]]:
    """``{task: {entry: (runs, points, 2) array of (steps, score)}}`` of ``track``'s learning curves, runs
    in the records' order, each entry's curves cut to its shortest."""
    by: dict[str, dict[str, list[list[list[float]]]]] = {}
    for r in records:
        if r["track"] == track and r.get("learning_curve"):
            by.setdefault(r["task"], {}).setdefault(entry_name(r), []).append(r["learning_curve"])
    out: dict[str, dict[str, np.ndarray]] = {}
    for task, algos in by.items():
        for algo, curves in algos.items():
            n = min(len(c) for c in curves)
            out.setdefault(task, {})[algo] = np.array([c[:n] for c in curves], dtype=float)
    return out


def _band(algo: str, scores: np.ndarray, reps: int) -> dict[str, list[float]]:
    """The IQM and its 95 % interval at each point of ``scores`` (runs, points[, tasks])."""
    band = [iqm_intervals({algo: scores[:, k].reshape(scores.shape[0], -1)}, reps)[algo]
            for k in range(scores.shape[1])]  # fmt: skip
    return {key: [b[key] for b in band] for key in ("iqm", "low", "high")}


def learning_curves(
    records: Iterable[Mapping[str, Any]], track: str, reps: int = 2_000
) -> dict[str, dict[str, dict[str, list[float]]]]:
    """IQM learning curves of ``track`` per task, with stratified-bootstrap 95 % bands: ``{task: {algorithm:
    {"steps", "iqm", "low", "high"}}}`` over the seeds' ``learning_curve`` points (aligned by index, cut to
    the shortest). Curves pooled over a task set are the set's (:func:`pooled_curves`)."""
    out: dict[str, dict[str, dict[str, list[float]]]] = {}
    for task, algos in sorted(_curve_scores(records, track).items()):
        for algo, pts in sorted(algos.items()):
            band = _band(algo, pts[:, :, 1], reps)
            out.setdefault(task, {})[algo] = {"steps": pts[0, :, 0].tolist(), **band}
    return out


def pooled_curves(
    records: Iterable[Mapping[str, Any]],
    track: str,
    tasks: Sequence[str],
    algos: Sequence[str],
    reps: int = 2_000,
) -> dict[str, dict[str, list[float]]]:
    """Per algorithm of ``algos`` with a learning curve on every task of ``tasks``: its IQM learning curve
    over those tasks (stratified bootstrap, the tasks as strata), ``{"steps", "iqm", "low", "high"}`` with
    the x axis as the fraction of each run's budget (the tasks' budgets differ), each task's curve cut to
    the points and runs all of them have."""
    by = _curve_scores(records, track)
    out = {}
    for algo in algos:
        if not all(algo in by.get(t, {}) for t in tasks):
            continue
        mats = [by[t][algo][:, :, 1] for t in tasks]
        n = min(m.shape[1] for m in mats)
        runs = min(m.shape[0] for m in mats)
        stacked = np.stack([m[:runs, :n] for m in mats], axis=2)  # (runs, points, tasks)
        out[algo] = {"steps": [(k + 1) / n for k in range(n)], **_band(algo, stacked, reps)}
    return out


def write_curve_plot(
    curves: Mapping[str, Mapping[str, Mapping[str, list[float]]]],
    path: Path,
    sets: Sequence[Mapping[str, Any]] = (),
) -> Path | None:
    """One panel per task, then one per task set of more than one task (``sets``: :func:`task_set_rows`,
    their pooled curves, the panel titled with the set): each algorithm's IQM learning curve and its 95 %
    band; None when there are no curves."""
    pooled = {_set_title(row["tasks"]): row["curves"] for row in sets
              if len(row["tasks"]) > 1 and row.get("curves")}  # fmt: skip
    curves = {**{t: c for t, c in curves.items() if t != "all"}, **pooled}
    if not curves:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(curves)
    colours = algorithm_colours(a for t in names for a in curves[t])
    # A grid of at most three panels a row: readable at page width (a single strip is not).
    cols = min(3, len(names))
    rows = -(-len(names) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), squeeze=False)
    for ax in axes.flat[len(names) :]:
        ax.remove()  # no empty panels
    for ax, task in zip(axes.flat, names, strict=False):
        for algo, c in curves[task].items():
            x = np.asarray(c["steps"], dtype=float) / (1.0 if task in pooled else 1e6)
            ax.plot(x, c["iqm"], label=algo, color=colours[algo])
            ax.fill_between(x, c["low"], c["high"], alpha=0.25, color=colours[algo])
        ax.axhline(1.0, color="grey", lw=0.8, ls=":")
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.set_title(task, fontsize=7 if task in pooled else 9)
        ax.set_xlabel("fraction of the budget" if task in pooled else "physics steps (millions)")
        ax.set_ylabel("normalized score (IQM, 95 % band)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def aggregate(records: Sequence[Mapping[str, Any]], reps: int | None = None) -> dict[str, Any]:
    """Per track: per-task IQM with stratified-bootstrap 95 % intervals per algorithm and per-task learning
    curves; the aggregates over task sets (:func:`task_set_rows`: only algorithms that ran on every task of
    a set are ranked together, each aggregate naming its set: IQM, performance profiles, pooled curves);
    and the probability of improvement between every two ranked algorithms on the tasks they have in
    common, naming them. No aggregate mixes task sets (an algorithm over its own tasks beside another over
    other tasks would rank numbers of different tasks)."""
    reps = reps or BOOTSTRAP_REPS
    out: dict[str, Any] = {}
    for track in TRACKS:
        mats = score_matrices(records, track)
        if not mats:
            continue
        # Per task every seed counts; only the aggregate over tasks needs the common count (rliable).
        per_task: dict[str, Any] = {}
        by = scores_by_seed(records, track)
        for algo, tasks in by.items():
            for task, seeds in tasks.items():
                column = np.array([seeds[s] for s in sorted(seeds)], dtype=float)[:, None]
                per_task.setdefault(task, {}).update(iqm_intervals({algo: column}, reps))
        # Every two algorithms on the tasks they have in common (each cut to the runs both have there).
        pairs = {}
        for x in sorted(by):
            for y in sorted(by):
                common = sorted(set(by[x]) & set(by[y]))
                if x < y and common and is_ranked(x) and is_ranked(y):
                    mx, my = _matrix_on(by[x], common), _matrix_on(by[y], common)
                    runs = min(mx.shape[0], my.shape[0])
                    pairs[(x, y)] = (mx[:runs], my[:runs])
        improvements = improvement_probabilities(pairs, reps=min(reps, 2_000))
        for row, (x, y) in zip(improvements, pairs, strict=True):
            row["tasks"] = sorted(set(by[x]) & set(by[y]))
        out[track] = {
            # What ran where (no aggregate): each entry's tasks and runs per task.
            "tasks": {a: names for a, (names, _) in mats.items()},
            "runs": {a: int(m.shape[0]) for a, (_, m) in mats.items()},
            # One task each.
            "per_task": per_task,
            # Every aggregate over tasks, one task set each, named: only the algorithms that ran on all of
            # it, ranked; with their profiles and pooled learning curves.
            "task_sets": task_set_rows(records, track, reps),
            # One pair each, on the tasks the pair has in common (named).
            "improvement": improvements,
            # One task each.
            "curves": learning_curves(records, track, reps=min(reps, 2_000)),
        }
    return out
