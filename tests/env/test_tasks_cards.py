"""Each task card (docs/tasks/<name>.md) against the registered spaces: a section per registered version,
and the observation size it states equal to ``gym.make(id).observation_space``."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.tasks import TASKS

CARDS = Path(__file__).parents[2] / "docs" / "tasks"
SECTION = re.compile(r"^## v(\d+): `(planetnav/[A-Za-z-]+-v\d+)`$", re.M)
OBSERVATION = re.compile(r"^- observation: `Box` of (\d+) float32", re.M)
ACTION = re.compile(r"^- action: `(Discrete\((\d+)\)|Box\(-1, 1, \((\d+),\)\))`", re.M)


def _sections(text: str) -> dict[str, str]:
    """Each version section's text by its id."""
    heads = list(SECTION.finditer(text))
    ends = [h.start() for h in heads[1:]] + [text.find("\n## ", heads[-1].end()) if heads else 0]
    return {h.group(2): text[h.end() : end] for h, end in zip(heads, ends, strict=True)}


def test_every_registered_version_has_its_section():
    found = {}
    for task in TASKS:
        found.update(_sections((CARDS / f"{task.name}.md").read_text()))
    assert set(found) == set(ENV_IDS)


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_the_card_states_the_registered_spaces(env_id):
    name = env_id.split("/", 1)[1].rsplit("-v", 1)[0]
    section = _sections((CARDS / f"{name}.md").read_text())[env_id]
    obs, act = OBSERVATION.findall(section), ACTION.search(section)
    env = gym.make(env_id)
    assert [int(n) for n in obs] == [env.observation_space.shape[0]] and env.observation_space.shape == (
        int(obs[0]),
    )
    assert act is not None, section
    space = env.action_space
    if act.group(2):
        assert isinstance(space, gym.spaces.Discrete) and space.n == int(act.group(2))
    else:
        assert isinstance(space, gym.spaces.Box) and space.shape == (int(act.group(3)),)
        assert (space.low == -1).all() and (space.high == 1).all()
    env.close()
