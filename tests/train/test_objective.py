"""The scenario objective in the evaluation (``planetnav_train.evaluate``): ``objective_mean``,
``objective_ci95`` and ``per_episode_objective`` [km] equal the env's ``info["objective"]`` at the episode's
end on an operations scenario and the mean position error elsewhere; paired, tabled and paired by
``research/commands/paired.py --metric objective``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import play_episode

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_train.evaluate import add_paired, evaluate_agent, results_json
from planetnav_train.report import markdown_table
from planetnav_train.stats import mean_ci, paired_difference

ID = "planetnav/ThrustArc-TCM-v0"
DT = ENV_IDS[ID]["step_s"]
SEED = 300
EPISODES = 3


def _ops_cfg(steps: int = 40) -> EnvConfig:
    """A short ThrustArc episode: deadlines at steps 10 and 25, the encounter at the end."""
    ops = {**ENV_IDS[ID]["operations"], "deadlines_s": (10 * DT, 25 * DT), "encounter_s": steps * DT}
    return EnvConfig.from_dict(ENV_IDS[ID], episode_steps=steps, operations=ops)


def _final_objectives(spec: str, cfg: EnvConfig) -> list[float]:
    """info["objective"] at the end of each episode of ``spec`` from SEED on, run by hand."""
    env = PlanetNavEnv(cfg)
    agent = make_agent(spec, env)
    out = []
    for seed in range(SEED, SEED + EPISODES):
        out.append(float(play_episode(agent, env, seed)["objective"]))
    env.close()
    return out


@pytest.mark.parametrize("spec", ["periodic:period=10,session=3,phase=2", "random"])
def test_objective_fields_equal_the_env_objective_per_seed(spec: str) -> None:
    cfg = _ops_cfg()
    res = evaluate_agent(spec, cfg, EPISODES, SEED, progress=False)
    m = res.metrics
    expected = _final_objectives(spec, cfg)
    assert m["objective_kind"] == "operations J"
    np.testing.assert_allclose(m["per_episode_objective"], expected, rtol=1e-12)
    ci = mean_ci(expected)
    assert m["objective_mean"] == pytest.approx(np.mean(expected), rel=1e-12)
    assert m["objective_ci95"] == pytest.approx([ci.low, ci.high], rel=1e-12)
    assert m["objective_ci95"][0] < m["objective_mean"] < m["objective_ci95"][1]
    assert all(v > 0 for v in m["per_episode_objective"])


def test_objective_is_the_mean_position_error_without_operations() -> None:
    cfg = EnvConfig.from_dict(ENV_IDS["planetnav/Cruise-Target-v0"], episode_steps=30)
    m = evaluate_agent("greedy", cfg, EPISODES, SEED, progress=False).metrics
    assert m["objective_kind"] == "mean position error"
    assert m["per_episode_objective"] == pytest.approx(m["per_episode_mean_pos_err_km"], rel=1e-12)
    assert m["objective_mean"] == pytest.approx(m["mean_pos_err_km"], rel=1e-12)
    assert m["objective_ci95"] == pytest.approx(m["mean_pos_err_ci95_km"], rel=1e-12)


def test_objective_is_paired_tabled_and_paired_by_the_research_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], research_command
) -> None:
    cfg = _ops_cfg()
    results = [evaluate_agent(s, cfg, EPISODES, SEED, progress=False) for s in ("idle", "random")]
    add_paired(results, "idle")
    idle, rnd = results
    d = paired_difference(rnd.metrics["per_episode_objective"], idle.metrics["per_episode_objective"])
    vs = rnd.metrics["vs_reference"]
    assert vs["mean_objective_diff_km"] == pytest.approx(d.mean, rel=1e-12)
    assert vs["objective_ci95_km"] == pytest.approx([d.low, d.high], rel=1e-12)
    table = markdown_table(results)
    assert "| J km [95% CI] | ΔJ vs idle km [95% CI] |" in table
    assert f"{rnd.metrics['objective_mean']:.1f} [" in table
    path = tmp_path / "eval.json"
    path.write_text(json.dumps(results_json(results)))
    paired = research_command("paired").main
    assert paired(["--a", f"{path}:random", "--b", f"{path}:idle", "--metric", "objective"]) == 0
    out = capsys.readouterr().out
    assert f"objective J: random: {rnd.metrics['objective_mean']:.1f} km" in out
    assert f"paired difference (first - second) {d.format('{:+.1f}')} km" in out
