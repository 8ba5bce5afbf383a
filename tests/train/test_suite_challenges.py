"""Challenge labels (planetnav_train.suite.challenges): the thresholds, and that a challenge is labelled
with its diagnosed limit, or as not diagnosed, never given a limit nobody measured."""

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
    assert task_status("Cruise-Target-v1", 0.89) == "below the target 0.9"
    assert task_status("Cruise-Target-v1", CHALLENGE_BELOW) == "below the target 0.9"
    assert task_status("Cruise-Torque-v1", 0.49, {}) == "**challenge**: not diagnosed"
    assert task_status("Cruise-Torque-v1", -0.3, SAMPLES) == "**challenge**: samples"


def test_challenge_lines_name_the_limit_and_its_run():
    best = {"Cruise-Torque-v1": 0.1, "Cruise-Hybrid-v1": 0.2, "Cruise-Target-v1": 0.9}
    text = "\n".join(challenge_lines(best, SAMPLES))
    assert "Cruise-Target-v1" not in text
    assert "**Cruise-Torque-v1** (best +0.10): limited by **samples**" in text and "(`cmd`)" in text
    assert "**Cruise-Hybrid-v1** (best +0.20): not diagnosed yet." in text
    assert "No task is a challenge" in "\n".join(challenge_lines({"Cruise-Target-v1": 0.5}, SAMPLES))


def test_diagnoses_are_of_known_tasks_and_limits():
    with pytest.raises(ValueError, match="limit 'luck'"):
        Diagnosis("Cruise-Torque-v1", "luck", "-", "-")
    for task, d in DIAGNOSES.items():
        assert task == d.task and task in TASKS_BY_ID
        assert d.command.startswith("python ") and d.finding
