"""The ``world`` option: its presets and per-effect options, the flight world's light time and stellar
aberration in truth (held to :mod:`planetnav_env.astro.apparent` on the row's own truth, with planet states
from DE421 rather than the row's table), and the onboard corrections from the estimated state."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.astro.apparent import SPEED_OF_LIGHT_KM_S, aberrate, apparent_direction
from planetnav_env.astro.bodies import GM_SUN
from planetnav_env.astro.ephemeris import DEEphemeris, make_ephemeris
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core import sensing
from planetnav_env.core.light_path import apparent_point
from planetnav_env.core.records import make_scratch
from planetnav_env.core.row_ephemeris import planets_at, truth_bodies_at
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError, OptionError, OptionTypeError
from planetnav_env.scenarios.episodes import CRUISE_EPOCH
from planetnav_env.sensors.star_tracker import (
    FIX_WORK_SHAPE,
    StarTrackerConfig,
    fix_apparent_kernel,
    fix_kernel,
    select_stars_kernel,
    star_fix_tables,
)
from planetnav_env.tasks.spec import Params
from planetnav_env.world import PRESETS, WorldConfig

ARCSEC = math.pi / 648_000.0


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle [rad] between two vectors (atan2 form: accurate at small angles)."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


# --- the option ------------------------------------------------------------------------------------------
def test_presets_and_per_effect_options_resolve() -> None:
    assert EnvConfig().world == WorldConfig() and EnvConfig().world.is_matched
    flight = EnvConfig(world="flight").world
    assert (
        flight == WorldConfig(preset="flight") == EnvConfig.from_dict({"world": {"preset": "flight"}}).world
    )
    assert flight.light_time_on and flight.aberration_on
    assert flight.light_time_corrected and flight.aberration_corrected
    one = EnvConfig.from_dict({"world": {"preset": "flight", "aberration": False}}).world
    assert one.light_time_on and not one.aberration_on and not one.aberration_corrected
    alone = WorldConfig(light_time=True)  # one effect swept in the matched world
    assert alone.light_time_on and not alone.aberration_on and not alone.is_matched
    off = WorldConfig(preset="flight", onboard_corrections=False)
    assert off.light_time_on and off.aberration_on
    assert not off.light_time_corrected and not off.aberration_corrected
    cfg = EnvConfig(world="flight")
    assert EnvConfig.from_dict(cfg.to_dict()) == cfg  # the YAML round trip keeps the world


def test_the_centroid_bias_and_the_pulsar_timing_error_are_off_in_both_presets() -> None:
    """Modelled world effects without a cited flight magnitude yet: 0 (nothing drawn) in both presets,
    swept on their own, and the kernel scalars copy the resolved value."""
    for preset in PRESETS:
        w = WorldConfig(preset=preset)
        assert w.centroid_bias_max is None and w.centroid_bias_bound == 0.0
        assert w.pulsar_frequency_error_max is None and w.pulsar_frequency_error_bound == 0.0
    swept = WorldConfig(centroid_bias_max=0.5)
    assert swept.centroid_bias_bound == 0.5 and not swept.is_matched and not swept.light_time_on
    assert not WorldConfig(pulsar_frequency_error_max=1e-10).is_matched
    kw = {**ENV_IDS["planetnav/MarsApproach-Tasking-v1"], "episode_steps": 4}
    for world, want in (({}, (0.0, 0.0)), ({"centroid_bias_max": 0.5, "pulsar_frequency_error_max": 2e-10},
                                           (0.5, 2e-10))):  # fmt: skip
        ps = BatchCore(EnvConfig.from_dict({**kw, "world": world}), 1).params.scalars[0]
        assert (float(ps["cob_max"]), float(ps["psr_df_max"])) == want


def test_every_registered_id_before_v3_is_the_matched_world_and_v3_the_flight_world() -> None:
    for env_id, kw in ENV_IDS.items():
        world = EnvConfig.from_dict(kw).world
        if env_id.endswith("-v3"):  # suite version 3's tasks live in the flight world
            assert world == WorldConfig(preset="flight"), env_id
        else:
            assert world.is_matched, env_id


def test_bad_world_gets_the_named_option_error_through_make_vec_and_yaml(tmp_path) -> None:
    cases = [
        ("mars", OptionError, "world must be one of 'matched', 'flight'"),
        (3, OptionTypeError, "world must be one of"),
        ({"preset": "earthlike"}, OptionError, "world.preset"),
        ({"light_time": 1}, OptionTypeError, "world.light_time"),
        ({"aberration": "yes"}, OptionTypeError, "world.aberration"),
        ({"onboard_corrections": 0.0}, OptionTypeError, "world.onboard_corrections"),
        ({"solar_sail": 1.0}, ConfigError, "world.'solar_sail'"),
    ]
    for value, err, match in cases:
        with pytest.raises(err, match=match):
            gym.make("planetnav/Cruise-Target-v2", world=value)
        with pytest.raises(err, match=match):
            gym.make_vec("planetnav/Cruise-Target-v2", num_envs=2, world=value)
    path = tmp_path / "env.yaml"
    path.write_text("env:\n  world: earthlike\n")
    with pytest.raises(OptionError, match="world must be one of"):
        EnvConfig.from_yaml(path)
    path.write_text("env:\n  world: {preset: flight, light_time: false}\n")
    assert EnvConfig.from_yaml(path).world == WorldConfig(preset="flight", light_time=False)


def test_task_params_take_a_world() -> None:
    p = Params(step_s=60.0, episode_steps=10, world="flight")
    assert p.world == WorldConfig(preset="flight")
    assert EnvConfig.from_dict(p.options()).world == WorldConfig(preset="flight")
    assert "world" not in Params(step_s=60.0, episode_steps=10).options()  # the ids stay at the default
    with pytest.raises(OptionError, match="world"):
        Params(step_s=60.0, episode_steps=10, world="earthlike")


# --- the truth's lines of sight --------------------------------------------------------------------------
def _stepped(env_id: str, world, target: int, steps: int):
    env = gym.make(env_id, world=world)
    env.reset(seed=5)
    for _ in range(steps):
        env.step(target)
    return env.unwrapped


@pytest.mark.parametrize(
    "env_id,target", [("planetnav/Cruise-Target-v0", 1), ("planetnav/MarsApproach-Tasking-v0", 0)]
)
def test_truth_and_onboard_target_points_are_the_apparent_directions(env_id: str, target: int) -> None:
    """On a row's own state after a few steps: the truth's camera target point is the apparent direction
    (CN+S, astro.apparent) of the planet seen from the true state, and the filter's the one seen from the
    estimated state, each at the geometric range. Planet and central-body states here come from the
    kernels themselves (the truth's DE440, the filter's DE421), not from the row's table."""
    env = _stepped(env_id, "flight", target, 6)
    core = env.core
    prm, st, f, i = core.params, core.state, core.f, core.i
    cfg = env.config
    t = f[0, L.F_T0] + i[0, L.I_K] * cfg.step_s
    eph, truth_eph = DEEphemeris(), make_ephemeris("de440")
    central = "mars" if cfg.scenario == "mars-approach" else "sun"
    name = cfg.planets[target]

    def states(e):
        rc, vc = np.zeros(3), np.zeros(3)
        if central != "sun":
            rc, vc = (s[0] for s in e.state(central, np.array([t])))
        rp, vp = (s[0] for s in e.state(name, np.array([t])))
        return rc, vc, rp, vp

    rc, vc, rp, vp = states(truth_eph)
    ob_rc, ob_vc, ob_rp, ob_vp = states(eph)
    sc = make_scratch(prm)
    planets_at(prm, st.eph, f, 0, t, sc.planets)
    assert np.allclose(sc.planets[target], ob_rp, atol=1e-4)  # the onboard channels are DE421 (0.1 m)
    sc.central[:] = ob_rc
    truth_bodies_at(prm, st.eph, f, 0, t, sc, True)
    assert np.allclose(sc.tplanets[target], rp, atol=1e-4)  # the truth's are DE440
    assert np.allclose(sc.tcentral, rc, atol=1e-4)
    x, xe = f[0, L.F_X : L.F_X + 6], f[0, L.F_XE : L.F_XE + 6]
    sc.r1[0] = x[:3] + rc
    sensing._truth_apparent(prm, st, 0, target, sc)
    want = np.empty(3)
    tau = apparent_direction(x[:3] + rc, x[3:] + vc, rp, vp, GM_SUN, want)
    assert 1.0 < tau < 2000.0
    got = sc.t1[0] - sc.r1[0]
    assert _angle(got, want) < 1e-4 * ARCSEC
    assert np.linalg.norm(got) == pytest.approx(np.linalg.norm(rp - sc.r1[0]), rel=1e-12)  # geometric range
    # The effects are there: to first order light time and aberration together turn the direction by the
    # relative velocity across the line of sight over c (on the approach, where the spacecraft nearly
    # moves with Mars and toward it, they nearly cancel).
    los = (rp - sc.r1[0]) / np.linalg.norm(rp - sc.r1[0])
    dv = (x[3:] + vc) - vp
    across = np.linalg.norm(dv - np.dot(dv, los) * los) / SPEED_OF_LIGHT_KM_S
    assert _angle(got, rp - sc.r1[0]) == pytest.approx(across, rel=0.01)
    # The onboard model: the same correction from the estimated state, on DE421.
    sensing._onboard_apparent(prm, st, 0, target, sc)
    apparent_direction(xe[:3] + ob_rc, xe[3:] + ob_vc, ob_rp, ob_vp, GM_SUN, want)
    model = sc.dirv + ob_rc - (xe[:3] + ob_rc)  # the filter's predicted line of sight
    assert _angle(model, want) < 1e-4 * ARCSEC


