"""Suite v3's learning curves: a learner's J on the first evaluation seeds at fixed fractions of its
training budget, and their table and figure over training runs.

    python -m planetnav_train.suite.v3 learners --task ID --seed S --out F   # the rows, with the curve
    python -m planetnav_train.suite.v3 curves F... [--plot P.png]             # the table and the figure

A point of a curve is a roll-out of the model being trained, at that decision, on the first
:data:`CURVE_EPISODES` evaluation seeds (per-step noise streams), its sampled actions drawn by the
evaluation's own rule (``v3._policy_fn``, draw seed 0): a function of the parameters and the seeds. It
reads the model and nothing of the training's random streams, so a run with a curve trains the
parameters a run without one trains (held by ``tests/train/test_suite_v3.py``). The first point is the
untrained network, the last the model the row scores. A point's J is paired on its seeds with the
published zero and best reference (the normalization record's per-seed J); the score is the blind-zero
score ``(J_zero - J) / (J_zero - J_best)`` against the published constants, where it is defined.
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.errors import ConfigError
from planetnav_train.stats import mean_ci

#: Points of a curve after the untrained one (the budget's tenths; the last at the end of training).
CURVE_POINTS = 10
#: Evaluation seeds of each point: the first of the evaluation's (fewer where the run evaluates fewer). On
#: the Mars approach one runaway episode (thousands of km) moves a 50-seed mean by tens of km; 200 seeds a
#: point cost ~1 min a run there, against ~5 min of training.
CURVE_EPISODES = 200


def curve_callback(evaluate: Callable[[], np.ndarray], budget: int, points: int = CURVE_POINTS) -> Any:
    """An SB3 callback scoring the model ``points`` + 1 times: before training, when the decisions pass
    each ``k * budget / points`` (k = 1 .. points - 1), and after the last update. ``evaluate()`` returns
    the current model's J per curve seed [km]. ``.curve`` holds ``{"decisions": [...], "per_seed":
    [[J per seed], ...]}``, ``.seconds`` the time its roll-outs took [s]."""
    from stable_baselines3.common.callbacks import BaseCallback

    if points < 1 or budget < points:
        raise ConfigError(
            f"a learning curve of {points} points over {budget} decisions: need 1 <= points <= budget"
        )
    marks = [budget * k // points for k in range(1, points)]

    class LearningCurve(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.curve: dict[str, list] = {"decisions": [], "per_seed": []}
            self.seconds = 0.0

        def _point(self) -> None:
            t0 = time.perf_counter()
            self.curve["decisions"].append(int(self.model.num_timesteps))
            self.curve["per_seed"].append(np.round(np.asarray(evaluate(), float), 4).tolist())
            self.seconds += time.perf_counter() - t0

        def _on_training_start(self) -> None:
            self._point()

        def _on_step(self) -> bool:
            if marks and self.model.num_timesteps >= marks[0]:
                marks.pop(0)
                self._point()
            return True

        def _on_training_end(self) -> None:
            self._point()

    return LearningCurve()


def _t_interval(x: Sequence[float]) -> tuple[float, float, float]:
    """(mean, lo, hi): :func:`planetnav_train.stats.mean_ci` over ``x`` (the training runs); (mean, mean,
    mean) for one run."""
    ci = mean_ci(x)
    return (ci.mean, ci.mean, ci.mean) if ci.n < 2 else (ci.mean, ci.low, ci.high)


#: ``(task, episode_steps, seeds, world_overridden) -> (recorded, scale)``: the normalization record's
#: per-seed J of the zero and best reference on the seeds (None where it holds none), and the published
#: (J_zero, J_best) where the score is defined (``v3.curve_table`` passes its own).
Published = Callable[[str, int, range, bool], tuple[dict[str, np.ndarray] | None, tuple[float, float] | None]]


def curve_table(
    runs: Sequence[dict[str, Any]], published: Published, label: str | None = None
) -> dict[str, Any]:
    """The curve of a group of runs of one task and learner (``learners`` files with a
    ``learning_curve``), points aligned by index and cut to the shortest: per point the mean decisions,
    the mean J [km] over runs with the runs' range, J minus the published zero [km] paired on the curve's
    seeds (mean over the runs, 95 % t-interval over them) and the blind-zero score likewise where the
    task's score is defined, from ``published``; ``label`` names the learner (:func:`group_runs`' key;
    default its algo).
    Raises ConfigError where a run has no curve or the runs' seeds differ."""
    if not runs:
        raise ConfigError("a curve table of no runs")
    task = runs[0]["task"]
    curves = []
    for run in runs:
        c = run.get("learning_curve")
        if not c:
            raise ConfigError(f"{task}, seed {run.get('seed')}: the rows carry no learning_curve")
        curves.append(c)
    if len({tuple(c["seeds"]) for c in curves}) != 1:
        raise ConfigError(f"{task}: the runs' curves are on different seeds: {[c['seeds'] for c in curves]}")
    first, n = curves[0]["seeds"]
    n_points = min(len(c["decisions"]) for c in curves)
    world = any(run.get("world_overrides") for run in runs)
    # Pairs with the record only in the task's own configuration (a shortened smoke run's is another).
    recorded, scale = published(task, runs[0]["episode_steps"], range(first, first + n), world)
    points = []
    for k in range(n_points):
        js = [np.asarray(c["per_seed"][k], float) for c in curves]
        means = [float(j.mean()) for j in js]
        p: dict[str, Any] = {"decisions": float(np.mean([c["decisions"][k] for c in curves])),
                             "J": float(np.mean(means)), "J_runs": [min(means), max(means)]}  # fmt: skip
        if recorded is not None:
            p["minus_zero"] = _t_interval([float(np.mean(j - recorded["zero"])) for j in js])
        if scale is not None:
            jz, jb = scale
            p["score"] = _t_interval([(jz - m) / (jz - jb) for m in means])
        points.append(p)
    return {"task": task, "algo": label or runs[0].get("algo", "ppo"), "runs": len(runs),
            "seeds": [first, n], "points": points,
            "zero_on_seeds": None if recorded is None else float(recorded["zero"].mean()),
            "best_on_seeds": None if recorded is None else float(recorded["best"].mean())}  # fmt: skip


