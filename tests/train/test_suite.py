"""The benchmark suite (planetnav_train.suite; docs/suite.md): the normalized score, the
rliable aggregation against direct numpy computations, the action mask, resume, and the CI smoke run of
``train.py suite`` end to end on one tiny task and budget."""

from __future__ import annotations

import dataclasses
import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError
from planetnav_train import suite
from planetnav_train.suite import runner
from planetnav_train.suite.scoring import entry_name, is_ranked, normalized_score

#: A fixed (runs, tasks) score matrix: 5 seeds x 3 tasks.
SCORES = np.array(
    [
        [0.10, 0.90, 1.20],
        [0.40, 0.70, 0.95],
        [-0.20, 1.10, 1.05],
        [0.55, 0.60, 1.40],
        [0.30, 0.85, 0.80],
    ]
)


def test_normalized_score_hand_values() -> None:
    # J_random 1000 km, best reference 200 km: random -> 0, reference -> 1, halfway -> 0.5.
    assert normalized_score(1000.0, 1000.0, 200.0) == 0.0
    assert normalized_score(200.0, 1000.0, 200.0) == 1.0
    assert normalized_score(600.0, 1000.0, 200.0) == 0.5
    assert normalized_score(100.0, 1000.0, 200.0) == pytest.approx(1.125)  # beats the reference
    assert normalized_score(1200.0, 1000.0, 200.0) == pytest.approx(-0.25)  # worse than random
    with pytest.raises(ConfigError, match="same objective"):
        normalized_score(5.0, 300.0, 300.0)
    with pytest.raises(ConfigError, match="non-finite"):
        normalized_score(float("nan"), 300.0, 200.0)


def _direct_iqm(m: np.ndarray) -> float:
    flat = np.sort(m.ravel())
    cut = int(0.25 * flat.size)
    return float(flat[cut : flat.size - cut].mean())


def test_iqm_with_stratified_bootstrap_matches_numpy() -> None:
    pytest.importorskip("rliable")
    from planetnav_train.suite.scoring import iqm_intervals

    got = iqm_intervals({"a": SCORES}, reps=4_000, seed=1)["a"]
    assert got["iqm"] == pytest.approx(_direct_iqm(SCORES), abs=1e-12)
    # The same bootstrap by hand: resample the runs within each task (stratified), IQM, percentiles.
    rng = np.random.default_rng(7)
    runs, tasks = SCORES.shape
    boot = np.empty(4_000)
    for b in range(boot.size):
        idx = rng.integers(0, runs, size=(runs, tasks))
        boot[b] = _direct_iqm(np.take_along_axis(SCORES, idx, axis=0))
    low, high = np.percentile(boot, [2.5, 97.5])
    # Two independent Monte Carlo estimates of the same percentiles: close, not equal.
    assert got["low"] == pytest.approx(low, abs=0.04)
    assert got["high"] == pytest.approx(high, abs=0.04)
    assert got["low"] < got["iqm"] < got["high"]


def test_bootstrap_intervals_are_the_same_on_every_call() -> None:
    """The published intervals are a function of the records: the same scores and seed give the same
    bounds on every call, whatever numpy's global generator holds before it (rliable draws from that
    generator), and the caller's generator is left as it was."""
    pytest.importorskip("rliable")
    from planetnav_train.suite.scoring import improvement_probabilities, iqm_intervals, performance_profiles

    np.random.seed(123)  # noqa: NPY002 - the state a caller may hold
    first = iqm_intervals({"a": SCORES}, reps=300)
    after = np.random.random()  # noqa: NPY002
    np.random.seed(456)  # noqa: NPY002 - another state: the intervals must not depend on it
    assert iqm_intervals({"a": SCORES}, reps=300) == first
    pair = {("a", "b"): (SCORES, SCORES[::-1])}
    assert improvement_probabilities(pair, reps=200) == improvement_probabilities(pair, reps=200)
    assert performance_profiles({"a": SCORES}, reps=200) == performance_profiles({"a": SCORES}, reps=200)
    np.random.seed(123)  # noqa: NPY002
    iqm_intervals({"a": SCORES}, reps=300)
    assert np.random.random() == after  # noqa: NPY002 - restored around the call
    assert iqm_intervals({"a": SCORES}, reps=300, seed=1) != first  # the seed does reach the draws


def test_profiles_and_probability_of_improvement_match_numpy() -> None:
    pytest.importorskip("rliable")
    from planetnav_train.suite.scoring import improvement_probabilities, performance_profiles

    taus = [0.0, 0.5, 1.0]
    prof = performance_profiles({"a": SCORES}, taus=taus, reps=200)["a"]
    assert prof["fraction"] == pytest.approx([np.mean(SCORES > t) for t in taus])
    other = SCORES[::-1] + 0.1
    (row,) = improvement_probabilities({("b", "a"): (other, SCORES)}, reps=200)
    # P(X > Y): per task, over all pairs of runs, ties count half; then the mean over tasks.
    direct = np.mean(
        [
            np.mean(
                (other[:, None, j] > SCORES[None, :, j]) + 0.5 * (other[:, None, j] == SCORES[None, :, j])
            )
            for j in range(SCORES.shape[1])
        ]
    )
    assert row["probability"] == pytest.approx(direct)
    assert row["low"] <= row["probability"] <= row["high"]


