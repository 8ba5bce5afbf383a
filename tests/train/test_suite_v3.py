"""Suite version 3's machinery (planetnav_train.suite.v3) on short episodes: the seed blocks, the blind
policies' draws against their definition, the fast roll-out against the suite's evaluator, the reward
constants against the environment that applies them, and the run score against its formula."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import ConfigError
from planetnav_train.suite import v3

STEPS = 40


def test_the_seed_blocks_are_disjoint_and_the_evaluation_has_a_thousand_seeds():
    spans = sorted((a, a + n, name) for name, a, n in v3.SEED_BLOCKS)
    for (_, b0, n0), (a1, _, n1) in itertools.pairwise(spans):
        assert b0 <= a1, (n0, n1)
    blocks = {name: (a, a + n) for name, a, n in v3.SEED_BLOCKS}
    for name, first, count in (("search", v3.SEARCH_SEED, v3.SEARCH_EPISODES),
                               ("search final", v3.FINAL_SEED, v3.FINAL_EPISODES),
                               ("normalization", v3.NORMALIZATION_SEED, v3.NORMALIZATION_EPISODES),
                               ("evaluation", v3.EVAL_SEED, v3.EVAL_EPISODES)):  # fmt: skip
        lo, hi = blocks[name]
        assert lo <= first and first + count <= hi, name
    assert v3.EVAL_EPISODES >= 1000


def test_a_time_indexed_distribution_draws_its_probabilities_and_holds_its_draws():
    p = np.tile([0.5, 0.3, 0.2], (6, 1))
    pol = v3.BlindTargets("w", p, hold=3)
    rng = np.random.default_rng(1)
    a0 = pol.actions(0, rng.random(200_000), np.zeros(200_000, np.int64))
    np.testing.assert_allclose(np.bincount(a0, minlength=3) / a0.size, p[0], atol=0.005)
    a1 = pol.actions(1, rng.random(a0.size), a0)
    assert (a1 == a0).all()  # held
    a3 = pol.actions(3, rng.random(a0.size), a0)
    assert (a3 != a0).mean() == pytest.approx(1 - (p[0] ** 2).sum(), abs=0.005)  # a fresh draw
    assert pol.entropy() == pytest.approx(-(p[0] * np.log(p[0])).sum())


def test_the_families_cover_the_interface():
    cfg = v3.eval_config("planetnav/ThrustArc-TCM-v3")
    names = [c.name for c in v3.target_candidates(cfg)]
    for kind in ("weighted:", "cycle:", "sessions:", "deadlines:"):
        assert any(n.startswith(kind) for n in names), kind
    weighted = [c for c in v3.target_candidates(cfg) if c.name.startswith("weighted:")]
    rows = {(tuple(np.round(c.probs[0], 9)), c.hold) for c in weighted}
    assert len(rows) == len(weighted)  # no distribution twice
    for c in v3.target_candidates(cfg):
        assert c.probs.shape == (cfg.episode_decisions, 4)
        np.testing.assert_allclose(c.probs.sum(axis=1), 1.0)
    tq = v3.torque_candidates(v3.eval_config("planetnav/Cruise-Torque-v3"))
    for kind in ("zero", "random:", "spin:", "pulse:", "scan:"):
        assert any(c.name.startswith(kind) for c in tq), kind
    assert all(np.abs(c.torques).max() <= 1.0 for c in tq)


def test_a_blind_schedule_rolled_out_scores_what_the_suite_evaluator_gives_its_rule_agent():
    from planetnav_train.suite.blind import evaluate_objective

    cfg = v3.eval_config("planetnav/Cruise-Target-v3", episode_steps=STEPS)
    seq = [(d // 1) % 3 for d in range(cfg.episode_decisions)]
    pol = v3.BlindTargets("cycle", v3._one_hot(seq, 3))
    ours = v3.roll_out(cfg, pol, range(v3.SEARCH_SEED, v3.SEARCH_SEED + 3)).objective
    theirs = evaluate_objective("schedule:targets=0-1-2,steps=10", cfg, 3, v3.SEARCH_SEED)
    np.testing.assert_allclose(ours, theirs, rtol=1e-9)


def test_a_roll_out_keeps_each_rows_final_state_its_fix_counts_those_of_its_targets():
    from planetnav_env.core import layout as L

    cfg = v3.eval_config("planetnav/Cruise-Target-v3", episode_steps=STEPS)
    pol = v3.BlindTargets("cycle:0-1", v3._one_hot([d % 2 for d in range(cfg.episode_decisions)], 3))
    out = v3.roll_out(cfg, pol, range(v3.SEARCH_SEED, v3.SEARCH_SEED + 3), final=True, actions=True)
    assert out.final.shape[0] == 3 and v3.roll_out(cfg, pol, [v3.SEARCH_SEED]).final is None
    want = np.tile(np.arange(cfg.episode_decisions)[:, None] % 2, (1, 3))
    np.testing.assert_array_equal(out.actions, want)  # the schedule's actions, each decision, each row
    fixes = out.final[:, L.F_RES_LOG : L.F_RES_LOG + 3]
    assert (fixes[:, 2] == 0).all()  # never pointed at
    assert (fixes[:, :2].sum(axis=1) > 0).all() and (fixes <= cfg.episode_steps).all()


def test_the_zero_check_pairs_every_finalist_with_the_winner_on_the_evaluation_seeds():
    cfg = v3.eval_config("planetnav/Cruise-Target-v3")
    d_n = cfg.episode_decisions
    cycle = v3.BlindTargets("cycle:0-1-2,dwell=1", v3._one_hot([d % 3 for d in range(d_n)], 3))
    stare = v3.BlindTargets("cycle:0,dwell=1", v3._one_hot([0] * d_n, 3))
    blind = {"winner": cycle.name, "policies": {p.name: v3._policy_record(p) for p in (cycle, stare)}}
    rec = v3.zero_check("planetnav/Cruise-Target-v3", 2, blind, log=lambda *_: None)
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + 2)
    jz, js = v3.roll_out(cfg, cycle, seeds).objective, v3.roll_out(cfg, stare, seeds).objective
    np.testing.assert_allclose(rec["jz"], jz)
    check = rec["finalists_vs_zero"]["cycle:0,dwell=1"]
    assert check["mean"] == pytest.approx(float(np.mean(js - jz)))
    assert check["zero_holds"] == (check["hi"] >= 0.0)
    assert set(rec["finalists_vs_zero"]) == {"cycle:0,dwell=1"}


def test_the_second_stage_reruns_on_more_seeds_and_picks_the_lowest_finalist_there():
    cfg = v3.eval_config("planetnav/Cruise-Target-v3")
    d_n = cfg.episode_decisions
    cycle = v3.BlindTargets("cycle:0-1-2,dwell=1", v3._one_hot([d % 3 for d in range(d_n)], 3))
    stare = v3.BlindTargets("cycle:0,dwell=1", v3._one_hot([0] * d_n, 3))
    record = {"winner": stare.name, "finalists": {stare.name: 1.0, cycle.name: 2.0},
              "candidates": {stare.name: 1.0, cycle.name: 2.0}, "final_episodes": 1,
              "policies": {p.name: v3._policy_record(p) for p in (cycle, stare)}}  # fmt: skip
    out = v3.refinal("planetnav/Cruise-Target-v3", record, 2, log=lambda *_: None)
    seeds = range(v3.FINAL_SEED, v3.FINAL_SEED + 2)
    for p in (cycle, stare):
        assert out["finalists"][p.name] == pytest.approx(v3.roll_out(cfg, p, seeds).objective.mean())
    assert out["winner"] == min(out["finalists"], key=out["finalists"].get)
    assert out["final_episodes"] == 2 and out["candidates"] == record["candidates"]
    with pytest.raises(ConfigError, match="final_episodes=6000"):
        v3.refinal("planetnav/Cruise-Target-v3", record, 6000)


def test_the_reward_constants_centre_and_scale_the_rewards_the_env_pays():
    over = {"episode_steps": STEPS}
    rec = v3.reward_constants("planetnav/Cruise-Target-v3", 4, seed=v3.NORMALIZATION_SEED, **over)
    assert len(rec["baseline_km"]) == STEPS // 10 and rec["scale_km"] > 0
    cfg = v3.eval_config("planetnav/Cruise-Target-v3", reward_baseline_km=tuple(rec["baseline_km"]),
                         reward_scale_km=rec["scale_km"], **over)  # fmt: skip
    env = PlanetNavVectorEnv(4, cfg, autoreset_mode="disabled")
    env.reset(seed=v3.NORMALIZATION_SEED)
    gens = [np.random.default_rng([s, 3]) for s in range(v3.NORMALIZATION_SEED, v3.NORMALIZATION_SEED + 4)]
    pol = v3.BlindTargets("uniform", np.full((cfg.episode_decisions, 3), 1 / 3))
    rewards, last = [], np.zeros(4, np.int64)
    for d in range(cfg.episode_decisions):
        last = pol.actions(d, np.array([g.random() for g in gens]), last)
        r, _, _ = env.step_rows(last, np.ones(4, bool))
        rewards.append(r)
    env.close()
    r = np.array(rewards)
    # The uniform policy the constants were measured with: mean 0 and standard deviation 1 per decision.
    assert abs(r.mean()) < 1e-6 and r.std() == pytest.approx(1.0, rel=1e-6)


def test_the_run_score_refuses_a_reference_that_does_not_beat_the_zero():
    """J_best at or above J_zero (the flight world's covariance rules can lose to a blind cycle) leaves no
    scale: a policy better than the zero would score below 0, so the score is refused, named."""
    for j_best in (20.0, 25.0):
        with pytest.raises(ConfigError, match="does not beat the blind zero"):
            v3.run_score(np.full(5, 15.0), j_zero=20.0, j_best=j_best)


def test_the_published_scale_is_the_records_constants_only_where_the_best_beats_the_zero(tmp_path) -> None:
    scored = [t for t in v3.V3_TASKS if v3.published_scale(t) is not None]
    assert "MarsApproach-Tasking-v3" in scored and "Cruise-Target-v3" not in scored
    for task in v3.V3_TASKS:
        rec = v3.normalization(task)
        jz, jb = rec["J_zero"]["mean"], rec["J_best"]["mean"]
        assert v3.published_scale(task) == ((jz, jb) if jb < jz else None)
    assert v3.published_scale("NoSuchTask-v3") is None
    # From another file: a task absent there has no scale, one listed there has the file's.
    path = tmp_path / "norm.json"
    record = {"J_zero": {"mean": 10.0}, "J_best": {"mean": 4.0}}
    v3.write_json(path, {"suite_version": 3, "tasks": {"T": record}})
    assert v3.published_scale("T", path) == (10.0, 4.0)
    assert v3.published_scale("MarsApproach-Tasking-v3", path) is None


def test_the_run_score_is_the_formula_with_a_bootstrap_over_the_seeds():
    j = np.array([8.0, 9.0, 10.0, 11.0, 12.0])
    s = v3.run_score(j, j_zero=20.0, j_best=10.0)
    assert s["score"] == pytest.approx((20.0 - 10.0) / 10.0)
    assert s["lo"] < s["score"] < s["hi"]
    flat = v3.run_score(np.full(5, 15.0), 20.0, 10.0)
    assert flat["lo"] == flat["hi"] == pytest.approx(0.5)
    two = v3.run_score([np.full(5, 15.0), np.full(5, 10.0)], 20.0, 10.0)
    assert (
        two["score"] == pytest.approx(0.75)
        and two["lo"] == pytest.approx(0.5)
        and two["hi"] == pytest.approx(1.0)
    )


def test_the_learner_rows_train_sb3_ppo_through_make_vec_env_and_report_entropies():
    from planetnav_train.suite.v3 import learner_rows

    rows = learner_rows("Cruise-Target-v3", 64, episodes=2, episode_steps=20,
                        ppo_overrides={"n_steps": 32, "batch_size": 32, "n_epochs": 1})  # fmt: skip
    by = {r["policy"]: r for r in rows["rows"]}
    learners = {"untrained network", "uniform random", "SB3 PPO (defaults, make_vec_env)"}
    published = {"blind zero (cycle:0-1-2,dwell=1)", "best reference (greedy:success=observed)"}
    assert set(by) == learners | published
    # Each learner row is paired with the published zero and the best reference on the same seeds.
    assert set(rows["per_seed"]) == learners | {"zero", "best_reference"}
    for name, row in (("uniform random", "uniform random"), ("best_reference", sorted(published)[0])):
        assert np.mean(rows["per_seed"][name]) == pytest.approx(by[row]["J"]["mean"], abs=1e-3)
    for name in learners:
        for other, key in zip(sorted(published), ("minus_best_reference", "minus_zero"), strict=True):
            d = by[name][key]
            assert d["mean"] == pytest.approx(by[name]["J"]["mean"] - by[other]["J"]["mean"])
            assert d["lo"] <= d["mean"] <= d["hi"]
    assert by["uniform random"]["entropy_nats"] == pytest.approx(np.log(3))
    # SB3's initial policy is near uniform (its last layer's gain is 0.01).
    assert by["untrained network"]["entropy_nats"] == pytest.approx(np.log(3), abs=0.01)
    assert all(np.isfinite(r["J"]["mean"]) for r in rows["rows"])


def test_the_learner_rows_in_another_world_are_made_there_and_carry_no_score() -> None:
    """A regime sweep's rows: trained and scored in the task's flight world with the named options
    changed, and no blind-zero score, since the task's constants belong to its own world."""
    from planetnav_train.suite.v3 import learner_rows

    world = {"boresight_drift": False}
    rows = learner_rows("Cruise-Torque-v3", 64, episodes=2, episode_steps=20, world=world,
                        ppo_overrides={"n_steps": 32, "batch_size": 32, "n_epochs": 1})  # fmt: skip
    assert rows["world_overrides"] == world
    assert rows["learner_overrides"] == {"n_steps": 32, "batch_size": 32, "n_epochs": 1}  # named in the file
    scored = [r for r in rows["rows"] if "score" in r]
    assert scored and all(r["score"] is None and "world overrides" in r["score_undefined"] for r in scored)
    blind = v3.read_json(v3.BLIND_FILE)["tasks"]["Cruise-Torque-v3"]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + 2)
    there = v3.eval_config("planetnav/Cruise-Torque-v3", episode_steps=20, world=world)
    assert there.world.preset == "flight" and there.world.boresight_drift is False
    np.testing.assert_allclose(rows["per_seed"]["zero"], v3.roll_out(there, zero, seeds).objective, atol=1e-3)


