"""Environment conformance, seeding, rendering, bad input, physics sanity."""

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS, id_options
from planetnav_env.errors import ConfigError, InvalidParameterError, NonFiniteError, UnknownOptionError

SHORT = {"episode_steps": 50}


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_registered_ids_pass_gymnasium_and_sb3_checkers(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **SHORT)
    gym_check_env(env.unwrapped, skip_render_check=False)
    # SB3 is the [train] extra (the environment alone does not need it): its checker runs where it is.
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(gym.make(env_id, **SHORT).unwrapped, warn=True)


def test_dict_observation_variant_passes_checker():
    env = PlanetNavEnv(observation="dict", **SHORT)
    gym_check_env(env)
    obs, _ = env.reset(seed=1)
    assert set(obs) == set(env.observation_space.spaces)
    box = PlanetNavEnv(**SHORT)
    flat, _ = box.reset(seed=1)
    np.testing.assert_array_equal(np.concatenate([np.ravel(v) for v in obs.values()]), flat)


@pytest.mark.parametrize(
    ("env_id", "steps"),
    [
        ("planetnav/Cruise-Target-v0", 1100),
        ("planetnav/Cruise-TargetTorque-v0", 1100),
        ("planetnav/MarsApproach-Tasking-v0", 1128),
    ],
)
def test_seeding_is_bit_for_bit_reproducible(env_id, steps):
    def rollout():
        env = gym.make(env_id, episode_steps=steps)
        env.action_space.seed(123)
        obs, info = env.reset(seed=7)
        frames = [obs.tobytes()]
        rewards, infos = [], []
        for _ in range(1000):
            obs, r, term, trunc, info = env.step(env.action_space.sample())
            frames.append(obs.tobytes())
            rewards.append(r)
            infos.append(
                (info["pos_err_km"], info["nees"], info["measured"], info["rejected"], info["target"])
            )
            if term or trunc:
                break
        return frames, rewards, infos

    a, b = rollout(), rollout()
    assert len(a[0]) > 1000
    assert a[0] == b[0] and a[1] == b[1] and a[2] == b[2]
    # A different seed gives a different episode.
    env = gym.make(env_id)
    o1, _ = env.reset(seed=7)
    o2, _ = env.reset(seed=8)
    assert o1.tobytes() != o2.tobytes()


def test_vector_entry_point():
    vec = gym.make_vec(
        "planetnav/Cruise-Target-v0", num_envs=3, vectorization_mode="vector_entry_point", **SHORT
    )
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (3, *gym.make("planetnav/Cruise-Target-v0").observation_space.shape)
    obs, rew, _, _, _ = vec.step(np.array([0, 1, 2]))
    assert rew.shape == (3,) and np.all(np.isfinite(rew))


def test_target_mode_points_camera_and_measures():
    env = PlanetNavEnv(episode_steps=200)
    env.reset(seed=0)
    measured = []
    for _ in range(60):
        _, _, _, _, info = env.step(0)
        measured.append(info["measured"])
    # A slew from a random attitude completes well inside an hour; then every step measures.
    assert all(measured[-20:])
    assert info["target"] == "venus" and info["visibility"] == "visible"
    # The star tracker's attitude error is arcseconds.
    assert info["attitude_err_arcsec"] < 60.0


