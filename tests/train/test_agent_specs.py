"""Agent specs (``name:key=value``), the periodic and planner agents, observation features, shaping."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from planetnav_agents import (
    AGENTS,
    NotApplicableError,
    PeriodicAgent,
    PlannerAgent,
    make_agent,
    not_applicable,
    parse_spec,
    requires_idle_action,
)
from planetnav_agents.base import with_planet_choice
from planetnav_agents.periodic import parse_cycle
from planetnav_env.config import EnvConfig
from planetnav_env.core.decisions import relative_to_absolute
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.errors import ConfigError
from planetnav_train.batch_wrappers import PointingShapingRows, SingleEnvRows, single_training_env
from planetnav_train.features import FeatureBatch, check_features


def _run(agent, env: PlanetNavEnv, seed: int) -> tuple[list[str | None], list[float], list[float]]:
    """(targets, pos_err, pos_sigma) of one episode."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    targets, err, sig = [], [], []
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        targets.append(info["target"])
        err.append(info["pos_err_km"])
        sig.append(info["pos_sigma_km"])
        done = terminated or truncated
    return targets, err, sig


def test_parse_spec_values_and_errors() -> None:
    assert parse_spec("greedy") == ("greedy", {})
    assert parse_spec("periodic:period=30,cycle=0-1") == ("periodic", {"period": 30, "cycle": "0-1"})
    assert parse_spec("planner:horizon=20, replan=5") == ("planner", {"horizon": 20, "replan": 5})
    assert parse_spec("periodic:skip_invisible=false")[1] == {"skip_invisible": False}
    # Not a registered name: a model path (which may hold ':' or '@sampled'), untouched.
    assert parse_spec("runs/x:y/model.zip@sampled") == ("runs/x:y/model.zip@sampled", {})
    with pytest.raises(ValueError, match=r"unknown parameter 'perod'.*\['period', 'cycle'"):
        parse_spec("periodic:perod=3")
    with pytest.raises(ValueError, match="'period' given twice"):
        parse_spec("periodic:period=3,period=4")
    with pytest.raises(ValueError, match="'period' is not key=value"):
        parse_spec("periodic:period")
    with pytest.raises(ValueError, match="unknown parameter 'criterion'"):
        parse_spec("baseline:criterion=size")  # fixed by the registered name


def test_periodic_schedule_and_validation() -> None:
    env = PlanetNavEnv(episode_steps=12)
    agent = make_agent("periodic:period=3,cycle=venus-earth", env)
    assert isinstance(agent, PeriodicAgent) and agent.name == "periodic:period=3,cycle=0-2"
    targets, _, _ = _run(agent, env, seed=10_000)
    # All three planets are observable in the default cruise: the schedule is followed exactly.
    assert targets == ["venus"] * 3 + ["earth"] * 3 + ["venus"] * 3 + ["earth"] * 3
    assert parse_cycle("0-1-0-2", env.planets) == (0, 1, 0, 2)
    assert parse_cycle([2, "mars"], env.planets) == (2, 1)
    for bad, named in (("0-3", "'3'"), ("venus-pluto", "'pluto'"), ("0--1", "empty")):
        with pytest.raises(ValueError, match=named):
            parse_cycle(bad, env.planets)
    for period in (0, -5, 2.5, True):
        with pytest.raises(ValueError, match=f"period must be an integer.*{period!r}"):
            PeriodicAgent(env, period=period)


def test_every_agent_spec_in_every_action_mode() -> None:
    """Each registered agent either acts validly or is reported not applicable (never a crash)."""
    for mode in ("target", "torque", "target+torque"):
        cfg = EnvConfig.from_dict({"action_mode": mode, "episode_steps": 3})
        for name in sorted(AGENTS):
            reason = not_applicable(name, cfg)
            if reason is not None:
                needs = {"idle": "target", "zero": "torque"}
                assert name in needs and mode != needs[name] and f"action_mode '{needs[name]}'" in reason
                continue
            env = PlanetNavEnv(cfg, idle_action=requires_idle_action(name))
            agent = make_agent(name if name != "planner" else "planner:horizon=2,replan=1", env)
            _, err, _ = _run(agent, env, seed=1)
            assert len(err) == 3 and np.all(np.isfinite(err))


