"""The ``-v1`` ids' decision interface (held decisions, relative targets, ``since_measured``) held to an
oracle over the ``-v0`` physics: this test's own composition of the vector env's physics steps (the
decision held k physics steps with the rewards summed, relative targets counted from the current target,
the steps since each target was last measured in libm's log1p), bit for bit. The training recipe used to
build the interface from layers like these; it now trains on the env's (``planetnav_train.moved_options``),
and this oracle keeps the two definitions held together."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.envs.vector_env import PlanetNavVectorEnv

SINCE_SCALE = 1440  # steps: the since_measured block's scale (docs/environment.md)


class HoldOracle:
    """``k`` physics steps a decision over a physics-step vector env, relative targets, and the
    since-measured values appended to its observation: the decision interface written out once more."""

    def __init__(self, venv: PlanetNavVectorEnv, k: int) -> None:
        self.venv, self.k = venv, k
        self.n_targets = venv.config.n_targets
        self.since = np.full((venv.num_envs, self.n_targets), np.inf)

    def _seen(self, rows: np.ndarray) -> None:
        """One physics step (or a reset) seen by ``rows``: counts advance, a measured target's restarts."""
        measured, target = self.venv.measured_flags(), self.venv.current_targets()
        for r in np.flatnonzero(rows):
            self.since[r] += 1.0
            if measured[r] and 0 <= target[r] < self.n_targets:
                self.since[r, target[r]] = 0.0

    def reset(self, seeds: list[int]) -> None:
        self.venv.reset(seed=seeds)
        self.since[:] = np.inf
        self._seen(np.ones(self.venv.num_envs, dtype=bool))

    def observations(self) -> np.ndarray:
        values = np.array(
            [[1.0 if not math.isfinite(s) else min(math.log1p(s) / math.log1p(SINCE_SCALE), 1.0) for s in row]
             for row in self.since],
            dtype=np.float32,
        )  # fmt: skip
        return np.concatenate([self.venv.observations(), values], axis=1)

    def step(self, relative: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        current = np.maximum(self.venv.current_targets(), 0)
        targets = (current + relative) % self.n_targets
        running = active.copy()
        total = np.zeros(self.venv.num_envs)
        done = np.zeros(self.venv.num_envs, dtype=bool)
        for _ in range(self.k):
            reward, terminated, truncated = self.venv.step_rows(targets, running)
            total[running] += reward[running]
            self._seen(running)
            done |= terminated | truncated
            running &= ~(terminated | truncated)
            if not running.any():
                break
        return total, done


@pytest.mark.parametrize("name", ["Cruise-Target", "RandomCruise-Target"])
def test_v1_equals_the_oracle_over_v0(name: str) -> None:
    v1 = dict(ENV_IDS[f"planetnav/{name}-v1"])
    assert v1["target_actions"] == "relative" and v1["observe_since_measured"]
    steps = 95  # ends inside a hold of 10
    k = v1["decision_steps"]
    native = PlanetNavVectorEnv(4, EnvConfig.from_dict({**v1, "episode_steps": steps}))
    physics = {**v1, "episode_steps": steps, "decision_steps": 1, "target_actions": "absolute"}
    physics.pop("observe_since_measured")
    oracle = HoldOracle(PlanetNavVectorEnv(4, EnvConfig.from_dict(physics)), k)
    seeds = [3, 4, 5, 6]
    obs, _ = native.reset(seed=seeds)
    oracle.reset(seeds)
    np.testing.assert_array_equal(obs, oracle.observations())
    rng = np.random.default_rng(0)
    running = np.ones(4, dtype=bool)
    decisions = 0
    while running.any():
        a = rng.integers(0, 3, size=4)
        r1, t1, u1 = native.step_rows(a, running)
        r2, d2 = oracle.step(a, running)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1 | u1, d2)
        np.testing.assert_array_equal(native.observations(), oracle.observations())
        running &= ~(t1 | u1)
        decisions += 1
    assert decisions == -(-steps // k)
    assert (native.observations()[:, -3:] < 1).any()  # something was measured: the block moved
