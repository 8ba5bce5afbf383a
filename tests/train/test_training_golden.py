"""Bit identity of the training environments: golden hashes of a fixed rollout of the training VecEnv for
every option of the recipe (features ``since_measured``, ``gain``, ``pd_torque``; action repeat; relative
actions; the pointing shaping), in every action mode.

The hashes were recorded from the implementation before the batch wrappers (per-env Gymnasium wrappers
in SB3's ``DummyVecEnv`` for ``pd_torque`` and the shaping, ``NavTrainingVecEnv`` for the rest), so the
native path for every option is held to the numbers training saw before. A change meant to alter
numbers regenerates the file (``PLANETNAV_UPDATE_GOLDEN=1``) and says why in its commit.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

GOLDEN = Path(__file__).parents[1] / "golden" / "training_env_hashes.json"
UPDATE = os.environ.get("PLANETNAV_UPDATE_GOLDEN") == "1"
N, SEED, DECISIONS, EPISODE_STEPS = 3, 11, 30, 20

#: One case per recipe option and action mode (repeats that do not divide the episode put episode ends
#: inside a held decision).
CASES: list[dict[str, Any]] = [
    {"name": "target-since-rel-r3", "mode": "target", "scenario": "cruise", "features": ["since_measured"],
     "repeat": 3, "relative": True},
    {"name": "target-gain-since-rel-r3-random", "mode": "target", "scenario": "random-cruise",
     "features": ["gain", "since_measured"], "repeat": 3, "relative": True},
    {"name": "torque-pd-shaping", "mode": "torque", "scenario": "cruise", "features": ["pd_torque"],
     "repeat": 1, "relative": False, "pointing": 1.0, "gamma": 0.99, "env": {"torque_action_scale": 0.05}},
    {"name": "torque-all-shaping-r4-random", "mode": "torque", "scenario": "random-cruise",
     "features": ["since_measured", "gain", "pd_torque"], "repeat": 4, "relative": False,
     "pointing": 0.5, "gamma": 0.9},
    {"name": "target+torque-pd-gain-rel-r2", "mode": "target+torque", "scenario": "cruise",
     "features": ["pd_torque", "gain"], "repeat": 2, "relative": True},
    {"name": "target-shaping", "mode": "target", "scenario": "cruise", "features": [], "repeat": 1,
     "relative": False, "pointing": 2.0, "gamma": 1.0},
]  # fmt: skip


def rollout_hashes(venv: Any) -> dict[str, str]:
    """sha256 per quantity of ``DECISIONS`` seeded random decisions of an SB3 VecEnv of ``N`` rows."""
    hashes = {k: hashlib.sha256() for k in ("obs", "reward", "done", "terminal_obs", "measured", "pos_err")}

    def add(key: str, value: Any) -> None:
        hashes[key].update(np.ascontiguousarray(value).tobytes())

    add("obs", venv.reset())
    space = venv.action_space
    space.seed(3)
    for _ in range(DECISIONS):
        obs, reward, done, infos = venv.step(np.stack([space.sample() for _ in range(N)]))
        add("obs", obs)
        add("reward", np.asarray(reward, np.float32))
        add("done", np.asarray(done, bool))
        for info in infos:
            add("measured", np.asarray(bool(info["measured"])))
            add("pos_err", np.asarray(float(info["pos_err_km"])))
            if "terminal_observation" in info:
                add("terminal_obs", info["terminal_observation"])
                add("terminal_obs", np.asarray(bool(info["TimeLimit.truncated"])))
    return {k: h.hexdigest() for k, h in hashes.items()}


def build(case: dict[str, Any]) -> Any:
    """The native training VecEnv of ``case`` (every option on arrays)."""
    from planetnav_env.config import EnvConfig
    from planetnav_train.vec_training import NavTrainingVecEnv

    cfg = EnvConfig(
        action_mode=case["mode"], episode_steps=EPISODE_STEPS, scenario=case["scenario"],
        **case.get("env", {}),
    )  # fmt: skip
    return NavTrainingVecEnv(
        N, cfg, seed=SEED, features=case["features"], action_repeat=case["repeat"],
        relative_actions=case["relative"], pointing=case.get("pointing"), gamma=case.get("gamma", 0.99),
    )  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_training_env_rollout_matches_golden(case):
    got = rollout_hashes(build(case))
    if UPDATE:
        stored = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
        stored[case["name"]] = got
        GOLDEN.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
        return
    expected = json.loads(GOLDEN.read_text())[case["name"]]
    moved = sorted(k for k in expected if got.get(k) != expected[k])
    assert not moved, f"{case['name']}: these quantities changed: {moved}"
