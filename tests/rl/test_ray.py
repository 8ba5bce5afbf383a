"""RLlib training and Tune sweeps on a two-node Ray cluster on this machine, all on 127.0.0.1.

Needs the ``[ray]`` extra (``make test-ray``); skipped without it. Every cluster is a
``ray.cluster_utils.Cluster`` that the fixture shuts down itself (never ``ray stop``, which would end every
Ray process on the machine by name). Each node has one CPU, so 4 one-CPU trials must use both nodes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

# Ray reads this once, at import: keep every Ray address on 127.0.0.1 (planetnav_rl.cluster explains).
os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
ray = pytest.importorskip("ray")

from planetnav_env.errors import ConfigError  # noqa: E402
from planetnav_rl.cluster import LOOPBACK, loopback_cluster  # noqa: E402
from planetnav_rl.tune import load_sweep, run_sweep  # noqa: E402
from planetnav_train.cli import main  # noqa: E402
from planetnav_train.config import load_config, parse_config  # noqa: E402

pytestmark = pytest.mark.ray

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    c = loopback_cluster(num_nodes=2, cpus_per_node=1)
    yield c
    ray.shutdown()
    c.shutdown()  # ends exactly the processes this Cluster started


def _node_ids() -> set[str]:
    return {n["NodeID"] for n in ray.nodes() if n["Alive"]}


def test_cluster_is_two_loopback_nodes(cluster: Any) -> None:
    nodes = [n for n in ray.nodes() if n["Alive"]]
    assert len(nodes) == 2
    assert {n["NodeManagerAddress"] for n in nodes} == {LOOPBACK}
    assert os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] == "0"


def test_rllib_training_on_cluster_writes_the_run_directory(cluster: Any, tmp_path: Path) -> None:
    run_dir = tmp_path / "rllib"
    # A separate driver process that joins the cluster through --address, as on a real cluster.
    cmd = [sys.executable, str(ROOT / "train.py"), "train", "--config", str(CONFIGS / "rllib_smoke.yaml")]
    cmd += ["--run-dir", str(run_dir), "--no-progress", "--address", cluster.address]
    # The limit only guards against a hang: the driver and each env runner compile the kernels cold (a
    # fresh checkout has no numba cache), which on CI's two cores, shared with the other test pass, has
    # taken more than 300 s.
    rc = subprocess.run(cmd, cwd=ROOT, timeout=1200).returncode
    assert rc == 0
    assert (run_dir / "checkpoint" / "rllib_checkpoint.json").is_file()
    assert any((run_dir / "tb").rglob("events.out.tfevents*"))
    for name in ("config.yaml", "report.md", "pos_err.png", "pos_sigma.png"):
        assert (run_dir / name).is_file(), name
    agents = json.loads((run_dir / "eval.json").read_text())["agents"]
    # The trained policy (mode and sampled) beside the baseline, each with a finite position error.
    assert {"rllib_ppo:rllib", "rllib_ppo:rllib:stochastic", "baseline"} <= set(agents)
    assert all(0.0 < a["mean_pos_err_km"] < 1e5 for a in agents.values())
    # evaluate/compare take the RLlib run directory as an agent, and find its env through config.yaml.
    out = tmp_path / "eval.json"
    rc = main(["evaluate", "--agent", str(run_dir), "--episodes", "1", "--json", str(out), "--no-progress"])
    assert rc == 0
    evaluated = json.loads(out.read_text())["agents"]["rllib_ppo:rllib"]
    # Same policy, env, seed and deterministic actions: the same metric as in the run's eval.json.
    assert evaluated["mean_pos_err_km"] == pytest.approx(agents["rllib_ppo:rllib"]["mean_pos_err_km"])


def test_sweep_on_cluster_uses_both_nodes_and_its_best_config_trains(cluster: Any, tmp_path: Path) -> None:
    sc = load_sweep(CONFIGS / "sweep_smoke.yaml")
    summary = run_sweep(sc, tmp_path / "sweep")
    rows = summary["rows"]
    assert len(rows) == 4
    assert all(r["status"] in ("TERMINATED", "STOPPED") for r in rows), rows
    # Trials ran on both nodes (node ids differ even though both nodes are 127.0.0.1).
    assert {r["node_id"] for r in rows} == {n[:12] for n in _node_ids()}
    assert {r["node_ip"] for r in rows} == {LOOPBACK}
    for name in ("results.csv", "report.md", "metric_per_trial.png", "best_config.yaml"):
        assert (tmp_path / "sweep" / name).is_file(), name
    best = summary["best"]
    assert best["mean_pos_err_km"] == min(r["mean_pos_err_km"] for r in rows)
    report = (tmp_path / "sweep" / "report.md").read_text()
    assert all(r["node_id"] in report for r in rows)
    # The best config is a training config: it reloads with its trial's parameters and trains.
    tc = load_config(summary["best_config"])
    assert tc.seed == best["seed"]
    assert tc.hyperparams["learning_rate"] == pytest.approx(best["hyperparams.learning_rate"])
    run_dir = tmp_path / "best"
    rc = main(
        ["train", "--config", str(summary["best_config"]), "--run-dir", str(run_dir)]
        + ["--no-eval", "--no-progress"]
    )
    assert rc == 0 and (run_dir / "model.zip").is_file()


def test_trial_is_reproducible_from_config_and_seed(cluster: Any) -> None:
    """The same parameters give the same held-out metric, on whichever node the trial runs."""
    from planetnav_rl.tune import run_trial

    sc = load_sweep(CONFIGS / "sweep_smoke.yaml")
    params = {"hyperparams.learning_rate": 5e-4, "seed": 1}

    @ray.remote(num_cpus=1)
    def one() -> tuple[float, str]:
        reports: list[dict[str, Any]] = []
        run_trial(
            params, base=sc.base_config, settings={"iterations": 1, "eval": sc.eval}, report=reports.append
        )
        return reports[-1]["mean_pos_err_km"], reports[-1]["node_id"]

    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    # One run pinned to each node: the two nodes must agree to the last bit.
    runs = ray.get(
        [
            one.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n, soft=False)).remote()
            for n in _node_ids()
        ]
    )
    (a, node_a), (b, node_b) = runs
    assert node_a != node_b
    assert a == b and 0.0 < a < 1e5


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--address", "nonsense:99999"], "nonsense:99999"),
        (["--address", "256.1.1.1:6379"], "256.1.1.1"),
        (["--address", "127.0.0.1:1"], "127.0.0.1:1"),  # well-formed, nothing listening
    ],
)
def test_bad_address_fails_before_any_trial(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], named: str
) -> None:
    run_dir = tmp_path / "sweep"
    rc = main(["tune", "--config", str(CONFIGS / "sweep_smoke.yaml"), "--run-dir", str(run_dir), *args])
    assert rc == 2
    assert named in capsys.readouterr().err
    assert not run_dir.exists()  # nothing started


def test_bad_sweep_inputs_fail_before_any_trial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import yaml

    sweep = yaml.safe_load((CONFIGS / "sweep_smoke.yaml").read_text())
    sweep["base"] = str(CONFIGS / "rllib_smoke.yaml")  # RLlib's PPO has lr, not learning_rate
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(sweep))
    rc = main(["tune", "--config", str(path), "--run-dir", str(tmp_path / "out")])
    assert rc == 2 and "learning_rate" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match="lr_typo"):
        parse_config({"algo": "rllib_ppo", "hyperparams": {"lr_typo": 1e-3}})


def test_rllib_sweep_with_optuna_on_cluster(cluster: Any, tmp_path: Path) -> None:
    """The other two paths of a sweep: RLlib trials (sampling in the trial's process) and Optuna search."""
    import yaml

    sweep = {
        "name": "rllib_optuna",
        "base": str(CONFIGS / "rllib_smoke.yaml"),
        "space": {"hyperparams.lr": {"loguniform": [1e-4, 1e-3]}, "seed": {"choice": [0, 1]}},
        "num_samples": 2,
        "search": "optuna",
        "iterations": 2,
        "eval": {"episodes": 1, "seed": 10000},
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep))
    summary = run_sweep(load_sweep(path), tmp_path / "out")
    rows = summary["rows"]
    assert len(rows) == 2 and all(r["status"] in ("TERMINATED", "STOPPED") for r in rows), rows
    assert all(0.0 < r["mean_pos_err_km"] < 1e5 and 1e-4 <= r["hyperparams.lr"] <= 1e-3 for r in rows)
    best = load_config(summary["best_config"])
    assert best.algo == "rllib_ppo" and best.hyperparams["lr"] == pytest.approx(
        summary["best"]["hyperparams.lr"]
    )