def test_omitted_solar_velocity_cancels_with_both_effects_and_is_below_a_fiftieth_alone() -> None:
    """The env's velocities are heliocentric; the barycentric ones add the Sun's ~13 m/s to observer and
    target alike. With both effects on, that common velocity cancels (the net turn is the relative velocity
    over c): < 1e-4". With one effect alone it is ~0.01" (documented)."""
    eph = DEEphemeris()
    t = np.array([CRUISE_EPOCH])
    t_sun = np.array([t[0] - 10.0, t[0] + 10.0])
    v_sun = np.diff(eph.sun_barycentric_position(t_sun), axis=0)[0] / 20.0
    assert 0.005 < np.linalg.norm(v_sun) < 0.02  # km/s
    r_obs, v_obs = (s[0] for s in eph.state("venus", t))  # a cruise start near Venus' orbit
    r_obs = r_obs + 2e6
    worst = {"both": 0.0, "light_time": 0.0, "aberration": 0.0}
    work = np.empty(3)
    for name in EnvConfig().planets:
        rp, vp = (s[0] for s in eph.state(name, t))
        for key, lt, ab in (("both", True, True), ("light_time", True, False), ("aberration", False, True)):
            helio, bary = np.empty(3), np.empty(3)
            apparent_point(r_obs, v_obs, rp, vp, lt, ab, work, helio)
            apparent_point(r_obs, v_obs + v_sun, rp, vp + v_sun, lt, ab, work, bary)
            worst[key] = max(worst[key], _angle(helio - r_obs, bary - r_obs))
    assert worst["both"] < 1e-4 * ARCSEC
    assert 1e-3 * ARCSEC < worst["light_time"] < 0.02 * ARCSEC
    assert 1e-3 * ARCSEC < worst["aberration"] < 0.02 * ARCSEC