def test_the_learner_rows_save_the_trained_model_that_scored_the_row(tmp_path) -> None:
    import stable_baselines3

    from planetnav_train.suite.v3 import learner_rows

    path = tmp_path / "dqn.zip"
    rows = learner_rows("Cruise-Target-v3", 64, episodes=2, episode_steps=20, algo="dqn", save_model=path,
                        ppo_overrides={"learning_starts": 16, "buffer_size": 1000})  # fmt: skip
    assert rows["model"] == str(path)
    model = stable_baselines3.DQN.load(path, device="cpu")
    cfg = v3.eval_config("planetnav/Cruise-Target-v3", episode_steps=20)
    # DQN's row acts deterministically: the saved network, rolled out again, scores the row's J per seed.
    j = v3.roll_out(cfg, v3._policy_fn(model, [], True), range(v3.EVAL_SEED, v3.EVAL_SEED + 2)).objective
    np.testing.assert_allclose(j, rows["per_seed"]["SB3 DQN (defaults, make_vec_env)"], atol=1e-3)


def test_a_sampled_learner_row_is_a_function_of_the_model_not_of_torchs_global_stream(tmp_path) -> None:
    """PPO's row samples its actions from the evaluation's own generator: the saved model, rolled out
    again after torch's global stream has moved on, scores the row's J per seed; the draws are
    torch.multinomial's from a generator seeded 0 over the rows' probabilities."""
    import stable_baselines3
    import torch

    from planetnav_train.suite.v3 import learner_rows

    path = tmp_path / "ppo.zip"
    rows = learner_rows("Cruise-Target-v3", 64, episodes=3, episode_steps=40, save_model=path,
                        ppo_overrides={"n_steps": 32, "batch_size": 32, "n_epochs": 1})  # fmt: skip
    model = stable_baselines3.PPO.load(path, device="cpu")
    cfg = v3.eval_config("planetnav/Cruise-Target-v3", episode_steps=40)
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + 3)
    torch.manual_seed(12345)
    torch.rand(1000)
    j = v3.roll_out(cfg, v3._policy_fn(model, []), seeds).objective
    np.testing.assert_allclose(j, rows["per_seed"]["SB3 PPO (defaults, make_vec_env)"], atol=1e-3)
    obs = np.random.default_rng(0).normal(size=(5, model.observation_space.shape[0])).astype(np.float32)
    with torch.no_grad():
        probs = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0]).distribution.probs
    want = torch.multinomial(probs, 1, True, generator=torch.Generator().manual_seed(0))[:, 0].numpy()
    np.testing.assert_array_equal(v3._policy_fn(model, [])(0, obs), want)


