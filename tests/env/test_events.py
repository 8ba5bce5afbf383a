"""Events the filter does not model: image-processing failures, the centre-of-brightness centroid bias and a
pulsar timing-model error.

Held to independent truth: the failure rate to the binomial law of the drawn probability; the centroid
offset formula to a brute-force centroid of the lit part of a uniformly bright sphere's disk; the logs the
observation carries to counts made from the infos; the timing error's effect on the estimate to the Kalman
gain times the phase error ``c delta t / lambda``, against an episode without it. The v0/v1 ids draw
nothing (their golden hashes, tests/env/test_golden.py, hold that bit for bit); the options leave the rest
of the episode as it was.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import RESIDUAL_CAP
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError, UnknownOptionError
from planetnav_env.sensors.camera_kernels import COB_UNIFORM_DISK, centroid_bias_kernel
from planetnav_env.sensors.pulsar import PULSARS, SPEED_OF_LIGHT_KM_S

V1 = ENV_IDS["planetnav/Cruise-Target-v1"]


def _physics_env(**options) -> PlanetNavEnv:
    return PlanetNavEnv(EnvConfig.from_dict({**V1, **options}).at_physics_step())


def _assert_same_episode(base: PlanetNavEnv, ev: PlanetNavEnv, columns=("X", "XE", "Q", "T0")) -> None:
    """The two envs' rows hold the same state ``columns`` and the same noise key: an option drawn after
    everything else left the rest of the episode as the same seed gives it without the option."""
    widths = {"X": 6, "XE": 6, "Q": 4, "T0": 1}
    for col in columns:
        a = L.F_OFFSETS[col][0]
        np.testing.assert_array_equal(base.core.f[0, a : a + widths[col]], ev.core.f[0, a : a + widths[col]])
    np.testing.assert_array_equal(base.core.rng, ev.core.rng)


def test_posing_v2_ids_change_only_the_posing():
    torque, arc = ENV_IDS["planetnav/Cruise-Torque-v1"], ENV_IDS["planetnav/ThrustArc-TCM-v1"]
    assert ENV_IDS["planetnav/Cruise-Torque-v2"] == {**torque, "torque_action_scale": 0.05}
    assert ENV_IDS["planetnav/ThrustArc-TCM-v2"] == {**arc, "decision_steps": 12}
    env = gym.make("planetnav/ThrustArc-TCM-v2")
    env.reset(seed=0)
    _, _, _, _, info = env.step(3)  # one decision: keep thrusting for a 2-h session
    assert info["time_s"] - env.unwrapped.core.f[0, L.F_T0] == pytest.approx(12 * 600.0)


def test_v2_ids_are_v1_plus_the_event_options():
    for name in ("Cruise-Target", "RandomCruise-Target", "MarsApproach-Tasking"):
        v1, v2 = ENV_IDS[f"planetnav/{name}-v1"], ENV_IDS[f"planetnav/{name}-v2"]
        extra = {k: v for k, v in v2.items() if v1.get(k, object()) != v}
        assert set(extra) <= {
            "image_success_min",
            "observe_image_log",
            "observe_residual_log",
            "filter",
            "prior_long_sigma_km",
            "observe_position_correlation",
        }
        assert extra


@pytest.mark.parametrize(
    "options",
    [
        {"image_success_min": 0.0},
        {"world": {"centroid_bias_max": 1.0}},
        {"image_success_min": 0.3, "world": {"centroid_bias_max": 0.5}},
    ],
)
def test_events_are_drawn_after_the_episode(options):
    """The same seed gives the same scenario, initial error, attitude and noise key with and without an
    event: its draws come last, so a paired comparison isolates the event."""
    base, ev = _physics_env(), _physics_env(**options)
    base.reset(seed=11)
    ev.reset(seed=11)
    _assert_same_episode(base, ev)
    drawn = ev.core.true_image_success()[0], ev.core.true_centroid_bias()[0]
    assert np.all((drawn[0] >= options.get("image_success_min", 1.0)) & (drawn[0] <= 1.0))
    top = options.get("world", {}).get("centroid_bias_max", 0.0)
    assert np.all((drawn[1] >= 0.0) & (drawn[1] <= top))


def test_image_failures_follow_the_drawn_probability_and_skip_the_update():
    env = _physics_env(image_success_min=0.0, observe_image_log=True, noise_streams="per_step")
    counts = np.zeros((2, 3))  # images in view, fixes
    for seed in range(3):
        env.reset(seed=100 + seed)
        p = env.core.true_image_success()[0]
        images = np.zeros(3)
        fixes = np.zeros(3)
        for k in range(600):
            _, _, _, _, info = env.step((k // 60) % 3)
            t = info["target_index"]
            if info["visibility"] == "image_failed":
                images[t] += 1
                assert not info["measured"] and info["sensor"] is None
                assert math.isnan(env.core.f[0, L.F_NIS])  # no update: the filter never saw the image
            elif info["sensor"] == "camera":
                images[t] += 1
                fixes[t] += 1
        # Binomial law of the drawn probability, planet by planet (4.5 sigma: a wrong rate fails).
        for j in range(3):
            n, k = images[j], fixes[j]
            if n >= 30:
                sd = math.sqrt(n * p[j] * (1 - p[j])) + 1.0
                assert abs(k - n * p[j]) < 4.5 * sd, (seed, j, n, k, p[j])
        # The image log is these counts: (fixes + 1) / (images + 2) and log1p(images) / log1p(1440).
        log = env.decode_observation(env.core.obs[0].astype(np.float32))["image_log"]
        np.testing.assert_allclose(log[0], (fixes + 1) / (images + 2), rtol=1e-6)
        np.testing.assert_allclose(log[1], np.minimum(np.log1p(images) / np.log1p(1440), 1), rtol=1e-6)
        counts += (images, fixes)
    assert counts[0].sum() > 300 and 0 < counts[1].sum() < counts[0].sum()


def test_no_failures_without_the_option():
    env = _physics_env(observe_image_log=True)
    env.reset(seed=3)
    for k in range(200):
        _, _, _, _, info = env.step((k // 50) % 3)
        assert info["visibility"] != "image_failed"
    log = env.decode_observation(env.core.obs[0].astype(np.float32))["image_log"]
    imaged = log[1] > 0
    assert imaged.any() and np.all(log[0, imaged] > 0.9)  # every image gave a fix


def _brute_force_centroid_offset(phase: float, n: int = 1201) -> float:
    """Centroid of the lit part of a uniformly bright unit sphere's disk, along the projected Sun direction
    (image x axis): a grid over the disk, each point lit when its surface normal faces the Sun."""
    g = np.linspace(-1.0, 1.0, n)
    x, y = np.meshgrid(g, g)
    inside = x * x + y * y < 1.0
    z = np.sqrt(np.where(inside, 1.0 - x * x - y * y, 0.0))  # toward the camera
    sun = np.array(
        [math.sin(phase), 0.0, math.cos(phase)]
    )  # phase angle between Sun and camera at the planet
    lit = inside & (x * sun[0] + z * sun[2] > 0.0)
    return float(x[lit].mean())


@pytest.mark.parametrize("phase_deg", [20.0, 60.0, 90.0, 120.0, 150.0])
def test_centroid_offset_is_the_uniform_disk_centroid(phase_deg):
    phase = math.radians(phase_deg)
    expected = _brute_force_centroid_offset(phase)  # in radii
    assert COB_UNIFORM_DISK * (1.0 - math.cos(phase)) == pytest.approx(expected, abs=3e-3)


def test_centroid_bias_kernel_rotates_toward_the_sun_by_delta():
    rng = np.random.default_rng(0)
    for _ in range(20):
        los = rng.normal(size=3)
        los /= np.linalg.norm(los)
        sun = rng.normal(size=3)
        sun /= np.linalg.norm(sun)
        alpha, cos_phase, scale = 1e-4, float(rng.uniform(-1, 1)), float(rng.uniform(0, 2))
        out = los.copy()
        delta = centroid_bias_kernel(out, sun, cos_phase, alpha, scale)
        assert delta == pytest.approx(scale * COB_UNIFORM_DISK * alpha / 2 * (1 - cos_phase), rel=1e-12)
        assert np.linalg.norm(out) == pytest.approx(1.0, abs=1e-12)
        angle = math.atan2(
            float(np.linalg.norm(np.cross(los, out))), float(out @ los)
        )  # exact for small angles
        assert angle == pytest.approx(delta, rel=1e-6, abs=1e-15)
        # In the plane of the line of sight and the Sun, on the Sun's side.
        assert abs(np.linalg.det(np.stack([los, sun, out]))) < 1e-12
        assert out @ sun >= los @ sun


def test_centroid_bias_moves_the_estimate_and_the_residual_log_counts_the_fixes():
    clean = _physics_env(noise_streams="per_step")
    biased = _physics_env(
        world={"centroid_bias_max": 2.0}, observe_residual_log=True, noise_streams="per_step"
    )
    clean.reset(seed=5)
    biased.reset(seed=5)
    total = np.zeros(3)
    fixes = np.zeros(3)
    offsets = []
    for _ in range(300):  # Venus: a crescent from this transfer, so its offset is several arcsec
        _, _, _, _, info_c = clean.step(0)
        _, _, _, _, info_b = biased.step(0)
        if info_b["sensor"] == "camera":
            fixes[0] += 1
            total[0] += biased.core.f[0, L.F_NIS] / 3.0
            offsets.append(biased.core.f[0, L.F_COB_LAST])
    assert fixes[0] > 200
    assert np.mean(offsets) > 1e-6 and np.all(np.asarray(offsets) > 0)  # rad: > 0.2 arcsec
    assert abs(info_b["pos_err_km"] - info_c["pos_err_km"]) > 1.0
    log = biased.decode_observation(biased.core.obs[0].astype(np.float32))["residual_log"]
    expected = np.minimum((total + 2) / (fixes + 2), RESIDUAL_CAP) / RESIDUAL_CAP
    np.testing.assert_allclose(log, expected, rtol=1e-5)


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"image_success_min": 1.5}, "image_success_min"),
        ({"world": {"centroid_bias_max": -0.1}}, "world.centroid_bias_max"),
        ({"world": {"centroid_bias_max": 2.5}}, "world.centroid_bias_max"),
    ],
)
def test_event_options_are_checked(options, name):
    with pytest.raises(ConfigError, match=name):
        EnvConfig.from_dict({**V1, **options})


@pytest.mark.parametrize("env_id", ["planetnav/Cruise-Target-v2", "planetnav/MarsApproach-Tasking-v2"])
def test_v2_observation_blocks_decode(env_id):
    env = gym.make(env_id, episode_steps=30)
    obs, _ = env.reset(seed=0)
    d = env.unwrapped.decode_observation(obs)
    cfg = env.unwrapped.config
    if cfg.observe_image_log:
        assert d["image_log"].shape == (2, cfg.n_planets)
    if cfg.observe_residual_log:
        assert d["residual_log"].shape == (cfg.n_targets,)
    assert env.observation_space.contains(obs)


MARS = ENV_IDS["planetnav/MarsApproach-Tasking-v1"]


def _mars_env(**options) -> PlanetNavEnv:
    return PlanetNavEnv(
        EnvConfig.from_dict({**MARS, "noise_streams": "per_step", **options}).at_physics_step()
    )


def test_pulsar_timing_error_is_drawn_after_the_episode():
    base, ev = _mars_env(), _mars_env(world={"pulsar_frequency_error_max": 1e-10})
    base.reset(seed=3)
    ev.reset(seed=3)
    _assert_same_episode(base, ev)
    drift = ev.core.true_pulsar_drift()[0]
    assert drift.shape == (2,) and np.all(np.abs(drift) <= SPEED_OF_LIGHT_KM_S * 1e-10) and np.all(drift != 0)
    np.testing.assert_array_equal(base.core.true_pulsar_drift()[0], 0.0)
    assert L.MAX_PULSARS >= len(PULSARS)


def test_pulsar_timing_error_shifts_each_update_by_the_gain_times_the_phase_error():
    """Timing the Crab (target 1) from the start: both episodes have the same covariance (it does not
    depend on the measured values) and the same noise, so after the first phase the estimates differ by
    K * dz with K = P+ H^T / R (the Kalman gain from the updated covariance) and dz = c delta (t - t0) /
    lambda cycles; the residual log counts the phase with one degree of freedom."""
    opts = {"observe_residual_log": True}
    clean, drifting = _mars_env(**opts), _mars_env(world={"pulsar_frequency_error_max": 1e-8}, **opts)
    clean.reset(seed=8)
    drifting.reset(seed=8)
    prm = drifting.core_params
    n_dir, lam, sigma = prm.psr[0, :3], prm.psr[0, 3], prm.psr[0, 4]
    total = fixes = 0.0
    for _ in range(12):
        _, _, _, _, info_c = clean.step(1)
        _, _, _, _, info_d = drifting.step(1)
        if info_d["sensor"] == "xray":
            break
    assert info_d["sensor"] == info_c["sensor"] == "xray"
    p_plus = drifting.core.p[0]
    np.testing.assert_allclose(p_plus, clean.core.p[0], rtol=1e-12)
    elapsed = drifting.core.i[0, L.I_K] * drifting.config.step_s
    dz = drifting.core.true_pulsar_drift()[0, 0] * elapsed / lam
    gain = p_plus[:, :3] @ (n_dir / lam) / sigma**2
    xe = L.F_OFFSETS["XE"][0]
    shift = drifting.core.f[0, xe : xe + 6] - clean.core.f[0, xe : xe + 6]
    assert abs(dz * lam) > 0.05  # km: a shift well above round-off
    np.testing.assert_allclose(shift, gain * dz, rtol=1e-6, atol=1e-9)
    total, fixes = drifting.core.f[0, L.F_NIS], 1.0
    log = drifting.decode_observation(drifting.core.obs[0].astype(np.float32))["residual_log"]
    expected = min((total + 2) / (fixes + 2), RESIDUAL_CAP) / RESIDUAL_CAP
    assert log.shape == (3,)
    np.testing.assert_allclose(log, [0.1, expected, 0.1], rtol=1e-5)


def test_pulsar_timing_error_option_is_checked():
    for bad in (-1e-10, 1e-3, math.nan):
        with pytest.raises(ConfigError, match=r"world\.pulsar_frequency_error_max"):
            EnvConfig.from_dict({**MARS, "world": {"pulsar_frequency_error_max": bad}})


@pytest.mark.parametrize("name", ["centroid_bias_max", "pulsar_frequency_error_max"])
def test_the_former_top_level_event_options_name_the_world_option(name, tmp_path):
    """The two events are effects of the world: their former top-level names are unknown options whose
    error names the ``world`` option to set, through EnvConfig, gym.make, gym.make_vec and YAML."""
    want = rf"unexpected keyword argument '{name}'.*world\.{name}"
    with pytest.raises(UnknownOptionError, match=want):
        EnvConfig.from_dict({**MARS, name: 1e-10})
    with pytest.raises(UnknownOptionError, match=want):
        gym.make("planetnav/MarsApproach-Tasking-v1", **{name: 1e-10})
    with pytest.raises(UnknownOptionError, match=want):
        gym.make_vec("planetnav/MarsApproach-Tasking-v1", num_envs=2, **{name: 1e-10})
    path = tmp_path / "env.yaml"
    path.write_text(f"env:\n  {name}: 1.0e-10\n")
    with pytest.raises(UnknownOptionError, match=want):
        EnvConfig.from_yaml(path)
    assert getattr(EnvConfig.from_dict({"world": {name: 1e-10}}).world, name) == 1e-10


def test_elongated_prior_is_drawn_after_the_episode_along_its_long_axis():
    """The same seed gives the same episode with and without the elongated prior but for the initial
    estimate's extra error, which lies along the prior's long axis; P_rr has sigmas (s, s, L)."""
    base = _physics_env(filter={"sigma_pos0": 100.0})
    ev = _physics_env(filter={"sigma_pos0": 100.0}, prior_long_sigma_km=5000.0)
    base.reset(seed=21)
    ev.reset(seed=21)
    _assert_same_episode(base, ev, ("X", "Q", "T0"))  # XE differs: the long axis's error
    xe = L.F_OFFSETS["XE"][0]
    np.testing.assert_array_equal(base.core.f[0, xe + 3 : xe + 6], ev.core.f[0, xe + 3 : xe + 6])
    p_rr = ev.core.p[0, :3, :3]
    values, vectors = np.linalg.eigh(p_rr)
    np.testing.assert_allclose(np.sqrt(values), [100.0, 100.0, 5000.0], rtol=1e-9)
    extra = ev.core.f[0, xe : xe + 3] - base.core.f[0, xe : xe + 3]
    assert np.linalg.norm(np.cross(extra, vectors[:, 2])) < 1e-6 * np.linalg.norm(extra)
    np.testing.assert_array_equal(ev.core.p[0, 3:, 3:], base.core.p[0, 3:, 3:])


def test_elongated_prior_error_is_distributed_as_its_covariance():
    """NEES of the initial position error against the drawn P_rr over 400 resets: chi-square with 3
    degrees of freedom (mean 3, variance 6; the bound is 5 standard errors)."""
    env = _physics_env(filter={"sigma_pos0": 100.0}, prior_long_sigma_km=8000.0)
    x, xe = L.F_OFFSETS["X"][0], L.F_OFFSETS["XE"][0]
    nees = []
    for seed in range(400):
        env.reset(seed=seed)
        e = env.core.f[0, xe : xe + 3] - env.core.f[0, x : x + 3]
        nees.append(e @ np.linalg.solve(env.core.p[0, :3, :3], e))
    assert abs(np.mean(nees) - 3.0) < 5 * np.sqrt(6.0 / 400)


def test_elongated_prior_must_not_be_shorter_than_the_spherical_one():
    with pytest.raises(ConfigError, match="prior_long_sigma_km"):
        EnvConfig.from_dict({**V1, "prior_long_sigma_km": 500.0})  # cruise sigma_pos0 is 1000 km
    with pytest.raises(ConfigError, match="prior_long_sigma_km"):
        EnvConfig.from_dict({**V1, "prior_long_sigma_km": -1.0})


def test_position_correlation_block_is_the_filters_p_rr():
    """The block holds rho_xy, rho_xz, rho_yz of the filter's P_rr at reset and after each step, so that with
    log_sigma's diagonal the observation carries the elongated prior's direction; the vector env's rows
    agree with single envs."""
    options = {"filter": {"sigma_pos0": 100.0}, "prior_long_sigma_km": 5000.0}
    env = _physics_env(observe_position_correlation=True, observation="dict", **options)

    def rho(p):
        s = np.sqrt(np.diag(p[:3, :3]))
        return np.array([p[0, 1] / (s[0] * s[1]), p[0, 2] / (s[0] * s[2]), p[1, 2] / (s[1] * s[2])])

    obs, info = env.reset(seed=9)
    assert np.max(np.abs(obs["position_correlation"])) > 0.3  # the long axis is not a coordinate axis
    np.testing.assert_allclose(obs["position_correlation"], rho(info["filter"]["P"]), atol=1e-6)
    for k in range(40):
        obs, _, _, _, info = env.step(k // 20)
        np.testing.assert_allclose(obs["position_correlation"], rho(info["filter"]["P"]), atol=1e-6)
    assert env.observation_space.contains(obs)
    cfg = EnvConfig.from_dict({**V1, "observe_position_correlation": True, **options}).at_physics_step()
    from planetnav_env.envs.vector_env import PlanetNavVectorEnv

    venv = PlanetNavVectorEnv(2, cfg)
    vobs, _ = venv.reset(seed=30)
    for r in range(2):
        single = PlanetNavEnv(cfg)
        sobs, _ = single.reset(seed=30 + r)
        np.testing.assert_array_equal(vobs[r], sobs)