def test_planner_leaves_the_real_environment_untouched() -> None:
    """The planner simulates on deep copies with its own noise stream: the real episode is bit-for-bit
    the one that the same actions give without the planner's simulations."""
    env = PlanetNavEnv(episode_steps=30)
    planner = PlannerAgent(env, horizon=10, replan=5)
    planner.reset(seed=3)
    obs, info = env.reset(seed=3)
    actions, trace = [], []
    for _ in range(30):
        a = planner.act(obs, info)
        actions.append(a)
        obs, _, _, _, info = env.step(a)
        trace.append(info["filter"]["x"].copy())
    assert planner.rollout_steps > 0 and len(set(actions)) >= 2
    replay = PlanetNavEnv(episode_steps=30)
    replay.reset(seed=3)
    for a, x in zip(actions, trace, strict=True):
        _, _, _, _, info = replay.step(a)
        np.testing.assert_array_equal(info["filter"]["x"], x)


def test_planner_parameters_are_validated() -> None:
    env = PlanetNavEnv(episode_steps=5)
    with pytest.raises(ValueError, match="replan"):
        PlannerAgent(env, horizon=5, replan=10)
    with pytest.raises(ValueError, match="horizon"):
        make_agent("planner:horizon=0", env)
    assert make_agent("planner:horizon=20,replan=5", env).name.startswith("planner:horizon=20,replan=5")
    # Agents with parameters are named by their spec, so two settings never share a row of a report.
    assert make_agent("greedy:horizon=10", env).name == "greedy:horizon=10"
    assert make_agent("greedy", env).name == "greedy"


def test_features_and_the_since_measured_block() -> None:
    """The ``gain`` feature appended after the env's ``since_measured`` block; ``since_measured`` as a
    feature names the env option."""
    assert check_features(["gain"]) == ("gain",)
    with pytest.raises(ValueError, match="'since'"):
        check_features(["since"])
    with pytest.raises(ConfigError, match="set env option observe_since_measured=true"):
        check_features(["since_measured"])
    env = single_training_env(PlanetNavEnv(episode_steps=20, observe_since_measured=True), features=["gain"])
    obs, _ = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape == (PlanetNavEnv().observation_space.shape[0] + 6,)
    assert np.all(obs[-6:-3] == 1.0)  # nothing measured yet
    measured_steps = 0
    for _ in range(8):
        obs, _, _, _, info = env.step(0)
        measured_steps += info["measured"]
        if info["measured"]:
            assert obs[-6] == 0.0 and obs[-5] == 1.0  # Venus just measured, Mars never
    assert measured_steps >= 3
    gains = obs[-3:]
    # All observable: relative to the best planet's reduction, which is 1 (greedy's choice).
    assert np.all((gains > 0) & (gains <= 1)) and gains.max() == 1.0


