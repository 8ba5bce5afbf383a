"""The suite's outputs: the JSON of all runs with the aggregates (``OUT/suite.json``), the markdown
summary (the README's block) and the leaderboard page (``OUT/benchmark.md``) with its plots.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_train.provenance import provenance
from planetnav_train.spread import prediction_interval
from planetnav_train.suite.cells import Settings, coverage_lines
from planetnav_train.suite.challenges import challenge_lines, task_status
from planetnav_train.suite.runner import INTERFACE_RANDOM, write_json_atomic
from planetnav_train.suite.scoring import aggregate, best_ranked, entry_name, is_ranked
from planetnav_train.suite.tasks import SUITES, records_version
from planetnav_train.suite.walltime import WallTime, reference_seconds, table_wall_time, wall_time_lines


def suite_json(
    records: Sequence[Mapping[str, Any]], references: Mapping[str, Any], agg: Mapping[str, Any]
) -> dict[str, Any]:
    """The published JSON: the suite version and its tasks, the references used, every run, and the
    aggregates."""
    version = records_version(records)
    return {
        "suite_version": version,
        "tasks": [t.to_dict() for t in SUITES[version]],
        "references": dict(references),
        "runs": list(records),
        "aggregate": dict(agg),
    }


def _fmt_interval(v: Mapping[str, float]) -> str:
    return f"{v['iqm']:.2f} [{v['low']:.2f}, {v['high']:.2f}]"


#: What the score's 0 is, per suite version (:func:`score_legend`).
_ZERO_POINT = {
    1: "0 is the better of random and idle, 1 the best non-learned reference, both acting at the physics "
    "step",
    2: "0 is the task's best blind policy (the winner of its published search over policies that ignore "
    "the observation: docs/tasks_v2_blind.json), 1 the best non-learned, non-privileged reference",
}


def score_legend(version: int) -> str:
    """What the normalized score and its aggregate mean, said once for the page and the README summary of
    suite ``version``'s table (its zero point differs between versions)."""
    return (
        f"Normalized score = (J_zero − J) / (J_zero − J_best): {_ZERO_POINT[version]}; IQM over runs with "
        "stratified-bootstrap 95 % intervals (rliable). Only algorithms that ran on every task of a set are "
        "ranked together; `-tuned` marks per-task settings (the algorithm's standard set otherwise); "
        "`(short budget)` marks fewer physics steps than the task's budget: shown, never ranked."
    )


def aggregate_rows(track_agg: Mapping[str, Any]) -> list[str]:
    """Markdown table of one track's aggregates (:func:`aggregate`): one block of rows per task set, named,
    ranking only the algorithms that ran on every task of it (best first), with their runs per task and
    IQM over those tasks with the 95 % interval."""
    sets = track_agg["task_sets"]
    lines = ["| task set | rank | algorithm | runs per task | IQM [95 % CI] |", "|---|---|---|---|---|"]
    for row in sets:
        algos = row["algorithms"]
        name = f"{len(row['tasks'])}: " + ", ".join(row["tasks"])
        if row.get("headline"):  # the tasks where a blind policy leaves 25 % or more of the error
            name = f"**headline** ({name}; closed-loop gap ≥ 25 %)"
        for rank, x in enumerate(sorted(algos, key=lambda k: (-algos[k]["iqm"], k)), start=1):
            lines.append(f"| {name if rank == 1 else ''} | {rank} | {x} | {row['runs'][x]} | "
                         f"{_fmt_interval(algos[x])} |")  # fmt: skip
    return lines


def _new_run_interval(runs: Sequence[Mapping[str, Any]], task: str, algo: str, track: str) -> str:
    """The 95 % prediction interval of a new training run's objective from the seeds of one cell group
    (planetnav_train.spread); "-" with fewer than two finite runs."""
    key = (task, algo, track)
    values = [r["objective"] for r in runs if (r["task"], entry_name(r), r.get("track", "raw")) == key]
    try:
        pi = prediction_interval(values)
    except ValueError:
        return "-"
    # Objectives are errors (>= 0): a normal interval's lower end below zero is cut there.
    return f"{pi.mean:.1f} [{max(pi.lo, 0.0):.1f}, {pi.hi:.1f}]"


