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
