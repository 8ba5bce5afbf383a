"""The prediction interval of a trained figure (planetnav_train.spread): hand values and its coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_train.spread import format_spread, prediction_interval


def test_prediction_interval_by_hand() -> None:
    pi = prediction_interval([1.0, 2.0, 3.0, 4.0, 5.0])
    sd = math.sqrt(2.5)
    half = 2.7764451051977987 * sd * math.sqrt(1.2)  # t(0.975, 4) from tables
    assert (pi.n, pi.mean, pi.sd) == (5, 3.0, pytest.approx(sd))
    assert (pi.lo, pi.hi) == (pytest.approx(3.0 - half), pytest.approx(3.0 + half))


def test_prediction_interval_covers_a_new_draw_19_times_in_20() -> None:
    rng = np.random.default_rng(0)
    trials = 20000
    samples = rng.normal(100.0, 10.0, size=(trials, 6))
    hits = 0
    for row in samples:
        pi = prediction_interval(row[:5])
        hits += pi.lo <= row[5] <= pi.hi
    assert abs(hits / trials - 0.95) < 0.006  # binomial sd 0.0015


@pytest.mark.parametrize("bad", [[1.0], [1.0, float("nan")], []])
def test_prediction_interval_refuses_too_few_or_non_finite(bad: list[float]) -> None:
    with pytest.raises(ValueError, match="at least 2 finite"):
        prediction_interval(bad)


def test_format_spread_prints_each_mode() -> None:
    runs = [{"seed": s, "argmax": 100.0 + s, "sampled": 110.0 + s} for s in range(5)]
    result = {
        "config": "c.yaml", "eval_seed": 10000, "eval_episodes": 20, "runs": runs,
        "intervals": {m: prediction_interval([r[m] for r in runs]).__dict__ for m in ("argmax", "sampled")},
    }  # fmt: skip
    text = format_spread(result)
    assert "| argmax | 100.0, 101.0, 102.0, 103.0, 104.0 | 102.0 |" in text
    assert "| sampled |" in text


def test_spread_command_trains_each_seed_and_prints_the_interval(tmp_path) -> None:
    """``train.py spread`` on the smoke config with two seeds: two runs, both modes, the table, and a
    second call reuses the trained runs."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    cmd = [sys.executable, str(root / "train.py"), "spread", "--config", str(root / "configs" / "smoke.yaml"),
           "--seeds", "0", "1", "--out", str(tmp_path), "--no-progress"]  # fmt: skip
    first = subprocess.run(cmd, cwd=root, capture_output=True, text=True, timeout=900, check=False)
    assert first.returncode == 0, first.stderr[-2000:]
    data = json.loads((tmp_path / "spread.json").read_text())
    assert [r["seed"] for r in data["runs"]] == [0, 1]
    assert set(data["intervals"]) == {"argmax", "sampled"}
    assert "| argmax |" in first.stdout and "| sampled |" in first.stdout
    mtime = (tmp_path / "seed0" / "model.zip").stat().st_mtime
    again = subprocess.run(cmd, cwd=root, capture_output=True, text=True, timeout=900, check=False)
    assert again.returncode == 0, again.stderr[-2000:]
    assert (tmp_path / "seed0" / "model.zip").stat().st_mtime == mtime  # reused, not retrained


def test_leaderboard_gives_a_new_runs_prediction_interval() -> None:
    """The suite's best-algorithm table carries the prediction interval of the best algorithm's seeds."""
    from planetnav_train.suite.leaderboard import best_per_task_rows

    seeds = {"x": [10.0, 12.0, 11.0, 13.0, 9.0], "y": [50.0, 60.0]}
    runs = [{"task": "T", "algorithm": a, "track": "raw", "objective": v} for a in seeds for v in seeds[a]]
    per = {"x": {"iqm": 0.5, "low": 0.4, "high": 0.6}, "y": {"iqm": 0.1, "low": 0.0, "high": 0.2}}
    agg = {"per_task": {"T": per}}
    rows = best_per_task_rows(agg, {}, runs, "raw")
    pi = prediction_interval([10.0, 12.0, 11.0, 13.0, 9.0])
    # Then the interface random's score ("-" without references) and the task's status.
    assert rows[2] == (f"| T | x | 0.50 [0.40, 0.60] | 11.0 [{pi.lo:.1f}, {pi.hi:.1f}] | - | - "
                       "| below the target 0.9: not diagnosed |")  # fmt: skip