def test_sb3_agent_rebuilds_the_features_of_its_run(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    features = ["gain"]
    train_env = single_training_env(PlanetNavEnv(episode_steps=20), features=features)
    model = PPO("MlpPolicy", train_env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(32)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo", "features": features}))
    env = PlanetNavEnv(episode_steps=20)
    agent = make_agent(str(run), env)
    state = FeatureBatch.for_env(env, features)
    agent.reset(seed=4)
    obs, info = env.reset(seed=4)
    for _ in range(6):
        expected, _ = model.predict(state.augment_info(obs, info), deterministic=True)
        action = agent.act(obs, info)
        assert action == int(expected)
        obs, _, _, _, info = env.step(action)
    # A model for other spaces is "not applicable" (a ValueError the harness turns into a skipped row).
    with pytest.raises(NotApplicableError):
        make_agent(str(run), PlanetNavEnv(episode_steps=5, action_mode="torque"))


def test_pointing_shaping_is_potential_based() -> None:
    """The shaping terms telescope: their discounted sum is gamma^T Phi(s_T) - Phi(s_0)."""
    gamma = 0.9
    env = single_training_env(PlanetNavEnv(episode_steps=15, action_mode="torque"), pointing=1.0, gamma=gamma)

    def potential(o: np.ndarray) -> float:
        return float(env.rows.potential(np.asarray(o)[None])[0])

    obs, _ = env.reset(seed=2)
    phi0 = potential(obs)
    rng = np.random.default_rng(0)
    total, t = 0.0, 0
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
        total += gamma**t * info["shaping"]
        t += 1
        done = terminated or truncated
    assert total == pytest.approx(gamma**t * potential(obs) - phi0, abs=1e-12)
    assert -1.0 <= phi0 <= 1.0
    with pytest.raises(ValueError, match="weight"):
        PointingShapingRows(SingleEnvRows(PlanetNavEnv(episode_steps=5)), 0.0, 0.9)


def test_pointing_shaping_is_potential_based_between_decisions_under_the_hold() -> None:
    """With the env's hold of k physics steps the shaping is taken between decisions (discounted by the
    decision's gamma): the decision-level terms telescope, and each equals gamma Phi(s') - Phi(s) of the
    observations the agent sees."""
    from planetnav_train.shaping import PointingPotential

    gamma = 0.9
    raw = PlanetNavEnv(episode_steps=20, action_mode="torque", decision_steps=4)
    env = single_training_env(raw, features=("pd_torque",), pointing=1.0, gamma=gamma)
    potential = PointingPotential(raw.config, 1.0)

    def phi(o: np.ndarray) -> float:
        return float(potential(np.asarray(o)[None, : raw.observation_space.shape[0]])[0])

    obs, _ = env.reset(seed=2)
    phi0 = previous = phi(obs)
    rng = np.random.default_rng(0)
    total, t, done = 0.0, 0, False
    while not done:
        obs, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
        now = 0.0 if terminated else phi(obs)
        assert info["shaping"] == pytest.approx(gamma * now - previous, abs=1e-12)
        total += gamma**t * info["shaping"]
        previous, t, done = now, t + 1, terminated or truncated
    assert t == 5  # 20 physics steps, 4 per decision
    assert total == pytest.approx(gamma**t * previous - phi0, abs=1e-12)


def test_sb3_agent_acts_in_the_envs_decision_interface(tmp_path: Path) -> None:
    """A model trained on an env that holds decisions 3 physics steps acts once per step of that env; a run
    whose config.yaml still holds the training-side action_repeat names the env option."""
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", PlanetNavEnv(episode_steps=30, decision_steps=3), n_steps=32, batch_size=32,
                n_epochs=1, seed=0, device="cpu")  # fmt: skip
    model.learn(32)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo", "env": {"decision_steps": 3}}))
    env = PlanetNavEnv(episode_steps=30, decision_steps=3)
    agent = make_agent(str(run), env)
    agent.reset(seed=1)
    obs, info = env.reset(seed=1)
    for _ in range(10):
        action = agent.act(obs, info)
        assert action == int(model.predict(obs, deterministic=True)[0])
        obs, _, _, truncated, info = env.step(action)
    assert truncated  # 10 decisions of 3 steps: the 30-step episode
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo", "action_repeat": 3}))
    with pytest.raises(ConfigError, match="action_repeat is no longer a training option: set env option "
                       "decision_steps=3"):  # fmt: skip
        make_agent(str(run), env)
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo", "relative_actions": True}))
    with pytest.raises(ConfigError, match="set env option target_actions='relative'"):
        make_agent(str(run), env)
    # The no-op values every older config.yaml holds pass: the model acts as before.
    (run / "config.yaml").write_text(
        yaml.safe_dump({"algo": "ppo", "action_repeat": 1, "relative_actions": False, "features": []})
    )
    obs, info = env.reset(seed=1)
    assert make_agent(str(run), env).act(obs, info) == int(model.predict(obs, deterministic=True)[0])


def test_relative_target_actions(tmp_path: Path) -> None:
    """The env's relative targets count from its current target (from target 0 after a reset); a model
    trained on them acts in a target+torque env (absolute targets) on that env's current target."""
    from stable_baselines3 import PPO

    assert [relative_to_absolute(a, -1, 3) for a in range(3)] == [0, 1, 2]
    assert relative_to_absolute(2, 1, 3) == 0 and relative_to_absolute(0, 2, 3) == 2
    with pytest.raises(ValueError, match="relative action"):
        relative_to_absolute(3, 0, 3)
    env = PlanetNavEnv(episode_steps=10, target_actions="relative")
    env.reset(seed=0)
    assert [env.step(a)[-1]["target"] for a in (1, 0, 2, 1)] == ["mars", "mars", "venus", "mars"]
    with pytest.raises(ConfigError, match="target_actions 'relative' needs action_mode 'target'"):
        PlanetNavEnv(episode_steps=5, action_mode="torque", target_actions="relative")
    rel = {"episode_steps": 30, "decision_steps": 2, "target_actions": "relative"}
    train_env = PlanetNavEnv(**rel)
    model = PPO("MlpPolicy", train_env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(32)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo", "env": rel}))
    tt = PlanetNavEnv(episode_steps=30, decision_steps=2, action_mode="target+torque")
    agent = make_agent(str(run), tt)
    agent.reset(seed=6)
    obs_e, _ = train_env.reset(seed=6)
    obs, info = tt.reset(seed=6)
    targets = set()
    for _ in range(15):  # decisions
        rel_action = int(model.predict(obs_e, deterministic=True)[0])
        obs_e, _, _, _, info_e = train_env.step(rel_action)
        action = agent.act(obs, info)
        assert action.shape == (6,) and np.all(action[3:] == 0.0)
        obs, _, _, _, info = tt.step(action)
        assert info["target"] == info_e["target"] and info["pos_err_km"] == info_e["pos_err_km"]
        targets.add(info["target"])
    assert len(targets) >= 2  # the translation was exercised through switches


def test_behaviour_cloning_copies_the_teacher() -> None:
    """A policy cloned from the baseline's torque-mode demonstrations reproduces its actions closely."""
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import clone, demonstrations

    cfg = EnvConfig.from_dict({"action_mode": "torque", "episode_steps": 60})
    obs, actions = demonstrations(cfg, "baseline", 2, ["pd_torque"])
    assert obs.shape == (120, PlanetNavEnv(cfg).observation_space.shape[0] + 9) and actions.shape == (120, 3)
    env = single_training_env(PlanetNavEnv(cfg), features=["pd_torque"])
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, seed=0, device="cpu")
    before = np.abs(model.predict(obs, deterministic=True)[0] - actions).mean()
    nll = clone(model, obs, actions, epochs=200)
    after = np.abs(model.predict(obs, deterministic=True)[0] - actions).mean()
    # Measured: mean |error| 0.0061 before, 0.00096 after (baseline's mean |torque|: 0.0049 of the limit).
    assert np.isfinite(nll) and after < 0.5 * before


def _decision_config(mode: str, **more) -> EnvConfig:
    """The training env of the demonstration tests: 25 physics steps in holds of 3, since_measured, and
    relative targets in target mode."""
    relative = {"target_actions": "relative"} if mode == "target" else {}
    return EnvConfig.from_dict(
        {"action_mode": mode, "episode_steps": 25, "decision_steps": 3, "observe_since_measured": True,
         **relative, **more}
    )  # fmt: skip


@pytest.mark.parametrize("mode", ["target", "target+torque"])
def test_demonstrations_are_recorded_in_the_training_mdp(mode: str) -> None:
    """The recorded (observation, action) pairs replay exactly in the training env (the env's hold,
    relative targets and since_measured, the gain feature on top): feeding the recorded actions reproduces
    the recorded observations bit for bit; the physics-step teacher's choices are encoded relative."""
    from planetnav_train.pretrain import DEMO_SEED, demonstrations, relative_label

    cfg = _decision_config(mode)
    features = ["gain"]
    obs, actions = demonstrations(cfg, "periodic:period=4", 1, features)
    assert len(obs) == 9  # ceil(25 / 3) decisions
    env = single_training_env(PlanetNavEnv(cfg), features=features)
    o, _ = env.reset(seed=DEMO_SEED)
    for k in range(len(obs)):
        np.testing.assert_array_equal(o, obs[k])
        o, _, terminated, truncated, _ = env.step(actions[k])
    assert terminated or truncated
    choice = actions if mode == "target" else np.argmax(actions[:, :3], axis=1)
    if mode == "target":  # relative encodings: stay (0) and switches both appear for a periodic teacher
        assert 0 in choice and np.any(choice > 0)
    else:
        assert len(set(choice.tolist())) >= 2
    # relative_label inverts the env's relative_to_absolute from every current target, including none.
    for current in (-1, 0, 1, 2):
        for target in range(3):
            assert relative_to_absolute(relative_label(target, current, 3), current, 3) == target
    with pytest.raises(ValueError, match="absolute target must be in"):
        relative_label(3, 0, 3)


@pytest.mark.parametrize("mode", ["target", "target+torque"])
def test_dagger_records_the_students_states_with_the_teachers_labels(mode: str) -> None:
    """With a ``student``, the student's decisions drive the episode (replaying them in the training env
    reproduces the recorded observations) and each label is the teacher's target at the decision's first
    physics step (the teacher sees every physics step), encoded relative to the target the student holds;
    ``dagger`` aggregates the rounds and refits."""
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import DEMO_SEED, dagger, demonstrations, relative_label

    cfg = _decision_config(mode)
    env = PlanetNavEnv(cfg)
    student = PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=3, device="cpu")
    teacher = "periodic:period=4,skip_invisible=false"  # its choice depends on the step count only
    obs, labels = demonstrations(cfg, teacher, 1, [], student=student)
    assert len(obs) == len(labels) == 9
    periodic = make_agent(teacher, PlanetNavEnv(cfg.at_physics_step()))
    o, info = env.reset(seed=DEMO_SEED)
    for k in range(len(obs)):
        np.testing.assert_array_equal(o, obs[k])
        chosen = periodic.cycle[periodic.scheduled(3 * k)]
        current = cfg.planets.index(info["target"]) if info["target"] in cfg.planets else -1
        if mode == "target":
            expected = relative_label(chosen, current, 3)
        else:
            expected = with_planet_choice(np.zeros((1, 6)), np.array([chosen]), 3)[0]
        np.testing.assert_array_equal(labels[k], expected)
        action = student.predict(o, deterministic=True)[0]
        o, _, terminated, truncated, info = env.step(action)
    assert terminated or truncated
    # The student's first decision is its own: it does not follow the teacher's.
    assert not np.array_equal(obs, demonstrations(cfg, teacher, 1, [])[0])
    all_obs, all_labels, nll = dagger(student, cfg, teacher, 2, 1, 5, [], (obs, labels))
    assert len(all_obs) == len(all_labels) == 27 and np.isfinite(nll)
    np.testing.assert_array_equal(all_obs[:9], obs)


