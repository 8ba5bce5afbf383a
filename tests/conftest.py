"""Shared test helpers: pytest reads this file first (fixtures used by several test files go here)."""

import importlib.util
import sys
from pathlib import Path

import pytest

RESEARCH_COMMANDS = Path(__file__).resolve().parents[1] / "research" / "commands"


@pytest.fixture
def research_command():
    """``research_command("paired").main(argv)``: a script of research/commands loaded from its file
    (research/ is no package; the scripts find their shared helpers beside them)."""

    def load(name: str):
        path = RESEARCH_COMMANDS / f"{name}.py"
        spec = importlib.util.spec_from_file_location(f"research_command_{name}", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
        return module

    return load


def play_episode(agent, env, seed: int) -> dict:
    """Run ``agent`` in ``env`` for one episode seeded ``seed`` (by hand, as an oracle of the evaluation
    harness); return the last step's info."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        done = terminated or truncated
    return info


# The golden tests under other CPU settings (tests/env/test_same_numbers.py, marked cpu_settings) run in
# processes of their own: those for another numba target (minutes of compiling) start in the background as
# soon as the session knows it has such a test, on the second core beside the rest of the suite; the tests
# come last, where the host-target settings run and all results are collected.
_CPU_SETTINGS_MODULE = pytest.StashKey[object]()


def pytest_collection_modifyitems(config, items) -> None:
    items[:] = sorted(items, key=lambda item: item.get_closest_marker("cpu_settings") is not None)


def pytest_collection_finish(session) -> None:
    if session.config.option.collectonly:
        return
    for item in session.items:
        if item.get_closest_marker("cpu_settings") is not None:
            session.config.stash[_CPU_SETTINGS_MODULE] = item.module
            item.module.start_golden_runs()
            return


def pytest_sessionfinish(session) -> None:
    module = session.config.stash.get(_CPU_SETTINGS_MODULE, None)
    if module is not None:
        module.stop_golden_runs()  # kills what still runs when the session ended early (-x, Ctrl-C)


# Helpers of the tests that hold a single-file PPO's training loop to Stable-Baselines3's on SB3's draws.
@pytest.fixture
def sb3_learn(monkeypatch: pytest.MonkeyPatch):
    """``learn(model, n)``: SB3's ``model.learn(n)``, returning its weights before and after and the global
    torch and numpy generator states where its first rollout found them (what a loop given SB3's draws
    starts from). numpy's global generator, which SB3's minibatches draw from, is restored afterwards."""
    import numpy as np
    import torch

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

    import numpy as np

    def shuffler(_rng, _inds):
        def permutation():
            k = np.random.permutation(T * N)  # noqa: NPY002 - SB3's minibatches' generator
            return (k % T) * N + k // T

        return permutation

    return shuffler


@pytest.fixture
def sb3_order():
    """:func:`sb3_minibatch_order` as a fixture (conftest helpers are not importable by name)."""
    return sb3_minibatch_order
