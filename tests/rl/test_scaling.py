"""The Ray integration's parts that need no Ray: import hygiene, address and sweep validation.

These run in both virtual environments (with and without the ``[ray]`` extra); the cluster tests are in
``tests/rl/test_ray.py``.
"""

from __future__ import annotations

import importlib.util
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from planetnav_env.errors import ConfigError
from planetnav_rl.cluster import check_address, parse_address
from planetnav_rl.tune import load_sweep
from planetnav_train.cli import main
from planetnav_train.config import load_config, parse_config

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
HAS_RAY = importlib.util.find_spec("ray") is not None


def test_importing_planetnav_never_imports_ray() -> None:
    code = (
        "import sys, planetnav_env, planetnav_agents, planetnav_rl, planetnav_rl.cluster, "
        "planetnav_rl.rllib, planetnav_rl.tune, planetnav_rl.agent, planetnav_rl.extensions, "
        "planetnav_rl.suite_grid, train; "
        "planetnav_rl.extensions.register(); planetnav_rl.extensions.register_agent_loader(); "
        "import gymnasium as gym; gym.make('planetnav/Cruise-Target-v0'); "
        "bad = sorted(m for m in sys.modules if m == 'ray' or m.startswith('ray.')); "
        "assert not bad, bad[:5]"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, timeout=120)


@pytest.mark.parametrize(
    ("address", "fragment"),
    [
        ("nonsense:99999", "99999"),
        ("256.1.1.1:6379", "256.1.1.1"),
        ("nonsense", "nonsense"),
        ("127.0.0.1:port", "port"),
        ("127.0.0.1:0", "0"),
    ],
)
def test_bad_address_form_is_named(address: str, fragment: str) -> None:
    with pytest.raises(ConfigError, match=address.replace(".", r"\.")) as exc:
        parse_address(address)
    assert fragment in str(exc.value)


def test_address_forms() -> None:
    assert parse_address("127.0.0.1:6379") == ("", "127.0.0.1", 6379)
    assert parse_address("ray://head.example:10001") == ("ray://", "head.example", 10001)
    assert parse_address("[::1]:6379") == ("", "::1", 6379)


def test_unreachable_loopback_address_fails_fast() -> None:
    # A port that was free a moment ago: nothing listens there, the connect is refused at once.
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=f"127.0.0.1:{port}"):
        check_address(f"127.0.0.1:{port}", timeout_s=2.0)
    assert time.perf_counter() - t0 < 2.5


def test_reachable_loopback_address_passes() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert check_address(f"127.0.0.1:{port}") == f"127.0.0.1:{port}"


def _write_sweep(tmp_path: Path, **changes: object) -> Path:
    data = yaml.safe_load((CONFIGS / "sweep_smoke.yaml").read_text())
    data["base"] = str(CONFIGS / data["base"])
    data.update(changes)
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("name", ["sweep.yaml", "sweep_smoke.yaml"])
def test_shipped_sweeps_load(name: str) -> None:
    sc = load_sweep(CONFIGS / name)
    assert sc.num_samples >= 4 and sc.metric == "mean_pos_err_km"
    assert parse_config(sc.base_config).n_timesteps >= sc.iterations


def test_smoke_sweep_loads_with_the_base_merged() -> None:
    sc = load_sweep(CONFIGS / "sweep_smoke.yaml")
    assert sc.num_samples == 4 and sc.iterations == 2
    assert sc.base_config["algo"] == "ppo" and sc.base_config["n_timesteps"] == 256
    assert set(sc.space) == {"hyperparams.learning_rate", "seed"}


def test_sweep_space_key_that_is_not_a_hyperparameter_is_named(tmp_path: Path) -> None:
    space = {"hyperparams.learning_rate": {"choice": [1e-3]}, "hyperparams.warp_factor": {"choice": [9]}}
    with pytest.raises(ConfigError, match="warp_factor"):
        load_sweep(_write_sweep(tmp_path, space=space))
    with pytest.raises(ConfigError, match=r"'env\.reward' is not a hyperparameter"):
        load_sweep(_write_sweep(tmp_path, space={"env.reward": {"choice": ["covariance"]}}))


def test_sweep_unknown_algo_is_named(tmp_path: Path) -> None:
    base = yaml.safe_load((CONFIGS / "smoke.yaml").read_text())
    base["algo"] = "ppo_turbo"
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base))
    with pytest.raises(ConfigError, match="ppo_turbo"):
        load_sweep(_write_sweep(tmp_path, base=str(tmp_path / "base.yaml")))


def test_sweep_unknown_key_and_distribution_are_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="num_trials"):
        load_sweep(_write_sweep(tmp_path, num_trials=4))
    with pytest.raises(ConfigError, match="gaussian"):
        load_sweep(_write_sweep(tmp_path, space={"seed": {"gaussian": [0, 1]}}))


def test_train_config_unknown_algo_lists_rllib() -> None:
    with pytest.raises(ConfigError, match=r"'ppo_turbo' is not one of .*rllib_ppo"):
        parse_config({"algo": "ppo_turbo"})


@pytest.mark.skipif(HAS_RAY, reason="checks the message given where the [ray] extra is missing")
def test_rllib_config_without_ray_names_the_extra() -> None:
    with pytest.raises(ConfigError, match=r"\[ray\]"):
        load_config(CONFIGS / "rllib_smoke.yaml")
    assert main(["tune", "--config", str(CONFIGS / "sweep_smoke.yaml")]) == 2
