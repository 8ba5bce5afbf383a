"""Provenance of the result records (planetnav_train.provenance): its fields and types, the git state of a
checkout (the dirty flag follows tracked changes and untracked files, not ignored ones), the writers that
attach it, and a record restored from a published JSON keeping its own provenance or getting null."""

from __future__ import annotations

import datetime as dt
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planetnav_train import provenance as P
from planetnav_train import suite
from planetnav_train.suite import publish, runner
from planetnav_train.suite.restore import restore

FIELDS = {"git_commit", "git_dirty", "git_changes", "versions", "platform", "cpu_model", "cpus",
          "torch_threads", "utc", "wall_s"}  # fmt: skip
VERSIONS = {"python", "numpy", "numba", "torch", "gymnasium", "stable-baselines3"}
needs_git = pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")


def _check(prov: dict, wall_s: float | None) -> None:
    """``prov`` has every field with its type."""
    assert set(prov) == FIELDS
    json.dumps(prov)  # JSON-ready as it is
    assert prov["git_commit"] is None or (len(prov["git_commit"]) == 40 and int(prov["git_commit"], 16) >= 0)
    assert prov["git_dirty"] is None or isinstance(prov["git_dirty"], bool)
    assert prov["git_changes"] is None or all(isinstance(s, str) for s in prov["git_changes"])
    assert set(prov["versions"]) == VERSIONS
    assert prov["versions"]["python"] == ".".join(map(str, sys.version_info[:3]))
    assert prov["versions"]["numpy"] == np.__version__
    assert all(v is None or isinstance(v, str) for v in prov["versions"].values())
    assert isinstance(prov["platform"], str) and prov["platform"]
    assert prov["cpu_model"] is None or isinstance(prov["cpu_model"], str)
    assert isinstance(prov["cpus"], int) and prov["cpus"] >= 1
    assert prov["torch_threads"] is None or isinstance(prov["torch_threads"], int)
    when = dt.datetime.fromisoformat(prov["utc"])
    assert when.utcoffset() == dt.timedelta(0)
    assert abs((dt.datetime.now(dt.UTC) - when).total_seconds()) < 600
    assert prov["wall_s"] == wall_s


def test_fields_and_types(monkeypatch) -> None:
    _check(P.provenance(wall_s=1.25), 1.25)
    _check(P.provenance(), None)
    assert P.package_versions(("numpy", "no-such-distribution-planetnav")) == {
        "python": sys.version.split()[0], "numpy": np.__version__, "no-such-distribution-planetnav": None
    }  # fmt: skip
    # torch's threads only where torch is imported: an imported (stand-in) module is asked, none is None.
    monkeypatch.setitem(sys.modules, "torch", type("T", (), {"get_num_threads": staticmethod(lambda: 3)}))
    assert P.provenance()["torch_threads"] == 3
    monkeypatch.delitem(sys.modules, "torch")
    assert P.provenance()["torch_threads"] is None


def test_reading_the_versions_imports_no_torch() -> None:
    code = (
        "import sys; from planetnav_train.provenance import provenance; p = provenance(); "
        "print('torch' in sys.modules, p['versions']['torch'] is not None, p['torch_threads'])"
    )
    got = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    imported, _, threads = got.stdout.split()
    assert imported == "False" and threads == "None"


@needs_git
def test_dirty_flag_follows_tracked_changes_and_untracked_files(tmp_path) -> None:
    repo = tmp_path / "repo"
    repo.mkdir()

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false", *args],
            cwd=repo, capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip

    git("init", "-q")
    (repo / "a.txt").write_text("one\n")
    (repo / ".gitignore").write_text("runs/\n")
    git("add", "a.txt", ".gitignore")
    git("commit", "-q", "-m", "first")
    head = git("rev-parse", "HEAD").strip()

    clean = P.provenance(repo)
    assert (clean["git_commit"], clean["git_dirty"], clean["git_changes"]) == (head, False, [])
    (repo / "runs").mkdir()
    (repo / "runs" / "eval.json").write_text("{}")  # ignored: still clean
    assert P.git_state(repo)["git_dirty"] is False
    (repo / "a.txt").write_text("two\n")  # a tracked file changed: dirty
    dirty = P.git_state(repo)
    assert dirty["git_dirty"] is True and dirty["git_changes"] == [" M a.txt"] and dirty["git_commit"] == head
    (repo / "a.txt").write_text("one\n")
    assert P.git_state(repo)["git_dirty"] is False
    (repo / "new.py").write_text("x = 1\n")  # untracked, not ignored: dirty
    assert P.git_state(repo) == {"git_commit": head, "git_dirty": True, "git_changes": ["?? new.py"]}
    # Not a git checkout (nothing tracked there): no commit, no flag.
    plain = tmp_path / "plain"
    plain.mkdir()
    assert P.git_state(plain) == {"git_commit": None, "git_dirty": None, "git_changes": None}
    assert P.git_state(repo / "runs") == {"git_commit": None, "git_dirty": None, "git_changes": None}


