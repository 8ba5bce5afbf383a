"""Training checkpoints: a run killed at any moment (SIGKILL included) continues from its last one.

``RUN_DIR/resume/`` holds the newest checkpoint of a run (for RLlib runs, ``RUN_DIR/checkpoint/`` is the
final algorithm checkpoint, as before); for SB3:

* ``model_<T>.zip``: the model after ``T`` decisions (SB3's own save: weights, optimizer state, step count,
  learning-rate schedule position);
* ``replay_buffer_<T>.pkl``: off-policy algorithms' replay buffer at the same moment (SB3's pickle);
* ``state.json``: which files are current, the decisions done, the training seconds so far, the finished
  training episodes and the warm start's statistics; ``done`` once the final ``model.zip`` is written.

``state.json`` is replaced atomically after the files it names are complete, and older files are deleted
only then, so a kill leaves either the previous checkpoint or the new one, never half of one.

Checkpoints are taken at the start of a rollout (after the previous update), every
``TrainConfig.checkpoint_every`` decisions (default 50,000; 0 turns them off), and once after a warm start
(behaviour cloning, DAgger). What a resumed run does not carry over: the environments' episodes in
progress (it starts new ones, seeded from the config's seed plus the decisions done, so it does not replay
the first episodes) and the random state of the sampler; a resumed run therefore differs from an unkilled
one in its numbers, while its step count, schedule and evaluation are the same.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

CHECKPOINT_DIR = "resume"
STATE_FILE = "state.json"


@dataclass
class TrainingState:
    """What ``state.json`` records (see the module docstring)."""

    timesteps: int
    seconds: float
    model: str
    replay_buffer: str | None = None
    episodes: list[list[float]] = field(default_factory=list)
    pretrain: dict[str, Any] = field(default_factory=dict)
    done: bool = False
    stats: dict[str, Any] = field(default_factory=dict)


def checkpoint_dir(run_dir: Path) -> Path:
    """The folder of ``run_dir``'s checkpoint."""
    return Path(run_dir) / CHECKPOINT_DIR


def load_state(run_dir: Path) -> TrainingState | None:
    """The newest checkpoint's state of ``run_dir``, or None when it has none."""
    path = checkpoint_dir(run_dir) / STATE_FILE
    if not path.is_file():
        return None
    return TrainingState(**json.loads(path.read_text()))


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def write_state(run_dir: Path, state: TrainingState) -> None:
    """Make ``state`` the current checkpoint (atomically), then delete the files no longer named."""
    folder = checkpoint_dir(run_dir)
    folder.mkdir(parents=True, exist_ok=True)
    _write_atomic(folder / STATE_FILE, json.dumps(asdict(state), indent=1))
    keep = {STATE_FILE, state.model, state.replay_buffer}
    for p in folder.iterdir():
        if p.name not in keep and not p.name.startswith("."):
            shutil.rmtree(p) if p.is_dir() else p.unlink()


def save_checkpoint(model: Any, run_dir: Path, state: TrainingState) -> TrainingState:
    """Save ``model`` (and its replay buffer, if it has one) after ``model.num_timesteps`` decisions and make
    it the current checkpoint with the rest of ``state``; returns the state written."""
    folder = checkpoint_dir(run_dir)
    folder.mkdir(parents=True, exist_ok=True)
    t = int(model.num_timesteps)
    state.timesteps, state.model = t, f"model_{t}.zip"
    model.save(folder / state.model)
    if getattr(model, "replay_buffer", None) is not None:
        state.replay_buffer = f"replay_buffer_{t}.pkl"
        model.save_replay_buffer(folder / state.replay_buffer)
    write_state(run_dir, state)
    return state


def checkpoint_callback_class() -> type:
    """The SB3 callback that checkpoints every ``every`` decisions (defined here so that SB3 is imported only
    when training)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class CheckpointCallback(BaseCallback):
        """Checkpoints at the start of a rollout once ``every`` decisions have passed since the last one;
        ``make_state()`` supplies the rest of the state (seconds, episodes, warm start)."""

        def __init__(self, run_dir: Path, every: int, make_state: Any, last: int = 0) -> None:
            super().__init__()
            self.run_dir, self.every, self.make_state, self.last = Path(run_dir), int(every), make_state, last

        def _on_rollout_start(self) -> None:
            if self.every > 0 and self.num_timesteps - self.last >= self.every:
                save_checkpoint(self.model, self.run_dir, self.make_state())
                self.last = self.num_timesteps

        def _on_step(self) -> bool:
            return True

    return CheckpointCallback