def test_agreement_of_a_policy_with_itself_and_with_another_teacher(tmp_path: Path, research_command) -> None:
    """``agreement``: a relative-action policy labelled by itself (it acts in the training env, on the
    target the driver holds) never differs; labelled by a periodic schedule it differs at some decisions."""
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import DEMO_SEED, agreement, demonstrations

    options = {"episode_steps": 40, "decision_steps": 4, "target_actions": "relative",
               "observe_since_measured": True}  # fmt: skip
    cfg = EnvConfig.from_dict(options)
    env = PlanetNavEnv(cfg)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=1, device="cpu")
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    sidecar = {"algo": "ppo", "env": options}
    (run / "config.yaml").write_text(yaml.safe_dump(sidecar))
    itself = agreement(str(run), cfg, str(run), 2, DEMO_SEED)
    assert itself["decisions"] == 20 and itself["different"] == 0.0
    # Another policy labels the first one's states with its own relative choice there, counted from the
    # target the driver holds (the env's current target).
    other_model = PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=2, device="cpu")
    run2 = tmp_path / "run2"
    run2.mkdir()
    other_model.save(run2 / "model.zip")
    (run2 / "config.yaml").write_text(yaml.safe_dump(sidecar))
    obs, labels = demonstrations(cfg, str(run2), 3, [], student=model)
    np.testing.assert_array_equal(labels, other_model.predict(obs, deterministic=True)[0])
    assert np.any(labels != model.predict(obs, deterministic=True)[0])
    other = agreement(str(run), cfg, "periodic:period=8,skip_invisible=false", 2, DEMO_SEED)
    assert 0.0 < other["different"] < 1.0
    # The research command prints and writes the same figures (JSON without NaN: target mode has no residual).
    import json

    out = tmp_path / "agreement.json"
    teacher = "periodic:period=8,skip_invisible=false"
    args = ["--student", str(run), "--teacher", teacher, "--episodes", "2",
            "--seed", str(DEMO_SEED), "--episode-steps", "40", "--json", str(out)]  # fmt: skip
    assert research_command("agreement").main(args) == 0
    written = json.loads(out.read_text())
    assert written["different"] == other["different"] and written["mean_abs_residual"] is None
    with pytest.raises(ValueError, match="planet choices"):
        agreement(str(run), EnvConfig.from_dict({"action_mode": "torque"}), "baseline", 1, DEMO_SEED)


