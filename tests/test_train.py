"""train.py: the smoke training run, evaluate's JSON, compare, configuration errors."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
METRIC_KEYS = {
    "episodes",
    "mean_pos_err_km",
    "final_pos_err_km",
    "mean_vel_err_km_s",
    "measured_fraction",
    "return",
}


def _load_train():
    spec = importlib.util.spec_from_file_location("planetnav_train", ROOT / "train.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve annotations through sys.modules
    spec.loader.exec_module(module)
    return module


train = _load_train()


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The CI smoke test: ``python train.py train --config configs/smoke.yaml`` into a temporary dir."""
    run_dir = tmp_path_factory.mktemp("runs") / "smoke"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "train.py"), "train", "--config", str(ROOT / "configs" / "smoke.yaml"),
         "--run-dir", str(run_dir), "--no-progress"],
        capture_output=True, text=True, timeout=120, cwd=ROOT,
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


def test_evaluate_json_schema(tmp_path: Path, smoke_run: Path) -> None:
    out = tmp_path / "eval.json"
    rc = train.main(
        ["evaluate", "--agent", "greedy", "--episodes", "2", "--seed", "10000", "--episode-steps", "20",
         "--json", str(out), "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    data = json.loads(out.read_text())
    assert list(data) == ["agents"] and list(data["agents"]) == ["greedy"]
    metrics = data["agents"]["greedy"]
    assert METRIC_KEYS <= set(metrics)
    assert metrics["episodes"] == 2 and 0.0 <= metrics["measured_fraction"] <= 1.0
    # A saved model by its run directory: the env comes from the run's config.yaml (120-step episodes).
    out2 = tmp_path / "model.json"
    assert (
        train.main(
            ["evaluate", "--agent", str(smoke_run), "--episodes", "1", "--json", str(out2), "--no-progress"]
        )
        == 0
    )
    assert json.loads(out2.read_text())["agents"]["ppo:smoke"]["episodes"] == 1


def test_compare_prints_one_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = train.main(
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


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("n_timestep: 10\n", "n_timestep"),
        ("env: {episode_step: 10}\n", "episode_step"),
        ("hyperparams: {n_step: 10}\n", "n_step"),
        ("eval: {episode: 1}\n", "episode"),
        ("algo: ppo2\n", "ppo2"),
    ],
)
def test_bad_config_key_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, named: str
) -> None:
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(text)
    assert train.main(["train", "--config", str(cfg), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert named in err and "error:" in err


def test_shipped_configs_parse() -> None:
    has_ray = importlib.util.find_spec("ray") is not None
    for path in sorted((ROOT / "configs").glob("*.yaml")):
        if path.name.startswith("sweep"):
            continue  # Tune sweep configs, not training configs: tests/test_scaling.py loads them
        if path.name.startswith("rllib") and not has_ray:
            continue  # algo: rllib_ppo is validated against RLlib itself: the [ray] extra's venv checks them
        tc = train.load_config(path)
        tc.env_config()
        train.algo_kwargs(tc)
    assert train.load_config(ROOT / "configs" / "cruise_ppo.yaml").name == "cruise_ppo"
