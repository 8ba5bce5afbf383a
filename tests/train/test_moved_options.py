"""The training-side decision options are the env's now: a YAML that still uses ``action_repeat``,
``relative_actions`` or ``features: [since_measured]`` is refused, before anything runs, with the env
option that keeps its meaning (``planetnav_train.moved_options``); the rewritten form trains the same
environment."""

from __future__ import annotations

from pathlib import Path

import pytest

from planetnav_env.errors import ConfigError
from planetnav_train.cli import main
from planetnav_train.config import load_config, parse_config

CASES = [
    # YAML, the message's env option
    ("env_id: planetnav/Cruise-Target-v0\naction_repeat: 10\n",
     "config: action_repeat is no longer a training option: set env option decision_steps=10 in the config's "
     "env section (see docs/environment.md, 'The decision interface')"),
    # Over an id that holds decisions itself the old hold was the product.
    ("env_id: planetnav/Cruise-Target-v1\naction_repeat: 2\n", "set env option decision_steps=20"),
    ("env: {decision_steps: 3}\naction_repeat: 4\n", "set env option decision_steps=12"),
    ("action_repeat: 0\n", "set env option decision_steps (an integer >= 1)"),
    ("relative_actions: true\n",
     "config: relative_actions is no longer a training option: set env option target_actions='relative'"),
    ("relative_actions: 1\n", "set env option target_actions ('absolute' or 'relative')"),
    ("features: [gain, since_measured]\n",
     "config: features: since_measured is no longer a training feature: set env option "
     "observe_since_measured=true"),
]  # fmt: skip


@pytest.mark.parametrize(("text", "named"), CASES)
def test_a_training_side_decision_key_names_the_env_option(
    tmp_path: Path, text: str, named: str, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "old.yaml"
    cfg.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(cfg)
    assert str(info.value).startswith(f"{cfg}: config") and named in str(info.value)
    # The command line reports it as any configuration error, before training.
    assert main(["train", "--config", str(cfg), "--no-progress", "--run-dir", str(tmp_path / "run")]) == 2
    assert named in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_an_older_runs_config_with_the_no_op_values_loads(tmp_path: Path) -> None:
    """Every run trained before the move wrote ``action_repeat: 1`` and ``relative_actions: false`` (the
    defaults) into its config.yaml: those changed nothing and are dropped, so the run can be evaluated and
    resumed; any other value is refused as above."""
    cfg = tmp_path / "config.yaml"
    cfg.write_text(
        "env_id: planetnav/Cruise-Torque-v0\naction_repeat: 1\nrelative_actions: false\nfeatures: []\n"
    )
    tc = load_config(cfg)
    assert tc.env_config().decision_steps == 1 and "action_repeat" not in tc.to_dict()
    cfg.write_text("action_repeat: true\n")  # True == 1 in Python: not the no-op value
    with pytest.raises(ConfigError, match="decision_steps \\(an integer >= 1\\)"):
        load_config(cfg)


def test_the_env_options_give_the_environment_the_old_keys_described() -> None:
    new = parse_config(
        {"env_id": "planetnav/Cruise-Target-v0",
         "env": {"decision_steps": 10, "target_actions": "relative", "observe_since_measured": True}}
    ).env_config()  # fmt: skip
    v1 = parse_config({"env_id": "planetnav/Cruise-Target-v1"}).env_config()
    # The -v1 id is this interface over the -v0 physics with the covariance reward.
    assert (new.decision_steps, new.target_actions, new.observe_since_measured) == (10, "relative", True)
    assert (v1.decision_steps, v1.target_actions, v1.observe_since_measured) == (10, "relative", True)
