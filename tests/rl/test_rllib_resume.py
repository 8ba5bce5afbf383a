"""RLlib runs survive a kill: an RLlib PPO run is killed with SIGKILL after its first checkpoint, then
``train.py train --resume RUN_DIR`` finishes it to the configured env steps and evaluates it (needs the
[ray] extra; a local Ray on loopback, one env runner)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("ray")
pytestmark = pytest.mark.ray

ROOT = Path(__file__).resolve().parents[2]

#: Trains the config; the algorithm's third train() call kills the process (after the checkpoint that
#: follows the second iteration).
KILL_DRIVER = """
import os, signal, sys
from pathlib import Path
import planetnav_rl.rllib as R
from planetnav_train.config import load_config

build = R.build_algorithm
def killing_build(tc, *a, **k):
    algo = build(tc, *a, **k)
    real, calls = algo.train, [0]
    def train():
        calls[0] += 1
        if calls[0] == 3:
            os.kill(os.getpid(), signal.SIGKILL)
        return real()
    algo.train = train
    return algo
R.build_algorithm = killing_build
R.train(load_config(sys.argv[1]), Path(sys.argv[2]), progress=False)
"""


def test_killed_rllib_run_resumes_and_evaluates(tmp_path: Path) -> None:
    cfg = yaml.safe_load((ROOT / "configs" / "rllib_smoke.yaml").read_text())
    cfg["n_timesteps"] = 512  # four iterations of 128 env steps
    cfg["checkpoint_every"] = 128
    cfg["hyperparams"]["num_env_runners"] = 1
    config = tmp_path / "rllib.yaml"
    config.write_text(yaml.safe_dump(cfg))
    run = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-c", KILL_DRIVER, str(config), str(run)],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert proc.returncode == -signal.SIGKILL, proc.stderr[-3000:]
    before = json.loads((run / "resume" / "state.json").read_text())
    assert not before["done"] and before["timesteps"] >= 128

    resumed = subprocess.run(
        [sys.executable, str(ROOT / "train.py"), "train", "--resume", str(run), "--no-progress"],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert f"resuming {run.resolve()} at env step {before['timesteps']}" in resumed.stdout
    after = json.loads((run / "resume" / "state.json").read_text())
    assert after["done"] and after["stats"]["timesteps"] >= 512
    assert after["stats"]["resumed_at"] == before["timesteps"]
    assert json.loads((run / "eval.json").read_text())["agents"]
