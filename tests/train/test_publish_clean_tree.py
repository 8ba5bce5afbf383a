"""Published tables come from a clean tree at a commit: the publisher refuses uncommitted changes (or a
source outside git) unless ``--allow-dirty``, and the page and the JSON then say which tree it was."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from planetnav_env.errors import ConfigError
from planetnav_train import provenance, suite
from planetnav_train.suite import publish
from planetnav_train.suite.leaderboard import provenance_lines

DIRTY = {"git_commit": "0123456789abcdef" * 2 + "01234567", "git_dirty": True,
         "git_changes": [" M planetnav_train/suite/scoring.py", "?? notes.txt"]}  # fmt: skip
CLEAN = {**DIRTY, "git_dirty": False, "git_changes": []}
OUTSIDE = {"git_commit": None, "git_dirty": None, "git_changes": None}


def _git(cwd: Path, *args: str) -> None:
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=cwd, check=True,
                   capture_output=True)  # fmt: skip


def test_check_tree_on_a_real_checkout(tmp_path) -> None:
    """A clean checkout passes and names its commit; a changed tracked file or a new file is refused with
    the change named, unless allowed."""
    _git(tmp_path, "init", "-q")
    (tmp_path / "a.py").write_text("x = 1\n")
    _git(tmp_path, "add", "a.py")
    _git(tmp_path, "commit", "-q", "-m", "one")
    state = publish.check_tree(source_dir=tmp_path)
    assert state["git_dirty"] is False and len(state["git_commit"]) == 40
    (tmp_path / "a.py").write_text("x = 2\n")
    named = r"refusing to publish: .* uncommitted changes \(M a.py\).*--allow-dirty"
    with pytest.raises(ConfigError, match=named):
        publish.check_tree(source_dir=tmp_path)
    assert publish.check_tree(True, source_dir=tmp_path)["git_dirty"] is True
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "new.txt").write_text("n\n")
    with pytest.raises(ConfigError, match=r"\?\? new.txt"):
        publish.check_tree(source_dir=tmp_path)


def test_check_tree_refuses_a_source_outside_git(monkeypatch) -> None:
    monkeypatch.setattr(publish, "git_state", lambda source_dir=None: OUTSIDE)
    with pytest.raises(ConfigError, match="not a git checkout"):
        publish.check_tree()
    assert publish.check_tree(True) == OUTSIDE


def test_provenance_lines_say_which_tree() -> None:
    assert provenance_lines(None) == []
    (clean,) = [ln for ln in provenance_lines({**CLEAN, "allow_dirty": False}) if ln]
    assert clean == "Aggregated from a clean tree at commit `0123456789ab` (the JSON's `provenance`)."
    (dirty,) = [ln for ln in provenance_lines({**DIRTY, "allow_dirty": True}) if ln]
    assert dirty.startswith("**Aggregated from a tree with uncommitted changes** at commit `0123456789ab` "
                            "(published with `--allow-dirty`)")  # fmt: skip
    assert "outside a git checkout" in provenance_lines({**OUTSIDE, "allow_dirty": True})[0]


def _records() -> list[dict]:
    task = "Cruise-Target-v2"
    return [{"task": task, "algorithm": "ppo", "track": "raw", "seed": s, "normalized_score": 0.1 * s,
             "objective": 300.0 - 10 * s, "objective_ci95": [290.0 - 10 * s, 310.0 - 10 * s],
             "official": True,
             "env_steps": suite.get_task(task).budget, "budget_scale": 1.0, "suite_version": 2,
             "task_version": 2, "wall_seconds": 1.0, "command": "c", "eval_mode": "sampled"}
            for s in range(3)]  # fmt: skip


@pytest.mark.parametrize("state", [DIRTY, CLEAN], ids=["dirty", "clean"])
def test_the_page_and_json_name_the_tree(tmp_path, monkeypatch, state) -> None:
    pytest.importorskip("rliable")
    monkeypatch.setattr(provenance, "git_state", lambda source_dir=None: state)
    result = {"ran": [], "records": _records(), "references": {}}
    out = suite.finish(result, suite.Settings(out=tmp_path), None, tmp_path / "page.md", reps=100,
                       allow_dirty=state["git_dirty"])  # fmt: skip
    data = json.loads(out["json"].read_text())
    assert data["provenance"]["git_dirty"] is state["git_dirty"]
    assert data["provenance"]["allow_dirty"] is state["git_dirty"]
    page, summary = out["markdown"].read_text(), suite.summary_markdown(data)
    line = provenance_lines(data["provenance"])[0]
    assert line in page and line in summary
    assert ("uncommitted changes" in line) is state["git_dirty"]


def test_suite_publish_refuses_a_dirty_tree_before_writing(tmp_path, monkeypatch, capsys) -> None:
    from planetnav_train.cli import main

    monkeypatch.setattr(publish, "git_state", lambda source_dir=None: DIRTY)
    page = tmp_path / "page.md"
    assert main(["suite-publish", "--out", str(tmp_path / "none"), "--markdown", str(page)]) == 2
    assert "refusing to publish" in capsys.readouterr().err and not page.exists()
    # with --allow-dirty it gets past the check (and stops at the empty folder: nothing to publish)
    assert main(["suite-publish", "--out", str(tmp_path / "none"), "--allow-dirty"]) == 2
    assert "no run records" in capsys.readouterr().err
    # the suite command checks before it trains when it is to publish into the repository
    suite_run = ["suite", "--tasks", "Cruise-Target-v2", "--out", str(tmp_path / "s"), "--readme", "x.md"]
    assert main(suite_run) == 2
    assert "refusing to publish" in capsys.readouterr().err and not (tmp_path / "s").exists()
