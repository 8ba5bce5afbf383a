"""Long runs survive a kill: a short run is killed with SIGKILL at a fixed step, then
``train.py train --resume RUN_DIR`` continues it from its last checkpoint to the configured step count and
evaluates it, for on-policy PPO, off-policy DQN (its replay buffer too) and PPO with a DAgger warm start.

A resumed run does not equal the unkilled one bit for bit (it starts new episodes from another seed and a
fresh sampler state, planetnav_train.checkpoint), so the tests compare what must be equal: the number of
decisions trained, the schedule's end, and that the evaluation ran.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[2]

#: Trains a config with a callback that kills its own process (SIGKILL: no cleanup, no atexit) at a step.
KILL_DRIVER = """
import os, signal, sys
from pathlib import Path
from stable_baselines3.common.callbacks import BaseCallback
from planetnav_train.config import load_config
from planetnav_train.training import train

class KillAt(BaseCallback):
    def __init__(self, step):
        super().__init__()
        self.step = step
    def _on_step(self):
        if self.num_timesteps >= self.step:
            os.kill(os.getpid(), signal.SIGKILL)
        return True

train(load_config(sys.argv[1]), Path(sys.argv[2]), progress=False, callbacks=[KillAt(int(sys.argv[3]))])
"""

BASE = {
    "env_id": "planetnav/Cruise-Target-v0",
    "policy": "MlpPolicy",
    "n_envs": 2,
    "seed": 3,
    "env": {"episode_steps": 40},
    "eval": {"episodes": 1, "seed": 10000, "agents": ["random"]},
}
CASES = {
    # 2 x 32 decisions a rollout: checkpoints at 64, 128, 192; killed at 200; 320 decisions in all.
    "ppo": {"algo": "ppo", "n_timesteps": 320, "checkpoint_every": 64,
            "hyperparams": {"n_steps": 32, "batch_size": 32, "n_epochs": 1,
                            "policy_kwargs": {"net_arch": [16]}}},
    # Off-policy: the replay buffer is part of the checkpoint.
    "dqn": {"algo": "dqn", "n_timesteps": 300, "checkpoint_every": 50,
            "hyperparams": {"buffer_size": 1000, "learning_starts": 20, "train_freq": 4, "batch_size": 16,
                            "policy_kwargs": {"net_arch": [16]}}},
    # A DAgger warm start (one round): checkpointed after it, so the resumed run does not clone again.
    "ppo_dagger": {"algo": "ppo", "n_timesteps": 192, "checkpoint_every": 64,
                   "env": {"episode_steps": 40, "observe_since_measured": True},
                   "pretrain": {"teacher": "greedy", "episodes": 1, "epochs": 1, "dagger_rounds": 1},
                   "hyperparams": {"n_steps": 32, "batch_size": 32, "n_epochs": 1,
                                   "policy_kwargs": {"net_arch": [16]}}},
}  # fmt: skip
KILL_AT = {"ppo": 200, "dqn": 180, "ppo_dagger": 100}


def _train_py(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "train.py"), "train", *args, "--no-progress"],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip


def _final_state(run_dir: Path) -> dict:
    return json.loads((run_dir / "resume" / "state.json").read_text())


@pytest.mark.parametrize("case", list(CASES))
def test_killed_run_resumes_to_the_configured_steps_and_evaluates(tmp_path: Path, case: str) -> None:
    config = tmp_path / f"{case}.yaml"
    config.write_text(yaml.safe_dump({"name": case, **BASE, **CASES[case]}))

    unkilled = tmp_path / "unkilled"
    done = _train_py("--config", str(config), "--run-dir", str(unkilled))
    assert done.returncode == 0, done.stderr[-2000:]

    killed = tmp_path / "killed"
    proc = subprocess.run(
        [sys.executable, "-c", KILL_DRIVER, str(config), str(killed), str(KILL_AT[case])],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert proc.returncode == -signal.SIGKILL, proc.stderr[-2000:]
    before = _final_state(killed)
    assert not before["done"] and 0 < before["timesteps"] <= KILL_AT[case]
    assert not (killed / "model.zip").exists()

    resumed = _train_py("--resume", str(killed))
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"resuming {killed} at decision {before['timesteps']}" in resumed.stdout
    assert "pretrained on" not in resumed.stdout  # the warm start is not done again

    want, got = _final_state(unkilled), _final_state(killed)
    assert got["done"] and want["done"]
    assert got["stats"]["timesteps"] == want["stats"]["timesteps"] >= CASES[case]["n_timesteps"]
    assert got["stats"]["resumed_at"] == before["timesteps"]
    assert (killed / "model.zip").is_file()
    assert json.loads((killed / "eval.json").read_text())["agents"]  # the evaluation ran
    # The checkpoint's files are gone once the run is finished; only its state remains.
    assert [p.name for p in (killed / "resume").iterdir()] == ["state.json"]


def test_resume_refuses_a_folder_without_a_run(tmp_path: Path) -> None:
    proc = _train_py("--resume", str(tmp_path / "nothing"))
    assert proc.returncode == 2
    assert "no run there" in proc.stderr


def test_resume_takes_no_other_config(tmp_path: Path) -> None:
    proc = _train_py("--resume", str(tmp_path), "--seed", "3")
    assert proc.returncode == 2
    assert "drop --seed" in proc.stderr