def group_runs(files: Sequence[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """Runs grouped by task and learner (its budget, target actions, changed defaults and world named in
    the learner's key)."""
    import json

    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for d in files:
        algo = f"{d.get('algo', 'ppo')}, {d['budget_decisions']:,} decisions"
        if d.get("target_actions", "absolute") != "absolute":
            algo = f"{algo}, {d['target_actions']} target actions"
        if d.get("learner_overrides"):
            algo = f"{algo} {json.dumps(d['learner_overrides'], sort_keys=True)}"
        if d.get("world_overrides"):
            algo = f"{algo} world {json.dumps(d['world_overrides'], sort_keys=True)}"
        groups[(d["task"], algo)].append(d)
    return dict(groups)


def format_table(table: dict[str, Any]) -> list[str]:
    """The lines ``curves`` prints for one group's :func:`curve_table`."""
    first, n = table["seeds"]
    seeds = f"evaluation seeds {first}..{first + n - 1}"
    lines = [f"## {table['task']}, {table['algo']}: {table['runs']} runs, {seeds}"]
    if table["zero_on_seeds"] is not None:
        lines.append(f"  on these seeds: the published zero J {table['zero_on_seeds']:.1f} km, "
                     f"the best reference {table['best_on_seeds']:.1f} km")  # fmt: skip
    for p in table["points"]:
        lo_j, hi_j = p["J_runs"]
        line = f"  {p['decisions']:>9,.0f} decisions: J {p['J']:.1f} (runs {lo_j:.1f}..{hi_j:.1f})"
        if "minus_zero" in p:
            m, lo, hi = p["minus_zero"]
            line += f", minus zero {m:+.1f} [{lo:+.1f}, {hi:+.1f}]"
        if "score" in p:
            m, lo, hi = p["score"]
            line += f", score {m:+.2f} [{lo:+.2f}, {hi:+.2f}]"
        lines.append(line)
    return lines


_LABELS = {"score": "blind-zero score", "minus_zero": "J minus the zero [km]", "J": "J [km]"}


def write_plot(tables: Sequence[dict[str, Any]], path: Path) -> Path:
    """One panel per group: the blind-zero score where the task's is defined, else J minus the published
    zero [km], the mean over the runs with its 95 % t band, against decisions; a line at 0 (the zero) and,
    on the score, at 1 (the best reference)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(3, len(tables))
    rows = -(-len(tables) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.4 * cols, 3.3 * rows), squeeze=False)
    for ax in axes.flat[len(tables) :]:
        ax.remove()
    for ax, t in zip(axes.flat, tables, strict=False):
        key = "score" if "score" in t["points"][0] else "minus_zero"
        if key not in t["points"][0]:  # no published zero on these seeds: J itself
            key = "J"
        x = np.array([p["decisions"] for p in t["points"]]) / 1e3
        if key == "J":
            ax.plot(x, [p["J"] for p in t["points"]], marker=".")
        else:
            m, lo, hi = (np.array([p[key][i] for p in t["points"]]) for i in range(3))
            ax.plot(x, m, marker=".")
            ax.fill_between(x, lo, hi, alpha=0.25)
            ax.axhline(0.0, color="grey", lw=0.8)
            if key == "score":
                ax.axhline(1.0, color="grey", lw=0.8, ls=":")
        ax.set_title(f"{t['task']}, {t['algo']} ({t['runs']} runs)", fontsize=8)
        ax.set_xlabel("decisions (thousands)")
        ax.set_ylabel(_LABELS[key])
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