def test_tasks_are_registered_ids_with_100_seeds() -> None:
    # Every registered v1 id is a task of suite version 1, every v2 id one of version 2, the published
    # table's (a new id joins the suite as one entry), each with its own objective.
    assert {t.env_id for t in suite.TASKS_V1} == {i for i in ENV_IDS if i.endswith("-v1")}
    assert {t.env_id for t in suite.TASKS_V2} == {i for i in ENV_IDS if i.endswith("-v2")}
    assert suite.SUITE_VERSION == 2 and suite.TASKS == suite.TASKS_V2
    assert {t.suite_version for t in suite.TASKS_V1} == {1}
    assert {t.suite_version for t in suite.TASKS_V2} == {2}
    assert len(suite.TASKS_BY_ID) == len(suite.TASKS_V1) + len(suite.TASKS_V2)
    for t in (*suite.TASKS_V1, *suite.TASKS_V2):
        assert len(t.eval_seeds) == 100 and t.noise_streams == "per_step"
        assert t.eval_config().noise_streams == "per_step"
        assert t.id.endswith(f"-v{t.version}")
        assert t.budget >= 1 and t.references
        # The scenario's J on operations scenarios, the mean position error elsewhere.
        ops = t.env_config().operations is not None
        assert t.objective == ("operations_J_km" if ops else "mean_pos_err_km"), t.id
        space = t.env_config().action_mode
        assert t.action_kind == ("discrete" if space == "target" else "continuous"), t.id
    assert suite.get_task("ThrustArc-TCM-v1").objective == "operations_J_km"
    with pytest.raises(ConfigError, match="unknown task 'Nope-v0'"):
        suite.get_task("Nope-v0")
    with pytest.raises(ConfigError, match=r"action_kind 'both' is not one of .*budget 0 must be >= 1"):
        suite.Task("planetnav/Cruise-Target-v1", "both", 0, ("greedy",))


def test_references_are_loadable_agents_on_their_task() -> None:
    # Built on the task's own environment (a bad parameter, e.g. a periodic cycle over planets the task
    # lacks, raises here); acting is left to the agents' tests (the planner's kernels compile for minutes).
    from planetnav_agents import make_agent, not_applicable, parse_spec
    from planetnav_env.envs.env import PlanetNavEnv

    for t in (*suite.TASKS_V1, *suite.TASKS_V2):
        # Full length: optimum's sessions must fit the episode. At the physics step, where the suite's
        # references act (runner.reference_agent).
        env_cfg = t.eval_config().at_physics_step()
        env = PlanetNavEnv(env_cfg)
        for spec in (t.random, *t.references):
            parse_spec(spec)  # a bad key raises ValueError naming it
            assert not_applicable(spec, env_cfg) is None, (t.id, spec)
            make_agent(spec, env).reset(seed=0)


def test_operations_objective_is_the_evaluations_J() -> None:
    obj = suite.OBJECTIVES["operations_J_km"]
    metrics = {"objective_kind": "operations J", "per_episode_objective": [8000.0, 9000.0],
               "per_episode_mean_pos_err_km": [1.0, 2.0]}  # fmt: skip
    assert obj.values(metrics).tolist() == [8000.0, 9000.0]
    with pytest.raises(ConfigError, match="needs an evaluation of kind 'operations J'"):
        obj.values({**metrics, "objective_kind": "mean position error"})
    assert suite.OBJECTIVES["mean_pos_err_km"].values(metrics).tolist() == [1.0, 2.0]


def test_best_reference_is_chosen_from_the_candidates_and_cached_per_agent(tmp_path, monkeypatch) -> None:
    import dataclasses

    from planetnav_train import evaluate

    evaluated: list[str] = []
    fake_j = {"random": 20_000.0, "idle": 15_000.0, "periodic:period=432": 9_000.0,
              "greedy:threshold=4": 8_500.0, "optimum": 8_000.0}  # fmt: skip

    def fake_evaluate(spec, env_cfg, episodes, seed, progress=True):
        evaluated.append(spec)
        # The random policy in the task's interface (held decisions): 18,000 here.
        j = 18_000.0 if spec == "random" and env_cfg.decision_steps > 1 else fake_j[spec]
        per = [j + k for k in range(episodes)]
        metrics = {"objective_kind": "operations J", "per_episode_objective": per}
        return evaluate.EvalResult(spec, metrics, np.zeros(0), np.zeros(0))

    monkeypatch.setattr(evaluate, "evaluate_agent", fake_evaluate)
    settings = suite.Settings(out=tmp_path, eval_episodes=3, episode_steps=10)
    task = dataclasses.replace(
        suite.get_task("ThrustArc-TCM-v1"), references=("periodic:period=432", "greedy:threshold=4")
    )
    refs = suite.task_references(task, settings)
    assert refs["best"] == "greedy:threshold=4" and refs["J_best"] == pytest.approx(8_501.0)
    assert refs["J_random"] == pytest.approx(20_001.0) and len(evaluated) == 5
    # The zero point is the better of random and idle (idle here), the random one is kept too.
    assert refs["zero"] == "idle" and refs["J_zero"] == pytest.approx(15_001.0)
    assert refs["agents"]["random@interface"]["objective"] == pytest.approx(20_001.0)  # no hold here
    # One more candidate: only it is evaluated; it is the best now.
    more = dataclasses.replace(task, references=(*task.references, "optimum"))
    refs = suite.task_references(more, settings)
    assert evaluated[5:] == ["optimum"] and refs["best"] == "optimum"
    assert json.loads((tmp_path / "references" / "ThrustArc-TCM-v1.json").read_text())["best"] == "optimum"


