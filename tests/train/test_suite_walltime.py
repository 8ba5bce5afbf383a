"""The published table's wall time (planetnav_train.suite.walltime): measured cells and references summed,
unfinished cells projected from finished ones, and the cells with no basis named rather than dropped."""

import json

import pytest

from planetnav_train.suite.cells import published_grid
from planetnav_train.suite.tasks import get_task
from planetnav_train.suite.walltime import reference_seconds, table_wall_time, wall_time_lines


def _record(task: str, algo: str, seed: int, wall: float, track: str = "raw", official: bool = True) -> dict:
    return {"task": task, "algorithm": algo, "track": track, "seed": seed, "wall_seconds": wall,
            "official": official}  # fmt: skip


def test_projection_from_the_same_cell_then_per_physics_step():
    # Two PPO seeds on Cruise-Target: its other three seeds are projected at their mean (150 s); PPO on the
    # other discrete tasks from PPO's seconds per physics step of budget, times their budget.
    records = [_record("Cruise-Target-v1", "ppo", 0, 100.0), _record("Cruise-Target-v1", "ppo", 1, 200.0)]
    wall = table_wall_time(records, {"Cruise-Target-v1": 50.0})
    rate = 150.0 / get_task("Cruise-Target-v1").budget
    other_discrete = [
        c for c in published_grid(1)
        if (c.algo, c.track) == ("ppo", "raw") and c.task != "Cruise-Target-v1"
        and get_task(c.task).action_kind == "discrete"
    ]  # fmt: skip
    assert wall.measured_cells == 2 and wall.measured_cell_s == 300.0
    expected = 3 * 150.0 + sum(rate * get_task(c.task).budget for c in other_discrete)
    assert wall.projected_cells == 3 + len(other_discrete)
    assert wall.projected_cell_s == pytest.approx(expected)
    assert wall.reference_s == 50.0 and wall.reference_tasks == 1
    assert wall.total_s == pytest.approx(300.0 + expected + 50.0)
    assert wall.hours == pytest.approx(wall.total_s / 2 / 3600)
    # Nothing projects continuous PPO, DQN or the assisted track: they are named, not silently dropped.
    assert "Cruise-Torque-v1 ppo raw" in wall.unprojected
    assert "Cruise-Target-v1 dqn raw" in wall.unprojected
    assert "Cruise-Target-v1 ppo assisted" in wall.unprojected
    assert "Cruise-Torque-v1" in wall.unreferenced and "Cruise-Target-v1" not in wall.unreferenced
    text = "\n".join(wall_time_lines(wall))
    assert "Not in the total" in text and "Cruise-Torque-v1 ppo raw" in text
    # Where the time goes: PPO raw holds every measured and projected cell, nothing else has a basis.
    assert wall.by_algo == (("ppo raw", 5 + len(other_discrete), pytest.approx(300.0 + expected)),)
    assert f"| ppo raw | {5 + len(other_discrete)} |" in text


def test_smoke_records_and_tasks_outside_the_table_do_not_count():
    records = [_record("Cruise-Target-v1", "ppo", 0, 100.0, official=False)]
    wall = table_wall_time(records, {"Cruise-Target-v0": 999.0})
    assert wall.measured_cells == 0 and wall.projected_cells == 0
    assert wall.reference_s == 0.0 and wall.reference_tasks == 0
    assert len(wall.unprojected) == len({(c.task, c.algo, c.track) for c in published_grid(1)})


def test_whole_table_measured():
    records = [_record(c.task, c.algo, c.seed, 10.0, c.track) for c in published_grid()]
    wall = table_wall_time(records, {c.task: 1.0 for c in published_grid()})
    assert wall.projected_cells == 0 and not wall.unprojected and not wall.unreferenced
    assert wall.total_s == 10.0 * len(published_grid()) + len({c.task for c in published_grid()})
    assert "Not in the total" not in "\n".join(wall_time_lines(wall))


def test_reference_seconds_reads_the_per_agent_cache(tmp_path):
    agents = tmp_path / "references" / "agents"
    agents.mkdir(parents=True)
    (agents / "Cruise-Target-v1__aaa.json").write_text(json.dumps({"agent": "random", "wall_seconds": 3.5}))
    (agents / "Cruise-Target-v1__bbb.json").write_text(json.dumps({"agent": "greedy", "wall_seconds": 1.5}))
    (agents / "Cruise-Torque-v1__ccc.json").write_text(json.dumps({"agent": "random", "wall_seconds": 2.0}))
    assert reference_seconds(tmp_path) == {"Cruise-Target-v1": 5.0, "Cruise-Torque-v1": 2.0}
    assert reference_seconds(tmp_path / "nothing") == {}