def test_a_sampled_row_refuses_a_policy_without_a_distribution() -> None:
    import gymnasium as gym
    import stable_baselines3

    env = gym.make("planetnav/Cruise-Torque-v3")
    model = stable_baselines3.SAC("MlpPolicy", env, buffer_size=100, seed=0)
    obs = np.zeros((1, model.observation_space.shape[0]), np.float32)
    with pytest.raises(ConfigError, match="SACPolicy"):
        v3._policy_fn(model, [])
    assert v3._policy_fn(model, [], deterministic=True)(0, obs).shape == (1, 3)  # SAC's row: its mean


def test_the_learner_rows_train_dqn_on_a_discrete_task_and_refuse_a_misfit() -> None:
    from planetnav_train.suite.v3 import learner_rows

    rows = learner_rows("Cruise-Target-v3", 64, episodes=2, episode_steps=20, algo="dqn",
                        ppo_overrides={"learning_starts": 16, "buffer_size": 1000})  # fmt: skip
    by = {r["policy"]: r for r in rows["rows"]}
    assert rows["acting"] == "deterministic"
    assert by["SB3 DQN (defaults, make_vec_env)"]["entropy_nats"] == 0.0
    assert np.isfinite(by["SB3 DQN (defaults, make_vec_env)"]["minus_zero"]["mean"])
    with pytest.raises(ConfigError, match="'sac' does not fit Cruise-Target-v3's discrete"):
        learner_rows("Cruise-Target-v3", 64, episodes=2, episode_steps=20, algo="sac")
    with pytest.raises(ConfigError, match="algo 'a2c'"):
        learner_rows("Cruise-Target-v3", 64, algo="a2c")


