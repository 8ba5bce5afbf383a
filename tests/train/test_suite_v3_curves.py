"""Suite v3's learning curves (planetnav_train.suite.v3_curves): the points a learner run records, that
recording them leaves the training alone, and the table that pairs them with the published constants."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planetnav_env.errors import ConfigError
from planetnav_train.suite import v3, v3_curves

SMALL_PPO = {"n_steps": 16, "batch_size": 16, "n_epochs": 1}


def test_a_curve_scores_the_model_at_its_points_and_leaves_the_training_alone(tmp_path) -> None:
    """Points before training, at each quarter and after the last update; the first is the untrained
    row's J per seed and the last the trained row's (the same seeds, the same draw rule); the trained
    parameters are those of a run without a curve."""
    import stable_baselines3
    import torch

    small = dict(episodes=2, episode_steps=20, ppo_overrides=SMALL_PPO)
    with_curve = v3.learner_rows("Cruise-Target-v3", 64, **small, curve_points=4, curve_episodes=5,
                                 save_model=tmp_path / "a.zip")  # fmt: skip
    without = v3.learner_rows("Cruise-Target-v3", 64, **small, curve_points=0, save_model=tmp_path / "b.zip")
    assert "learning_curve" not in without
    curve = with_curve["learning_curve"]
    assert curve["decisions"] == [0, 16, 32, 48, 64]
    assert curve["seeds"] == [v3.EVAL_SEED, 2]  # at most the evaluation's seeds
    name = "SB3 PPO (defaults, make_vec_env)"
    np.testing.assert_allclose(curve["per_seed"][0], with_curve["per_seed"]["untrained network"], atol=1e-3)
    np.testing.assert_allclose(curve["per_seed"][-1], with_curve["per_seed"][name], atol=1e-3)
    np.testing.assert_array_equal(with_curve["per_seed"][name], without["per_seed"][name])
    a = stable_baselines3.PPO.load(tmp_path / "a.zip", device="cpu").policy.state_dict()
    b = stable_baselines3.PPO.load(tmp_path / "b.zip", device="cpu").policy.state_dict()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_a_curve_refuses_more_points_than_decisions() -> None:
    with pytest.raises(ConfigError, match="5 points over 4 decisions"):
        v3_curves.curve_callback(lambda: np.zeros(1), budget=4, points=5)


def _run(task: str, seed: int, per_seed: list[list[float]], first: int) -> dict:
    steps = v3.eval_config(f"planetnav/{task}").episode_steps
    curve = {
        "seeds": [first, len(per_seed[0])],
        "decisions": [0, 100, 200][: len(per_seed)],
        "per_seed": per_seed,
    }
    return {"task": task, "algo": "ppo", "seed": seed, "episode_steps": steps, "budget_decisions": 200,
            "learning_curve": curve}  # fmt: skip


def test_the_curve_table_pairs_each_point_with_the_records_zero_and_scores_it(tmp_path, capsys) -> None:
    """Two runs on the Mars approach whose points lie k and k + 2 km above the published zero on every
    seed: the table's paired difference is k + 1 on average with an interval around it, its score the
    formula's on the published constants; the command prints the table and writes the figure."""
    task = "MarsApproach-Tasking-v3"
    rec = v3.normalization(task)
    zero = np.asarray(rec["per_seed"]["zero"][:4])
    runs = [_run(task, s, [(zero + k + 2 * s).tolist() for k in range(3)], rec["eval_seed"]) for s in (0, 1)]
    table = v3.curve_table(runs)
    jz, jb = rec["J_zero"]["mean"], rec["J_best"]["mean"]
    assert table["zero_on_seeds"] == pytest.approx(zero.mean())
    for k, p in enumerate(table["points"]):
        m, lo, hi = p["minus_zero"]
        assert m == pytest.approx(k + 1) and lo < m < hi
        assert p["score"][0] == pytest.approx((jz - (zero.mean() + k + 1)) / (jz - jb))
        assert p["J_runs"] == pytest.approx([zero.mean() + k, zero.mean() + k + 2])
    files = []
    for r in runs:
        files.append(tmp_path / f"{r['seed']}.json")
        files[-1].write_text(json.dumps(r))
    assert v3.main(["curves", *map(str, files), "--plot", str(tmp_path / "c.png")]) == 0
    out = capsys.readouterr().out
    assert f"## {task}, ppo, 200 decisions: 2 runs" in out and "score" in out
    assert (tmp_path / "c.png").stat().st_size > 0


def test_the_curve_table_refuses_runs_without_a_curve_or_on_other_seeds() -> None:
    task = "Cruise-Target-v3"
    a = _run(task, 0, [[1.0, 2.0]], v3.EVAL_SEED)
    with pytest.raises(ConfigError, match="different seeds"):
        v3.curve_table([a, _run(task, 1, [[1.0, 2.0]], v3.EVAL_SEED + 1)])
    with pytest.raises(ConfigError, match="no learning_curve"):
        v3.curve_table([a, {"task": task, "seed": 2}])
    # A cruise's score is undefined (its references lose to the zero): the paired difference alone.
    p = v3.curve_table([a])["points"][0]
    assert "minus_zero" in p and "score" not in p


def test_runs_of_another_budget_or_target_actions_form_their_own_group() -> None:
    task = "Cruise-Target-v3"
    runs = [_run(task, s, [[1.0]], v3.EVAL_SEED) for s in range(3)]
    runs[1]["target_actions"] = "relative"
    runs[2]["budget_decisions"] = 400
    groups = v3_curves.group_runs(runs)
    want = ["ppo, 200 decisions", "ppo, 200 decisions, relative target actions", "ppo, 400 decisions"]
    assert sorted(k[1] for k in groups) == want