@needs_git
def test_the_package_names_its_own_checkout() -> None:
    root = Path(P.__file__).resolve().parents[1]
    if not (root / ".git").exists():
        pytest.skip("planetnav is not a git checkout here")
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True).stdout
    assert P.provenance()["git_commit"] == head.strip()


def test_evaluate_json_carries_provenance(tmp_path) -> None:
    from planetnav_train.cli import main

    out = tmp_path / "eval.json"
    assert main(["evaluate", "--agent", "random", "--episodes", "1", "--episode-steps", "5", "--json",
                 str(out), "--no-progress"]) == 0  # fmt: skip
    data = json.loads(out.read_text())
    assert set(data) == {"agents", "skipped", "provenance"}
    wall_s = data["provenance"]["wall_s"]
    _check(data["provenance"], wall_s)
    assert wall_s >= data["agents"]["random"]["seconds_per_episode"] * 0.5 > 0


def test_compare_json_and_report_carry_provenance(tmp_path) -> None:
    from planetnav_train.cli import main

    js, report = tmp_path / "cmp.json", tmp_path / "report"
    assert main(["compare", "--agents", "random", "idle", "--episodes", "2", "--episode-steps", "5",
                 "--json", str(js), "--report", str(report), "--no-progress"]) == 0  # fmt: skip
    data, ev = json.loads(js.read_text()), json.loads((report / "eval.json").read_text())
    _check(data["provenance"], data["provenance"]["wall_s"])
    assert data["provenance"]["wall_s"] > 0 and ev["provenance"]["wall_s"] == data["provenance"]["wall_s"]
    assert ev["agents"] == data["agents"]


def test_blind_search_task_entries_and_regime_map_carry_provenance(tmp_path, research_command) -> None:
    """Each task entry of blind-search's JSON has its own provenance (an entry of an earlier run, added
    to, keeps what it had); regime-map's JSON has one."""
    out = tmp_path / "blind.json"
    out.write_text(json.dumps({"search_seed": 0, "eval_seed": 0, "tasks": {"Old-v0": {"wall_s": 9.0}}}))
    short = ["--option", "episode_steps=20"]
    blind_search, regime_map = research_command("blind_search").main, research_command("regime_map").main
    assert blind_search(["--tasks", "Cruise-Target-v2", "--search-episodes", "2", "--finalists", "2",
                 "--final-episodes", "2", "--episodes", "3", "--references", "greedy", "--no-progress",
                 "--json", str(out), *short]) == 0  # fmt: skip
    tasks = json.loads(out.read_text())["tasks"]
    assert tasks["Old-v0"] == {"wall_s": 9.0}  # nothing invented for an entry written before
    rec = tasks["Cruise-Target-v2 episode_steps=20"]
    _check(rec["provenance"], rec["wall_s"])
    js = tmp_path / "map.json"
    assert regime_map(["--task", "Cruise-Target-v2", "--strengths", "0", "--agents", "greedy",
                 "--candidates", "random", "--search-episodes", "2", "--final-episodes", "0",
                 "--episodes", "2", "--json", str(js), *short]) == 0  # fmt: skip
    data = json.loads(js.read_text())
    _check(data["provenance"], data["wall_s"])


def _fake_evaluate(spec, env_cfg, episodes, seed, progress=True, batched=True, exact_actions=True):
    from planetnav_train import evaluate

    base = 300.0 if str(spec).startswith("random") else 100.0  # the references need a scale
    metrics = {"per_episode_mean_pos_err_km": [base + k for k in range(episodes)]}
    return evaluate.EvalResult(spec, metrics, np.zeros(0), np.zeros(0))


