"""The ``-v1`` ids' decision interface (held decisions, relative targets, ``since_measured``) held to the
training recipe's layers over the ``-v0`` physics: the same numbers, bit for bit, from two compositions
(the env's own hold over its core, and the recipe's Rows layers over the vector env's physics steps)."""

from __future__ import annotations

import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_train.batch_wrappers import TrainingOptions, VectorRows


@pytest.mark.parametrize("name", ["Cruise-Target", "RandomCruise-Target"])
def test_v1_equals_the_recipe_layers_over_v0(name: str) -> None:
    v1 = dict(ENV_IDS[f"planetnav/{name}-v1"])
    steps = 95  # ends inside a hold of 10
    k = v1["decision_steps"]
    native = PlanetNavVectorEnv(4, EnvConfig.from_dict({**v1, "episode_steps": steps}))
    physics = {**v1, "episode_steps": steps, "decision_steps": 1, "target_actions": "absolute"}
    physics.pop("observe_since_measured")
    rows = TrainingOptions(features=("since_measured",), action_repeat=k, relative_actions=True).stack(
        VectorRows(PlanetNavVectorEnv(4, EnvConfig.from_dict(physics)))
    )
    seeds = [3, 4, 5, 6]
    obs, _ = native.reset(seed=seeds)
    rows.reset_rows(np.ones(4, dtype=bool), seeds)
    np.testing.assert_array_equal(obs, rows.observations())
    rng = np.random.default_rng(0)
    running = np.ones(4, dtype=bool)
    decisions = 0
    while running.any():
        a = rng.integers(0, 3, size=4)
        r1, t1, u1 = native.step_rows(a, running)
        r2, t2, u2 = rows.step_rows(a, running)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1 | u1, t2 | u2)
        np.testing.assert_array_equal(native.observations(), rows.observations())
        running &= ~(t1 | u1)
        decisions += 1
    assert decisions == -(-steps // k)
    assert (native.observations()[:, -3:] < 1).any()  # something was measured: the block moved