def test_bad_actions_raise_and_never_reach_the_physics():
    env = PlanetNavEnv(**SHORT)
    env.reset(seed=0)
    before = env.truth
    with pytest.raises(InvalidParameterError, match="integer in"):
        env.step(5)
    with pytest.raises(InvalidParameterError, match="integer in"):
        env.step(-1)
    with pytest.raises(NonFiniteError):
        env.step(np.nan)
    with pytest.raises(InvalidParameterError):
        env.step(1.5)
    after = env.truth
    for k in before:
        np.testing.assert_array_equal(before[k], after[k])
    tenv = PlanetNavEnv(action_mode="torque", **SHORT)
    tenv.reset(seed=0)
    with pytest.raises(NonFiniteError, match="NaN"):
        tenv.step(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(NonFiniteError):
        tenv.step(np.array([np.inf, 0.0, 0.0]))
    with pytest.raises(InvalidParameterError, match="shape"):
        tenv.step(np.zeros(4))
    # Out-of-range Box actions are clipped (documented): same result as the clipped action.
    a, b = PlanetNavEnv(action_mode="torque", **SHORT), PlanetNavEnv(action_mode="torque", **SHORT)
    a.reset(seed=4)
    b.reset(seed=4)
    oa = a.step(np.array([5.0, -3.0, 0.5]))[0]
    ob = b.step(np.array([1.0, -1.0, 0.5]))[0]
    np.testing.assert_array_equal(oa, ob)
    assert np.all(np.isfinite(oa))


def test_episode_end_and_step_before_reset():
    env = PlanetNavEnv(episode_steps=3)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset(seed=0)
    for _ in range(2):
        assert not env.step(0)[3]
    assert env.step(0)[3]  # truncated
    with pytest.raises(RuntimeError, match="ended"):
        env.step(0)


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="bogus_key"):
        PlanetNavEnv(bogus_key=1)
    with pytest.raises(ConfigError, match="step_s"):
        PlanetNavEnv(step_s=-1)
    with pytest.raises(ConfigError, match="pluto"):
        PlanetNavEnv(planets=["venus", "pluto"])
    with pytest.raises(ConfigError, match="focal_length"):
        EnvConfig.from_dict({"camera": {"focal_length_mm": 0}})
    with pytest.raises(ConfigError, match=r"camera\.'pixels'"):
        EnvConfig.from_dict({"camera": {"pixels": 3}})
    with pytest.raises(ConfigError, match="divide"):
        PlanetNavEnv(step_s=60, attitude_substep_s=7)
    with pytest.raises(ConfigError, match="action_mode"):
        PlanetNavEnv(action_mode="dance")


def test_config_yaml_roundtrip(tmp_path):
    import yaml

    cfg = EnvConfig.from_dict({"planets": ["venus", "mars"], "filter": {"sigma_pos0": 500.0}, "step_s": 30})
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({"env": cfg.to_dict()}))
    assert EnvConfig.from_yaml(path) == cfg


def test_idle_action_never_measures():
    env = PlanetNavEnv(idle_action=True, **SHORT)
    env.reset(seed=0)
    assert env.action_space.n == env.config.n_planets + 1
    for _ in range(20):
        _, _, _, _, info = env.step(env.config.n_planets)
        assert not info["measured"] and info["target"] is None


