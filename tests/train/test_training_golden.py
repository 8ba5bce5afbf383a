"""Bit identity of the training environments: golden hashes of a fixed rollout of the training VecEnv for
every option of the recipe (features ``gain``, ``pd_torque``; the pointing shaping) over the env's
decision interface (``decision_steps``, relative ``target_actions``, ``observe_since_measured``), in every
action mode.

The hashes were recorded from the implementation before the batch wrappers (per-env Gymnasium wrappers
in SB3's ``DummyVecEnv`` for ``pd_torque`` and the shaping, ``NavTrainingVecEnv`` for the rest), when the
hold, the relative targets and ``since_measured`` were training-side layers over a physics-step env. The
env's decision interface gives the same numbers, so the cases below hold it to those recordings: each
case sets the env options that replaced the layers it was recorded with. One observation differs only in
its column order (``since_measured`` is the env's block, ahead of the appended features, where the
recording appended it after ``gain``): that case's observations are put back in the recorded order before
hashing (``reorder``), every value still held bit for bit. A change meant to alter numbers regenerates the
file (``PLANETNAV_UPDATE_GOLDEN=1``) and says why in its commit.
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

#: One case per recipe option and action mode (holds that do not divide the episode put episode ends
#: inside a held decision). ``env``: the env options of the case (the decision interface among them).
CASES: list[dict[str, Any]] = [
    {"name": "target-since-rel-r3", "mode": "target", "scenario": "cruise", "features": [],
     "env": {"decision_steps": 3, "target_actions": "relative", "observe_since_measured": True}},
    {"name": "target-gain-since-rel-r3-random", "mode": "target", "scenario": "random-cruise",
     "features": ["gain"], "reorder": "gain-before-since",
     "env": {"decision_steps": 3, "target_actions": "relative", "observe_since_measured": True}},
    {"name": "torque-pd-shaping", "mode": "torque", "scenario": "cruise", "features": ["pd_torque"],
     "pointing": 1.0, "gamma": 0.99, "env": {"torque_action_scale": 0.05}},
    {"name": "torque-all-shaping-r4-random", "mode": "torque", "scenario": "random-cruise",
     "features": ["gain", "pd_torque"], "pointing": 0.5, "gamma": 0.9,
     "env": {"decision_steps": 4, "observe_since_measured": True}},
    {"name": "target-shaping", "mode": "target", "scenario": "cruise", "features": [], "pointing": 2.0,
     "gamma": 1.0},
]  # fmt: skip

#: Stored cases no longer run, and why (their hashes stay in the file as recorded).
RETIRED = {
    # Relative target actions in target+torque mode (a relative choice in the Box's planet entries) were a
    # training-side layer only; the env's relative targets take action_mode 'target'.
    "target+torque-pd-gain-rel-r2": "relative target actions need action_mode 'target'",
}


def _reorder(case: dict[str, Any], venv: Any) -> Any:
    """The function that puts an observation (D,) or a batch (N, D) of ``case`` in the recorded column
    order, or None when it is already in it."""
    if case.get("reorder") != "gain-before-since":
        return None
    lay = venv.venv.layout
    s0, p = lay.since_measured_start, venv.config.n_planets
    assert lay.size == s0 + p  # since_measured is the env's last block, then the appended gain (P values)
    order = np.r_[np.arange(s0), np.arange(s0 + p, s0 + 2 * p), np.arange(s0, s0 + p)]
    return lambda obs: np.asarray(obs)[..., order]


def rollout_hashes(venv: Any, reorder: Any = None) -> dict[str, str]:
    """sha256 per quantity of ``DECISIONS`` seeded random decisions of an SB3 VecEnv of ``N`` rows;
    ``reorder``: applied to the observations first."""
    hashes = {k: hashlib.sha256() for k in ("obs", "reward", "done", "terminal_obs", "measured", "pos_err")}

    def add(key: str, value: Any) -> None:
        if reorder is not None and key in ("obs", "terminal_obs") and np.ndim(value) >= 1:
            value = reorder(value)
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
        N, cfg, seed=SEED, features=case["features"], pointing=case.get("pointing"),
        gamma=case.get("gamma", 0.99),
    )  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_training_env_rollout_matches_golden(case):
    venv = build(case)
    got = rollout_hashes(venv, _reorder(case, venv))
    if UPDATE:
        stored = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
        stored[case["name"]] = got
        GOLDEN.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
        return
    expected = json.loads(GOLDEN.read_text())[case["name"]]
    moved = sorted(k for k in expected if got.get(k) != expected[k])
    assert not moved, f"{case['name']}: these quantities changed: {moved}"


def test_every_stored_case_runs_or_is_retired():
    stored = set(json.loads(GOLDEN.read_text()))
    names = {c["name"] for c in CASES}
    assert stored == names | set(RETIRED), sorted(stored ^ (names | set(RETIRED)))
    assert not names & set(RETIRED)
