"""Every aggregate of the suite's JSON ranks algorithms over one task set and names it: an algorithm over its
own tasks is never set beside another over other tasks, and a short-budget entry is never ranked."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest

from planetnav_train import suite
from planetnav_train.suite.scoring import SHORT_BUDGET, is_ranked

V2 = ["Cruise-Target-v2", "Cruise-Torque-v2", "MarsApproach-Tasking-v2", "RandomCruise-Target-v2",
      "ThrustArc-TCM-v2"]  # fmt: skip


def _record(task: str, algo: str, seed: int, score: float, short: bool = False) -> dict[str, Any]:
    budget = suite.get_task(task).budget
    steps = budget // 10 if short else budget
    curve = [[steps * k / 4, score * k / 4] for k in range(1, 5)]
    return {"task": task, "algorithm": algo, "track": "raw", "seed": seed, "normalized_score": score,
            "objective": 1000.0 - 800.0 * score, "official": True, "env_steps": steps, "budget_scale": 1.0,
            "learning_curve": curve, "suite_version": 2, "task_version": 2}  # fmt: skip


def _records() -> list[dict[str, Any]]:
    """The published table's shape: PPO on all five tasks, DQN on the four discrete ones, and SAC on one
    task with a tenth of its budget and a higher score than either (the case that was ranked first)."""
    out = [_record(t, "ppo", s, -0.7 + 0.1 * s) for t in V2 for s in range(4)]
    out += [_record(t, "dqn", s, -1.5 + 0.1 * s) for t in V2 if t != "Cruise-Torque-v2" for s in range(4)]
    out += [_record("Cruise-Torque-v2", "sac", s, -0.2 + 0.05 * s, short=True) for s in range(4)]
    return out


def aggregates_over_tasks(track_agg: Mapping[str, Any]) -> list[tuple[list[str], set[str]]]:
    """Every aggregate over more than one entry of one track, as (the task set it names, its entries)."""
    found = []
    for row in track_agg["task_sets"]:
        for key in ("algorithms", "runs", "profiles", "curves"):
            found.append((row["tasks"], set(row[key])))
    for row in track_agg["improvement"]:
        found.append((row["tasks"], {row["x"], row["y"]}))
    return found


def check_one_task_set_each(track_agg: Mapping[str, Any]) -> None:
    """The invariant: no aggregate outside the named ones, and each named one covers only entries (ranked)
    that ran on every task it names."""
    named = {"tasks", "runs", "per_task", "task_sets", "improvement", "curves"}
    assert set(track_agg) <= named, set(track_agg) - named
    assert all(task in suite.TASKS_BY_ID for task in track_agg["per_task"])  # one task each
    assert all(task in suite.TASKS_BY_ID for task in track_agg["curves"])  # one task each (no "all")
    for tasks, entries in aggregates_over_tasks(track_agg):
        assert tasks, "an aggregate names no task set"
        for entry in entries:
            assert is_ranked(entry), f"{entry} is ranked in the aggregate over {tasks}"
            assert set(tasks) <= set(track_agg["tasks"][entry]), f"{entry} did not run on all of {tasks}"


def test_every_aggregate_names_one_task_set_and_ranks_only_full_budget_entries() -> None:
    pytest.importorskip("rliable")
    agg = suite.aggregate(_records(), reps=100)["raw"]
    check_one_task_set_each(agg)
    sets = {tuple(row["tasks"]): row for row in agg["task_sets"]}
    # PPO alone over all five tasks; PPO and DQN over DQN's four; the headline pair (PPO's alone)
    assert set(sets) == {tuple(V2), tuple(t for t in V2 if t != "Cruise-Torque-v2"),
                         ("Cruise-Torque-v2", "RandomCruise-Target-v2")}  # fmt: skip
    assert set(sets[tuple(V2)]["algorithms"]) == {"ppo"}
    assert set(sets[tuple(t for t in V2 if t != "Cruise-Torque-v2")]["algorithms"]) == {"ppo", "dqn"}
    # the short-budget SAC keeps its per-task figure, named as such, and is in no aggregate over tasks
    sac = "sac" + SHORT_BUDGET
    assert sac in agg["per_task"]["Cruise-Torque-v2"]
    assert all(sac not in entries for _, entries in aggregates_over_tasks(agg))
    # the pooled learning curve of a set pools exactly its tasks: PPO's mean over the five at the last point
    curve = sets[tuple(V2)]["curves"]["ppo"]
    assert curve["steps"][-1] == 1.0 and curve["low"][-1] <= curve["iqm"][-1] <= curve["high"][-1]


def test_the_check_fails_on_a_mixed_aggregate() -> None:
    """An "overall" of each algorithm over its own tasks (SAC on one task beside PPO on five) fails it, as
    does a set row that ranks an algorithm missing one of its tasks."""
    pytest.importorskip("rliable")
    agg = suite.aggregate(_records(), reps=100)["raw"]
    with pytest.raises(AssertionError):
        check_one_task_set_each({**agg, "overall": {}})
    row = next(r for r in agg["task_sets"] if len(r["tasks"]) == 5)
    mixed = {**row, "algorithms": {**row["algorithms"], "dqn": row["algorithms"]["ppo"]}}
    with pytest.raises(AssertionError, match="dqn did not run on all"):
        check_one_task_set_each({**agg, "task_sets": [mixed]})


def test_summary_ranks_no_short_budget_entry() -> None:
    pytest.importorskip("rliable")
    records = _records()
    text = suite.summary_markdown(suite.suite_json(records, {}, suite.aggregate(records, reps=100)))
    block = text.split("aggregated over tasks:")[1].split("best algorithm per task")[0]
    assert "sac" not in block and "| 1 | ppo |" in block


def test_shipped_v2_baselines_are_the_published_pages_ranked_best() -> None:
    """Each shipped ``suite:<task>`` of the published version-2 table is the run of the entry that the
    page (docs/benchmark.json's per-task IQMs) names best, the entry's lowest objective; none is unranked."""
    import json
    from pathlib import Path

    from planetnav_train.shipped import BASELINES_DIR, load_manifest
    from planetnav_train.suite.scoring import best_ranked, entry_name

    root = Path(__file__).resolve().parents[2]
    published = json.loads((root / "docs" / "benchmark.json").read_text())
    assert published["suite_version"] == 2
    shipped = {t: e for t, e in load_manifest(BASELINES_DIR)["baselines"].items() if e["suite_version"] == 2}
    assert shipped, "no version-2 baseline shipped"
    per_task = published["aggregate"]["raw"]["per_task"]
    for task, entry in shipped.items():
        best = best_ranked(per_task[task])
        runs = [r for r in published["runs"] if r["task"] == task and r["track"] == "raw"
                and entry_name(r) == best]  # fmt: skip
        want = min(runs, key=lambda r: (r["objective"], r["seed"]))
        assert (entry["algorithm"], entry["seed"]) == (want["algorithm"], want["seed"]), task
        assert entry["source_cell"] == f"{task}__{want['algorithm']}__raw__s{want['seed']}"
        assert entry["objective"] == pytest.approx(want["objective"])


def test_the_published_json_names_one_task_set_per_aggregate_from_a_clean_tree() -> None:
    """docs/benchmark.json as published: every aggregate over tasks names its one task set and ranks only
    full-budget entries that ran on all of it, and it was aggregated from a clean tree at a commit."""
    import json
    from pathlib import Path

    published = json.loads((Path(__file__).resolve().parents[2] / "docs" / "benchmark.json").read_text())
    assert published["aggregate"]
    for track_agg in published["aggregate"].values():
        check_one_task_set_each(track_agg)
    prov = published["provenance"]
    assert len(prov["git_commit"]) == 40 and prov["git_dirty"] is False and prov["allow_dirty"] is False
