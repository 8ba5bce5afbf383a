"""The flight world's attitude loop against independent truth: conservation, analytic secular rates,
closed forms, the dump's impulse, and the attitude estimator's consistency over Monte Carlo runs."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401
from planetnav_env.astro.bodies import body
from planetnav_env.attitude.quaternion import dcm_body_to_inertial, normalize, rotate_body_to_inertial
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.attitude_loop import error_vector, external_torque
from planetnav_env.core.records import make_scratch
from planetnav_env.dynamics.srp import solar_pressure
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import OptionError
from planetnav_env.world import WorldConfig

J = np.diag([10.0, 12.0, 8.0])  # the default inertia [kg m^2]
#: Every effect of the attitude loop off: a flight world whose attitude loop only runs the estimator.
QUIET = {
    "cp_offset_m": [0.0, 0.0, 0.0],
    "gravity_gradient": False,
    "thrust_offset_m": [0.0, 0.0, 0.0],
    "wheel_coulomb_n_m": 0.0,
    "wheel_viscous_n_m_s": 0.0,
    "momentum_dumping": False,
}
ONLY_LOOP = {"light_time": False, "aberration": False, "third_bodies": False, "srp": False}


def _env(world: dict, n: int = 1, **kw) -> PlanetNavVectorEnv:
    return PlanetNavVectorEnv(n, world={"preset": "flight", **ONLY_LOOP, **world}, **kw)


def _total_momentum(f: np.ndarray) -> np.ndarray:
    """R(q) (J omega + h_w) [N m s, inertial] of every row of the state ``f``."""
    q = f[:, L.F_Q : L.F_Q + 4]
    body_h = f[:, L.F_W : L.F_W + 3] @ J.T + f[:, L.F_HW : L.F_HW + 3]
    return rotate_body_to_inertial(q, body_h)


def test_matched_world_runs_no_attitude_loop_and_flight_runs_all_of_it() -> None:
    m, fl = WorldConfig(), WorldConfig(preset="flight")
    assert not m.attitude_world_on and m.is_matched
    assert fl.attitude_world_on and fl.srp_torque_on and fl.gravity_gradient_on and fl.dumping_on
    assert fl.estimate_pointing_on and fl.gyro_bias_rad_s > 0 and fl.wheel_coulomb > 0
    assert math.isfinite(fl.wheel_speed_limit_rad_s) and not math.isfinite(m.wheel_speed_limit_rad_s)
    assert WorldConfig(preset="flight", **QUIET).srp_torque_on is False


def test_without_external_torque_total_momentum_is_conserved_over_a_day() -> None:
    """No disturbance torque and no dump: whatever the PD law, the estimator, the wheels' limits and their
    friction do, the total angular momentum only moves between body and wheels (1e-12 relative over a
    day, 1,440 steps of 60 s with slews between the planets)."""
    env = _env({**QUIET, "wheel_coulomb_n_m": 1e-4, "wheel_viscous_n_m_s": 2e-7}, n=2)
    env.reset(seed=3)
    f = env.core.f
    f[:, L.F_HW : L.F_HW + 3] = [[0.12, -0.05, 0.2], [-0.3, 0.1, 0.05]]
    h0 = _total_momentum(f)
    for k in range(1440):
        env.step(np.array([(k // 200) % 3, (k // 300) % 3]))
    h1 = _total_momentum(env.core.f)
    rel = np.linalg.norm(h1 - h0, axis=1) / np.linalg.norm(h0, axis=1)
    assert np.all(rel < 1e-12), rel


def test_constant_srp_torque_builds_momentum_at_the_analytic_rate() -> None:
    """SRP torque alone on a held target: the secular growth of the total angular momentum over half a
    day equals the torque r_cp x F (F = C_R A P(r) from the Sun, in the settled attitude), integrated by
    hand at the steps' states, within 1 %."""
    cp = np.array([0.0, 0.3, 0.1])
    env = _env({**QUIET, "cp_offset_m": cp.tolist(), "pointing_from_estimate": False})
    env.reset(seed=5)
    for _ in range(60):  # settle on Venus
        env.step(np.array([0]))
    f = env.core.f
    h0 = _total_momentum(f)[0]
    cfg = env.core.config
    area, c_r = cfg.world.srp_torque_area_m2, f[0, L.F_SRP_CR]
    expected = np.zeros(3)
    steps = 720
    for _ in range(steps):
        row = env.core.f[0]
        r_helio = row[L.F_X : L.F_X + 3]  # the cruise is heliocentric
        s_hat = -r_helio / np.linalg.norm(r_helio)
        force = -c_r * area * solar_pressure(np.linalg.norm(r_helio)) * s_hat  # inertial [N]
        q = row[L.F_Q : L.F_Q + 4]
        tau_i = np.cross(rotate_body_to_inertial(q, cp), force)
        env.step(np.array([0]))
        expected += tau_i * cfg.step_s
    built = _total_momentum(env.core.f)[0] - h0
    assert np.linalg.norm(built - expected) < 0.01 * np.linalg.norm(expected), (built, expected)
    assert np.linalg.norm(expected) > 1e-3  # N m s: a real build-up, not a test of zero


