"""Publishing the suite (planetnav_train.suite.publish, planetnav_train.shipped; docs/suite.md "Publishing"):
the README summary block, the summary tables against direct numpy IQMs, choosing and shipping the best
raw-track model of each task with its size limit, and loading a shipped baseline by name. The end-to-end
path (a real smoke suite, then ``suite-publish`` and ``compare --agents suite:<task>``) is in
tests/train/test_suite.py::test_suite_smoke_end_to_end."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from planetnav_agents import make_agent
from planetnav_env.errors import ConfigError
from planetnav_train import shipped, suite
from planetnav_train.spread import prediction_interval
from planetnav_train.suite import publish, runner
from planetnav_train.suite.challenges import task_status

README = f"# x\n\nintro\n\n{publish.README_START}\nold text\n{publish.README_END}\n\n## after\n"


def test_replace_block_keeps_the_rest_and_names_bad_markers() -> None:
    got = publish.replace_block(README, "| a | b |\n")
    assert got == f"# x\n\nintro\n\n{publish.README_START}\n| a | b |\n{publish.README_END}\n\n## after\n"
    assert publish.replace_block(got, "| a | b |") == got  # idempotent
    with pytest.raises(ConfigError, match=r"R\.md: expected one .* found 0 and 1"):
        publish.replace_block(README.replace(publish.README_START, ""), "t", "R.md")
    with pytest.raises(ConfigError, match="found 2 and 2"):
        publish.replace_block(README + README, "t")
    swapped = f"{publish.README_END}\n{publish.README_START}\n"
    with pytest.raises(ConfigError, match="comes before"):
        publish.replace_block(swapped, "t")


def _record(task: str, algo: str, seed: int, score: float, track: str = "raw", official: bool = True):
    # objective falls as the score rises (J_random 1000 km, J_best 200 km)
    return {"task": task, "algorithm": algo, "track": track, "seed": seed, "normalized_score": score,
            "objective": 1000.0 - 800.0 * score, "official": official,
            "suite_version": suite.get_task(task).suite_version, "task_version": 0,
            "command": f"python train.py suite --tasks {task}"}  # fmt: skip


def _iqm(values: list[float]) -> float:
    flat = np.sort(np.asarray(values, dtype=float))
    cut = int(0.25 * flat.size)
    return float(flat[cut : flat.size - cut].mean())


#: (task, algorithm) -> four seeds' scores: ppo wins on Cruise, dqn on ThrustArc (tasks where the suite's PPO
#: runs its standard settings, so both entries are plain algorithm names).
SCORES = {
    ("Cruise-Target-v1", "ppo"): [0.9, 1.1, 0.7, 1.3],
    ("Cruise-Target-v1", "dqn"): [0.2, 0.5, 0.4, 0.1],
    ("ThrustArc-TCM-v1", "ppo"): [0.3, 0.35, 0.2, 0.6],
    ("ThrustArc-TCM-v1", "dqn"): [0.8, 0.6, 0.9, 0.75],
}


def _row(text: str, first: str) -> list[str]:
    (line,) = [ln for ln in text.splitlines() if ln.startswith(f"| {first} |")]
    return [c.strip() for c in line.strip("|").split("|")]


def _set_rows(text: str, tasks: str) -> dict[str, list[str]]:
    """The aggregate rows of the task set named ``tasks``: algorithm -> [rank, runs per task, IQM]."""
    lines = text.splitlines()
    start = next(k for k, ln in enumerate(lines) if ln.startswith(f"| {tasks} |"))
    rows = {}
    for ln in lines[start:]:
        cells = [c.strip() for c in ln.strip("|").split("|")]
        if len(cells) != 5 or (cells[0] and ln is not lines[start]):
            break
        rows[cells[2]] = [cells[1], cells[3], cells[4]]
    return rows


def test_summary_tables_match_direct_iqms() -> None:
    pytest.importorskip("rliable")
    records = [_record(t, a, s, v) for (t, a), vals in SCORES.items() for s, v in enumerate(vals)]
    # The random policy in the task's interface: (1000 - 600) / (1000 - 200) = 0.5 of the way to greedy.
    refs = {t: {"best": "greedy", "J_best": 200.0, "J_zero": 1000.0,
                "agents": {"random@interface": {"objective": 600.0}}} for t, _ in SCORES}  # fmt: skip
    agg = suite.aggregate(records, reps=200)
    text = suite.summary_markdown(suite.suite_json(records, refs, agg))
    assert "runs on 2 task(s)" in text and "Not a leaderboard" not in text
    # Both ran on both tasks: one task set, named, ranking them by their IQM over it.
    rows = _set_rows(text, "2: Cruise-Target-v1, ThrustArc-TCM-v1")
    iqms = {a: _iqm([v for (_, x), vals in SCORES.items() if x == a for v in vals]) for a in ("ppo", "dqn")}
    for algo, value in iqms.items():
        rank = "1" if value == max(iqms.values()) else "2"
        assert rows[algo][:2] == [rank, "4"] and rows[algo][2].startswith(f"{value:.2f} [")
    for task in ("Cruise-Target-v1", "ThrustArc-TCM-v1"):
        per = {a: _iqm(vals) for (t, a), vals in SCORES.items() if t == task}
        best = max(per, key=per.get)
        row = _row(text, task)
        assert row[1] == best and row[2].startswith(f"{per[best]:.2f} [") and row[4] == "greedy (200.0 km)"
        # A new training run of the best algorithm: mean objective and 95 % prediction interval of its seeds.
        pi = prediction_interval([1000.0 - 800.0 * v for v in SCORES[(task, best)]])
        assert row[3] == f"{pi.mean:.1f} [{max(pi.lo, 0.0):.1f}, {pi.hi:.1f}]"
        assert row[5] == "+0.50"
        # The status column: the best IQM's label (thresholds in tests/train/test_suite_challenges.py).
        assert row[6] == task_status(task, per[best]) and row[6].startswith(
            "target met" if per[best] >= 0.9 else "below the target 0.9"
        )
    smoke = suite.summary_markdown(suite.suite_json([{**records[0], "official": False}], refs, agg))
    assert "**Not a leaderboard**: 1 of 1 runs" in smoke
    assert suite.summary_markdown(suite.suite_json([], refs, {})) == "No run recorded yet.\n"


def test_update_readme_writes_the_summary_block(tmp_path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text(README)
    data = {"runs": [], "aggregate": {}}
    publish.update_readme(readme, data)
    assert readme.read_text() == README.replace("old text", "No run recorded yet.")
    with pytest.raises(ConfigError, match="no such file"):
        publish.update_readme(tmp_path / "nope.md", data)


def test_the_repositorys_readme_has_one_summary_block() -> None:
    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    publish.replace_block(text, "x", "README.md")  # raises unless each marker occurs once, in order
    assert "docs/benchmark.md" in text


def test_best_raw_runs_ship_the_pages_ranked_best_never_a_short_budget_entry() -> None:
    """The shipped run is the page's best entry's (best_per_task_rows names the same one), even where an
    unranked short-budget entry has the lowest objective; a task with only unranked runs ships nothing."""
    pytest.importorskip("rliable")
    task = "Cruise-Torque-v2"
    budget = suite.get_task(task).budget
    ppo = [{**_record(task, "ppo", s, v), "env_steps": budget} for s, v in enumerate([-0.6, -0.5, -0.55])]
    sac = [{**_record(task, "sac", s, v), "env_steps": budget // 10} for s, v in enumerate([-0.1, -0.3, 0.2])]
    best = publish.best_raw_runs([*ppo, *sac])[task]
    assert (best["algorithm"], best["seed"]) == ("ppo", 1)
    agg = suite.aggregate([*ppo, *sac], reps=100)["raw"]
    (row,) = [ln for ln in suite.leaderboard.best_per_task_rows(agg, {}) if ln.startswith(f"| {task} |")]
    assert row.split("|")[2].strip() == "ppo"
    named = (r"task Cruise-Torque-v2: no official raw-track run to ship \(0 raw-track record\(s\) with smoke "
             r"settings; unranked, never shipped: sac \(short")
    with pytest.raises(ConfigError, match=named):
        publish.best_raw_runs([*sac, _record("Cruise-Target-v1", "ppo", 0, 0.5)], tasks=[task])
    with pytest.raises(ConfigError, match="all unranked"):
        publish.best_raw_runs(sac)


def test_best_raw_runs_lowest_objective_official_only() -> None:
    records = [
        _record("Cruise-Target-v1", "ppo", 0, 0.5),
        _record("Cruise-Target-v1", "dqn", 3, 0.9),
        _record("Cruise-Target-v1", "a2c", 1, 1.5, track="assisted"),  # assisted: never shipped
        _record("Cruise-Target-v1", "ppo", 2, 1.2, official=False),  # smoke settings
        _record("Cruise-Torque-v1", "sac", 0, 0.1, official=False),
    ]
    best = publish.best_raw_runs(records)
    assert list(best) == ["Cruise-Target-v1"] and (best["Cruise-Target-v1"]["algorithm"], best[
        "Cruise-Target-v1"]["seed"]) == ("dqn", 3)  # fmt: skip
    # with the smoke runs: PPO's IQM over seeds 0 and 2 is 0.85, below DQN's 0.9: DQN is still the best
    # entry; shipped is the best entry's best run, not the best run of any entry (PPO's seed 2)
    smoke = publish.best_raw_runs(records, official_only=False)
    assert (smoke["Cruise-Target-v1"]["algorithm"], smoke["Cruise-Target-v1"]["seed"]) == ("dqn", 3)
    assert smoke["Cruise-Torque-v1"]["algorithm"] == "sac"
    with pytest.raises(ConfigError, match=r"task Cruise-Torque-v1: no official raw-track run .*1 raw"):
        publish.best_raw_runs(records, tasks=["Cruise-Torque-v1"])
    with pytest.raises(ConfigError, match="unknown task 'Nope-v0'"):
        publish.best_raw_runs(records, tasks=["Nope-v0"])
    with pytest.raises(ConfigError, match="no raw-track record"):
        publish.best_raw_runs([records[2]])


@pytest.fixture
def suite_out(tmp_path: Path) -> Path:
    """A suite output folder with two official raw-track records of Cruise-Target-v1 and their models (an
    untrained PPO: shipping and loading do not need a trained one)."""
    from stable_baselines3 import PPO

    from planetnav_env.envs.env import PlanetNavEnv

    out = tmp_path / "suite"
    env = PlanetNavEnv(suite.get_task("Cruise-Target-v1").env_config(episode_steps=10))
    for seed, score in ((0, 0.4), (1, 0.8)):
        rec = _record("Cruise-Target-v1", "ppo", seed, score)
        cell = suite.Cell(rec["task"], "ppo", "raw", seed)
        runner.write_json_atomic(suite.record_path(out, cell), rec)
        (out / "models" / cell.key).mkdir(parents=True)
        PPO("MlpPolicy", env, seed=seed, n_steps=16, batch_size=16).save(out / "models" / cell.key / "model")
    return out


def test_ship_baselines_copies_the_best_and_loads_it_by_name(suite_out, tmp_path, monkeypatch) -> None:
    from planetnav_env.envs.env import PlanetNavEnv

    dest = tmp_path / "baselines"
    (entry,) = publish.ship_baselines(suite_out, dest)
    source = suite_out / "models" / "Cruise-Target-v1__ppo__raw__s1" / "model.zip"
    assert (entry["task"], entry["seed"], entry["source_cell"]) == ("Cruise-Target-v1", 1, source.parent.name)
    shipped_file = dest / "Cruise-Target-v1.zip"
    assert shipped_file.read_bytes() == source.read_bytes()
    assert entry["sha256"] == hashlib.sha256(source.read_bytes()).hexdigest()
    assert entry["bytes"] == source.stat().st_size < shipped.MAX_BASELINE_BYTES
    manifest = json.loads((dest / shipped.MANIFEST_NAME).read_text())
    assert manifest["baselines"] == {"Cruise-Target-v1": entry}

    monkeypatch.setattr(shipped, "BASELINES_DIR", dest)
    env = PlanetNavEnv(suite.get_task("Cruise-Target-v1").env_config(episode_steps=10))
    agent = make_agent("suite:Cruise-Target-v1", env)
    direct = make_agent(str(source), env)
    assert agent.name == "suite:Cruise-Target-v1" and type(agent.model) is type(direct.model)
    obs, info = env.reset(seed=3)
    agent.reset(seed=3)
    direct.reset(seed=3)
    assert agent.act(obs, info) == direct.act(obs, info)  # the same policy
    assert make_agent("suite:planetnav/Cruise-Target-v1@sampled", env).name.endswith(":stochastic")

    shipped_file.write_bytes(shipped_file.read_bytes() + b"x")
    with pytest.raises(ValueError, match=r"has sha256 .* the manifest says"):
        make_agent("suite:Cruise-Target-v1", env)
    shipped_file.unlink()
    with pytest.raises(FileNotFoundError, match=r"Cruise-Target-v1\.zip, which is missing"):
        make_agent("suite:Cruise-Target-v1", env)


def test_ship_baselines_refuses_a_large_model_before_copying(suite_out, tmp_path) -> None:
    """A model whose policy-only export is still over the limit is refused, naming the task, the algorithm
    and both sizes; nothing is written."""
    from planetnav_train.export import export_policy

    dest = tmp_path / "baselines"
    source = suite_out / "models" / "Cruise-Target-v1__ppo__raw__s1" / "model.zip"
    size = source.stat().st_size
    small = export_policy(source, tmp_path / "probe.policy.zip", "ppo").stat().st_size  # same bytes each time
    assert small < size
    with pytest.raises(
        ConfigError,
        match=rf"task Cruise-Target-v1: the best raw-track model .*model\.zip \(ppo\) is {size:,} bytes "
        rf"\(.* MB\) and its policy-only export {small:,} bytes \(.* MB\), neither under the shipped limit "
        rf"of {small:,} bytes",
    ):
        publish.ship_baselines(suite_out, dest, max_bytes=small)
    assert not dest.exists()  # nothing copied, no manifest written
    rec = _record("Cruise-Target-v1", "rllib_ppo", 0, 2.0)
    runner.write_json_atomic(
        suite.record_path(suite_out, suite.Cell(rec["task"], "rllib_ppo", "raw", 0)), rec
    )
    with pytest.raises(ConfigError, match="rllib_ppo__raw__s0 is an RLlib checkpoint"):
        publish.ship_baselines(suite_out, dest)


def test_a_large_model_ships_as_its_policy_only_export(suite_out, tmp_path, monkeypatch) -> None:
    """A model of the limit or more ships as its policy-only export when that is under the limit; loaded by
    name it acts and evaluates (batched, as the suite evaluates) exactly as the source model; shipped again
    under a higher limit, the full model replaces it and the export's file goes."""
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.policy_only import PolicyOnlyModel

    dest = tmp_path / "baselines"
    source = suite_out / "models" / "Cruise-Target-v1__ppo__raw__s1" / "model.zip"
    size = source.stat().st_size
    (entry,) = publish.ship_baselines(suite_out, dest, max_bytes=size)  # the full model is not under it
    shipped_file = dest / "Cruise-Target-v1.policy.zip"
    assert (entry["form"], entry["file"]) == ("policy-only", shipped_file.name)
    assert entry["bytes"] == shipped_file.stat().st_size < size
    assert entry["sha256"] == hashlib.sha256(shipped_file.read_bytes()).hexdigest()
    assert (entry["source_bytes"], entry["source_sha256"]) == (size, shipped.file_sha256(source))
    assert sorted(p.name for p in dest.iterdir()) == sorted([shipped.MANIFEST_NAME, shipped_file.name])
    assert json.loads((dest / shipped.MANIFEST_NAME).read_text())["baselines"] == {"Cruise-Target-v1": entry}

    monkeypatch.setattr(shipped, "BASELINES_DIR", dest)
    env = PlanetNavEnv(suite.get_task("Cruise-Target-v1").env_config(episode_steps=10))
    agent = make_agent("suite:Cruise-Target-v1", env)
    direct = make_agent(str(source), env)
    assert agent.name == "suite:Cruise-Target-v1" and isinstance(agent.model, PolicyOnlyModel)
    obs, info = env.reset(seed=3)
    agent.reset(seed=3)
    direct.reset(seed=3)
    for _ in range(10):  # one whole episode, action by action
        a = agent.act(obs, info)
        assert a == direct.act(obs, info)
        obs, _, terminated, truncated, info = env.step(a)
        if terminated or truncated:
            break
    cfg = suite.get_task("Cruise-Target-v1").eval_config(10)
    got = evaluate_agent("suite:Cruise-Target-v1", cfg, 3, 50_000, progress=False)
    want = evaluate_agent(str(source), cfg, 3, 50_000, progress=False)
    assert got.metrics["batched"] and want.metrics["batched"]
    assert got.metrics["per_episode_mean_pos_err_km"] == want.metrics["per_episode_mean_pos_err_km"]
    # The command line's path: compare the shipped name with the source model on the same seeds.
    from planetnav_train.cli import main

    cmp = tmp_path / "compare.json"
    assert main(["compare", "--agents", "suite:Cruise-Target-v1", str(source), "--episodes", "2", "--seed",
                 "50000", "--episode-steps", "10", "--json", str(cmp), "--no-progress"]) == 0  # fmt: skip
    results = json.loads(cmp.read_text())["agents"]
    (other,) = set(results) - {"suite:Cruise-Target-v1"}
    per = "per_episode_mean_pos_err_km"
    assert results["suite:Cruise-Target-v1"][per] == results[other][per] and len(results[other][per]) == 2

    shipped_file.write_bytes(shipped_file.read_bytes() + b"x")
    with pytest.raises(ValueError, match=r"policy\.zip has sha256 .* the manifest says"):
        make_agent("suite:Cruise-Target-v1", env)
    (again,) = publish.ship_baselines(suite_out, dest)
    assert (again["form"], again["file"]) == ("full", "Cruise-Target-v1.zip") and not shipped_file.exists()
    assert make_agent("suite:Cruise-Target-v1", env).name == "suite:Cruise-Target-v1"