def test_onboard_correction_error_follows_the_estimate_error() -> None:
    """The correction (apparent minus geometric direction) computed from an estimate 100 km and 1 m/s off
    differs from the true one by ~1e-3": the corrections leave the estimate's own error."""
    eph = DEEphemeris()
    t = np.array([CRUISE_EPOCH])
    r, v = (s[0] for s in eph.state("venus", t))
    r = r + np.array([3e6, -1e6, 5e5])
    rp, vp = (s[0] for s in eph.state("mars", t))
    work = np.empty(3)

    def correction(r_obs, v_obs):
        point = np.empty(3)
        apparent_point(r_obs, v_obs, rp, vp, True, True, work, point)
        return point - r_obs, rp - r_obs

    app, geo = correction(r, v)
    app_e, geo_e = correction(r + np.array([100.0, -60.0, 30.0]), v + np.array([1e-3, 0.0, -5e-4]))
    size = _angle(app, geo)
    assert 1.0 * ARCSEC < size < 60.0 * ARCSEC
    # The rotation from geometric to apparent, for the estimate and for the truth.
    rot_true = np.cross(geo / np.linalg.norm(geo), app / np.linalg.norm(app))
    rot_est = np.cross(geo_e / np.linalg.norm(geo_e), app_e / np.linalg.norm(app_e))
    assert np.linalg.norm(rot_true - rot_est) < 2e-3 * ARCSEC


