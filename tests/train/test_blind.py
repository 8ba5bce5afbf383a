"""The blind family, its search, the closed-loop gap and the blind-zero score (planetnav_train.suite.blind),
and the blind schedule agent."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_agents import make_agent
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError
from planetnav_train.suite import blind as B


def _cfg(env_id: str, **options) -> EnvConfig:
    return EnvConfig.from_dict({**ENV_IDS[env_id], **options})


def test_candidates_cover_every_cycle_at_the_decision_interface():
    cfg = _cfg("planetnav/Cruise-Target-v2")
    specs = B.blind_candidates(cfg)
    assert specs[0] == "random" and len(specs) == len(set(specs))
    schedules = [s for s in specs if s.startswith("schedule:")]
    # 3 stares, 3 pairs and 2 orientations of the triple; every dwell a multiple of the decision.
    cycles = {s.split(",")[0] for s in schedules}
    assert len(cycles) == 3 + 3 + 2
    for s in schedules:
        dwells = [int(d) for d in s.split("steps=")[1].split("-")]
        assert all(d % cfg.decision_steps == 0 for d in dwells)
    mars = B.blind_candidates(_cfg("planetnav/MarsApproach-Tasking-v2"))
    assert "schedule:targets=0-1-2,steps=8-4-4" in mars  # planet dwell, then each pulsar
    # Wheel torques: only torques chosen without the state (a schedule through the PD law reads the attitude).
    assert B.blind_candidates(_cfg("planetnav/Cruise-Torque-v2")) == ["random", "zero"]
    with pytest.raises(ConfigError, match="target-choice and wheel-torque"):
        B.blind_candidates(_cfg("planetnav/Cruise-Hybrid-v1"))


def test_operations_candidates_are_sessions_with_the_camera_off_between():
    cfg = _cfg("planetnav/ThrustArc-TCM-v2")
    specs = B.blind_candidates(cfg)
    assert specs[:2] == ["random", "idle"] and len(specs) == len(set(specs))
    sessions = [s for s in specs if "off" in s]
    per_cycle = len(B.SESSION_DECISIONS) * len(B.SESSION_GAPS) * len(B.SESSION_STARTS)
    assert len(sessions) == 8 * per_cycle
    # The rules' tuned sessions (2 h every 3 days over the three planets) are in the family, at every start.
    rule = "schedule:targets=0-off-1-off-2-off,steps=12-420-12-420-12-420"
    assert rule in sessions and f"{rule},phase=1188" in sessions
    env = PlanetNavEnv(cfg.at_physics_step())
    a = make_agent(f"{rule},phase=1188", env)
    a.reset(0)
    acts = [a.act(None, {}) for _ in range(3 * 432 + 120)]
    # phase 1188 of a 1,296-step cycle: the first session (planet 0) starts after 108 steps (a quarter block).
    off = cfg.n_targets
    assert acts[:108] == [off] * 108 and acts[108:120] == [0] * 12 and acts[120:540] == [off] * 420
    assert acts[540:552] == [1] * 12


def test_default_references_per_task():
    assert B.default_references(_cfg("planetnav/Cruise-Target-v2")) == (B.V2_REFERENCES, B.V2_PRIVILEGED)
    refs, priv = B.default_references(_cfg("planetnav/ThrustArc-TCM-v2"))
    assert "optimum" in refs and priv == ()
    assert B.default_references(_cfg("planetnav/Cruise-Torque-v2"))[0] == (
        "greedy", "periodic", "planner", "baseline"
    )  # fmt: skip
    timing = _cfg("planetnav/MarsApproach-Tasking-v1", world={"pulsar_frequency_error_max": 1e-10})
    assert B.default_references(timing) == (B.TIMING_REFERENCES, B.TIMING_PRIVILEGED)
    assert B.default_references(_cfg("planetnav/Cruise-Target-v1")) == (("greedy",), ())


def test_evaluate_objective_reads_the_operations_J():
    cfg = _cfg("planetnav/ThrustArc-TCM-v2", episode_steps=72)
    j = B.evaluate_objective("idle", cfg, 2, 0)
    from planetnav_train.evaluate import evaluate_agent

    m = evaluate_agent("idle", cfg, 2, 0, progress=False).metrics
    assert m["objective_kind"] == "operations J"
    np.testing.assert_array_equal(j, m["per_episode_objective"])
    assert not np.allclose(j, m["per_episode_mean_pos_err_km"])


def test_search_picks_the_lowest_mean_and_measure_reports_the_gap():
    table = {"random": [9.0, 11.0], "schedule:a": [5.0, 7.0], "schedule:b": [6.0, 6.5]}
    evals = {"schedule:a": [6.0] * 4, "greedy": [4.0, 5.0, 4.0, 5.0], "adaptive": [3.0] * 4,
             "oracle": [1.0, 1.0, 1.0, 1.0]}  # fmt: skip

    def search_eval(spec, cfg, episodes, seed):
        return np.asarray(table[spec])

    def eval_eval(spec, cfg, episodes, seed):
        return np.asarray(evals[spec])

    res = B.search_blind(None, search_eval, 1, 2, candidates=list(table), final_episodes=0)
    assert res.winner == "schedule:a" and res.search["schedule:b"] == pytest.approx(6.25)
    assert res.winner_mean == 6.0 and not res.final
    rec = B.measure_task(None, res, ["greedy", "adaptive"], ["oracle"], eval_eval, 7, 4)
    assert rec["best_reference"] == "adaptive"  # the oracle is never the score's 1
    assert rec["closed_loop_gap"]["gap"] == pytest.approx((6.0 - 3.0) / 6.0)
    assert rec["agents"]["schedule:a"]["score"] == pytest.approx(0.0)
    assert rec["agents"]["adaptive"]["score"] == pytest.approx(1.0)
    assert rec["agents"]["greedy"]["score"] == pytest.approx((6.0 - 4.5) / 3.0)
    assert rec["agents"]["oracle"]["role"] == "privileged" and rec["agents"]["oracle"]["score"] > 1.0
    assert rec["winner_search_inside_eval_ci"] is True  # search mean 6.0 = eval mean (zero spread)


def test_paired_interval_is_a_bootstrap_of_the_seeds():
    rng = np.random.default_rng(1)
    blind = 100 + rng.normal(0, 10, 100)
    best = blind * 0.7 + rng.normal(0, 1, 100)  # paired: shares each seed's difficulty
    out = B.paired_ratio_ci(blind, best)
    assert out["gap_lo"] < out["gap"] < out["gap_hi"]
    assert out["gap"] == pytest.approx(0.3, abs=0.02)
    assert out["gap_hi"] - out["gap_lo"] < 0.02  # pairing removes the seeds' common spread
    with pytest.raises(ConfigError, match="paired"):
        B.paired_ratio_ci(blind, best[:50])


def test_blind_zero_score_and_its_errors():
    assert B.blind_zero_score(5.0, 10.0, 5.0) == 1.0
    assert B.blind_zero_score(10.0, 10.0, 5.0) == 0.0
    assert B.blind_zero_score(12.0, 10.0, 5.0) == pytest.approx(-0.4)
    with pytest.raises(ConfigError, match="no scale"):
        B.blind_zero_score(1.0, 2.0, 2.0)
    with pytest.raises(ConfigError, match="non-finite"):
        B.blind_zero_score(float("nan"), 2.0, 1.0)


def test_schedule_agent_ignores_the_observation():
    env = PlanetNavEnv(_cfg("planetnav/MarsApproach-Tasking-v2").at_physics_step())
    a = make_agent("schedule:targets=mars-1-2,steps=3-1-2", env)
    assert a.name == "schedule:targets=0-1-2,steps=3-1-2"
    obs, info = env.reset(seed=0)
    a.reset(0)
    first = [a.act(obs, info) for _ in range(12)]
    a.reset(1)
    noise = np.random.default_rng(0)
    second = [a.act(noise.normal(size=obs.shape), {}) for _ in range(12)]
    assert first == second == [0, 0, 0, 1, 2, 2] * 2


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("schedule:targets=0-7,steps=3", "neither an index"),
        ("schedule:targets=0-1,steps=1-2-3", "gives 3 dwells for 2 targets"),
        ("schedule:targets=0-1,steps=0", "integer >= 1"),
        ("schedule:targets=0--1,steps=2", "empty entry"),
        ("schedule:targets=0-off,steps=2", "idle_action=True"),
        ("schedule:targets=0-1,steps=2,phase=-3", "phase -3 must be an integer >= 0"),
    ],
)
def test_schedule_agent_named_errors(spec, match):
    env = PlanetNavEnv(_cfg("planetnav/Cruise-Target-v1").at_physics_step())
    with pytest.raises(ValueError, match=match):
        make_agent(spec, env)


def test_greedy_adaptive_rules_need_their_observation_blocks():
    env = PlanetNavEnv(_cfg("planetnav/Cruise-Target-v1").at_physics_step())
    with pytest.raises(ValueError, match="image_log"):
        make_agent("greedy:success=observed", env)
    with pytest.raises(ValueError, match="residual_log"):
        make_agent("greedy:bias=observed", env)
    with pytest.raises(ValueError, match="success must be one of"):
        make_agent("greedy:success=sometimes", env)


def test_greedy_timing_rules_score_pulsars_by_their_residuals_and_the_true_drift():
    cruise = PlanetNavEnv(_cfg("planetnav/Cruise-Target-v1", observe_residual_log=True).at_physics_step())
    with pytest.raises(ValueError, match="has none"):
        make_agent("greedy:timing=observed", cruise)
    mars_v1 = PlanetNavEnv(_cfg("planetnav/MarsApproach-Tasking-v1").at_physics_step())
    with pytest.raises(ValueError, match="residual_log"):
        make_agent("greedy:timing=observed", mars_v1)
    env = PlanetNavEnv(
        _cfg(
            "planetnav/MarsApproach-Tasking-v1",
            world={"pulsar_frequency_error_max": 1e-9},
            observe_residual_log=True,
        ).at_physics_step()
    )
    adaptive, oracle = make_agent("greedy:timing=observed", env), make_agent("greedy:timing=oracle", env)
    assert adaptive.name == "greedy:timing=observed"
    obs, info = env.reset(seed=2)
    for k in range(40):
        obs, _, _, _, info = env.step(1 + k // 20)
    from planetnav_agents.base import parse_observation

    p = parse_observation(obs, env)
    log = env.decode_observation(obs)["residual_log"]
    np.testing.assert_allclose(
        adaptive.pulsar_weights(p, info["filter"]["P"]), 1.0 / np.maximum(log[1:] * 10, 1)
    )
    # The documented oracle: 1 / (1 + (d / sigma)^2), d the true range error now, sigma^2 the phase's range
    # variance plus the filter's along the pulsar.
    psr, p_rr = env.core_params.psr, np.asarray(info["filter"]["P"])[:3, :3]
    d = env.core.true_pulsar_drift()[0] * 40 * env.config.step_s
    var = (psr[:, 3] * psr[:, 4]) ** 2 + np.array([n @ p_rr @ n for n in psr[:, :3]])
    w = oracle.pulsar_weights(p, info["filter"]["P"])
    np.testing.assert_allclose(w, 1.0 / (1.0 + d**2 / var), rtol=1e-12)
    assert np.all((w > 0) & (w < 1))


def test_greedy_photometric_rule_scores_the_onboard_models_residual(monkeypatch):
    raw = PlanetNavEnv(_cfg("planetnav/Cruise-Target-v1").at_physics_step())
    with pytest.raises(ValueError, match="lambert_cob"):
        make_agent("greedy:bias=photometric", raw)
    env = PlanetNavEnv(_cfg("planetnav/MarsApproach-Tasking-v3").at_physics_step())
    agent = make_agent("greedy:bias=photometric", env)
    assert agent.name == "greedy:bias=photometric"
    obs, info = env.reset(seed=3)
    from planetnav_agents.base import parse_observation
    from planetnav_env.astro.bodies import body
    from planetnav_env.sensors.photometry import COB_LAMBERT_QUADRATURE

    # Known geometry: Mars 1.5 AU out on +x, the spacecraft 1e5 km from it on the Sun's side (full phase:
    # no offset) or across the Sun line (quadrature: 3 pi / 16 of the disk's angular radius).
    mars = np.array([[2.25e8, 0.0, 0.0]])
    monkeypatch.setattr(env.core, "body_positions", lambda row: {"central": mars[0], "planets": mars})
    p = parse_observation(obs, env)
    for rel, cob in (([-1e5, 0.0, 0.0], 0.0), ([0.0, 1e5, 0.0], COB_LAMBERT_QUADRATURE)):
        monkeypatch.setattr(agent, "estimate", lambda o, i, rel=rel: np.array([*rel, 0.0, 0.0, 0.0]))
        want = 0.05 / np.sqrt(3.0) * cob * np.arcsin(body("mars").radius / 1e5)
        np.testing.assert_allclose(agent._photometric_residuals(p, info), [want], rtol=1e-9, atol=1e-15)
    monkeypatch.undo()
    # In the episode: Mars's weight falls as the disk grows on the approach; an exact model weighs nothing.
    weights = []
    for k in range(1, 1001):
        obs, _, _, _, info = env.step(0)
        if k in (1, 1000):
            weights.append(agent.planet_weights(parse_observation(obs, env), info)[0])
    assert 0.0 < weights[1] < weights[0] < 1.0
    world = {**ENV_IDS["planetnav/MarsApproach-Tasking-v3"]["world"], "cob_model_error": 0.0}
    exact = PlanetNavEnv(_cfg("planetnav/MarsApproach-Tasking-v3", world=world).at_physics_step())
    obs, info = exact.reset(seed=3)
    exact_agent = make_agent("greedy:bias=photometric", exact)
    assert exact_agent.planet_weights(parse_observation(obs, exact), info) == 1.0


def test_greedy_centroid_offsets_at_known_phases(monkeypatch):
    """The expected-bias rule's offset at three phases it can be checked by hand: quadrature (1 - cos = 1),
    full (0) and new (2), each planet 1e5 km from the spacecraft."""
    from planetnav_agents.base import parse_observation
    from planetnav_env.envs.parsed_observation import ParsedObservation
    from planetnav_env.sensors.camera_kernels import COB_UNIFORM_DISK

    env = PlanetNavEnv(_cfg("planetnav/Cruise-Target-v2").at_physics_step())
    agent = make_agent("greedy:bias=expected", env)
    obs, info = env.reset(seed=3)
    # The spacecraft on +x; the first planet seen at a right angle to its Sun line, the others on the x axis.
    s, d = 2.25e8, 1e5
    sc = np.array([s, 0.0, 0.0])
    u = np.array([-d / s, np.sqrt(1.0 - (d / s) ** 2), 0.0])  # sc . u = -d: (P - sc) is normal to P
    planets = np.array([sc + d * u, [s + d, 0.0, 0.0], [s - d, 0.0, 0.0]])
    monkeypatch.setattr(ParsedObservation, "planet_positions", lambda self, x: planets)
    monkeypatch.setattr(agent, "estimate", lambda o, i: np.array([*sc, 0.0, 0.0, 0.0]))
    scale = np.array([1.0, 0.5, 2.0])
    alpha = 2.0 * np.arcsin(agent._radii / d)
    want = scale * COB_UNIFORM_DISK * 0.5 * alpha * np.array([1.0, 0.0, 2.0])
    got = agent._offsets(parse_observation(obs, env), info, scale)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-15)


def test_greedy_weights_follow_the_image_log_and_the_oracle():
    env = gym.make("planetnav/Cruise-Target-v2").unwrapped
    env = PlanetNavEnv(env.config.at_physics_step())
    adaptive = make_agent("greedy:success=observed", env)
    oracle = make_agent("greedy:success=oracle", env)
    obs, info = env.reset(seed=4)
    for k in range(120):
        obs, _, _, _, info = env.step(k // 40)
    parsed = adaptive.env.unwrapped.decode_observation(obs)
    from planetnav_agents.base import parse_observation

    p = parse_observation(obs, env)
    np.testing.assert_allclose(adaptive.planet_weights(p, info), parsed["image_log"][0])
    np.testing.assert_array_equal(oracle.planet_weights(p, info), env.core.true_image_success()[0])


def test_second_stage_picks_among_the_finalists_on_fresh_seeds():
    first = {"random": 9.0, "schedule:a": 5.0, "schedule:b": 6.0, "schedule:c": 7.0}
    second = {"schedule:a": 8.0, "schedule:b": 6.5, "schedule:c": 6.9}  # a was flattered by its seeds
    calls = []

    def evaluate(spec, cfg, episodes, seed):
        calls.append((spec, episodes, seed))
        return np.full(episodes, (first if seed == 100 else second)[spec])

    res = B.search_blind(None, evaluate, 100, 30, candidates=list(first), finalists=3, final_episodes=50)
    assert res.winner == "schedule:b" and res.winner_mean == 6.5
    assert set(res.final) == {"schedule:a", "schedule:b", "schedule:c"}  # random was not a finalist
    assert {(s, n, seed) for s, n, seed in calls if seed != 100} == {
        (s, 50, 130) for s in ("schedule:a", "schedule:b", "schedule:c")
    }


def test_measure_compares_the_winners_search_and_evaluation_figures():
    rng = np.random.default_rng(3)
    second = {"schedule:a": 10 + rng.normal(0, 1, 60), "schedule:b": 12 + rng.normal(0, 1, 60)}
    evals = {"schedule:a": 10 + rng.normal(0, 1, 80), "greedy": 8 + rng.normal(0, 1, 80)}

    def evaluate(spec, cfg, episodes, seed):
        if seed == 0:
            return np.full(episodes, {"schedule:a": 11.0, "schedule:b": 11.5}[spec])
        return second[spec] if seed == 20 else evals[spec]

    res = B.search_blind(None, evaluate, 0, 20, candidates=["schedule:a", "schedule:b"], final_episodes=60)
    assert res.winner == "schedule:a" and np.allclose(res.winner_values, second["schedule:a"])
    rec = B.measure_task(None, res, ["greedy"], [], evaluate, 7, 80)
    agree = rec["winner_search_minus_eval"]
    assert agree["lo"] < agree["difference"] < agree["hi"] and agree["holds_0"]  # same law, other seeds
    evals["schedule:a"] = evals["schedule:a"] + 3.0  # the search flattered it: the interval leaves 0
    flattered = B.measure_task(None, res, ["greedy"], [], evaluate, 7, 80)
    assert not flattered["winner_search_minus_eval"]["holds_0"]


def test_blind_search_and_regime_map_commands_end_to_end(tmp_path, capsys, research_command):
    """The two research commands on 20-step episodes: the JSON holds the search, the winner, the gap and
    the roles; the regime map writes its points and a figure."""
    import json

    out = tmp_path / "blind.json"
    short = ["--option", "episode_steps=20"]
    blind_search, regime_map = research_command("blind_search").main, research_command("regime_map").main
    assert blind_search(["--tasks", "Cruise-Target-v2", "--search-episodes", "2", "--finalists", "2",
                 "--final-episodes", "2", "--episodes", "3", "--references", "greedy", "--privileged",
                 "--no-progress", "--json", str(out), *short]) == 0  # fmt: skip
    rec = json.loads(out.read_text())["tasks"]["Cruise-Target-v2 episode_steps=20"]
    assert rec["blind_winner"] in rec["blind_search"]["finalists"]
    family = B.blind_candidates(_cfg("planetnav/Cruise-Target-v2"))
    assert len(rec["blind_search"]["candidates"]) == len(family)
    assert rec["agents"]["greedy"]["role"] == "reference" and len(rec["agents"]["greedy"]["per_seed"]) == 3
    assert "closed-loop gap" in capsys.readouterr().out
    png, js = tmp_path / "map.png", tmp_path / "map.json"
    assert regime_map(["--task", "Cruise-Target-v2", "--strengths", "0", "1", "--agents", "greedy",
                 "--candidates", "random", "schedule:targets=0-1,steps=10", "--search-episodes", "2",
                 "--final-episodes", "0", "--episodes", "2", "--json", str(js), "--plot", str(png),
                 *short]) == 0  # fmt: skip
    data = json.loads(js.read_text())
    assert [p["strength"] for p in data["points"]] == [0.0, 1.0] and png.stat().st_size > 10_000
    assert set(data["points"][0]["agents"]) == {"blind", "greedy"}


def test_zero_agent_holds_the_wheels():
    env = PlanetNavEnv(_cfg("planetnav/Cruise-Torque-v2").at_physics_step())
    a = make_agent("zero", env)
    obs, info = env.reset(seed=0)
    act = a.act(obs, info)
    assert act.shape == env.action_space.shape and not act.any()
    from planetnav_agents import not_applicable

    target = _cfg("planetnav/Cruise-Target-v1")
    assert "action_mode 'torque'" in not_applicable("zero", target)
    with pytest.raises(ValueError, match="needs action_mode 'torque', got 'target'"):
        make_agent("zero", PlanetNavEnv(target.at_physics_step()))
