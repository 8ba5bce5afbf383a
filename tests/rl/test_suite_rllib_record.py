"""The suite's record of an RLlib cell (needs the [ray] extra: an RLlib cell's configuration checks that
Ray is installed)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("ray")
pytestmark = pytest.mark.ray

from planetnav_train import suite  # noqa: E402
from planetnav_train.suite import runner  # noqa: E402


def test_record_counts_physics_steps_for_rllib_too(tmp_path, monkeypatch) -> None:
    """RLlib's trainer counts decisions (``timesteps``); the record's ``env_steps`` is physics steps, as
    SB3's training reports them: decisions x the id's decision_steps."""
    from planetnav_train import evaluate

    def fake_evaluate(spec, env_cfg, episodes, seed, progress=True, batched=True, exact_actions=True):
        metrics = {"per_episode_mean_pos_err_km": [100.0 + k for k in range(episodes)]}
        return evaluate.EvalResult(spec, metrics, np.zeros(0), np.zeros(0))

    monkeypatch.setattr(evaluate, "evaluate_agent", fake_evaluate)
    monkeypatch.setattr(runner, "train_cell", lambda *a, **k: (tmp_path / "checkpoint", {"timesteps": 1234}))
    refs = {"random": "random", "zero": "random", "best": "greedy", "J_random": 300.0, "J_zero": 300.0,
            "J_best": 100.0}  # fmt: skip
    cell = suite.Cell("Cruise-Target-v1", "rllib_ppo", "raw", 0)
    record = suite.run_cell(cell, suite.Settings(out=tmp_path, eval_episodes=2), refs)
    decision_steps = suite.get_task("Cruise-Target-v1").env_config().decision_steps
    assert decision_steps == 10 and record["env_steps"] == 1234 * decision_steps