# --- the star tracker ------------------------------------------------------------------------------------
def _fix_setup():
    tables = star_fix_tables(StarTrackerConfig())
    q = np.array([0.9, 0.1, -0.3, 0.2])
    q /= np.linalg.norm(q)
    rot = np.empty((3, 3))
    idx = np.empty(tables.max_stars, np.int64)
    n = select_stars_kernel(
        q, tables.boresight, tables.dirs, tables.cos_half, tables.cell_start, tables.cell_stars,
        tables.grid_n, rot, idx,
    )  # fmt: skip
    assert n >= tables.min_stars
    noise = np.random.default_rng(2).normal(scale=tables.sigma_rad, size=(n, 3))
    return tables, q, rot, idx, n, noise


def test_star_aberration_biases_the_uncorrected_fix_and_the_correction_removes_it() -> None:
    tables, q, rot, idx, n, noise = _fix_setup()
    zero = np.zeros((n, 3))
    work = np.empty(FIX_WORK_SHAPE)
    boresight = rot @ tables.boresight
    side = np.cross(boresight, [0.0, 0.0, 1.0])
    v = 30.0 * side / np.linalg.norm(side)  # 30 km/s across the boresight: v/c = 20.6"
    out = [np.empty(4) for _ in range(4)]
    plain, _ = fix_kernel(q, rot, tables.dirs, idx, n, noise, work, out[0])
    same, _ = fix_apparent_kernel(q, rot, tables.dirs, idx, n, noise, v, v, False, False, work, out[1])
    assert np.array_equal(out[0], out[1]) and plain == same  # no effect: fix_kernel bit for bit
    biased, _ = fix_apparent_kernel(q, rot, tables.dirs, idx, n, zero, v, v, True, False, work, out[2])
    exact, _ = fix_apparent_kernel(q, rot, tables.dirs, idx, n, zero, v, v, True, True, work, out[3])
    # Uncorrected, the fix turns by the field's mean aberration (v/c = 20.6" across the boresight).
    vc = 30.0 / SPEED_OF_LIGHT_KM_S
    assert 0.95 * vc < biased < 1.01 * vc
    assert exact < 1e-6 * ARCSEC  # corrected by the true velocity: the aberration is gone
    # Corrected by a velocity 1 m/s off: the residual is that velocity error's aberration, 7e-4".
    v_off = v + 1e-3 * np.cross(boresight, side) / np.linalg.norm(side)
    off, _ = fix_apparent_kernel(q, rot, tables.dirs, idx, n, zero, v, v_off, True, True, work, out[3])
    assert off == pytest.approx(1e-3 / SPEED_OF_LIGHT_KM_S, rel=0.1)