def test_unshipped_task_names_the_task(tmp_path, monkeypatch) -> None:
    from planetnav_env.envs.env import PlanetNavEnv

    env = PlanetNavEnv(episode_steps=5)
    monkeypatch.setattr(shipped, "BASELINES_DIR", tmp_path)  # no manifest at all
    with pytest.raises(ValueError, match=r"no shipped baseline for task 'Cruise-Target-v1' .*none yet"):
        make_agent("suite:Cruise-Target-v1", env)
    with pytest.raises(ValueError, match="no task after 'suite:'"):
        make_agent("suite:", env)


def test_the_repositorys_baselines_load_or_say_they_are_unshipped() -> None:
    """Every task either loads its shipped model (size and sha256 checked) or raises the clear error."""
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_env.envs.registration import ENV_IDS

    manifest = shipped.load_manifest()
    # Baselines of the current tasks, or of an earlier suite version's (still registered) ids.
    assert {f"planetnav/{t}" for t in manifest["baselines"]} <= set(ENV_IDS)
    for task in suite.TASKS_BY_ID.values():
        env = PlanetNavEnv(task.env_config(episode_steps=5))
        if task.id in manifest["baselines"]:
            entry = manifest["baselines"][task.id]
            assert entry["bytes"] < shipped.MAX_BASELINE_BYTES and entry["track"] == "raw"
            # It acts in its record's evaluation mode (sampled: the name says so).
            sampled = ":stochastic" if entry.get("eval_mode") == "sampled" else ""
            assert make_agent(f"suite:{task.id}", env).name == f"suite:{task.id}{sampled}"
        else:
            with pytest.raises(ValueError, match=f"no shipped baseline for task '{task.id}'"):
                make_agent(f"suite:{task.id}", env)