def best_per_task_rows(
    track_agg: Mapping[str, Any],
    references: Mapping[str, Any],
    runs: Sequence[Mapping[str, Any]] = (),
    track: str = "raw",
) -> list[str]:
    """Markdown table of one track: per task the algorithm with the highest IQM of the normalized score
    (ties: the first by name), the objective a new training run of it gives (mean over its seeds and the
    95 % prediction interval of one more run; from ``runs``), and the best non-learned reference it is
    scored against (its objective, on the task's evaluation seeds)."""
    lines = [
        "| task | best algorithm | IQM [95 % CI] | a new run's objective: mean [95 % prediction interval] "
        "| best non-learned reference | random in the task's interface: score | status |",
        "|---|---|---|---|---|---|---|",
    ]
    for task in sorted(track_agg["per_task"]):
        per = track_agg["per_task"][task]
        best = best_ranked(per)
        if best is None:
            continue  # only short-budget entries: nothing to rank
        ref = references.get(task)
        ref_text = f"{ref['best']} ({ref['J_best']:.1f} km)" if ref else "-"
        new_run = _new_run_interval(runs, task, best, track)
        lines.append(f"| {task} | {best} | {_fmt_interval(per[best])} | {new_run} | {ref_text} | "
                     f"{_interface_random(ref)} | {task_status(task, per[best]['iqm'])} |")  # fmt: skip
    return lines


def best_scores(track_agg: Mapping[str, Any]) -> dict[str, float]:
    """Per task, the highest IQM normalized score of any ranked entry (full budget) in one track's
    aggregate."""
    out = {}
    for task, per in track_agg["per_task"].items():
        ranked = [v["iqm"] for k, v in per.items() if is_ranked(k)]
        if ranked:
            out[task] = max(ranked)
    return out


def _interface_random(ref: Mapping[str, Any] | None) -> str:
    """The normalized score of the random policy in the task's own interface (what the posing alone buys),
    "-" when the references do not hold it."""
    if not ref or "J_zero" not in ref or INTERFACE_RANDOM not in ref.get("agents", {}):
        return "-"
    j = ref["agents"][INTERFACE_RANDOM]["objective"]
    return f"{(ref['J_zero'] - j) / (ref['J_zero'] - ref['J_best']):+.2f}"


#: The sample-efficiency budget, physics steps, reported apart from the full budget.
SAMPLE_EFFICIENCY_STEPS = 1_000_000
#: A curve has flattened when its IQM rises by less than this over the last 20 % of its budget.
FLAT_RISE = 0.05


def curve_rows(curves: Mapping[str, Mapping[str, Mapping[str, list[float]]]]) -> list[str]:
    """Markdown table from one track's IQM learning curves (:func:`scoring.learning_curves`): per task and
    algorithm, the IQM at the last curve point within :data:`SAMPLE_EFFICIENCY_STEPS` (the
    sample-efficiency budget), at the end of the budget, and the rise over the last 20 % of the budget
    (from the point nearest 80 % to the end): below :data:`FLAT_RISE` the curve has flattened, unless the
    final band's half-width exceeds twice that, where 5 curve seeds cannot tell (``unresolved``)."""
    lines = [
        f"| task | algorithm | IQM at ≤ {SAMPLE_EFFICIENCY_STEPS / 1e6:g}M physics steps [95 % CI] | "
        "IQM at the full budget | rise over the last 20 % | flattened |",
        "|---|---|---|---|---|---|",
    ]
    for task in sorted(t for t in curves if t != "all"):
        for algo, c in sorted(curves[task].items()):
            steps = np.asarray(c["steps"], dtype=float)
            within = np.flatnonzero(steps <= SAMPLE_EFFICIENCY_STEPS * 1.001)  # curve points land on rollouts
            early = (f"{c['iqm'][within[-1]]:.2f} [{c['low'][within[-1]]:.2f}, {c['high'][within[-1]]:.2f}] "
                     f"at {steps[within[-1]] / 1e6:.2f}M" if within.size else "-")  # fmt: skip
            k80 = int(np.argmin(np.abs(steps - 0.8 * steps[-1])))
            rise = c["iqm"][-1] - c["iqm"][k80]
            half = 0.5 * (c["high"][-1] - c["low"][-1])
            flat = "unresolved" if half > 2 * FLAT_RISE else "yes" if rise < FLAT_RISE else "**no**"
            lines.append(f"| {task} | {algo} | {early} | {c['iqm'][-1]:.2f} [{c['low'][-1]:.2f}, "
                         f"{c['high'][-1]:.2f}] at {steps[-1] / 1e6:.2f}M | {rise:+.2f} | "
                         f"{flat} |")  # fmt: skip
    return [*lines, ""]


