"""Ctrl-C during ``model.learn`` ends training early but keeps the model (planetnav_train.training.train)."""

from __future__ import annotations

from pathlib import Path

import pytest

from planetnav_train import training
from planetnav_train.config import load_config

ROOT = Path(__file__).resolve().parents[2]


def test_interrupt_saves_the_model_and_reports_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = training._nav_callback_class

    def interrupting_class() -> type:
        class Interrupting(real()):  # type: ignore[misc]
            def _on_step(self) -> bool:
                super()._on_step()
                if self.num_timesteps >= 128:  # after the first rollout: what a SIGINT raises in learn
                    raise KeyboardInterrupt
                return True

        return Interrupting

    monkeypatch.setattr(training, "_nav_callback_class", interrupting_class)
    tc = load_config(ROOT / "configs" / "smoke.yaml")  # 2 rows x 64 steps a rollout, 256 decisions
    model_path, stats = training.train(tc, tmp_path / "run", progress=False)
    assert stats["interrupted"] is True
    assert 128 <= stats["timesteps"] < tc.n_timesteps
    assert model_path.is_file()
    from planetnav_train.sb3 import load_model

    assert load_model(model_path).num_timesteps == stats["timesteps"]
