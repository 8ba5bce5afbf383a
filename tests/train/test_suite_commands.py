"""The benchmark suite's maintenance commands of ``train.py`` (docs/suite.md): ``suite-references`` (the
reference values, cached where the suite reads them), ``suite-rerun`` (a recorded cell re-run with its
command and compared with its record) and ``suite-sizes`` (model and policy-only export bytes), each on
the smallest input that exercises it, and their errors naming the bad value (exit status 2)."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from planetnav_env.errors import ConfigError
from planetnav_train import suite
from planetnav_train.cli import main
from planetnav_train.shipped import MAX_BASELINE_BYTES
from planetnav_train.suite.references import reference_specs
from planetnav_train.suite.rerun import format_rerun, rerun_cell
from planetnav_train.suite.sizes import ships_as

SMOKE = ["--eval-episodes", "1", "--episode-steps", "5"]


def test_suite_references_caches_one_agent(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["suite-references", "--tasks", "Cruise-Target-v1", "--agents", "random", *SMOKE, "--out"]
    assert main([*argv, str(tmp_path)]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("Cruise-Target-v1 | random | mean_pos_err_km ")
    assert "| 1 seeds from 50000 |" in line
    (cached,) = (tmp_path / "references" / "agents").iterdir()
    summary = json.loads(cached.read_text())
    assert summary["agent"] == "random" and len(summary["per_episode"]) == 1
    # the suite's own path reads the same cache entry: nothing is evaluated again
    settings = suite.Settings(out=tmp_path, eval_episodes=1, episode_steps=5)
    assert suite.reference_agent(suite.get_task("Cruise-Target-v1"), "random", settings) == summary
    assert main([*argv, str(tmp_path)]) == 0
    assert capsys.readouterr().out.strip() == line  # the cached wall time, not a new one


def test_suite_references_names_bad_values(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    task = suite.get_task("Cruise-Target-v1")
    assert reference_specs(task) == ["random", *task.references]
    assert reference_specs(task, ["planner", "random"]) == ["random", "planner"]
    out = ["--out", str(tmp_path)]
    cases = [
        (["--tasks", "Cruise-Target-v1", "--agents", "random", "nope"], "--agents ['nope']: not among"),
        (["--tasks", "Nope-v0"], "unknown task 'Nope-v0'"),
        (["--eval-episodes", "0"], "--eval-episodes must be >= 1, got 0"),
        (["--episode-steps", "-3"], "--episode-steps must be >= 1, got -3"),
    ]
    for args, message in cases:
        assert main(["suite-references", *args, *out]) == 2
        captured = capsys.readouterr()
        assert message in captured.err and captured.out == ""
    assert not (tmp_path / "references").exists()  # checked before anything was evaluated


# A stand-in for train.py: writes the cell's record into --out with the objective of $FAKE_OBJECTIVE.
FAKE_TRAIN = """
import json, os, sys
from pathlib import Path
out = Path(sys.argv[sys.argv.index("--out") + 1])
assert "--no-progress" in sys.argv and "--no-ray" in sys.argv
assert (out / "references" / "Cruise-Target-v1.json").is_file()
key = "Cruise-Target-v1__ppo__raw__s1"
(out / "runs").mkdir(parents=True)
record = {"objective": float(os.environ["FAKE_OBJECTIVE"]), "per_episode": [1.0, 2.0]}
(out / "runs" / f"{key}.json").write_text(json.dumps(record))
"""


def _published(tmp_path: Path, key: str, command: str) -> Path:
    published = tmp_path / "published"
    (published / "runs").mkdir(parents=True)
    (published / "references").mkdir()
    (published / "references" / "Cruise-Target-v1.json").write_text("{}")
    record = {"command": command, "algorithm": "ppo", "objective": 600.0, "objective_ci95": [590.0, 610.0],
              "per_episode": [1.0, 2.0]}  # fmt: skip
    (published / "runs" / f"{key}.json").write_text(json.dumps(record))
    return published


def test_rerun_cell_runs_the_recorded_command_and_compares(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    key = "Cruise-Target-v1__ppo__raw__s1"
    cell = suite.Cell("Cruise-Target-v1", "ppo", "raw", 1)
    command = suite.rerun_command(cell, suite.Settings(out=tmp_path))
    published = _published(tmp_path, key, command)
    root = tmp_path / "repo"
    root.mkdir()
    (root / "train.py").write_text(FAKE_TRAIN)
    monkeypatch.setenv("FAKE_OBJECTIVE", "600.0")
    got = rerun_cell(key, published, root=root)
    assert got == {"key": key, "published": 600.0, "rerun": 600.0, "half_width": 10.0,
                   "per_episode_equal": True, "inside": True}  # fmt: skip
    assert format_rerun(got).startswith(f"{key}: published 600.0, re-run 600.0, diff +0 ")
    out = root / shlex.split(command)[shlex.split(command).index("--out") + 1]
    with pytest.raises(ConfigError, match="already holds a re-run; remove it first"):
        rerun_cell(key, published, root=root)
    monkeypatch.setenv("FAKE_OBJECTIVE", "620.5")
    for f in (out / "runs").iterdir():
        f.unlink()
    (out / "runs").rmdir()
    got = rerun_cell(key, published, root=root)
    assert got["inside"] is False and got["rerun"] == 620.5
    (root / "train.py").write_text("raise SystemExit(3)")
    (out / "runs" / f"{key}.json").unlink()
    with pytest.raises(ConfigError, match="exited with status 3"):
        rerun_cell(key, published, root=root)


def test_suite_rerun_names_a_missing_cell_or_an_odd_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    key = "Cruise-Target-v1__ppo__raw__s9"
    assert main(["suite-rerun", key, "--published", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"cell {key!r}: no record at {tmp_path / 'runs' / (key + '.json')}" in err
    published = _published(tmp_path, key, "python other.py suite --out x")
    assert main(["suite-rerun", key, "--published", str(published)]) == 2
    assert "unexpected recorded command 'python other.py suite --out x'" in capsys.readouterr().err


def test_ships_as() -> None:
    small, big = MAX_BASELINE_BYTES - 1, MAX_BASELINE_BYTES
    assert ships_as(small, None) == ships_as(small, big) == "full"
    assert ships_as(big, small) == "policy-only"
    assert ships_as(big, big) == "none (refused)"
    assert ships_as(big, None) == "no"


def test_suite_sizes_builds_and_exports_a_model(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["suite-sizes", "--tasks", "Cruise-Target-v1", "--algos", "dqn", "sac"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "| task | algorithm | obs | full bytes | policy-only bytes | ships as |"
    dqn = lines[2].strip("| ").split(" | ")
    assert dqn[:2] == ["Cruise-Target-v1", "dqn"]
    full, small = (int(v.replace(",", "")) for v in dqn[3:5])
    assert 0 < small < full < MAX_BASELINE_BYTES and dqn[5] == "full"
    assert lines[3].endswith("| - | - | runs on continuous actions, not discrete |")
    assert len(lines) == 4


def test_suite_sizes_names_bad_values(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["suite-sizes", "--tasks", "Cruise-Target-v1", "--algos", "dqn", "nope"]) == 2
    captured = capsys.readouterr()
    assert "unknown algorithm 'nope'" in captured.err and captured.out == ""  # before the table starts
    assert main(["suite-sizes", "--tasks", "Nope-v0", "--no-export"]) == 2
    assert "unknown task 'Nope-v0'" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["suite-sizes", "--help"])
    assert "--no-export" in capsys.readouterr().out
