"""The operations references (issue 17, research/operations_log.md §3.3): ``periodic`` with sessions and
phase, and ``greedy:threshold=θ`` (planetnav_agents.operations)."""

from __future__ import annotations

import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_agents.base import parse_observation
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS

ID = "planetnav/ThrustArc-TCM-v0"
DT = ENV_IDS[ID]["step_s"]
STAY = 3


def _env(steps: int = 40) -> PlanetNavEnv:
    """A short ThrustArc episode: deadlines at steps 10.5 (reached at 11) and 25, the encounter at the end."""
    ops = {**ENV_IDS[ID]["operations"], "deadlines_s": (10.5 * DT, 25 * DT), "encounter_s": steps * DT}
    return PlanetNavEnv(EnvConfig.from_dict(ENV_IDS[ID], episode_steps=steps, operations=ops))


def _run(env: PlanetNavEnv, spec: str, seed: int = 7):
    """(actions, visible-any flags before each action, last info) of one episode."""
    agent = make_agent(spec, env)
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    actions, visible = [], []
    done = False
    while not done:
        a = int(agent.act(obs, info))
        visible.append(bool(np.any(parse_observation(obs, env).planet_observable)))
        actions.append(a)
        obs, _, term, trunc, info = env.step(a)
        done = term or trunc
    return agent, np.array(actions), np.array(visible), info


def test_periodic_sessions_and_phase_stay_between_sessions() -> None:
    env = _env()
    agent, actions, _, info = _run(env, "periodic:period=10,session=3,phase=2,cycle=0-1")
    k = np.arange(actions.size)
    in_session = (k - 2) % 10 < 3
    assert np.all(actions[~in_session] == STAY)
    assert np.all(actions[in_session] < STAY)
    assert agent.name == "periodic:period=10,session=3,phase=2,cycle=0-1"
    assert info["dv_lost_m_s"] > 0


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("periodic:period=10,session=11", "session must be an integer number of steps in \\[1, period = 10"),
        ("periodic:period=10,session=2,phase=10", "phase must be an integer number of steps in \\[0, period"),
        ("periodic:period=10,phase=3", "phase=3 needs session"),
    ],
)
def test_periodic_session_errors_name_the_bad_value(spec: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make_agent(spec, _env())


def test_greedy_threshold_zero_images_whenever_something_is_visible() -> None:
    env = _env()
    _, actions, visible, _ = _run(env, "greedy:threshold=0,session=3")
    # Outside a session under way, a decision with a planet visible images.
    assert visible.any()
    assert np.all(actions[visible] < STAY)


def test_greedy_huge_threshold_never_images() -> None:
    """Only stay: the Δv lost is that of the initial slew to the thrust attitude, as for always staying."""
    env = _env()
    _, actions, _, info = _run(env, "greedy:threshold=1e9")
    _, _, _, stay_info = _run(env, "idle")
    assert np.all(actions == STAY)
    assert info["dv_lost_m_s"] == stay_info["dv_lost_m_s"] < 0.02  # m/s: < 106 s of the thrust off


def test_greedy_predicted_deadline_sigma_is_the_envs_with_no_images() -> None:
    """From the step before a deadline (staying), the rule's σ equals the env's deadline_sigma_km."""
    env = _env()
    agent = make_agent("greedy:threshold=1e9", env)
    rule = agent.sessions
    agent.reset(seed=3)
    obs, info = env.reset(seed=3)
    for k in range(40):
        predicted = rule.predicted_sigma(k * DT, info["filter"]["x"], info["filter"]["P"])
        obs, _, _, _, info = env.step(agent.act(obs, info))
        if k + 1 in (11, 25):  # the step ends at which the env reaches the deadlines
            j = 0 if k + 1 == 11 else 1
            assert info["deadline_sigma_km"][j] > 0
            np.testing.assert_allclose(predicted[j], info["deadline_sigma_km"][j], rtol=1e-4)


def test_greedy_threshold_needs_an_operations_scenario() -> None:
    with pytest.raises(ValueError, match="threshold=1 needs an operations scenario"):
        make_agent("greedy:threshold=1", PlanetNavEnv(episode_steps=5))
    with pytest.raises(ValueError, match="threshold must be a finite number >= 0, got -1"):
        make_agent("greedy:threshold=-1", _env())
