"""Helpers of the tests that hold a single-file PPO's training loop to Stable-Baselines3's on SB3's draws."""

from __future__ import annotations

import numpy as np
import pytest
import torch


@pytest.fixture
def sb3_learn(monkeypatch: pytest.MonkeyPatch):
    """``learn(model, n)``: SB3's ``model.learn(n)``, returning its weights before and after and the global
    torch and numpy generator states where its first rollout found them (what a loop given SB3's draws
    starts from). numpy's global generator, which SB3's minibatches draw from, is restored afterwards."""
    saved = np.random.get_state()  # noqa: NPY002

    def learn(model, n: int) -> tuple[dict, dict, dict]:
        before = {k: v.clone() for k, v in model.policy.state_dict().items()}
        at_first_draw: dict = {}
        collect = model.collect_rollouts

        def record_collect(*a, **kw):
            at_first_draw.setdefault("torch", torch.get_rng_state())
            at_first_draw.setdefault("numpy", np.random.get_state())  # noqa: NPY002
            return collect(*a, **kw)

        monkeypatch.setattr(model, "collect_rollouts", record_collect)
        model.learn(n)
        return before, model.policy.state_dict(), at_first_draw

    yield learn
    np.random.set_state(saved)  # noqa: NPY002


def sb3_minibatch_order(T: int, N: int):
    """A ``shuffler`` (ppo_single_file's signature) drawing SB3's minibatch order from numpy's global
    generator: SB3 flattens a (T, N) rollout row after row, the single file step after step."""

    def shuffler(_rng, _inds):
        def permutation() -> np.ndarray:
            k = np.random.permutation(T * N)  # noqa: NPY002 - SB3's minibatches' generator
            return (k % T) * N + k // T

        return permutation

    return shuffler


@pytest.fixture
def sb3_order():
    """:func:`sb3_minibatch_order` as a fixture (conftest helpers are not importable by name)."""
    return sb3_minibatch_order