def test_cells_and_bad_values() -> None:
    cells = suite.make_cells(["Cruise-Target-v1", "Cruise-Torque-v1"], ["ppo", "dqn"], [0, 1], "raw")
    # dqn is discrete only: skipped on the torque task; ppo runs on both.
    assert sorted({(c.task, c.algo) for c in cells}) == [
        ("Cruise-Target-v1", "dqn"), ("Cruise-Target-v1", "ppo"), ("Cruise-Torque-v1", "ppo"),
    ]  # fmt: skip
    with pytest.raises(ConfigError, match="'sac' runs on"):
        suite.make_cells(["Cruise-Target-v1"], ["sac"], [0], "raw")
    # Asked for by name, RecurrentPPO runs on any discrete task; the table's pairs put it on the Mars
    # approach only, and RLlib's PPO on Cruise-Target-v1 only.
    tasks = ["Cruise-Target-v1", "MarsApproach-Tasking-v1"]
    assert {c.task for c in suite.make_cells(tasks, ["recurrent_ppo"], [0], "raw")} == set(tasks)
    table = suite.make_cells(tasks, ["recurrent_ppo", "rllib_ppo"], [0], "raw", table_only=True)
    assert {(c.task, c.algo) for c in table} == {
        ("MarsApproach-Tasking-v1", "recurrent_ppo"), ("Cruise-Target-v1", "rllib_ppo"),
    }  # fmt: skip
    with pytest.raises(ConfigError, match="unknown task"):
        suite.Algo("x", ("discrete",), tasks=("Cruise-Target-v9",))
    with pytest.raises(ConfigError, match=r"unknown task\(s\) \['Mars-v1'\]"):
        suite.Algo("x", ("discrete",), task_hyperparams={"Mars-v1": {"batch_size": 256}})
    with pytest.raises(ConfigError, match=r"unknown task\(s\) \['Mars-v1'\]"):
        suite.Algo("x", ("discrete",), task_reward_scale_km={"Mars-v1": 10.0})
    with pytest.raises(ConfigError, match=r"reward scale of Cruise-Target-v1 must be > 0 km, got -1\.0"):
        suite.Algo("x", ("discrete",), task_reward_scale_km={"Cruise-Target-v1": -1.0})
    with pytest.raises(ConfigError, match="--track 'both'"):
        suite.make_cells(["Cruise-Target-v1"], ["ppo"], [0], "both")
    with pytest.raises(ConfigError, match="unknown algorithm 'ppo2'"):
        suite.make_cells(["Cruise-Target-v1"], ["ppo2"], [0], "raw")