def test_suite_record_and_reference_cache_carry_provenance(tmp_path, monkeypatch) -> None:
    """A cell's record (trained and evaluated by stand-ins) carries the provenance with the cell's wall
    seconds; so does each reference agent in its cache and in the task's references; suite.json too."""
    from planetnav_train import evaluate

    monkeypatch.setattr(evaluate, "evaluate_agent", _fake_evaluate)
    monkeypatch.setattr(
        runner, "train_cell", lambda tc, run_dir, progress, resume, callbacks=(): (run_dir / "model.zip", {})
    )
    settings = suite.Settings(out=tmp_path, eval_episodes=2)
    task = suite.get_task("Cruise-Torque-v1")
    refs = suite.task_references(task, settings)
    for spec, agent in refs["agents"].items():
        cached = json.loads(runner.agent_cache_path(task, spec, settings).read_text())
        _check(cached["provenance"], cached["wall_seconds"])
        assert agent["provenance"] == cached["provenance"]
    record = suite.run_cell(suite.Cell(task.id, "sac", "raw", 0), settings, refs)
    _check(record["provenance"], record["wall_seconds"])
    # An agent cached before records carried provenance: None in the references, not this machine's.
    path = runner.agent_cache_path(task, "random", settings)
    old = {k: v for k, v in json.loads(path.read_text()).items() if k != "provenance"}
    path.write_text(json.dumps(old))
    assert suite.task_references(task, settings)["agents"]["random"]["provenance"] is None
    # suite.json: the aggregation's own provenance; each run keeps the one of the process that ran it.
    runner.write_json_atomic(suite.record_path(tmp_path, suite.Cell(task.id, "sac", "raw", 0)), record)
    result = {"records": runner.load_records(tmp_path), "ran": [record], "references": {task.id: refs}}
    suite.finish(result, settings, str(tmp_path / "ran.json"), tmp_path / "page.md", reps=50)
    for name in ("suite.json", "ran.json"):
        data = json.loads((tmp_path / name).read_text())
        prov = dict(data["provenance"])
        assert isinstance(prov.pop("allow_dirty"), bool)  # the publisher's own: was --allow-dirty given
        _check(prov, None)
        assert data["runs"][0]["provenance"] == record["provenance"]


TASK = "Cruise-Target-v1"
ORIGINAL = {"git_commit": "0" * 40, "git_dirty": False, "git_changes": [], "utc": "2020-01-01T00:00:00+00:00",
            "wall_s": 1234.5, "cpu_model": "the publishing machine"}  # fmt: skip


def _published(tmp_path: Path) -> Path:
    """A published suite JSON: run seed 0 with provenance, seed 1 written before records had it; the
    reference agent greedy with provenance, random without."""
    task = suite.get_task(TASK)

    def run(seed: int) -> dict:
        return {"task": TASK, "algorithm": "ppo", "track": "raw", "seed": seed, "normalized_score": 0.5,
                "objective": 150.0, "official": True, "suite_version": task.suite_version, "task_version": 1,
                "command": f"python train.py suite --tasks {TASK}"}  # fmt: skip

    agent = {"objective": 150.0, "ci95": [140.0, 160.0], "per_episode": [150.0] * 3, "wall_seconds": 12.5}
    refs = {"task": TASK, "objective": task.objective, "eval_seed": task.eval_seed,
            "eval_episodes": task.eval_episodes, "episode_steps": task.eval_config(None).episode_steps,
            "noise_streams": task.noise_streams,
            "agents": {"random": {**agent, "objective": 220.0}, "greedy": {**agent, "provenance": ORIGINAL}},
            "random": "random", "zero": "random", "best": "greedy",
            "J_random": 220.0, "J_zero": 220.0, "J_best": 150.0}  # fmt: skip
    data = {"suite_version": task.suite_version, "tasks": [], "references": {TASK: refs},
            "runs": [{**run(0), "provenance": ORIGINAL}, run(1)], "aggregate": {}}  # fmt: skip
    path = tmp_path / "benchmark.json"
    path.write_text(json.dumps(publish.compact_suite_json(data)))
    return path


def test_restored_records_keep_their_provenance_or_get_null(tmp_path) -> None:
    src, out = _published(tmp_path), tmp_path / "suite"
    done = restore(src, out)
    assert len(done.records) == 2 and len(done.agents) == 2
    by_seed = {r["seed"]: r for r in runner.load_records(out)}
    assert by_seed[0]["provenance"] == ORIGINAL and by_seed[0]["restored_from"] == str(src)
    assert "provenance" in by_seed[1] and by_seed[1]["provenance"] is None
    task, settings = suite.get_task(TASK), suite.Settings(out=out)
    greedy = json.loads(runner.agent_cache_path(task, "greedy", settings).read_text())
    random = json.loads(runner.agent_cache_path(task, "random", settings).read_text())
    assert greedy["provenance"] == ORIGINAL and "provenance" in random and random["provenance"] is None
    # The task's references come back as published (no provenance added to an agent that had none).
    refs = json.loads((out / "references" / f"{TASK}.json").read_text())
    assert "provenance" not in refs["agents"]["random"] and refs["agents"]["greedy"]["provenance"] == ORIGINAL
