"""train.py: the smoke training run, evaluate's JSON, compare, configuration errors."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from planetnav_train.algorithms import algo_kwargs
from planetnav_train.cli import main
from planetnav_train.config import load_config

ROOT = Path(__file__).resolve().parents[2]
METRIC_KEYS = {
    "episodes",
    "mean_pos_err_km",
    "final_pos_err_km",
    "mean_vel_err_km_s",
    "measured_fraction",
    "return",
}


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The CI smoke test: ``python train.py train --config configs/smoke.yaml`` into a temporary dir."""
    run_dir = tmp_path_factory.mktemp("runs") / "smoke"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "train.py"), "train", "--config", str(ROOT / "configs" / "smoke.yaml"),
         "--run-dir", str(run_dir), "--no-progress"],
        capture_output=True, text=True, timeout=600, cwd=ROOT,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return run_dir


def test_smoke_training_writes_the_run(smoke_run: Path) -> None:
    for name in ("model.zip", "config.yaml", "report.md", "eval.json", "pos_err.png", "pos_sigma.png"):
        assert (smoke_run / name).is_file(), name
    assert any((smoke_run / "tb").rglob("events.out.tfevents.*"))
    report = (smoke_run / "report.md").read_text()
    assert "| baseline |" in report and "| random |" in report and "ppo:smoke" in report
    data = json.loads((smoke_run / "eval.json").read_text())
    # The trained policy appears twice: argmax and sampled actions.
    assert set(data["agents"]) == {"ppo:smoke", "ppo:smoke:stochastic", "baseline", "random"}
    assert data["skipped"] == {}