def test_aberrate_by_minus_v_inverts_to_second_order() -> None:
    """What the docs state for de-aberrating a measurement: aberrate(aberrate(u, v), -v) is u to (v/c)^2."""
    rng = np.random.default_rng(4)
    worst = 0.0
    for _ in range(100):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = rng.normal(size=3)
        v *= 40.0 / np.linalg.norm(v)
        a, b = np.empty(3), np.empty(3)
        aberrate(u, v, a)
        aberrate(a, -v, b)
        worst = max(worst, _angle(u, b))
    assert worst < 2.0 * (40.0 / SPEED_OF_LIGHT_KM_S) ** 2


# --- the filter in the flight world ----------------------------------------------------------------------
def _run(world, steps: int = 240) -> tuple[float, float, float]:
    """(mean position error [km] over the last half, mean NIS of the fixes, median attitude error ["])."""
    env = gym.make("planetnav/Cruise-Target-v0", world=world)
    env.reset(seed=3)
    errs, nis, att = [], [], []
    core = env.unwrapped.core
    for k in range(steps):
        _, _, _, _, info = env.step((k // 80) % 3)
        if k >= steps // 2:
            errs.append(info["pos_err_km"])
        att.append(info["attitude_err_arcsec"])
        if info["measured"]:
            nis.append(core.f[0, L.F_NIS])
    return float(np.mean(errs)), float(np.mean(nis)), float(np.median(att))


def test_the_filter_that_ignores_the_effects_is_biased_and_the_corrected_one_is_not() -> None:
    # The light path alone (the flight preset's other effects have their own tests).
    light = {"light_time": True, "aberration": True}
    matched = _run("matched")
    flight = _run(light)
    ignored = _run({**light, "onboard_corrections": False})
    # Corrected from its estimate, the filter's errors are the matched world's (to the estimate's error).
    assert flight[0] == pytest.approx(matched[0], rel=0.05)
    assert flight[1] == pytest.approx(matched[1], rel=0.1)
    assert flight[2] == pytest.approx(matched[2], rel=0.1)
    # Ignoring them: a biased position (the uncorrected light time and aberration, 9-23" at 0.3-1 AU),
    # an inconsistent NIS, the star fix off by the field's aberration.
    assert ignored[0] > 5.0 * matched[0]
    assert ignored[1] > 2.0 * matched[1]
    assert ignored[2] > matched[2] + 8.0


def test_single_and_vector_env_agree_in_the_flight_world() -> None:
    """Row r of the vector env after reset(seed=s) is the single env after reset(seed=s + r), bit for bit,
    in the flight world (observation, reward, filter state, truth)."""
    n, seed = 3, 11
    for env_id in ("planetnav/Cruise-Target-v2", "planetnav/MarsApproach-Tasking-v2"):
        venv = gym.make_vec(env_id, num_envs=n, world="flight")
        singles = [gym.make(env_id, world="flight") for _ in range(n)]
        obs, _ = venv.reset(seed=seed)
        for r, env in enumerate(singles):
            o, _ = env.reset(seed=seed + r)
            assert np.array_equal(obs[r], o)
        rng = np.random.default_rng(0)
        core = venv.unwrapped.core
        for k in range(30):
            if k % 6 == 0:  # hold each target a few steps: slews, then fixes
                a = rng.integers(0, venv.single_action_space.n, n)
            obs, rew, _, _, _ = venv.step(a)
            for r, env in enumerate(singles):
                o, rw, _, _, _ = env.step(int(a[r]))
                assert np.array_equal(obs[r], o) and rew[r] == rw, (env_id, k, r)
                assert np.array_equal(core.f[r], env.unwrapped.core.f[0], equal_nan=True), (env_id, k, r)
                assert np.array_equal(core.p[r], env.unwrapped.core.p[0]), (env_id, k, r)
        venv.close()