def _obs_dim(task: str) -> int:
    """The width of v3 ``task``'s observation, as a saved agent's first layer takes it."""
    return PlanetNavVectorEnv(1, v3.eval_config(f"planetnav/{task}")).single_observation_space.shape[0]


def test_a_saved_single_file_ppo_agent_is_scored_on_the_v3_seeds_beside_the_published_rows(tmp_path) -> None:
    import torch

    script = v3.single_file_ppo()
    obs_dim = _obs_dim("Cruise-Target-v3")
    torch.manual_seed(0)
    torch.save(script.Agent(obs_dim, 3).state_dict(), tmp_path / "agent.pt")
    rows = v3.agent_rows("Cruise-Target-v3", tmp_path / "agent.pt", episodes=2)
    agent, zero = rows["rows"][0], rows["rows"][1]
    assert agent["policy"] == "single-file PPO" and zero["policy"].startswith("blind zero")
    # An untrained agent's last layer has gain 0.01: near uniform.
    assert agent["entropy_nats"] == pytest.approx(np.log(3), abs=0.01)
    assert agent["minus_zero"]["mean"] == pytest.approx(agent["J"]["mean"] - zero["J"]["mean"])
    torch.save(script.Agent(obs_dim, 4).state_dict(), tmp_path / "four.pt")
    with pytest.raises(ConfigError, match="4 discrete actions does not fit Cruise-Target-v3"):
        v3.agent_rows("Cruise-Target-v3", tmp_path / "four.pt", episodes=2)