def test_raw_and_assisted_configs(tmp_path) -> None:
    settings = suite.Settings(out=tmp_path)
    raw, names = suite.cell_config(suite.Cell("Cruise-Target-v1", "ppo", "raw", 3), settings)
    assert names == [] and raw.features == [] and not raw.pretrain
    # The budget counts physics steps: the v1 id holds each decision 10 of them.
    task = suite.get_task("Cruise-Target-v1")
    assert raw.env == {} and raw.seed == 3 and raw.n_timesteps * 10 == task.budget
    dqn, _ = suite.cell_config(suite.Cell("Cruise-Target-v1", "dqn", "raw", 3), settings)
    assert dqn.n_timesteps == round(task.budget * suite.get_algo("dqn").budget_fraction) // 10
    assisted, names = suite.cell_config(suite.Cell("Cruise-Target-v1", "ppo", "assisted", 3), settings)
    # The assisted track adds what a rule agent computes, named: greedy's gain.
    assert names == ["gain"] and assisted.features == ["gain"]
    assert assisted.n_timesteps == raw.n_timesteps
    # A task's hyperparameter overrides reach its cells only: PPO's minibatch on the Mars approach.
    mars, _ = suite.cell_config(suite.Cell("MarsApproach-Tasking-v1", "ppo", "raw", 3), settings)
    assert raw.hyperparams["batch_size"] == 1024 and mars.hyperparams["batch_size"] == 256
    assert {k: v for k, v in mars.hyperparams.items() if k != "batch_size"} == {
        k: v for k, v in raw.hyperparams.items() if k != "batch_size"
    }
    # RandomCruise: PPO reads the target blocks in the relative actions' order, scores every target with
    # one MLP and trains on the reward in units of 100,000 km, on both tracks; the objective and every
    # other task's reward are the id's.
    for track in ("raw", "assisted"):
        rc, _ = suite.cell_config(suite.Cell("RandomCruise-Target-v1", "ppo", track, 3), settings)
        assert rc.env == {"reward_scale_km": 100_000.0} and rc.env_config().reward_scale_km == 100_000.0
        assert rc.hyperparams["policy_kwargs"] == {
            "features_extractor": "relative_order",
            "action_head": "per_target",
            "contrast": True,
        }
    assert raw.env_config().reward_scale_km == 1000.0 and mars.env == {}
    rc_dqn, _ = suite.cell_config(suite.Cell("RandomCruise-Target-v1", "dqn", "raw", 3), settings)
    assert rc_dqn.env == {} and "policy_kwargs" not in rc_dqn.hyperparams
    smoke, _ = suite.cell_config(
        suite.Cell("RandomCruise-Target-v1", "ppo", "raw", 3), suite.Settings(out=tmp_path, episode_steps=40)
    )
    assert smoke.env == {"reward_scale_km": 100_000.0, "episode_steps": 40}


