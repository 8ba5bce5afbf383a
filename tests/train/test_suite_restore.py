"""Restoring a suite output folder from its published JSON (planetnav_train.suite.restore): the records
and references come back, the per-agent reference cache where the JSON holds official per-seed values,
nothing local is overwritten, and bad input is a named error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planetnav_env.errors import ConfigError
from planetnav_train import suite
from planetnav_train.cli import main
from planetnav_train.suite import publish, rerun, runner
from planetnav_train.suite.restore import restore
from planetnav_train.suite.scoring import aggregate, normalized_score
from planetnav_train.suite.walltime import reference_seconds

TASK = "Cruise-Target-v1"


def _run(seed: int, score: float) -> dict:
    return {"task": TASK, "algorithm": "ppo", "track": "raw", "seed": seed, "normalized_score": score,
            "objective": 200.0 - 100.0 * score, "official": True,
            "suite_version": suite.get_task(TASK).suite_version, "task_version": 1,
            "per_episode": [1.0, 2.0], "config": {"algo": "ppo"},
            "command": f"python train.py suite --tasks {TASK}"}  # fmt: skip


def _references(**over) -> dict:
    task = suite.get_task(TASK)
    agent = {"objective": 150.0, "ci95": [140.0, 160.0], "per_episode": [150.0] * 3, "wall_seconds": 12.5}
    return {
        "task": TASK, "objective": task.objective, "eval_seed": task.eval_seed,
        "eval_episodes": task.eval_episodes, "episode_steps": task.eval_config(None).episode_steps,
        "noise_streams": task.noise_streams,
        "agents": {"random": {**agent, "objective": 220.0}, "greedy": agent},
        "random": "random", "zero": "random", "best": "greedy",
        "J_random": 220.0, "J_zero": 220.0, "J_best": 150.0, **over,
    }  # fmt: skip


def _published(tmp_path: Path, **refs_over) -> Path:
    runs = [_run(0, 0.8), _run(1, 0.9)]
    full = {"suite_version": suite.get_task(TASK).suite_version, "tasks": [],
            "references": {TASK: _references(**refs_over)}, "runs": runs,
            "aggregate": aggregate(runs, 200)}  # fmt: skip
    path = tmp_path / "benchmark.json"
    path.write_text(json.dumps(publish.compact_suite_json(full)))
    return path


def test_compact_json_keeps_the_references_whole_and_strips_the_runs(tmp_path) -> None:
    data = json.loads(_published(tmp_path).read_text())
    assert all("per_episode" not in r and "config" not in r for r in data["runs"])
    assert data["references"][TASK]["agents"]["greedy"]["per_episode"] == [150.0] * 3


def test_restore_writes_records_references_and_the_reference_cache(tmp_path, monkeypatch) -> None:
    src, out = _published(tmp_path), tmp_path / "suite"
    done = restore(src, out)
    assert len(done.records) == 2 and len(done.references) == 1 and len(done.agents) == 2
    assert not done.uncached and not done.kept
    records = runner.load_records(out)
    assert [r["seed"] for r in records] == [0, 1] and all(r["restored_from"] == str(src) for r in records)
    assert records[1]["normalized_score"] == 0.9 and "per_episode" not in records[1]
    # The cache answers without evaluating anything, and the page's wall time counts the agents.
    import planetnav_train.evaluate as ev

    def no_eval(*a, **k):
        raise AssertionError("a restored reference was evaluated again")

    monkeypatch.setattr(ev, "evaluate_agent", no_eval)
    settings = suite.Settings(out=out)
    got = runner.reference_agent(suite.get_task(TASK), "greedy", settings)
    assert got["objective"] == 150.0 and got["per_episode"] == [150.0] * 3
    assert reference_seconds(out) == {TASK: 25.0}


def test_restore_keeps_existing_files(tmp_path) -> None:
    src, out = _published(tmp_path), tmp_path / "suite"
    local = {**_run(0, 0.5), "note": "local"}
    runner.write_json_atomic(suite.record_path(out, suite.Cell(TASK, "ppo", "raw", 0)), local)
    done = restore(src, out)
    assert len(done.records) == 1 and len(done.kept) == 1
    assert runner.load_records(out)[0]["note"] == "local"
    again = restore(src, out)
    assert not again.records and not again.agents and len(again.kept) == 5


def test_references_of_other_settings_or_without_values_are_not_cached(tmp_path) -> None:
    smoke = restore(_published(tmp_path, eval_episodes=2), tmp_path / "a")
    assert not smoke.agents and sorted(smoke.uncached) == [f"{TASK}/greedy", f"{TASK}/random"]
    src = _published(tmp_path)
    data = json.loads(src.read_text())
    del data["references"][TASK]["agents"]["random"]["per_episode"]
    src.write_text(json.dumps(data))
    old = restore(src, tmp_path / "b")
    assert len(old.agents) == 1 and old.uncached == [f"{TASK}/random"]


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: d.update(suite_version=0), "suite version 0"),
        (lambda d: d["runs"][0].pop("objective"), r"run 0 has no \['objective'\]"),
        (lambda d: d["runs"][1].update(task="Nowhere-v1"), "unknown task 'Nowhere-v1'"),
        (lambda d: d["runs"][1].update(task="Cruise-Target-v2"), "suite version 2, in a table of version 1"),
        (lambda d: d.pop("references"), "no 'runs' and 'references'"),
    ],
)
def test_bad_published_json_is_a_named_error(tmp_path, edit, match) -> None:
    src = _published(tmp_path)
    data = json.loads(src.read_text())
    edit(data)
    src.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match=match):
        restore(src, tmp_path / "suite")


def test_missing_or_unreadable_file_is_a_named_error(tmp_path) -> None:
    with pytest.raises(ConfigError, match=r"no suite JSON at .*nothing\.json"):
        restore(tmp_path / "nothing.json", tmp_path / "suite")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ConfigError, match=r"bad\.json is not a suite JSON"):
        restore(bad, tmp_path / "suite")
    assert main(["suite-restore", "--from", str(bad), "--out", str(tmp_path / "suite")]) == 2


def test_the_command_restores_and_a_restored_record_reruns_without_per_seed_values(tmp_path, capsys) -> None:
    src, out = _published(tmp_path), tmp_path / "suite"
    assert main(["suite-restore", "--from", str(src), "--out", str(out)]) == 0
    assert "2 run records, 1 task references, 2 cached reference agents" in capsys.readouterr().out
    line = rerun.format_rerun({"key": "k", "published": 1.0, "rerun": 1.0, "half_width": 0.5,
                               "per_episode_equal": None, "inside": True})  # fmt: skip
    assert "per-episode equal: not published" in line


PUBLISHED = ("benchmark.json", "benchmark_v1.json")  # version 2's table, and version 1's archived


@pytest.mark.parametrize("name", PUBLISHED)
def test_the_repositorys_published_json_restores(tmp_path, name) -> None:
    """docs/benchmark.json (and version 1's archived table) restores whole: one record per published run,
    every task's references and every reference agent's cache (so a re-run cell evaluates no reference
    again)."""
    src = Path(__file__).resolve().parents[2] / "docs" / name
    data = json.loads(src.read_text())
    done = restore(src, tmp_path / "suite")
    assert len(done.records) == len(data["runs"]) and len(done.references) == len(data["references"])
    agents = sum(len(r["agents"]) for r in data["references"].values())
    assert not done.uncached and len(done.agents) == agents

    def cells(runs: list[dict]) -> list[tuple]:
        return sorted((r["task"], r["algorithm"], r["track"], r["seed"], r["objective"]) for r in runs)

    assert cells(runner.load_records(tmp_path / "suite")) == cells(data["runs"])


@pytest.mark.parametrize("name", PUBLISHED)
def test_the_published_curves_end_inside_their_finals(name) -> None:
    """Every learning curve of the published JSON scored on the final's protocol (its points on the task's
    first evaluation seeds, normalized with the published references' values there) ends on the final
    evaluation, inside the final's 95 % interval mapped to the score. Version 1's table predates that
    protocol (its points were scored on 5 seeds 60,000.. and normalized there, docs/suite.md "Seeds"), so
    its curves are exempt; from version 2 on, every curve must follow it."""
    data = json.loads((Path(__file__).resolve().parents[2] / "docs" / name).read_text())
    assert data["suite_version"] == (1 if name.endswith("_v1.json") else suite.SUITE_VERSION)
    checked = 0
    for r in data["runs"]:
        if not r.get("learning_curve"):
            continue
        task = suite.get_task(r["task"])
        on_protocol = r.get("curve_seeds") is not None and r["curve_seeds"][0] == task.eval_seed
        if data["suite_version"] == 1 and not on_protocol:
            assert r["curve_seeds"] == [60_000, 60_005], r["task"]  # the old protocol, as documented
            continue
        assert on_protocol and r["curve_seeds"][1] - r["curve_seeds"][0] >= 20, (r["task"], r["curve_seeds"])
        ref = data["references"][r["task"]]
        lo, hi = sorted(normalized_score(j, ref["J_zero"], ref["J_best"]) for j in r["objective_ci95"])
        assert r["learning_curve"][-1] == [r["env_steps"], r["normalized_score"]], (r["task"], r["seed"])
        assert lo <= r["learning_curve"][-1][1] <= hi
        checked += 1
    assert checked or data["suite_version"] == 1