def test_agent_rows_with_the_training_seed_add_the_scripts_initialization_and_uniform(tmp_path) -> None:
    """With ``train_seed``, the untrained row is the script's own initialization (torch seeded, then the
    agent built): an agent saved as that initialization scores what the untrained row scores, draw for
    draw; uniform random is the learner rows' (the same policy on the same seeds)."""
    import torch

    script = v3.single_file_ppo()
    obs_dim = _obs_dim("Cruise-Target-v3")
    torch.manual_seed(5)
    torch.save(script.Agent(obs_dim, 3).state_dict(), tmp_path / "init5.pt")
    rows = v3.agent_rows("Cruise-Target-v3", tmp_path / "init5.pt", episodes=2, train_seed=5)
    names = [r["policy"] for r in rows["rows"]]
    assert names[:3] == ["untrained network", "uniform random", "single-file PPO"], names
    assert rows["per_seed"]["untrained network"] == rows["per_seed"]["single-file PPO"]
    assert rows["seed"] == 5
    other = v3.agent_rows("Cruise-Target-v3", tmp_path / "init5.pt", episodes=2, train_seed=6)
    assert other["per_seed"]["untrained network"] != rows["per_seed"]["untrained network"]
    assert other["per_seed"]["uniform random"] == rows["per_seed"]["uniform random"]