def test_target_policy_acts_in_target_torque_and_keep_std(tmp_path: Path) -> None:
    """A target-mode policy picks planets in a target+torque env (+1 on its choice, zero residual), as the
    teacher of the distilled target+torque config; ``keep_std`` clones the mean only."""
    import torch
    from stable_baselines3 import PPO

    from planetnav_train.pretrain import clone

    target_env = PlanetNavEnv(episode_steps=20)
    model = PPO("MlpPolicy", target_env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.save(tmp_path / "target.zip")
    tt_env = PlanetNavEnv(episode_steps=20, action_mode="target+torque")
    agent = make_agent(str(tmp_path / "target.zip"), tt_env)
    obs, info = tt_env.reset(seed=0)
    chosen = int(model.predict(obs, deterministic=True)[0])
    action = agent.act(obs, info)
    assert action.shape == (6,) and int(np.argmax(action[:3])) == chosen
    np.testing.assert_array_equal(action[3:], 0.0)
    assert tt_env.action_space.contains(action)
    # keep_std: the Gaussian's log std is the one before the fit; the mean moved to the teacher's actions.
    student = PPO("MlpPolicy", tt_env, n_steps=32, batch_size=32, seed=0, device="cpu")
    before = student.policy.log_std.detach().clone()
    demo_obs = np.repeat(obs[None].astype(np.float32), 64, axis=0)
    demo_act = np.repeat(action[None], 64, axis=0)
    clone(student, demo_obs, demo_act, epochs=50, keep_std=True)
    assert torch.equal(student.policy.log_std.detach(), before)
    mean = student.predict(obs, deterministic=True)[0]
    assert int(np.argmax(mean[:3])) == chosen and np.abs(mean[3:]).max() < 0.2
    clone(student, demo_obs, demo_act, epochs=50)
    assert float(student.policy.log_std.detach().max()) < float(before.max())