def test_budget_counts_the_physics_steps_of_the_cells_own_hold(tmp_path) -> None:
    """A cell's budget is physics steps, counted once: decisions = budget // the cell's decision_steps (its
    id's, or an assist's env option), so every published cell trains the physics steps it did when an
    assist's hold was a training option multiplied by the id's (no shipped assist sets a hold)."""
    settings = suite.Settings(out=tmp_path)
    checked = 0
    installed = []
    for name in suite.ALGOS:
        try:
            suite.get_algo(name).check_installed()
            installed.append(name)
        except ConfigError:  # an extra not installed here (RLlib): its cells are built by its own venv
            pass
    for tasks in suite.SUITES.values():
        names = [t.id for t in tasks]
        for track in ("raw", "assisted"):
            algos = ["ppo"] if track == "assisted" else installed
            for cell in suite.make_cells(names, algos, [0], track, table_only=True):
                tc, _ = suite.cell_config(cell, settings)
                task, algo = suite.get_task(cell.task), suite.get_algo(cell.algo)
                hold = tc.env_config().decision_steps
                assert hold == task.env_config().decision_steps, cell.key  # the id's hold
                assert tc.n_timesteps == max(1, round(algo.budget(task)) // hold), cell.key
                checked += 1
    assert checked >= 20
    # An assist's hold replaces the id's (10 physics steps on Cruise-Target-v1): the physics steps stay.
    assists = {
        "assists": {"hold_20": {"env": {"decision_steps": 20}}},
        "tasks": {"Cruise-Target-v1": ["hold_20"]},
    }
    task = suite.get_task("Cruise-Target-v1")
    held, names = suite.cell_config(suite.Cell(task.id, "ppo", "assisted", 0), settings, assists)
    assert names == ["hold_20"] and held.env_config().decision_steps == 20
    assert held.n_timesteps == round(suite.get_algo("ppo").budget(task)) // 20


def test_an_assist_with_a_training_side_decision_option_names_the_env_option(tmp_path) -> None:
    path = tmp_path / "assists.yaml"
    for frag, named in (
        (
            "action_repeat: 10",
            "action_repeat is no longer a training option: set env option decision_steps=10",
        ),
        (
            "relative_actions: true",
            "relative_actions is no longer a training option: set env option target_actions='relative'",
        ),
        (
            "features: [since_measured]",
            "since_measured is no longer a training feature: set env option observe_since_measured=true",
        ),
    ):
        path.write_text(f"assists:\n  old:\n    {frag}\ntasks: {{}}\n")
        with pytest.raises(ConfigError, match=f"assist 'old': {named}"):
            suite.load_assists(path)


def test_exact_actions_reaches_the_evaluation_the_record_and_the_command(tmp_path, monkeypatch) -> None:
    from planetnav_train import evaluate
    from planetnav_train.cli import build_parser

    seen: list[bool] = []

    def fake_evaluate(spec, env_cfg, episodes, seed, progress=True, batched=True, exact_actions=True):
        seen.append(exact_actions)
        metrics = {"per_episode_mean_pos_err_km": [100.0 + k for k in range(episodes)]}
        return evaluate.EvalResult(spec, metrics, np.zeros(0), np.zeros(0))

    monkeypatch.setattr(evaluate, "evaluate_agent", fake_evaluate)
    monkeypatch.setattr(
        runner, "train_cell", lambda tc, run_dir, progress, resume, callbacks=(): (run_dir / "model.zip", {})
    )
    refs = {"random": "random", "zero": "random", "best": "greedy", "J_random": 300.0, "J_zero": 300.0,
            "J_best": 100.0, "agents": {"random": {"per_episode": [300.0] * 2},
                                        "greedy": {"per_episode": [100.0] * 2}}}  # fmt: skip
    cell = suite.Cell("Cruise-Torque-v1", "sac", "raw", 0)
    for exact in (True, False):
        settings = suite.Settings(out=tmp_path, eval_episodes=2, exact_actions=exact)
        record = suite.run_cell(cell, settings, refs)
        assert seen[-1] is exact and record["exact_actions"] is exact
        args = build_parser().parse_args(shlex.split(record["command"])[2:])
        assert args.exact_actions is exact
    assert suite.Settings(out=tmp_path).exact_actions is False  # the suite's default: one forward pass


def test_contrib_algorithm_without_sb3_contrib_names_the_extra(monkeypatch) -> None:
    import sys

    from planetnav_train.sb3 import algorithm_class

    monkeypatch.setitem(sys.modules, "sb3_contrib", None)  # import sb3_contrib raises ImportError
    with pytest.raises(ConfigError, match=r"\.\[bench\]"):
        algorithm_class("tqc")


def _fake_record(cell: suite.Cell, settings: suite.Settings) -> dict:
    return {"task": cell.task, "algorithm": cell.algo, "track": cell.track, "seed": cell.seed,
            "objective": 100.0 + cell.seed, "normalized_score": 0.5 + 0.1 * cell.seed, "wall_seconds": 0.0,
            "official": False, "command": suite.rerun_command(cell, settings)}  # fmt: skip


def test_resume_skips_finished_runs(tmp_path, monkeypatch) -> None:
    trained: list[str] = []

    def fake_run_cell(cell, settings, references):
        trained.append(cell.key)
        return _fake_record(cell, settings)

    monkeypatch.setattr(runner, "run_cell", fake_run_cell)
    monkeypatch.setattr(runner, "task_references", lambda task, settings: {"task": task.id})
    settings = suite.Settings(out=tmp_path)
    cells = suite.make_cells(["Cruise-Target-v1"], ["ppo"], [0, 1], "raw")
    first = suite.run_suite(cells, settings, use_ray=False)
    assert len(trained) == 2 and len(first["records"]) == 2
    with pytest.raises(ConfigError, match="--resume"):
        suite.run_suite(cells, settings, use_ray=False)
    more = suite.make_cells(["Cruise-Target-v1"], ["ppo"], [0, 1, 2], "raw")
    again = suite.run_suite(more, settings, resume=True, use_ray=False)
    assert trained == [c.key for c in cells] + ["Cruise-Target-v1__ppo__raw__s2"]  # only the new cell
    assert len(again["skipped"]) == 2 and len(again["records"]) == 3


def test_curve_references_average_the_published_values_on_the_curve_seeds() -> None:
    refs = {"zero": "random", "best": "greedy", "agents": {
        "random": {"per_episode": list(range(100, 130))}, "greedy": {"per_episode": [10.0] * 29 + [70.0]},
    }}  # fmt: skip
    out = runner.curve_references(refs)
    assert out == {"episodes": runner.CURVE_EPISODES, "J_zero": 109.5, "J_best": 10.0}
    short = {**refs, "agents": {k: {"per_episode": v["per_episode"][:3]} for k, v in refs["agents"].items()}}
    assert runner.curve_references(short) == {"episodes": 3, "J_zero": 101.0, "J_best": 10.0}


def test_suite_smoke_end_to_end(tmp_path, monkeypatch) -> None:
    """CI: train a few hundred steps, evaluate on 2 seeds of 20 steps, score, aggregate, write the JSON and
    the markdown; then re-parse the recorded command of a cell; then publish (the JSON copied, the README
    summary, the best model shipped), evaluate the shipped baseline by name, and restore a folder from the
    published JSON."""
    pytest.importorskip("rliable")
    from planetnav_train.cli import build_parser, main

    out, js, md = tmp_path / "suite", tmp_path / "runs.json", tmp_path / "benchmark.md"
    argv = ["suite", "--tasks", "Cruise-Target-v1", "--algos", "ppo", "--seeds", "0", "1",
            "--budget-scale", "0.003", "--episode-steps", "20", "--eval-episodes", "2",
            "--out", str(out), "--json", str(js), "--markdown", str(md),
            "--no-ray", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    runs = json.loads(js.read_text())["runs"]
    assert len(runs) == 2
    for r in runs:
        assert r["env_steps"] >= 300 and len(r["per_episode"]) == 2 and not r["official"]
        assert np.isfinite(r["normalized_score"]) and r["wall_seconds"] > 0
    published = json.loads((out / "suite.json").read_text())
    ref = published["references"]["Cruise-Target-v1"]
    task = suite.get_task("Cruise-Target-v1")
    candidates = {k: ref["agents"][k]["objective"] for k in task.references}
    assert ref["J_best"] == min(candidates.values()) == ref["agents"][ref["best"]]["objective"]
    # The zero point: the better of random and idle.
    zeros = {k: ref["agents"][k]["objective"] for k in ("random", "idle")}
    assert ref["J_zero"] == min(zeros.values()) and ref["zero"] in zeros
    for r in runs:  # both modes recorded, the protocol's (PPO: sampled) in the headline; a curve
        assert set(r["evaluations"]) == {"argmax", "sampled"} and r["eval_mode"] == "sampled"
        assert r["objective"] == r["evaluations"]["sampled"]["objective"]
        assert len(r["learning_curve"]) >= 10 and r["learning_curve"][-1][0] == r["env_steps"]
        assert all(np.isfinite(score) for _, score in r["learning_curve"])
        # The curve ends on the final (its last point inside the final's 95 % interval, mapped to the score),
        # and its points were played on the evaluation seeds the references' values are averaged over.
        lo, hi = sorted(normalized_score(j, ref["J_zero"], ref["J_best"]) for j in r["objective_ci95"])
        assert r["learning_curve"][-1][1] == r["normalized_score"] and lo <= r["normalized_score"] <= hi
        assert r["curve_seeds"] == [task.eval_seed, task.eval_seed + 2]  # all of the smoke run's 2 seeds
    (task_set,) = published["aggregate"]["raw"]["task_sets"]
    assert task_set["tasks"] == ["Cruise-Target-v1"]
    agg = task_set["algorithms"]["ppo"]
    assert agg["low"] <= agg["iqm"] <= agg["high"]
    # IQM learning curves with their bands, per task and over the task set, and their plot.
    for c in (published["aggregate"]["raw"]["curves"]["Cruise-Target-v1"]["ppo"], task_set["curves"]["ppo"]):
        bands = zip(c["low"], c["iqm"], c["high"], strict=True)
        assert len(c["steps"]) >= 10 and all(lo <= m <= hi for lo, m, hi in bands)
    assert (tmp_path / "benchmark_plots" / "raw_curves.png").is_file()
    text = md.read_text()
    assert "Not a leaderboard" in text and (tmp_path / "benchmark_plots" / "raw_iqm.png").is_file()
    # Resume: nothing left to train.
    assert main([*argv, "--resume"]) == 0
    assert json.loads(js.read_text())["runs"] == []
    # The recorded command re-runs exactly that cell.
    args = build_parser().parse_args(shlex.split(runs[0]["command"])[2:])
    assert (args.tasks, args.algos, args.seeds, args.track) == (
        ["Cruise-Target-v1"],
        ["ppo"],
        [runs[0]["seed"]],
        "raw",
    )
    assert (args.budget_scale, args.episode_steps, args.eval_episodes) == (0.003, 20, 2)

    # Publishing (nothing trains): the JSON into the repository, the README's summary, the best model.
    from planetnav_train import shipped
    from planetnav_train.suite import publish

    readme, bench_json, baselines = tmp_path / "README.md", tmp_path / "benchmark.json", tmp_path / "bl"
    readme.write_text(f"# r\n\n{publish.README_START}\nnot yet\n{publish.README_END}\n\n## next\n")
    pub = ["suite-publish", "--out", str(out), "--markdown", str(md), "--publish-json", str(bench_json),
           "--readme", str(readme), "--baselines", str(baselines), "--allow-dirty"]  # fmt: skip
    assert main(pub) == 2 and not baselines.exists()  # smoke runs ship only with --allow-smoke
    assert main([*pub, "--allow-smoke"]) == 0
    published = json.loads((out / "suite.json").read_text())
    compact = json.loads(bench_json.read_text())
    assert compact == publish.compact_suite_json(published) and len(compact["runs"]) == 2
    assert "per_episode" not in compact["runs"][0] and compact["runs"][0]["learning_curve"]
    summary = suite.summary_markdown(published)
    assert "| 1: Cruise-Target-v1 | 1 | ppo | 2 |" in summary and "| Cruise-Target-v1 | ppo |" in summary
    assert readme.read_text() == (
        f"# r\n\n{publish.README_START}\n{summary.rstrip()}\n{publish.README_END}\n\n## next\n"
    )
    best = min(runs, key=lambda r: (r["objective"], r["seed"]))
    entry = json.loads((baselines / "manifest.json").read_text())["baselines"]["Cruise-Target-v1"]
    assert entry["source_cell"] == f"Cruise-Target-v1__ppo__raw__s{best['seed']}" and not entry["official"]
    # The shipped name evaluates to the cell's own record on the same seeds and settings.
    monkeypatch.setattr(shipped, "BASELINES_DIR", baselines)
    cmp = tmp_path / "compare.json"
    assert main(["compare", "--agents", "suite:Cruise-Target-v1", "--episodes", "2", "--seed", "50000",
                 "--episode-steps", "20", "--noise-streams", "per_step", "--json", str(cmp),
                 "--no-progress"]) == 0  # fmt: skip
    got = json.loads(cmp.read_text())["agents"]["suite:Cruise-Target-v1:stochastic"]  # PPO: sampled
    assert got["per_episode_mean_pos_err_km"] == best["per_episode"]
    # A fresh folder restored from the published JSON publishes the same runs and aggregates.
    from planetnav_train.suite.restore import restore

    restored = tmp_path / "restored"
    assert len(restore(bench_json, restored).records) == 2
    assert main(["suite-publish", "--out", str(restored), "--markdown", str(tmp_path / "again.md"),
                 "--allow-dirty"]) == 0  # a development tree may be dirty: test_publish_clean_tree.py
    again = json.loads((restored / "suite.json").read_text())
    assert again["aggregate"] == published["aggregate"] and again["references"] == published["references"]
    assert [r["objective"] for r in again["runs"]] == [r["objective"] for r in published["runs"]]


def test_aggregates_rank_only_algorithms_that_ran_on_the_whole_task_set() -> None:
    """PPO on three tasks, DQN on two of them (where it is better): no row ranks them over different sets;
    the set they share ranks both, and P(improvement) is taken on those tasks."""
    pytest.importorskip("rliable")
    from planetnav_train.suite import scoring
    from planetnav_train.suite.leaderboard import aggregate_rows

    def rec(algo: str, task: str, seed: int, score: float) -> dict:
        return {"track": "raw", "algorithm": algo, "task": task, "seed": seed, "normalized_score": score}

    records = [
        rec("ppo", t, s, base + 0.01 * s)
        for t, base in (("A", 0.2), ("B", 0.3), ("C", 2.0))
        for s in range(5)
    ]
    records += [rec("dqn", t, s, 0.8 + 0.01 * s) for t in ("A", "B") for s in range(5)]
    assert scoring.task_sets(records, "raw") == [("A", "B", "C"), ("A", "B")]
    rows = scoring.task_set_rows(records, "raw", reps=200)
    assert set(rows[0]["algorithms"]) == {"ppo"} and set(rows[1]["algorithms"]) == {"dqn", "ppo"}
    # On its own tasks PPO's IQM is lifted by C; on the shared two DQN ranks first.
    assert rows[1]["algorithms"]["dqn"]["iqm"] > rows[1]["algorithms"]["ppo"]["iqm"]
    assert rows[1]["algorithms"]["ppo"]["iqm"] == pytest.approx(
        np.mean([0.2 + 0.01 * s for s in range(1, 4)] + [0.3 + 0.01 * s for s in range(1, 4)]), abs=0.02
    )
    agg = scoring.aggregate(records, reps=200)["raw"]
    (pair,) = agg["improvement"]
    assert (pair["x"], pair["y"], pair["tasks"]) == ("dqn", "ppo", ["A", "B"]) and pair["probability"] == 1.0
    table = "\n".join(aggregate_rows(agg))
    assert "| 3: A, B, C | 1 | ppo | 5 |" in table
    assert "| 2: A, B | 1 | dqn | 5 |" in table and "|  | 2 | ppo | 5 |" in table


def test_entries_name_tuned_settings_and_short_budgets() -> None:
    """PPO's per-task settings appear as ppo-tuned; a cell below its task's budget is marked and never
    ranked (here DQN at a third of Cruise-Target-v1's 3M physics steps)."""
    pytest.importorskip("rliable")
    from planetnav_train.suite.scoring import entry_name, task_set_rows

    def rec(algo: str, task: str, seed: int, score: float, steps: int) -> dict:
        return {"track": "raw", "algorithm": algo, "task": task, "seed": seed, "normalized_score": score,
                "env_steps": steps, "budget_scale": 1.0}  # fmt: skip

    full = suite.get_task("Cruise-Target-v1").budget
    assert entry_name(rec("ppo", "Cruise-Target-v1", 0, 0.5, full)) == "ppo"
    assert entry_name(rec("ppo", "RandomCruise-Target-v1", 0, 0.5, full)) == "ppo-tuned"
    assert entry_name(rec("dqn", "Cruise-Target-v1", 0, 0.9, full // 3)) == "dqn (short budget)"
    assert entry_name({**rec("dqn", "Cruise-Target-v1", 0, 0.9, full // 3), "budget_scale": 1 / 3}) == "dqn"
    records = [rec("ppo", "Cruise-Target-v1", s, 0.5, full) for s in range(3)]
    records += [rec("dqn", "Cruise-Target-v1", s, 0.9, full // 3) for s in range(3)]
    (row,) = task_set_rows(records, "raw", reps=100)
    assert set(row["algorithms"]) == {"ppo"}  # the better-scoring short cell is not ranked
    agg = suite.aggregate(records, reps=100)["raw"]
    assert set(agg["per_task"]["Cruise-Target-v1"]) == {"ppo", "dqn (short budget)"}  # but it is shown
    assert agg["improvement"] == []


BLIND_JSON = Path(__file__).resolve().parents[2] / "docs" / "tasks_v2_blind.json"


def test_v2_tasks_take_their_zero_and_references_from_the_published_blind_search() -> None:
    published = json.loads(BLIND_JSON.read_text())["tasks"]
    for task in suite.TASKS_V2:
        rec = published[task.id]
        winner = rec["blind_winner"]
        assert task.zero == ((runner.INTERFACE_RANDOM,) if winner == "random" else (winner,)), task.id
        refs = {s for s, row in rec["agents"].items() if row["role"] == "reference"}
        assert set(task.references) == refs and rec["best_reference"] in task.references
        assert suite.get_task(task.id) is task and task in suite.TASKS  # the published table's


@pytest.mark.parametrize("task_id", ["Cruise-Target-v2", "RandomCruise-Target-v2"])
def test_v2_zero_point_evaluated_by_the_suite_equals_the_blind_search(tmp_path, task_id) -> None:
    """The suite's reference machinery and the blind search play the zero point on the same seeds, noise
    streams and interface: the same per-episode values, bit for bit (first 2 seeds)."""
    task = suite.get_task(task_id)
    rec = json.loads(BLIND_JSON.read_text())["tasks"][task_id]
    settings = suite.Settings(out=tmp_path, eval_episodes=2)
    (zero,) = task.zero
    got = runner.reference_agent(task, zero, settings)["per_episode"]
    assert got == rec["agents"][rec["blind_winner"]]["per_seed"][:2]


def test_v2_cells_train_for_the_task_budget_with_the_task_discount(tmp_path) -> None:
    """Suite version 2: every algorithm gets the task's physics-step budget (SAC, whose full budget does not
    fit the table, trains a stated fraction and is marked short), and a task that states its discount
    gives it to every algorithm; the v1 cells keep their budgets and discounts."""
    settings = suite.Settings(out=tmp_path)
    thrust = suite.get_task("ThrustArc-TCM-v2")
    assert thrust.suite_version == 2 and suite.get_task("ThrustArc-TCM-v1").suite_version == 1
    per_decision = thrust.env_config().decision_steps
    for algo in ("ppo", "dqn"):
        cfg, _ = suite.cell_config(suite.Cell(thrust.id, algo, "raw", 0), settings)
        assert cfg.n_timesteps * per_decision == thrust.budget, algo
        assert cfg.hyperparams["gamma"] == thrust.discount == 0.995, algo
    v1_dqn, _ = suite.cell_config(suite.Cell("ThrustArc-TCM-v1", "dqn", "raw", 0), settings)
    assert v1_dqn.hyperparams["gamma"] == 0.95
    assert v1_dqn.n_timesteps == round(3_000_000 * suite.get_algo("dqn").budget_fraction)
    torque = suite.get_task("Cruise-Torque-v2")
    sac, _ = suite.cell_config(suite.Cell(torque.id, "sac", "raw", 0), settings)
    assert sac.n_timesteps * torque.env_config().decision_steps == round(torque.budget * 0.1)
    steps = sac.n_timesteps * torque.env_config().decision_steps
    short = {"algorithm": "sac", "task": torque.id, "env_steps": steps, "budget_scale": 1.0}
    assert not is_ranked(entry_name(short))
    with pytest.raises(ConfigError, match=r"discount 1\.0 must lie in"):
        dataclasses.replace(thrust, discount=1.0)


def test_the_headline_task_set_is_the_v2_tasks_with_a_closed_loop_gap_of_25_percent() -> None:
    """``Task.headline`` holds exactly where the published blind search measured a closed-loop gap of 25 %
    or more; the aggregate ranks the entries that ran on all of the headline set in a row of its own."""
    from planetnav_train.suite import scoring

    published = json.loads(BLIND_JSON.read_text())["tasks"]
    for task in suite.TASKS_V2:
        assert task.headline == (published[task.id]["closed_loop_gap"]["gap"] >= 0.25), task.id
    assert not any(t.headline for t in suite.TASKS_V1)
    headline = scoring.headline_tasks([t.id for t in suite.TASKS_V2])
    assert headline == ("Cruise-Torque-v2", "RandomCruise-Target-v2")

    def rec(task: str, algo: str, seed: int, score: float) -> dict:
        steps = suite.get_task(task).budget
        return {"task": task, "algorithm": algo, "track": "raw", "seed": seed, "normalized_score": score,
                "env_steps": steps, "budget_scale": 1.0}  # fmt: skip

    recs = [rec(t, "ppo", s, 0.5) for s in range(3) for t in (*headline, "Cruise-Target-v2")]
    recs += [rec("RandomCruise-Target-v2", "dqn", s, 0.2) for s in range(3)]
    rows = {tuple(r["tasks"]): r for r in scoring.task_set_rows(recs, "raw", reps=50)}
    assert rows[headline]["headline"] and set(rows[headline]["algorithms"]) == {"ppo"}
    assert not rows[("RandomCruise-Target-v2",)]["headline"]
    # Without every headline task among an entry's tasks there is no headline row.
    assert all(not r["headline"] for r in scoring.task_set_rows(recs[-3:], "raw", reps=50))