def test_gravity_gradient_matches_its_closed_form_in_the_row_step() -> None:
    """The row step's external torque on the Mars approach with only the gravity gradient on, at an
    attitude and a position given by hand: 3 mu / r^3 (u x J u), u the body-frame direction to Mars."""
    env = _env({**QUIET, "gravity_gradient": True}, scenario="mars-approach", planets=["mars"])
    env.reset(seed=0)
    prm, f = env.core.params, env.core.f
    x = np.array([3000.0, -4000.0, 1200.0])  # km from Mars
    f[0, L.F_X : L.F_X + 3] = x
    q = normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    y = np.concatenate([q, np.zeros(3)])
    sc = make_scratch(prm)
    sc.central[:] = 0.0
    out = np.empty(3)
    external_torque(prm, f, 0, y, False, sc, out)
    u = dcm_body_to_inertial(q).T @ (-x / np.linalg.norm(x))
    r = np.linalg.norm(x)
    by_hand = 3.0 * body("mars").gm / r**3 * np.cross(u, J @ u)
    assert np.allclose(out, by_hand, rtol=1e-13, atol=0.0), (out, by_hand)
    assert np.linalg.norm(by_hand) > 1e-7  # N m


def test_friction_spins_a_free_wheel_down_as_its_closed_form() -> None:
    """Torque mode with zero torque (no PD law, no compensation): each wheel obeys J_w dw/dt = -tau_c
    sign(w) - c_v w, h(t) = J_w ((w0 + tau_c / c_v) exp(-c_v t / J_w) - tau_c / c_v), whatever the body
    does."""
    tau_c, c_v, jw = 2e-5, 5e-7, 8e-4
    world = {
        **QUIET,
        "wheel_coulomb_n_m": tau_c,
        "wheel_viscous_n_m_s": c_v,
        "wheel_friction_compensation": 0.0,
    }
    env = PlanetNavVectorEnv(
        1, world={"preset": "flight", **ONLY_LOOP, **world, "wheel_inertia_kg_m2": jw}, action_mode="torque"
    )
    env.reset(seed=1)
    h0 = np.array([0.3, -0.2, 0.1])
    env.core.f[0, L.F_HW : L.F_HW + 3] = h0
    steps = 15  # 900 s: every wheel still spins (it would stop after ~1,500 s)
    for _ in range(steps):
        env.step(np.zeros((1, 3)))
    t = steps * env.core.config.step_s
    w0 = np.abs(h0) / jw
    closed = jw * ((w0 + tau_c / c_v) * np.exp(-c_v * t / jw) - tau_c / c_v) * np.sign(h0)
    h = env.core.f[0, L.F_HW : L.F_HW + 3]
    assert np.allclose(h, closed, rtol=2e-3, atol=0.0), (h, closed)
    assert np.all(np.abs(h) < 0.9 * np.abs(h0))  # it did spin down


