"""Challenge labels (planetnav_train.suite.challenges): the thresholds, and that a challenge is labelled
with its diagnosed limit, or as not diagnosed, never given a limit nobody measured."""

from pathlib import Path

import pytest

from planetnav_train.suite.challenges import (
    CHALLENGE_BELOW,
    DIAGNOSES,
    TARGET_SCORE,
    Diagnosis,
    challenge_lines,
    task_status,
)
from planetnav_train.suite.tasks import TASKS_BY_ID

SAMPLES = {"Cruise-Torque-v1": Diagnosis("Cruise-Torque-v1", "samples", "Twice the budget: 0.4.", "cmd")}


def test_status_thresholds():
    assert task_status("Cruise-Target-v1", TARGET_SCORE) == "target met (≥ 0.9)"
    assert task_status("Cruise-Target-v1", 0.89, {}) == "below the target 0.9: not diagnosed"
    assert task_status("Cruise-Torque-v1", CHALLENGE_BELOW, SAMPLES) == "below the target 0.9: samples"
    assert task_status("Cruise-Torque-v1", 0.49, {}) == "**challenge**: not diagnosed"
    assert task_status("Cruise-Torque-v1", -0.3, SAMPLES) == "**challenge**: samples"


def test_challenge_lines_name_the_limit_and_its_run():
    best = {"Cruise-Torque-v1": 0.1, "Cruise-Hybrid-v1": 0.2, "Cruise-Target-v1": 0.9,
            "ThrustArc-TCM-v1": 0.6}  # fmt: skip
    text = "\n".join(challenge_lines(best, SAMPLES))
    assert "Cruise-Target-v1" not in text
    assert "**Cruise-Torque-v1** (best +0.10, **challenge**): limited by **samples**" in text
    assert "(`cmd`)" in text
    assert "**Cruise-Hybrid-v1** (best +0.20, **challenge**): not diagnosed yet." in text
    assert "**ThrustArc-TCM-v1** (best +0.60, below the target): not diagnosed yet." in text
    assert "Every task meets the target" in "\n".join(challenge_lines({"Cruise-Target-v1": 0.9}, SAMPLES))


def test_diagnoses_are_of_known_tasks_and_limits():
    with pytest.raises(ValueError, match="limit 'luck'"):
        Diagnosis("Cruise-Torque-v1", "luck", "-", "-")
    for task, d in DIAGNOSES.items():
        assert task == d.task and task in TASKS_BY_ID
        assert d.command.startswith("python ") and d.finding
        if "--config" in d.command:  # the diagnostic run's configuration ships with the repository
            config = d.command.split("--config", 1)[1].split()[0]
            assert (Path(__file__).resolve().parents[2] / config).is_file(), (task, config)


def _curve(steps, iqm, half):
    return {"steps": steps, "iqm": iqm, "low": [v - half for v in iqm], "high": [v + half for v in iqm]}


def test_curve_rows_sample_efficiency_and_flattening():
    from planetnav_train.suite.leaderboard import curve_rows

    steps = [3e5 * k for k in range(1, 11)]  # 0.3M .. 3M
    curves = {
        "Cruise-Target-v1": {
            "ppo": _curve(steps, [0.1 * k for k in range(1, 11)], 0.01),  # still rising: +0.2 over 2.4M-3M
            "dqn": _curve(steps, [0.5] * 9 + [0.52], 0.01),  # flat
        },
        "RandomCruise-Target-v1": {"ppo": _curve(steps, [0.5] * 10, 0.4)},  # too wide to tell
        "all": {"ppo": _curve([0.5, 1.0], [0.1, 0.2], 0.1)},  # the aggregate has no row
    }
    cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in curve_rows(curves)[2:] if ln]
    rows = {(c[0], c[1]): c for c in cells}
    assert set(rows) == {("Cruise-Target-v1", "ppo"), ("Cruise-Target-v1", "dqn"),
                         ("RandomCruise-Target-v1", "ppo")}  # fmt: skip
    ppo = rows[("Cruise-Target-v1", "ppo")]
    assert ppo[2] == "0.30 [0.29, 0.31] at 0.90M"  # the last point within 1M physics steps
    assert ppo[3] == "1.00 [0.99, 1.01] at 3.00M" and ppo[4] == "+0.20" and ppo[5] == "**no**"
    assert rows[("Cruise-Target-v1", "dqn")][4:] == ["+0.02", "yes"]
    assert rows[("RandomCruise-Target-v1", "ppo")][5] == "unresolved"
