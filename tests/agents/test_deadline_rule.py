"""Deadline-anchored sessions of the ``periodic`` rule (``periodic:lead=…``; research/operations_log.md
§7.5): the schedule on a tiny ThrustArc config and the spec's named errors."""

from __future__ import annotations

import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS

ID = "planetnav/ThrustArc-TCM-v0"
DT = ENV_IDS[ID]["step_s"]
STAY = 3  # three planets: the last action is "stay at the mission attitude"


def _env(steps: int = 40) -> PlanetNavEnv:
    """A 40-step ThrustArc episode: deadlines at 10.5 steps (reached at the end of step count 11) and at
    25 steps (reached at 25), the encounter at the end."""
    ops = {**ENV_IDS[ID]["operations"], "deadlines_s": (10.5 * DT, 25 * DT), "encounter_s": steps * DT}
    return PlanetNavEnv(EnvConfig.from_dict(ENV_IDS[ID], episode_steps=steps, operations=ops))


def _run(env: PlanetNavEnv, spec: str, seed: int = 7) -> tuple[np.ndarray, list[dict]]:
    """(actions, infos after each step) of one episode of ``spec``."""
    agent = make_agent(spec, env)
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    actions, infos = [], []
    done = False
    while not done:
        a = int(agent.act(obs, info))
        actions.append(a)
        obs, _, term, trunc, info = env.step(a)
        infos.append(info)
        done = term or trunc
    return np.array(actions), infos


def test_blocks_end_lead_steps_before_each_deadline_with_a_start_session() -> None:
    actions, _ = _run(_env(), "periodic:lead=2,session=4-3,start=2,cycle=0-1,skip_invisible=false")
    expected = np.full(40, STAY)
    expected[0:2] = 0  # the start session: piece 0 -> cycle[0]
    expected[5:9] = 1  # deadline reached at count 11, lead 2: steps 11-2-4 .. 11-2-1, piece 1
    expected[20:23] = 0  # deadline at count 25: steps 25-2-3 .. 25-2-1, piece 2 -> cycle[0]
    np.testing.assert_array_equal(actions, expected)


def test_dwell_alternates_planets_within_and_across_blocks() -> None:
    actions, _ = _run(_env(), "periodic:lead=0,session=6,dwell=2,cycle=0-1-2,skip_invisible=false")
    expected = np.full(40, STAY)
    expected[5:11] = [0, 0, 1, 1, 2, 2]
    expected[19:25] = [0, 0, 1, 1, 2, 2]  # pieces 3, 4, 5 continue the cycle
    np.testing.assert_array_equal(actions, expected)


def test_lead_zero_images_on_the_step_that_reaches_the_deadline() -> None:
    """The rule's deadline steps are the env's: with lead 0 the last imaging step is the one at whose end
    ``deadline_sigma_km`` first becomes non-zero."""
    actions, infos = _run(_env(), "periodic:lead=0,session=3,cycle=0-1")
    for j in range(2):
        reached = next(k for k, info in enumerate(infos) if info["deadline_sigma_km"][j] > 0)
        assert actions[reached] < STAY and actions[reached + 1] == STAY
        assert np.all(actions[reached - 2 : reached + 1] < STAY) and actions[reached - 3] == STAY


def test_blocks_are_clipped_at_step_zero_and_at_the_session_before() -> None:
    """A block reaching back before step 0 or into the session before it starts where that one ends."""
    actions, _ = _run(_env(), "periodic:lead=0,session=12-20,start=9,cycle=0-1-2,skip_invisible=false")
    expected = np.full(40, STAY)
    expected[0:9] = 0  # the start session
    expected[9:11] = 1  # the first block (steps -1..10) clipped to 9..10
    expected[11:25] = 2  # the second block (steps 5..24) clipped to 11..24
    np.testing.assert_array_equal(actions, expected)
    actions, _ = _run(_env(), "periodic:lead=0,session=4,start=12,cycle=0-1,skip_invisible=false")
    expected = np.full(40, STAY)
    expected[0:12] = 0  # the first block (steps 7..10) lies inside the start session: nothing left
    expected[21:25] = 1
    np.testing.assert_array_equal(actions, expected)


def test_canonical_name() -> None:
    agent = make_agent("periodic:lead=1,session=3-3,cycle=venus-mars", _env())
    assert agent.name == "periodic:lead=1,session=3,cycle=0-1"
    agent = make_agent("periodic:lead=0,session=4-0,start=2,dwell=2,cycle=0-1-2", _env())
    assert agent.name == "periodic:lead=0,session=4-0,start=2,dwell=2,cycle=0-1-2"


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("periodic:lead=0", "lead=0 needs session=<steps per block>"),
        ("periodic:lead=-1,session=3", "lead must be an integer number of steps >= 0, got -1"),
        ("periodic:lead=1.5,session=3", "lead must be an integer number of steps >= 0, got 1.5"),
        ("periodic:lead=0,session=0", "session must be an integer number of steps >= 1, got 0"),
        ("periodic:lead=0,session=4-3-2", "session='4-3-2' must be one integer or 2 integers"),
        ("periodic:lead=0,session=4-x", "session='4-x' must be one integer or 2 integers"),
        ("periodic:lead=0,session=3,dwell=0", "dwell must be an integer number of steps >= 1, got 0"),
        ("periodic:lead=0,session=3,start=-2", "start must be an integer number of steps >= 0, got -2"),
        ("periodic:period=10,lead=0,session=3", "period=10 and phase=0 do not apply"),
        ("periodic:lead=0,session=3,phase=2", "period=None and phase=2 do not apply"),
        ("periodic:period=10,session=3,start=3", "start=3 and dwell=None belong to deadline-anchored"),
        ("periodic:period=10,session=3,dwell=2", "start=0 and dwell=2 belong to deadline-anchored"),
    ],
)
def test_spec_errors_name_the_bad_value(spec: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make_agent(spec, _env())


def test_lead_needs_an_operations_scenario() -> None:
    with pytest.raises(ValueError, match="lead=0 anchors sessions on the deadlines of an operations"):
        make_agent("periodic:lead=0,session=3", PlanetNavEnv(episode_steps=5))