def test_mars_approach_sensor_tasking_matters():
    env = gym.make("planetnav/MarsApproach-Tasking-v0").unwrapped
    assert env.action_space.n == 3 and env.config.pulsars == ("B0531+21", "B1937+21")

    def run(policy, steps=400):
        env.reset(seed=2)
        for k in range(steps):
            _, _, term, _, info = env.step(policy(k))
            assert not term
        return info

    optical = run(lambda k: 0)
    crab = run(lambda k: 1)
    hybrid = run(lambda k: 0 if (k // 24) % 2 == 0 else 1)
    # Pulsar phases arrive once per integration time (1000 s = 4 steps of 300 s).
    assert crab["sensor"] in (None, "xray")
    # Mixing both sensors shrinks the filter's uncertainty below either alone (measured ~x3).
    assert hybrid["pos_sigma_km"] < 0.7 * min(optical["pos_sigma_km"], crab["pos_sigma_km"])
    # B1937+21's 467 km cycle cannot be resolved from the 100 km prior alone: skipped and counted.
    ms = run(lambda k: 2, steps=40)
    assert ms["ambiguous_skipped"] >= 1 and not ms["measured"]


def test_sun_blocked_pulsar_is_reported_not_measured():
    # B1821-24 is ~11 deg from the Sun seen from Mars in February 2021 (inside the 30 deg cone).
    env = PlanetNavEnv(
        scenario="mars-approach", planets=["mars"], pulsars=["B1821-24"], step_s=300.0, episode_steps=40
    )
    env.reset(seed=0)
    for _ in range(12):
        _, _, _, _, info = env.step(1)
        assert not info["measured"]
    assert info["visibility"] == "sun_exclusion"
    with pytest.raises(ConfigError, match="J9999"):
        PlanetNavEnv(scenario="mars-approach", planets=["mars"], pulsars=["J9999+99"])
    with pytest.raises(ConfigError, match="area_cm2"):
        PlanetNavEnv(detector={"area_cm2": -1.0})


SCENARIO_FILES = sorted((Path(__file__).resolve().parents[2] / "configs" / "scenarios").glob("*.yaml"))


def test_scenario_config_files_exist():
    assert {p.stem for p in SCENARIO_FILES} >= {"cruise", "random_cruise", "mars_approach"}


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.stem)
def test_scenario_configs_load_and_run(path):
    cfg = EnvConfig.from_yaml(path)
    env = PlanetNavEnv(cfg, episode_steps=5)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(0)
    assert np.isfinite(reward) and info["time_s"] > 0
    if cfg.scenario == "cruise":
        # The scenario file spells out the registered default environment.
        assert cfg == gym.make("planetnav/Cruise-Target-v0").unwrapped.config


def test_star_tracker_attitude_error_reaches_navigation():
    """The camera's line of sight is rotated to inertial with the star tracker's attitude, not the truth:
    a 20" attitude bias (identical random streams otherwise) shifts the estimate across the line of sight
    by ~20" x range."""
    from planetnav_env.attitude import quaternion as qt
    from planetnav_env.core import layout as L

    bias_rad = 20.0 / 206264.806

    def run(biased):
        # The bias rotates the fix about body z, which swings the boresight (body x).
        bias = (0.0, 0.0, 20.0) if biased else (0.0, 0.0, 0.0)
        env = PlanetNavEnv(star_tracker="ideal", episode_steps=400, star_tracker_bias_arcsec=bias)
        _, info = env.reset(seed=3)
        if biased:  # the configured bias is the Hamilton product q * tilt (quaternion.multiply's oracle)
            tilt = qt.from_axis_angle([0.0, 0.0, 1.0], bias_rad)
            np.testing.assert_allclose(
                env.core.f[0, L.F_QE : L.F_QE + 4], qt.multiply(env.truth["q"], tilt), atol=1e-15
            )
        for _ in range(400):
            _, _, _, _, info = env.step(0)  # Venus
        return env, info["filter"]["x"][:3]

    env, r_ideal = run(False)
    _, r_biased = run(True)
    venus = env.body_positions()["planets"][0] - r_ideal
    rng_km = np.linalg.norm(venus)
    u = venus / rng_km
    shift = r_biased - r_ideal
    across = np.linalg.norm(shift - (shift @ u) * u)
    assert 0.7 * bias_rad * rng_km < across < 1.3 * bias_rad * rng_km


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_unknown_option_is_a_type_error_worded_like_python(env_id):
    """TorchRL's GymEnv passes ``frameskip`` and retries without it only on a TypeError worded like
    Python's: an unknown option must be that TypeError, and still a ConfigError naming the option."""
    with pytest.raises(TypeError, match="got an unexpected keyword argument 'frameskip'") as err:
        gym.make(env_id, frameskip=4)
    assert isinstance(err.value, UnknownOptionError) and isinstance(err.value, ConfigError)
    with pytest.raises(UnknownOptionError, match="'episode_steps'"):  # Gymnasium's name gets a hint
        PlanetNavEnv(max_episode_steps=10)


def test_spec_reports_the_episode_length_without_a_time_limit():
    """``env.spec.max_episode_steps`` is the env's own truncation step, per id and after an override;
    no Gymnasium TimeLimit is added (a second counter would cut an episode longer than the registered
    one)."""
    for env_id, options in ENV_IDS.items():
        steps = options.get("episode_steps", EnvConfig().episode_steps)
        want = -(-steps // options.get("decision_steps", 1))  # decisions: a -v1 id holds each several steps
        env = gym.make(env_id)
        assert env.spec.max_episode_steps == want and env.unwrapped.spec.max_episode_steps == want
        wrapper = env
        while isinstance(wrapper, gym.Wrapper):
            assert not isinstance(wrapper, gym.wrappers.TimeLimit), env_id
            wrapper = wrapper.env
    assert ENV_IDS["planetnav/MarsApproach-Tasking-v0"]["episode_steps"] == 1128  # ids differ: per id
    env = gym.make("planetnav/Cruise-Target-v0", episode_steps=3)
    assert env.spec.max_episode_steps == 3
    env.reset(seed=0)
    assert [env.step(0)[3] for _ in range(3)] == [False, False, True]
    # A hold that the episode's end cuts short: 25 physics steps in decisions of 10 are 3 decisions.
    env = gym.make("planetnav/Cruise-Target-v1", episode_steps=25)
    assert env.spec.max_episode_steps == 3
    env.reset(seed=0)
    ends = [(env.step(0), len(env.unwrapped.held["pos_err_km"])) for _ in range(3)]
    assert [(e[3], k) for e, k in ends] == [(False, 10), (False, 10), (True, 5)]
    assert len(env.unwrapped.history) == 26  # the reset's and each physics step's


def test_env_accepts_a_registered_id_as_config():
    """``PlanetNavEnv(id)`` has the options ``gym.make(id)`` passes; other strings are named."""
    env = PlanetNavEnv("planetnav/MarsApproach-Tasking-v0", episode_steps=5)
    assert env.config == gym.make("planetnav/MarsApproach-Tasking-v0", episode_steps=5).unwrapped.config
    assert PlanetNavEnv("planetnav_env:planetnav/Cruise-Torque-v0").config.action_mode == "torque"
    with pytest.raises(ConfigError, match="'planetnav/Nope-v0'"):
        PlanetNavEnv("planetnav/Nope-v0")
    with pytest.raises(ConfigError, match="'CartPole-v1' is not a planetnav environment"):
        PlanetNavEnv("CartPole-v1")
    with pytest.raises(ConfigError, match="got 5 of type int"):
        PlanetNavEnv(5)


def test_make_merges_a_partial_nested_override_into_the_ids_options():
    """``gym.make(id, world={...})`` changes the named world options of the id's world and keeps the
    rest (its preset); gym.make's own shallow update of the spec's kwargs would drop them."""
    env_id = "planetnav/Cruise-Target-v3"
    made = gym.make(env_id, world={"boresight_drift": False}).unwrapped.config
    direct = EnvConfig.from_dict(id_options(env_id), world={"boresight_drift": False})
    assert made == direct
    assert (made.world.preset, made.world.boresight_drift) == ("flight", False)
    assert gym.make(env_id).unwrapped.config.world.boresight_drift is None  # the id itself unchanged
    vec = gym.make_vec(env_id, num_envs=2, world={"drift_sigma_arcsec": 0.5})
    assert (vec.config.world.preset, vec.config.world.drift_sigma_arcsec) == ("flight", 0.5)
    vec.close()
    # Any section alike: the id's filter prior (50 km, not the default 1,000 km) survives one key's override.
    v2 = gym.make("planetnav/RandomCruise-Target-v2", filter={"accel_psd": 1e-12}).unwrapped.config.filter
    assert (v2.sigma_pos0, v2.accel_psd) == (50.0, 1e-12)
    assert EnvConfig().filter.sigma_pos0 != 50.0


def test_single_env_bad_input_names_the_value_not_a_row():
    """The single env's errors name the bad value in its own words (no "row 0", no "no row was
    stepped"), blame a str's type rather than a shape, and reject an unknown reset option by name."""
    env = PlanetNavEnv(**SHORT)
    env.reset(seed=0)
    cases = [
        ("1", InvalidParameterError, "got '1' of type str"),
        (None, InvalidParameterError, "got None of type NoneType"),
        (np.nan, NonFiniteError, "action is not finite: nan"),
        (1.5, InvalidParameterError, "must be an integer in [0, 3), got 1.5"),
        (np.array([4]), InvalidParameterError, "must be an integer in [0, 3), got 4"),
        ([0, 1], InvalidParameterError, "one integer in [0, 3), got shape (2,)"),
    ]
    tenv = PlanetNavEnv(action_mode="torque", **SHORT)
    tenv.reset(seed=0)
    torque_cases = [
        ("1", InvalidParameterError, "must be numbers of shape (3,), got '1' of type str"),
        ([0.0, np.nan, 0.0], NonFiniteError, "action contains NaN or infinite values: [0.0, nan, 0.0]"),
        ([1.0, 2.0], InvalidParameterError, "action must have shape (3,), got shape (2,)"),
    ]
    for e, table in ((env, cases), (tenv, torque_cases)):
        for action, kind, text in table:
            with pytest.raises(kind) as err:
                e.step(action)
            assert text in str(err.value) and "row" not in str(err.value), (action, str(err.value))
    with pytest.raises(InvalidParameterError, match=r"option\(s\) \['foo'\]; it takes no reset options"):
        env.reset(options={"foo": 1})
    with pytest.raises(InvalidParameterError, match="must be a dict or None, got 'foo'"):
        env.reset(options="foo")
    assert env.reset(seed=0, options={})[1]["time_s"] == env.reset(seed=0)[1]["time_s"]
