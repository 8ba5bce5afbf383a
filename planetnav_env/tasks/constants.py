"""The v3 tasks' reward constants, read from the versioned file that one command writes.

A v3 reward is ``-(e_k - b(k)) / s`` per physics step (``EnvConfig.reward_baseline_km``): ``e_k`` the
step's true error term, ``b`` a baseline of time only and ``s`` a scale that brings a decision's reward to
order 1. Both are measured, not tuned: ``b`` is uniform random's mean error term in each bin of physics
steps and ``s`` the standard deviation of uniform random's per-decision sums of ``e_k - b(k)``, over the
normalization seeds (:data:`planetnav_train.suite.v3.NORMALIZATION_SEED`), in the world the task is
simulated in. ``python -m planetnav_train.suite.v3 reward`` writes them to
``planetnav_env/tasks/tasks_v3_reward.json``; the declarations read them here, once, at import.

A task missing from the file gets no baseline and the scale :data:`FALLBACK_SCALE_KM` (the reward is then
the v2 form on the true error), so a fresh tree registers every id before the command has run.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

from planetnav_env.tasks.spec import Reward

#: The file the reward command writes (package data).
REWARD_FILE = Path(__file__).with_name("tasks_v3_reward.json")
#: What every v3 target task's card note says of its posing.
V3_POSING = (
    "in the flight world (`world: flight`: the truth apart from the onboard model, "
    "[flight_world.md](../flight_world.md)), posed for learners ([tasks_v3.md](../tasks_v3.md)): the "
    "true-error reward less a time-only baseline, scaled to order 1 per decision (both measured by "
    "`python -m planetnav_train.suite.v3 reward`), absolute target actions, the observation in unit scaling "
    "(`observation_scaling: unit`) with the `residual_log` block"
)
#: The scale of a task the file does not hold [km].
FALLBACK_SCALE_KM = 1000.0


@cache
def reward_table() -> dict[str, Any]:
    """The file's ``tasks`` table (task name -> ``scale_km``, ``baseline_km``, provenance); empty without
    the file."""
    if not REWARD_FILE.exists():
        return {}
    return dict(json.loads(REWARD_FILE.read_text())["tasks"])


def v3_reward(name: str) -> Reward:
    """The true-error reward of v3 task ``name`` (``Cruise-Target``) with its measured baseline and scale."""
    row = reward_table().get(name)
    if row is None:
        return Reward("truth", scale_km=FALLBACK_SCALE_KM)
    return Reward("truth", scale_km=float(row["scale_km"]), baseline_km=tuple(row["baseline_km"]))


__all__ = ["FALLBACK_SCALE_KM", "REWARD_FILE", "V3_POSING", "reward_table", "v3_reward"]
