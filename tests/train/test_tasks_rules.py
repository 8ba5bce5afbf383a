"""The suite's rule agents play the interface each task declares for them (``TaskVersion.rules``): on every
suite task, the same configuration as the physics-step interface they played before."""

from __future__ import annotations

from planetnav_train.suite.tasks import SUITES


def test_rule_config_is_the_declared_rule_interface_of_the_eval_config():
    for tasks in SUITES.values():
        for task in tasks:
            cfg = task.rule_config(episode_steps=30)
            assert cfg == task.eval_config(episode_steps=30).at_physics_step(), task.id
            interface = (cfg.decision_steps, cfg.target_actions, cfg.observe_since_measured)
            assert interface == (1, "absolute", False)
            assert cfg.noise_streams == task.noise_streams and cfg.episode_steps == 30