def test_a_saved_gaussian_agent_is_scored_on_the_torque_task_and_refused_elsewhere(tmp_path) -> None:
    """ppo_continuous's agent on Cruise-Torque-v3: its row is a Gaussian's (the differential entropy of
    its initial unit spread, summed over three axes), paired with the published rows; a Gaussian agent on
    a target task, a Categorical one on the torque task and a file that is no agent are refused by name."""
    import math

    import torch

    cont = v3.continuous_ppo()
    obs_dim = _obs_dim("Cruise-Torque-v3")
    torch.manual_seed(0)
    torch.save(cont.GaussianAgent(obs_dim, 3).state_dict(), tmp_path / "gauss.pt")
    rows = v3.agent_rows("Cruise-Torque-v3", tmp_path / "gauss.pt", episodes=2)
    agent, zero = rows["rows"][0], rows["rows"][1]
    assert agent["policy"] == "single-file PPO (Gaussian)" and zero["policy"].startswith("blind zero")
    assert agent["entropy_nats"] == pytest.approx(3 * 0.5 * math.log(2 * math.pi * math.e), rel=1e-6)
    assert agent["minus_zero"]["mean"] == pytest.approx(agent["J"]["mean"] - zero["J"]["mean"])
    assert agent["score"] is not None  # the torque task is normalized
    with pytest.raises(ConfigError, match="Gaussian agent of 3 action dimensions does not fit Cruise-Target"):
        v3.agent_rows("Cruise-Target-v3", tmp_path / "gauss.pt", episodes=2)
    torch.save(v3.single_file_ppo().Agent(obs_dim, 3).state_dict(), tmp_path / "cat.pt")
    with pytest.raises(ConfigError, match="3 discrete actions does not fit Cruise-Torque-v3"):
        v3.agent_rows("Cruise-Torque-v3", tmp_path / "cat.pt", episodes=2)
    (tmp_path / "junk.pt").write_text("not a model")
    with pytest.raises(ConfigError, match=r"junk\.pt: not a saved agent"):
        v3.agent_rows("Cruise-Torque-v3", tmp_path / "junk.pt", episodes=2)


def test_the_published_rows_act_in_the_tasks_own_interface_when_the_learner_takes_relative_actions() -> None:
    from planetnav_train.suite.v3 import learner_rows

    small = {
        "episodes": 2,
        "episode_steps": 200,
        "ppo_overrides": {"n_steps": 32, "batch_size": 32, "n_epochs": 1},
    }
    absolute = learner_rows("Cruise-Target-v3", 32, **small)
    relative = learner_rows("Cruise-Target-v3", 32, target_actions="relative", **small)
    assert relative["target_actions"] == "relative"
    assert relative["per_seed"]["zero"] == absolute["per_seed"]["zero"]