def test_evaluate_json_schema(tmp_path: Path, smoke_run: Path) -> None:
    out = tmp_path / "eval.json"
    rc = main(
        ["evaluate", "--agent", "greedy", "--episodes", "2", "--seed", "10000", "--episode-steps", "20",
         "--json", str(out), "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    data = json.loads(out.read_text())
    assert list(data) == ["agents", "skipped", "provenance"] and list(data["agents"]) == ["greedy"]
    metrics = data["agents"]["greedy"]
    assert METRIC_KEYS <= set(metrics)
    assert metrics["episodes"] == 2 and 0.0 <= metrics["measured_fraction"] <= 1.0
    low, high = metrics["mean_pos_err_ci95_km"]
    assert low < metrics["mean_pos_err_km"] < high
    assert len(metrics["per_episode_mean_pos_err_km"]) == 2
    # A saved model by its run directory: the env comes from the run's config.yaml (120-step episodes).
    out2 = tmp_path / "model.json"
    assert (
        main(["evaluate", "--agent", str(smoke_run), "--episodes", "1", "--json", str(out2), "--no-progress"])
        == 0
    )
    assert json.loads(out2.read_text())["agents"]["ppo:smoke"]["episodes"] == 1


def test_compare_prints_one_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(
        ["compare", "--agents", "baseline", "greedy", "random", "idle", "--episodes", "1",
         "--episode-steps", "15", "--json", str(tmp_path / "c.json"), "--report", str(tmp_path / "rep"),
         "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    printed = capsys.readouterr().out
    for name in ("baseline", "greedy", "random", "idle"):
        assert name in printed
    assert set(json.loads((tmp_path / "c.json").read_text())["agents"]) == {
        "baseline",
        "greedy",
        "random",
        "idle",
    }
    assert (tmp_path / "rep" / "report.md").is_file() and (tmp_path / "rep" / "pos_err.png").is_file()


def test_compare_without_agents_runs_the_configs_eval_agents(tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("env: {episode_steps: 12}\neval: {agents: [greedy, idle], reference: greedy}\n")
    out = tmp_path / "c.json"
    rc = main(["compare", "--config", str(cfg), "--episodes", "1", "--json", str(out), "--no-progress"])
    assert rc == 0
    assert set(json.loads(out.read_text())["agents"]) == {"greedy", "idle"}


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("n_timestep: 10\n", "n_timestep"),
        ("env: {episode_step: 10}\n", "episode_step"),
        ("hyperparams: {n_step: 10}\n", "n_step"),
        ("eval: {episode: 1}\n", "episode"),
        ("algo: ppo2\n", "ppo2"),
        ("pretrain: {teacher: greedy, epoch: 3}\n", "epoch"),
        ("pretrain: {episodes: 3}\n", "teacher_config"),  # neither teacher nor teacher_config
        ("pretrain: {teacher: greedy, teacher_config: configs/cruise_ppo.yaml}\n", "not both"),
        ("pretrain: {teacher_config: configs/nope.yaml}\n", "nope.yaml"),
        ("pretrain: {teacher: greedy, keep_std: 2}\n", "keep_std"),
        ("pretrain: {teacher: greedy, dagger_rounds: -1}\n", "dagger_rounds must be an integer >= 0, got -1"),
    ],
)
def test_bad_config_key_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, named: str
) -> None:
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(text)
    assert main(["train", "--config", str(cfg), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert named in err and "error:" in err


def _sb3_configs() -> list[str]:
    """The shipped SB3 training configs; the Ray ones (rllib_*, sweep*) need the [ray] extra and are
    smoke-tested by tests/rl/test_ray.py in the Ray virtual environment (make test-ray)."""
    names = (p.name for p in (ROOT / "configs").glob("*.yaml"))
    return sorted(n for n in names if not n.startswith(("rllib", "sweep")))


def test_shipped_configs_parse() -> None:
    """Every training config parses: the shipped ones (configs/) and the research ones (research/), so
    that the experiments recorded in research/training_log.md and research/operations_log.md stay runnable."""
    has_ray = importlib.util.find_spec("ray") is not None
    configs = ROOT / "configs"
    paths = sorted(configs.glob("*.yaml")) + sorted((configs / "operations").glob("*.yaml"))
    paths += sorted((configs / "diagnostics").glob("*.yaml"))
    assert len(paths) >= 11
    research = sorted((ROOT / "research").rglob("*.yaml"))
    assert len(research) >= 20
    paths += research
    for path in paths:
        if path.name.startswith("sweep"):
            continue  # Tune sweep configs, not training configs: tests/rl/test_scaling.py loads them
        if path.name.startswith("rllib") and not has_ray:
            continue  # algo: rllib_ppo is validated against RLlib itself: the [ray] extra's venv checks them
        tc = load_config(path)
        tc.env_config()
        algo_kwargs(tc)
    assert load_config(ROOT / "configs" / "cruise_ppo.yaml").name == "cruise_ppo"


def test_compare_pairs_with_greedy_and_skips_what_does_not_apply(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Torque mode: idle has no 'camera off' action there, so it is skipped with a note, not a crash; the
    others are paired with greedy on the same seeds."""
    cfg = tmp_path / "torque.yaml"
    cfg.write_text("env_id: planetnav/Cruise-Torque-v0\n")
    out = tmp_path / "c.json"
    rc = main(
        ["compare", "--agents", "planner:horizon=4,replan=2", "greedy", "periodic", "baseline", "random",
         "idle", "--config", str(cfg), "--episodes", "3", "--episode-steps", "8", "--json", str(out),
         "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    printed = capsys.readouterr().out
    assert "skipped" in printed and "Δ vs greedy" in printed
    data = json.loads(out.read_text())
    assert set(data["skipped"]) == {"idle"} and "action_mode 'target'" in data["skipped"]["idle"]
    greedy = data["agents"]["greedy"]["per_episode_mean_pos_err_km"]
    for name, m in data["agents"].items():
        vs = m["vs_reference"]
        assert vs["reference"] == "greedy"
        diffs = np.subtract(m["per_episode_mean_pos_err_km"], greedy)
        assert vs["mean_diff_km"] == pytest.approx(np.mean(diffs), rel=1e-9, abs=1e-9), name
        # The filter's 1-sigma, paired the same way; its per-seed values average to the reported mean.
        sig = m["per_episode_mean_pos_sigma_km"]
        assert len(sig) == 3 and np.mean(sig) == pytest.approx(m["mean_pos_sigma_km"], rel=1e-12), name
        greedy_sig = data["agents"]["greedy"]["per_episode_mean_pos_sigma_km"]
        low, high = vs["sigma_ci95_km"]
        assert vs["mean_sigma_diff_km"] == pytest.approx(np.mean(np.subtract(sig, greedy_sig)), abs=1e-9)
        assert low <= vs["mean_sigma_diff_km"] <= high or name == "greedy"


def test_sweep_periodic_prints_the_best(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], research_command
) -> None:
    out = tmp_path / "sweep.json"
    rc = research_command("sweep_periodic").main(
        ["--periods", "2", "5", "--cycles", "0-1", "0-1-2", "--episodes", "2",
         "--episode-steps", "12", "--json", str(out), "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    data = json.loads(out.read_text())
    means = {k: v["mean_pos_err_km"] for k, v in data["agents"].items()}
    assert len(means) == 4 and data["best"] == min(means, key=means.get)
    assert f"best: {data['best']}" in capsys.readouterr().out


def _smoke_version(path: Path, tmp_path: Path) -> Path:
    """``path`` cut to a smoke run: a few hundred steps, 30-step episodes, 2 evaluation seeds."""
    data = yaml.safe_load(path.read_text())
    data["n_timesteps"] = 256
    data["n_envs"] = 2
    hp = dict(data.get("hyperparams") or {})
    if data.get("algo", "ppo") in ("ppo", "a2c"):
        hp.update(n_steps=64, batch_size=64, n_epochs=1)
    else:
        hp.update(learning_starts=64, batch_size=64, buffer_size=1000)
    data["hyperparams"] = hp
    data["env"] = {**(data.get("env") or {}), "episode_steps": 30}
    ev = dict(data.get("eval") or {})
    # The shipped agent list, with the planner's rollouts shortened to keep the test quick.
    agents = [("planner:horizon=4,replan=2" if a == "planner" else a) for a in ev.get("agents", [])]
    data["eval"] = {**ev, "episodes": 2, "agents": agents}
    pre = dict(data.get("pretrain") or {})
    if "teacher_config" in pre:  # a two-stage config: the teacher trains first, as a smoke run too
        (tmp_path / "teacher").mkdir(exist_ok=True)
        pre["teacher_config"] = str(_smoke_version(ROOT / pre["teacher_config"], tmp_path / "teacher"))
        data["pretrain"] = {**pre, "episodes": 2}
    out = tmp_path / path.name
    out.write_text(yaml.safe_dump(data))
    return out


@pytest.mark.parametrize("name", _sb3_configs())
def test_every_shipped_config_trains_and_evaluates(tmp_path: Path, name: str) -> None:
    """CI smoke test of each shipped training config, evaluation and report included (torque modes too)."""
    cfg = _smoke_version(ROOT / "configs" / name, tmp_path)
    run_dir = tmp_path / "run"
    rc = main(["train", "--config", str(cfg), "--run-dir", str(run_dir), "--no-progress"])
    assert rc == 0
    data = json.loads((run_dir / "eval.json").read_text())
    tc = load_config(cfg)
    ran = set(data["agents"]) | set(data["skipped"])
    assert len(ran) == 2 + len(tc.eval.agents)  # the trained policy (argmax, sampled) + the config's agents
    assert all(m["episodes"] == 2 for m in data["agents"].values())
    assert (run_dir / "report.md").read_text().count("|") > 10


def _operations_configs() -> list[str]:
    """The training configs of the operations scenarios (research/operations_log.md): the shipped recipe in
    configs/operations/ and the experiment variants in research/operations/, as paths from the root."""
    paths = sorted((ROOT / "configs" / "operations").glob("*.yaml"))
    paths += sorted((ROOT / "research" / "operations").glob("*.yaml"))
    return [p.relative_to(ROOT).as_posix() for p in paths]


def _operations_smoke_version(path: Path, tmp_path: Path, steps: int = 30) -> Path:
    """:func:`_smoke_version` of an operations config, with the knowledge deadlines and the encounter
    scaled by ``steps / episode_steps`` so that a ``steps``-step episode still reaches every deadline
    (a 3024-step, 21-day episode cut to 30 steps would otherwise reach none and score only the
    delta-v), and a cloning stage (``pretrain``) cut to one episode and one epoch."""
    data = yaml.safe_load(path.read_text())
    env = dict(data.get("env") or {})
    ops = dict(env.get("operations") or {})
    full_s = float(env["episode_steps"]) * float(env["step_s"])
    scale = steps * float(env["step_s"]) / full_s
    ops["deadlines_s"] = [float(t) * scale for t in ops["deadlines_s"]]
    ops["encounter_s"] = float(ops.get("encounter_s", full_s)) * scale
    data["env"] = {**env, "operations": ops}
    if data.get("pretrain"):
        data["pretrain"] = {**data["pretrain"], "episodes": 1, "epochs": 1}
    scaled = tmp_path / "scaled"
    scaled.mkdir(exist_ok=True)
    (scaled / path.name).write_text(yaml.safe_dump(data))
    out = _smoke_version(scaled / path.name, tmp_path)
    assert yaml.safe_load(out.read_text())["env"]["episode_steps"] == steps
    return out


def test_operations_configs_are_found() -> None:
    """The smoke test below is not vacuous: issue 17 ships at least one config per operations scenario."""
    assert "configs/operations/thrust_arc_tcm.yaml" in _operations_configs()


@pytest.mark.parametrize("name", _operations_configs())
def test_every_operations_config_trains_and_evaluates(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """CI smoke test of each configs/operations/*.yaml and research/operations/*.yaml (cloning stage,
    training, evaluation with the config's rules and references): every agent reports the scenario
    objective J [km] per episode."""
    cfg = _operations_smoke_version(ROOT / name, tmp_path)
    run_dir = tmp_path / "run"
    rc = main(["train", "--config", str(cfg), "--run-dir", str(run_dir), "--no-progress"])
    assert rc == 0
    data = json.loads((run_dir / "eval.json").read_text())
    tc = load_config(cfg)
    assert data["skipped"] == {}
    assert len(data["agents"]) == 2 + len(tc.eval.agents)
    for agent, m in data["agents"].items():
        j = np.asarray(m["per_episode_objective"], float)
        # J = the sigma at the (scaled) deadlines + the delta-v price: positive and finite for any schedule.
        assert m["episodes"] == 2 and j.shape == (2,) and np.all(np.isfinite(j)) and np.all(j > 0), agent
        assert m["objective_mean"] == pytest.approx(j.mean()), agent
    if tc.pretrain:  # the cloning stage ran on the teacher's demonstrations
        assert f"decisions of {tc.pretrain['teacher']}" in capsys.readouterr().out


def test_seed_override(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--seed`` trains another seed of a config (the spread across training runs in
    research/training_log.md)."""
    run_dir = tmp_path / "s3"
    args = ["train", "--config", str(ROOT / "configs" / "smoke.yaml"), "--run-dir", str(run_dir)]
    assert main([*args, "--seed", "3", "--no-eval", "--no-progress"]) == 0
    assert yaml.safe_load((run_dir / "config.yaml").read_text())["seed"] == 3
    assert main([*args, "--seed", "-1", "--no-eval", "--no-progress"]) == 2
    assert "--seed must be >= 0, got -1" in capsys.readouterr().err


def test_paired_pairs_two_evaluation_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], research_command
) -> None:
    """``research/commands/paired.py`` pairs two evaluation JSONs' agents seed by seed; other seeds fail."""

    def write(name: str, agent: str, errors: list[float], seed: int = 10000) -> str:
        sigmas = [2 * e for e in errors]
        entry = {"seed": seed, "episodes": len(errors), "mean_pos_err_km": float(np.mean(errors)),
                 "per_episode_mean_pos_err_km": errors, "mean_pos_sigma_km": float(np.mean(sigmas)),
                 "per_episode_mean_pos_sigma_km": sigmas}  # fmt: skip
        (tmp_path / name).write_text(json.dumps({"agents": {agent: entry}, "skipped": {}}))
        return str(tmp_path / name)

    main = research_command("paired").main
    a = write("a.json", "ppo:x", [10.0, 20.0, 30.0])
    b = write("b.json", "periodic:period=10", [9.0, 18.0, 27.0])
    assert main(["--a", f"{a}:ppo:x", "--b", f"{b}:periodic:period=10"]) == 0
    out = capsys.readouterr().out
    # differences 1, 2, 3: mean 2, t(0.975, 2) = 4.303 x sd 1 / sqrt(3) = 2.48
    assert "paired difference (first - second) +2.0 [-0.5, +4.5] km on 3 seeds from 10000" in out
    assert "5 % quantile +1.1 km, median +2.0 km, 95 % quantile +2.9 km" in out  # linear interpolation
    # sigma differences 2, 4, 6: mean 4, half-width 4.303 x 2 / sqrt(3) = 4.97
    assert "1-sigma (mean over the day): 40.0 km vs 36.0 km; paired difference +4.0 [-1.0, +9.0] km" in out
    c = write("c.json", "greedy", [1.0, 2.0, 3.0], seed=20000)
    assert main(["--a", f"{a}:ppo:x", "--b", f"{c}:greedy"]) == 2
    assert "different seeds" in capsys.readouterr().err
    assert main(["--a", f"{a}:nope", "--b", f"{c}:greedy"]) == 2
    assert "no agent 'nope'" in capsys.readouterr().err
    assert main(["--a", "missing.json:greedy", "--b", f"{c}:greedy"]) == 2
    assert "FILE:AGENT" in capsys.readouterr().err