def _dump_pair(world: dict, n: int, seed: int) -> tuple[PlanetNavVectorEnv, dict[bool, np.ndarray]]:
    """One step from the same episode with a wheel loaded above the threshold, with and without dumping:
    the rows' states after it (the dump happens at the first sub-step)."""
    h0 = np.array([0.45, -0.1, 0.2])
    out = {}
    for dumping in (True, False):
        env = _env({**world, "momentum_dumping": dumping}, n=n)
        env.reset(seed=seed)
        env.core.f[:, L.F_HW : L.F_HW + 3] = h0
        env.step(np.zeros(n, dtype=int))
        out[dumping] = (env.core.f.copy(), env.core.p.copy())
    return env, out


def test_a_dump_moves_the_centre_of_mass_by_the_momentum_over_lever_arm_and_mass() -> None:
    """A wheel loaded above the threshold is unloaded at the first sub-step; with the dump's errors off,
    the true velocity differs from the same episode without dumping by |dh| / (l m) (the momentum the
    dump removed, recorded by the row); the filter's estimate moves by the same nominal delta-v (to the
    share its measurement update then takes of the different prediction)."""
    world = {**QUIET, "dump_dv_error": 0.0, "dump_pointing_error_deg": 0.0, "dump_lever_arm_m": 0.4}
    env, runs = _dump_pair(world, 1, 2)
    mass = env.core.config.world.dump_mass(None)
    on, off = runs[True][0][0], runs[False][0][0]
    assert on[L.F_DUMPS] == 1.0 and off[L.F_DUMPS] == 0.0
    dv_true = np.linalg.norm(on[L.F_X + 3 : L.F_X + 6] - off[L.F_X + 3 : L.F_X + 6]) * 1000.0  # m/s
    dv_est = np.linalg.norm(on[L.F_XE + 3 : L.F_XE + 6] - off[L.F_XE + 3 : L.F_XE + 6]) * 1000.0
    recorded = on[L.F_DUMP_DV]
    assert dv_true == pytest.approx(recorded, rel=1e-9)
    assert dv_est == pytest.approx(recorded, rel=1e-2)
    # The momentum removed is the loaded one, moved by at most one sub-step of wheel torque (0.01 N m s).
    assert recorded == pytest.approx(np.linalg.norm([0.45, -0.1, 0.2]) / (0.4 * mass), rel=0.05)
    # What is unloaded is the momentum the wheels hold at rest, J omega + h_w: it ends near zero (the
    # wheels at -J omega, the body's rate unchanged by the dump).
    inertia = np.asarray(env.core.config.attitude.inertia)  # principal axes [kg m^2]
    at_rest = inertia * on[L.F_W : L.F_W + 3] + on[L.F_HW : L.F_HW + 3]
    assert np.all(np.abs(at_rest) < 0.05)


def test_a_dump_error_is_drawn_and_the_filter_gets_its_covariance() -> None:
    """The truth's dump delta-v less the filter's nominal one, over 64 rows: its spread is the model's
    (5 % in magnitude, 2 deg per cross axis), and the filter's velocity covariance grows by it."""
    n = 64
    env, runs = _dump_pair(QUIET, n, 4)
    (f1, p1), (f0, p0) = runs[True], runs[False]
    d_true = (f1[:, L.F_X + 3 : L.F_X + 6] - f0[:, L.F_X + 3 : L.F_X + 6]) * 1000.0  # m/s
    d_est = (f1[:, L.F_XE + 3 : L.F_XE + 6] - f0[:, L.F_XE + 3 : L.F_XE + 6]) * 1000.0
    dv = f1[:, L.F_DUMP_DV]
    w = env.core.config.world
    model2 = w.dump_dv_error**2 + 2 * math.radians(w.dump_pointing_error_deg) ** 2
    rms = np.sqrt(np.mean(np.sum((d_true - d_est) ** 2, axis=1) / dv**2))
    assert rms == pytest.approx(math.sqrt(model2), rel=0.25)
    grew = (np.trace(p1[:, 3:, 3:], axis1=1, axis2=2) - np.trace(p0[:, 3:, 3:], axis1=1, axis2=2)) * 1e6
    assert np.median(grew / (dv**2 * model2)) == pytest.approx(1.0, rel=0.2)