def test_provenance_names_what_differs_from_the_commit(tmp_path, monkeypatch):
    """A run's record says which files differed from its commit, so result files written beside a run in a
    clean checkout read as such, and code changes as code changes."""
    import subprocess

    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True, text=True).stdout

    git("init", "-q")
    (tmp_path / "code.py").write_text("x = 1\n")
    git("add", "code.py")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "c")
    monkeypatch.setattr(v3, "ROOT", tmp_path)
    clean = v3.provenance()
    head = git("rev-parse", "HEAD").strip()
    assert (clean["commit"], clean["dirty"], clean["changes"]) == (head, False, [])
    (tmp_path / "rows.json").write_text("{}")
    (tmp_path / "code.py").write_text("x = 2\n")
    dirty = v3.provenance()
    assert dirty["dirty"] is True and sorted(dirty["changes"]) == [" M code.py", "?? rows.json"]


def test_an_added_reference_that_beats_j_best_becomes_it_paired_with_the_records_zero(monkeypatch):
    rng = np.random.default_rng(0)
    zero = 70.0 + rng.normal(0.0, 5.0, 50)
    record = {
        "J_zero": v3.mean_interval(zero), "J_best": {"mean": 80.0}, "best_reference": "greedy",
        "references": {"greedy": {"mean": 80.0}}, "closed_loop_gap": {"gap": -0.14}, "headline": False,
        "eval_seed": v3.EVAL_SEED, "eval_episodes": 50,
        "per_seed": {"zero": zero.tolist(), "best": (zero + 10.0).tolist()},
    }  # fmt: skip
    seen = []
    better = zero * 0.6  # a 40 % gap on every seed
    task, quiet = "planetnav/MarsApproach-Tasking-v3", lambda m: None
    monkeypatch.setattr(v3, "policy_objective", lambda cfg, spec, s, n: seen.append((spec, s, n)) or better)
    rec = v3.add_reference(task, record, "greedy:bias=photometric", log=quiet)
    assert seen == [("greedy:bias=photometric", v3.EVAL_SEED, 50)]  # the record's own seeds
    assert rec["best_reference"] == "greedy:bias=photometric"
    assert rec["J_best"]["mean"] == pytest.approx(better.mean())
    assert rec["closed_loop_gap"]["gap"] == pytest.approx(0.4) and rec["headline"]
    assert rec["per_seed"]["best"] == pytest.approx(better, abs=1e-4)
    assert "commit" in rec["added_references"]["greedy:bias=photometric"]
    with pytest.raises(ConfigError, match="in the record already"):
        v3.add_reference(task, rec, "greedy:bias=photometric")
    # One that does not beat J_best is listed and changes nothing else.
    monkeypatch.setattr(v3, "policy_objective", lambda cfg, spec, seed, n: zero + 20.0)
    rec = v3.add_reference(task, rec, "greedy:lookahead_s=60", log=quiet)
    assert rec["best_reference"] == "greedy:bias=photometric" and "greedy:lookahead_s=60" in rec["references"]


@pytest.mark.parametrize("task", v3.V3_TASKS)
def test_the_published_normalization_still_holds_for_the_current_code(task: str) -> None:
    """The record's per-seed J of the zero and of the best reference, re-rolled on its first evaluation
    seeds by the current code: the published constants (and the learner rows that pair with them from
    the record) belong to this code, not to an older one."""
    rec = v3.normalization(task)
    cfg = v3.eval_config(f"planetnav/{task}")
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][task]
    assert rec["zero"] == blind["winner"]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    seeds = range(rec["eval_seed"], rec["eval_seed"] + 2)
    np.testing.assert_allclose(
        v3.roll_out(cfg, zero, seeds).objective, rec["per_seed"]["zero"][:2], atol=1e-3
    )
    best = v3.policy_objective(cfg, rec["best_reference"], rec["eval_seed"], 1)
    np.testing.assert_allclose(best, rec["per_seed"]["best"][:1], atol=1e-3)
    # The learner rows take these from the record on its seeds, and roll them out elsewhere.
    got = v3._recorded_per_seed(rec, cfg, task, range(rec["eval_seed"] + 5, rec["eval_seed"] + 8))
    np.testing.assert_array_equal(got["best"], rec["per_seed"]["best"][5:8])
    assert v3._recorded_per_seed(rec, cfg, task, range(rec["eval_seed"] - 1, rec["eval_seed"] + 2)) is None
    assert (
        v3._recorded_per_seed(rec, v3.eval_config(f"planetnav/{task}", episode_steps=20), task, seeds) is None
    )