def provenance_lines(prov: Mapping[str, Any] | None) -> list[str]:
    """Markdown: the tree the aggregation ran from, from its ``provenance``: a clean tree at a commit, or
    (in bold) a tree with uncommitted changes or outside a git checkout, with whether ``--allow-dirty``
    let it publish. Nothing when no provenance was recorded."""
    if not prov:
        return []
    commit = prov.get("git_commit")
    allowed = " (published with `--allow-dirty`)" if prov.get("allow_dirty") else ""
    if commit is None:
        text = f"**Aggregated outside a git checkout**{allowed}: no commit recorded."
    elif prov.get("git_dirty"):
        text = (f"**Aggregated from a tree with uncommitted changes** at commit `{commit[:12]}`{allowed}: "
                "the changes are listed in the JSON's `provenance`; no commit reproduces it.")  # fmt: skip
    else:
        text = f"Aggregated from a clean tree at commit `{commit[:12]}` (the JSON's `provenance`)."
    return [text, ""]


def summary_markdown(data: Mapping[str, Any]) -> str:
    """The summary of a suite JSON (``OUT/suite.json``, :func:`suite_json`) as markdown: per track the
    algorithms' IQM over tasks with 95 % intervals and per task the best algorithm. Flags smoke-setting
    runs ("Not a leaderboard"). The README's summary block is this text
    (:mod:`planetnav_train.suite.publish`)."""
    runs, agg = list(data.get("runs") or []), dict(data.get("aggregate") or {})
    if not runs or not agg:
        return "No run recorded yet.\n"
    tasks = sorted({r["task"] for r in runs})
    lines = [f"Suite version {data.get('suite_version')}: {len(runs)} runs on {len(tasks)} task(s). "
             + score_legend(int(data.get("suite_version") or 1)), ""]  # fmt: skip
    unofficial = sum(not r.get("official", False) for r in runs)
    if unofficial:
        lines += [f"**Not a leaderboard**: {unofficial} of {len(runs)} runs used smoke settings.", ""]
    lines += coverage_lines(runs, table=False)
    lines += provenance_lines(data.get("provenance"))
    for track, a in agg.items():
        lines += [f"Track `{track}`, aggregated over tasks:", "", *aggregate_rows(a), ""]
        lines += [f"Track `{track}`, best algorithm per task:", ""]
        lines += [*best_per_task_rows(a, data.get("references") or {}, runs, track), ""]
    return "\n".join(lines)