def test_attitude_estimator_nees_is_consistent_over_monte_carlo() -> None:
    """The estimator's error (attitude and gyro bias, 6 states) against its covariance over 64 runs of
    300 steps with slews: the mean NEES over runs stays in its chi-square 99 % band at most steps."""
    n = 64
    env = _env({**QUIET}, n=n)
    env.reset(seed=11)
    band_lo, band_hi = 6.0 - 2.58 * math.sqrt(12.0 / n), 6.0 + 2.58 * math.sqrt(12.0 / n)
    means = []
    e = np.empty(3)
    for k in range(300):
        env.step(np.full(n, (k // 100) % 3))
        f = env.core.f
        nees = np.empty(n)
        for r in range(n):
            error_vector(f[r, L.F_QH : L.F_QH + 4].copy(), f[r, L.F_Q : L.F_Q + 4].copy(), e)
            err = np.concatenate([e, f[r, L.F_GB : L.F_GB + 3] - f[r, L.F_BH : L.F_BH + 3]])
            pa = f[r, L.F_PA : L.F_PA + 36].reshape(6, 6)
            nees[r] = err @ np.linalg.solve(pa, err)
        means.append(nees.mean())
    means = np.array(means[20:])  # after the first fixes
    inside = np.mean((means > band_lo) & (means < band_hi))
    assert inside > 0.9, (inside, means.mean())
    assert abs(means.mean() - 6.0) < 0.6


def test_pointing_from_the_estimate_moves_the_true_pointing_error() -> None:
    """With the PD law on the estimate the camera's true pointing error follows the estimator's error
    (a few arcsec), where on the truth it is the control error alone."""
    errs = {}
    for est in (True, False):
        env = _env({**QUIET, "pointing_from_estimate": est}, n=8)
        env.reset(seed=6)
        for _ in range(120):
            env.step(np.zeros(8, dtype=int))
        errs[est] = np.degrees(env.core.f[:, L.F_POINT_ERR]) * 3600.0
    assert np.median(errs[True]) > 2.0 * np.median(errs[False])
    assert np.median(errs[True]) < 60.0


@pytest.mark.parametrize(
    "world,path",
    [
        ({"wheel_coulomb_n_m": -1e-4}, "world.wheel_coulomb_n_m"),
        ({"wheel_viscous_n_m_s": -1.0}, "world.wheel_viscous_n_m_s"),
        ({"cp_offset_m": [0.0, float("nan"), 0.0]}, "world.cp_offset_m"),
        ({"cp_offset_m": [0.0, 0.01]}, "world.cp_offset_m"),
        ({"cp_offset_m": [0.0, float("inf"), 0.0]}, "world.cp_offset_m"),
        ({"preset": "flight", "dump_threshold_n_m_s": 0.6}, "world.dump_threshold_n_m_s"),
        ({"momentum_dumping": True, "dump_threshold_n_m_s": 0.5}, "world.dump_threshold_n_m_s"),
    ],
)
def test_bad_attitude_options_get_the_named_option_error_through_make(world: dict, path: str) -> None:
    with pytest.raises(OptionError) as info:
        gym.make("planetnav/Cruise-Target-v2", world=world)
    assert info.value.path == path, info.value


def test_a_threshold_above_capacity_is_fine_without_dumping() -> None:
    EnvConfig(world=WorldConfig(dump_threshold_n_m_s=0.6))  # matched: no dumping, nothing to check
    with pytest.raises(OptionError):
        EnvConfig(world=WorldConfig(preset="flight", dump_threshold_n_m_s=0.6))
