"""``optimum`` (planetnav_agents.optimum, research/operations_log.md §3.3 item 3 and §3.5): its predicted J
is the
env's realised ``info["objective"]`` with ``reward: covariance``, its search never ends above its starts, and
bad parameters raise errors that name the value."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent, not_applicable
from planetnav_agents.optimum import ScheduleSearch, periodic_sessions
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.cli import main

ID = "planetnav/ThrustArc-TCM-v0"
DT = ENV_IDS[ID]["step_s"]
STAY = 3


def _env(steps: int = 240) -> PlanetNavEnv:
    """A 40-h ThrustArc episode: deadlines at steps 90.5 (reached at 91) and 200, the encounter at the end;
    per-step noise streams, the covariance reward (J depends on the schedule and the geometry only)."""
    ops = {**ENV_IDS[ID]["operations"], "deadlines_s": (90.5 * DT, 200 * DT), "encounter_s": steps * DT}
    cfg = EnvConfig.from_dict(ENV_IDS[ID], episode_steps=steps, operations=ops, noise_streams="per_step")
    assert cfg.reward == "covariance"
    return PlanetNavEnv(cfg)


def _play(env: PlanetNavEnv, agent, seed: int):
    """(actions, last info) of one episode of ``agent``."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    actions, done = [], False
    while not done:
        a = int(agent.act(obs, info))
        actions.append(a)
        obs, _, term, trunc, info = env.step(a)
        done = term or trunc
    return np.array(actions), info


@pytest.mark.parametrize("seed", [3, 11])
def test_predicted_objective_is_the_envs(seed: int) -> None:
    """The agent's predicted J of the schedule it plays equals the env's J to 1e-3 (the model's departures:
    the estimate's innovations move H and Φ by ~1e-5, the session moves the trajectory by km)."""
    env = _env()
    agent = make_agent("optimum", env)
    actions, info = _play(env, agent, seed)
    assert np.any(actions < STAY), "the search found no session worth its Δv: the check would be empty"
    np.testing.assert_array_equal(actions, np.where(agent.acts < 0, STAY, agent.acts))
    np.testing.assert_allclose(agent.predicted_objective_km, info["objective"], rtol=1e-3)


def test_model_of_staying_is_idles_objective() -> None:
    """The model's J of the empty schedule (the initial slew, the thrust noise, no image) is idle's J."""
    env = _env()
    agent = make_agent("optimum", env)
    _play(env, agent, seed=5)
    empty = agent.model.objective(agent.model.actions([]))
    _, idle_info = _play(env, make_agent("idle", env), seed=5)
    np.testing.assert_allclose(empty, idle_info["objective"], rtol=1e-4)


def test_search_ends_at_or_below_its_starts() -> None:
    """Local search only accepts improvements: the schedule found is no worse than the empty and the
    periodic starts under the model."""
    env = _env()
    agent = make_agent("optimum", env)
    _play(env, agent, seed=2)
    m = agent.model
    search = ScheduleSearch(m, agent.session)
    starts = [[], [c for c in periodic_sessions(m, agent.session) if search._ok([c])]]
    for start in starts:
        assert agent.predicted_objective_km <= m.objective(m.actions(start)) + 1e-9
    assert agent.predicted_objective_km < m.objective(m.actions([]))


#: Bad optimum specs and the error each must raise (the value named).
BAD_SPECS = [
    ("optimum:session=0", "session must be an integer number of steps >= 1, got 0"),
    ("optimum:grid=-2", "grid must be an integer number of steps >= 1, got -2"),
    ("optimum:session=true", "session must be an integer number of steps >= 1, got True"),
    ("optimum:session=1.5", "session must be an integer number of steps >= 1, got 1.5"),
    ("optimum:session=10,grid=4", "session=10 must be a multiple of grid=4"),
    ("optimum:session=240,grid=6", "session=240 \\+ grid=6 steps exceed the episode \\(240 steps\\)"),
    ("optimum:horizon=3", "unknown parameter 'horizon'"),
]


@pytest.mark.parametrize(("spec", "match"), BAD_SPECS)
def test_bad_parameters_name_the_value(spec: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make_agent(spec, _env())


def test_needs_an_operations_scenario() -> None:
    with pytest.raises(ValueError, match="optimum needs an operations scenario"):
        make_agent("optimum", PlanetNavEnv(episode_steps=5))
    # The harness skips it there with the reason (it is not one of the agents every env can run).
    assert "needs an operations scenario" in not_applicable("optimum:grid=3", EnvConfig())
    assert not_applicable("optimum", _env().config) is None


def test_compare_runs_optimum_from_the_shipped_config(tmp_path: Path) -> None:
    """The evaluation path of configs/operations/thrust_arc_tcm.yaml with optimum, cut to 60 steps."""
    cfg = Path(__file__).resolve().parents[2] / "configs" / "operations" / "thrust_arc_tcm.yaml"
    out = tmp_path / "c.json"
    rc = main(
        ["compare", "--config", str(cfg), "--episode-steps", "60", "--episodes", "1", "--agents", "optimum",
         "idle", "--reference", "idle", "--json", str(out), "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    agents = json.loads(out.read_text())["agents"]
    assert set(agents) == {"optimum", "idle"}
    # No deadline inside 60 steps: only the Δv counts, and the best schedule images nothing.
    assert agents["optimum"]["objective_mean"] == pytest.approx(agents["idle"]["objective_mean"], rel=1e-9)