def write_leaderboard(
    records: Sequence[Mapping[str, Any]],
    references: Mapping[str, Any],
    agg: Mapping[str, Any],
    path: Path,
    plots: bool = True,
    wall: WallTime | None = None,
    prov: Mapping[str, Any] | None = None,
) -> Path:
    """The leaderboard markdown at ``path`` (plots beside it in ``<stem>_plots/``): the references used,
    per track the per-task and aggregated IQM tables, P(improvement), the plots, and every run with its
    command. Runs with smoke settings are flagged at the top: such a page is no leaderboard."""
    from planetnav_train.suite import scoring

    path.parent.mkdir(parents=True, exist_ok=True)
    lines = ["# planetnav benchmark suite: results", ""]
    unofficial = [r for r in records if not r.get("official", False)]
    if not records:
        lines += ["No run recorded yet.", ""]
    if unofficial:
        lines += [
            f"**Not a leaderboard**: {len(unofficial)} of {len(records)} runs used smoke settings (budget "
            "scale, episode length or evaluation seeds other than the task's). Their numbers check the "
            "machinery only.",
            "",
        ]
    lines += [score_legend(records_version(records)), ""]
    lines += provenance_lines(prov)
    lines += ["## Coverage", "", *coverage_lines(records)]
    if wall is not None:
        lines += ["## Wall time of the table", "", "Worker-seconds of the published table on this run's "
                  "machine: the finished cells and references as measured, the rest projected from the "
                  "finished cells of the same algorithm and track (docs/suite.md).", "",
                  *wall_time_lines(wall)]  # fmt: skip
    lines += ["## References", "", "| task | agent | objective [95 % CI] | role |", "|---|---|---|---|"]
    for task, ref in sorted(references.items()):
        for agent, v in ref["agents"].items():
            if agent == ref.get("zero"):
                role = "**zero point**"
            elif agent == ref["best"]:
                role = "**best**"
            elif agent == ref["random"] or agent == "random@interface":
                role = "random" if agent == ref["random"] else "random in the task's interface"
            else:
                role = "candidate"
            lines.append(
                f"| {task} | {agent} | {v['objective']:.1f} [{v['ci95'][0]:.1f}, {v['ci95'][1]:.1f}] "
                f"| {role} |"
            )
    lines.append("")
    plot_dir = path.parent / f"{path.stem}_plots"
    for track, a in agg.items():
        lines += [f"## Track `{track}`", "", "### Per task (IQM of the normalized score over seeds)", ""]
        algos = sorted(a["tasks"])
        lines += ["| task | " + " | ".join(algos) + " |", "|---|" + "---|" * len(algos)]
        for task in sorted(a["per_task"]):
            cells = [
                _fmt_interval(a["per_task"][task][x]) if x in a["per_task"][task] else "-" for x in algos
            ]
            lines.append(f"| {task} | " + " | ".join(cells) + " |")
        lines += ["", "### Aggregated over tasks", "", *aggregate_rows(a)]
        lines += ["", "### Best algorithm per task", "", *best_per_task_rows(a, references, records, track)]
        lines += ["", "### Challenges", "", *challenge_lines(best_scores(a))]
        if a["improvement"]:
            lines += [
                "",
                "| P(X > Y) on the tasks in common | tasks | probability [95 % CI] |",
                "|---|---|---|",
            ]
            for row in a["improvement"]:
                tasks = ", ".join(row.get("tasks", [])) or "-"
                lines.append(
                    f"| P({row['x']} > {row['y']}) | {tasks} | {row['probability']:.2f} "
                    f"[{row['low']:.2f}, {row['high']:.2f}] |"
                )
        if plots:
            for p in scoring.write_plots(a["task_sets"], a["improvement"], plot_dir, prefix=f"{track}_"):
                lines += ["", f"![{p.stem}]({plot_dir.name}/{p.name})"]
            curve = scoring.write_curve_plot(a.get("curves", {}), plot_dir / f"{track}_curves.png",
                                             sets=a["task_sets"])  # fmt: skip
            if curve is not None:
                title = "### Learning curves (IQM over seeds, 95 % stratified-bootstrap band)"
                lines += ["", title, "", f"![{curve.stem}]({plot_dir.name}/{curve.name})"]
        if a.get("curves"):
            head = "### Sample efficiency and flattening (from the learning curves)"
            lines += ["", head, "", *curve_rows(a["curves"])]
        lines.append("")
    lines += ["## Runs", "", "The headline is the protocol's evaluation mode; the other mode's objective "
              "beside it.", "", "| task | algorithm | track | seed | mode | objective | other mode | score "
              "| score vs random | wall s | command |", "|---" * 11 + "|"]  # fmt: skip
    for r in sorted(records, key=lambda r: (r["track"], r["task"], r["algorithm"], r["seed"])):
        mode = r.get("eval_mode", "argmax")
        other = [v["objective"] for m, v in r.get("evaluations", {}).items() if m != mode]
        vs_random = r.get("score_vs_random")
        lines.append(f"| {r['task']} | {r['algorithm']} | {r['track']} | {r['seed']} | {mode} | "
                     f"{r['objective']:.1f} | {f'{other[0]:.1f}' if other else '-'} | "
                     f"{r['normalized_score']:+.2f} | {'-' if vs_random is None else f'{vs_random:+.2f}'} | "
                     f"{r['wall_seconds']:.0f} | `{r['command']}` |")  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    return path


def finish(
    result: Mapping[str, Any],
    settings: Settings,
    json_path: str | None,
    markdown: Path | None,
    reps: int | None = None,
    allow_dirty: bool = False,
) -> dict[str, Any]:
    """Aggregate every record under ``settings.out``, write ``OUT/suite.json``, the invocation's runs to
    ``json_path`` (same form) and the leaderboard markdown (default ``OUT/benchmark.md``). Both JSON carry
    the ``provenance`` of this aggregation (each run keeps its own, of the process that ran it), with
    ``allow_dirty``: whether the publisher was told to accept a tree that is not clean (``--allow-dirty``);
    the page says which tree it was (:func:`provenance_lines`)."""
    records = result["records"]
    references = dict(result["references"])
    for p in sorted((settings.out / "references").glob("*.json")):  # tasks run by earlier invocations
        ref = json.loads(p.read_text())
        references.setdefault(ref["task"], ref)
    agg = aggregate(records, reps) if records else {}
    prov = {**provenance(), "allow_dirty": bool(allow_dirty)}
    data = {**suite_json(records, references, agg), "provenance": prov}
    write_json_atomic(settings.out / "suite.json", data)
    if json_path:
        write_json_atomic(Path(json_path), {**data, "runs": list(result["ran"])})
    wall = table_wall_time(records, reference_seconds(settings.out))
    md = write_leaderboard(records, references, agg, markdown or settings.out / "benchmark.md", wall=wall,
                           prov=prov)  # fmt: skip
    return {"json": settings.out / "suite.json", "markdown": md, "aggregate": agg}