def test_coverage_counts_official_cells_of_the_published_grid() -> None:
    """The page and the summary say how much of the published table the records are: per task and track
    the finished official cells against the grid (every task x its kind's algorithms x 5 seeds,
    RecurrentPPO on the Mars approach and RLlib's PPO on Cruise-Target-v1 only; assisted: PPO); smoke runs
    and cells outside the grid do not count."""
    grid = suite.published_grid(1)
    kinds = {t.id: t.action_kind for t in suite.TASKS_V1}
    assert len(grid) == len(set(grid))
    raw = [c for c in grid if c.track == "raw"]
    assert {c.algo for c in raw if kinds[c.task] == "continuous"} == {"ppo", "sac"}
    assert {c.algo for c in raw if c.task == "Cruise-Target-v1"} == {"ppo", "dqn", "rllib_ppo"}
    assert {c.algo for c in raw if c.task == "MarsApproach-Tasking-v1"} == {"ppo", "dqn", "recurrent_ppo"}
    assert {c.task for c in raw if c.algo == "recurrent_ppo"} == {"MarsApproach-Tasking-v1"}
    assisted = {(c.task, c.algo) for c in grid if c.track == "assisted"}
    assert assisted == {(t.id, "ppo") for t in suite.TASKS_V1}
    recs = [_record(c.task, c.algo, c.seed, 0.5, track=c.track) for c in grid if c.task == "Cruise-Target-v1"]
    recs += [
        _record("Cruise-Target-v1", "ppo", 9, 0.5),
        _record("Cruise-Torque-v1", "sac", 0, 0.5, official=False),
    ]
    cov = suite.coverage(recs)
    n_ct = sum(c.task == "Cruise-Target-v1" for c in grid)
    assert (cov["done"], cov["expected"]) == (n_ct, len(grid))
    assert cov["per_task"]["Cruise-Target-v1"] == {"raw": [n_ct - 5, n_ct - 5], "assisted": [5, 5]}
    assert cov["per_task"]["Cruise-Torque-v1"]["raw"] == [0, 10]
    text = "\n".join(suite.coverage_lines(recs))
    short = [c for c in grid if suite.cells.is_short_budget(c)]  # v1: DQN, SAC, ... on a share of the budget
    assert {c.algo for c in short} == {"dqn", "sac", "recurrent_ppo", "rllib_ppo"}
    n_short = sum(c.task == "Cruise-Target-v1" for c in short)
    assert (f"**Partial**: {n_ct - n_short} of the published table's {len(grid) - len(short)} ranked cells "
            f"are finished (and {n_short} of its {len(short)} short-budget cells, never ranked)") in text
    assert "| Cruise-Torque-v1 | 0 / 10 | 0 / 5 |" in text
    full = [_record(c.task, c.algo, c.seed, 0.5, track=c.track) for c in grid]
    assert suite.coverage_lines(full, table=False)[0] == (
        f"Complete: all {len(grid) - len(short)} ranked cells of the published table, and its {len(short)} "
        "short-budget cells (shown, never ranked)."
    )
    # Version 2: the raw track only, every algorithm of the task's kind (RecurrentPPO and RLlib's PPO ran on
    # v1 tasks only); a table of v2 records is covered against it, and records never mix versions.
    grid2 = suite.published_grid(2)
    assert {c.track for c in grid2} == {"raw"} and {c.task for c in grid2} == {t.id for t in suite.TASKS_V2}
    assert {c.algo for c in grid2 if c.task == "Cruise-Torque-v2"} == {"ppo", "sac"}
    assert {c.algo for c in grid2 if c.task == "ThrustArc-TCM-v2"} == {"ppo", "dqn"}
    v2 = [_record(c.task, c.algo, c.seed, 0.5) for c in grid2 if c.task == "ThrustArc-TCM-v2"]
    assert (suite.coverage(v2)["done"], suite.coverage(v2)["expected"]) == (10, len(grid2))
    assert "| ThrustArc-TCM-v2 | 10 / 10 |" in "\n".join(suite.coverage_lines(v2))
    # the v2 table's short-budget cells are SAC's on Cruise-Torque-v2: not counted as the table's ranked
    short2 = {(c.task, c.algo) for c in grid2 if suite.cells.is_short_budget(c)}
    assert short2 == {("Cruise-Torque-v2", "sac")}
    full2 = [_record(c.task, c.algo, c.seed, 0.5) for c in grid2]
    assert suite.coverage_lines(full2, table=False)[0] == (
        f"Complete: all {len(grid2) - 5} ranked cells of the published table, and its 5 short-budget cells "
        "(shown, never ranked).")  # fmt: skip
    with pytest.raises(ConfigError, match=r"the records mix suite versions \[1, 2\]"):
        suite.coverage([*v2, *full])
    with pytest.raises(ConfigError, match="unknown suite version 3"):
        suite.published_grid(3)


def test_per_task_iqm_uses_every_seed_when_tasks_have_unequal_seeds() -> None:
    pytest.importorskip("rliable")
    # Four PPO seeds on Cruise-Target, one on ThrustArc: the aggregate over tasks cuts to one run per
    # task, the per-task IQM must not.
    scores = [0.9, 1.1, 0.7, 1.3]
    records = [_record("Cruise-Target-v1", "ppo", s, v) for s, v in enumerate(scores)]
    records.append(_record("ThrustArc-TCM-v1", "ppo", 0, 0.4))
    agg = suite.aggregate(records, reps=200)["raw"]
    assert agg["per_task"]["Cruise-Target-v1"]["ppo"]["iqm"] == pytest.approx(_iqm(scores))
    assert agg["per_task"]["ThrustArc-TCM-v1"]["ppo"]["iqm"] == pytest.approx(0.4)
    assert agg["runs"]["ppo"] == 1  # the aggregate's common count
