"""Disturbance torques, wheel friction and momentum dumps against closed forms computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM, body
from planetnav_env.attitude.disturbances import (
    dump_delta_v,
    gravity_gradient_torque,
    srp_torque,
    thrust_torque,
    wheel_friction,
)
from planetnav_env.attitude.plant import AttitudeConfig
from planetnav_env.attitude.pointing import propagate_pointing
from planetnav_env.attitude.quaternion import rotate_body_to_inertial
from planetnav_env.dynamics.srp import P_1AU_N_M2, solar_pressure, srp_gm


def test_solar_pressure_and_srp_acceleration():
    assert P_1AU_N_M2 == pytest.approx(4.54e-6, rel=1e-3)  # 1361 W/m^2 / c
    assert solar_pressure(0.5 * AU_KM) == pytest.approx(4.0 * P_1AU_N_M2, rel=1e-15)
    # A 0.01 m^2/kg probe of C_R 1.3 at 0.84 AU: a = C_R (A/m) P(r) = 8.37e-8 m/s^2, and the same from
    # the reduced GM: k / r^2 [km/s^2].
    r = 0.84 * AU_KM
    direct = 1.3 * 0.01 * solar_pressure(r)  # m/s^2
    assert direct == pytest.approx(8.37e-8, rel=1e-3)
    assert srp_gm(0.01, 1.3) / r**2 * 1e3 == pytest.approx(direct, rel=1e-14)
    assert srp_gm(0.01, 1.3) / body("sun").gm == pytest.approx(1.0e-5, rel=0.02)


def test_srp_torque_closed_form():
    # Sun along +x, the centre of pressure 2 cm along +y: the push along -x gives a torque along +z of
    # |r_cp| C_R A P.
    out = np.empty(3)
    srp_torque(np.array([1.0, 0.0, 0.0]), AU_KM, 2.0, 1.5, np.array([0.0, 0.02, 0.0]), out)
    f = 1.5 * 2.0 * P_1AU_N_M2
    assert out == pytest.approx([0.0, 0.0, 0.02 * f], rel=1e-15)
    # The centre of pressure on the Sun line: no torque.
    srp_torque(np.array([0.0, 0.6, 0.8]), AU_KM, 2.0, 1.5, np.array([0.0, 0.03, 0.04]), out)
    assert np.abs(out).max() < 1e-22


def test_gravity_gradient_closed_form():
    # J = diag(100, 200, 300) kg m^2, the central body in the x-y plane at 30 deg from x, 4000 km from
    # Mars's centre: tau = 3 mu / r^3 (u x J u) = (0, 0, 3 mu / r^3 (J_yy - J_xx) sin cos).
    jm = np.diag([100.0, 200.0, 300.0])
    th = math.radians(30.0)
    u = np.array([math.cos(th), math.sin(th), 0.0])
    out = np.empty(3)
    mu = body("mars").gm
    gravity_gradient_torque(u, 4000.0, mu, jm, out)
    expected = 3.0 * mu / 4000.0**3 * (200.0 - 100.0) * math.sin(th) * math.cos(th)
    assert out[2] == pytest.approx(expected, rel=1e-14)
    assert out[0] == 0.0 and out[1] == 0.0
    gravity_gradient_torque(np.array([0.0, 0.0, 1.0]), 4000.0, mu, jm, out)  # along a principal axis
    assert np.all(out == 0.0)


def test_thrust_torque_closed_form():
    out = np.empty(3)
    # 25 mN along +x acting 1 cm off the centre of mass along +z: 2.5e-4 N m about +y.
    thrust_torque(0.025, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.01]), out)
    assert out == pytest.approx([0.0, 0.025 * 0.01, 0.0], rel=1e-15)


def test_friction_spins_a_free_wheel_down_as_its_closed_form():
    """J_w dw/dt = -tau_c sign(w) - c_v w: w(t) = (w0 + tau_c / c_v) exp(-c_v t / J_w) - tau_c / c_v until
    it stops (in momentum h = J_w w). Integrated by RK4 at 0.1 s."""
    jw, tau_c, c_v = 1e-4, 2e-5, 5e-6  # kg m^2, N m, N m s
    h0 = 0.05  # N m s: 500 rad/s
    dt = 0.1
    h = h0
    t_stop = jw / c_v * math.log((h0 / jw + tau_c / c_v) / (tau_c / c_v))
    times = np.arange(0.0, 0.9 * t_stop, dt)
    for _ in times[1:]:
        k1 = wheel_friction(h, jw, tau_c, c_v)
        k2 = wheel_friction(h + 0.5 * dt * k1, jw, tau_c, c_v)
        k3 = wheel_friction(h + 0.5 * dt * k2, jw, tau_c, c_v)
        k4 = wheel_friction(h + dt * k3, jw, tau_c, c_v)
        h += dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    t = times[-1]
    closed = jw * ((h0 / jw + tau_c / c_v) * math.exp(-c_v * t / jw) - tau_c / c_v)
    assert h == pytest.approx(closed, rel=1e-9)
    assert wheel_friction(0.0, jw, tau_c, c_v) == 0.0
    assert wheel_friction(-h0, jw, tau_c, c_v) == -wheel_friction(h0, jw, tau_c, c_v)


def test_dump_delta_v():
    # 0.4 N m s unloaded by thrusters 0.5 m from the centre of mass of a 100 kg probe: 0.8 N s, 8 mm/s.
    assert dump_delta_v(0.4, 0.5, 100.0) == pytest.approx(8e-6, rel=1e-15)  # km/s


def test_constant_srp_torque_builds_wheel_momentum_at_its_rate():
    """Pointing held by the PD law under a constant SRP torque (an exaggerated 5 cm offset of the centre
    of pressure): the body settles at the PD law's constant offset (tau / K, a few arcminutes here) and
    stays there, so the torque is constant in inertial axes too, and the total angular momentum, all of it
    in the wheels, grows at the torque's rate."""
    cfg = AttitudeConfig()
    tau = np.empty(3)
    srp_torque(np.array([0.0, 1.0, 0.0]), 0.72 * AU_KM, 1.0, 1.3, np.array([0.05, 0.0, 0.0]), tau)
    hours = 2.0
    q, w, h = propagate_pointing(
        np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3), np.array([1.0, 0.0, 0.0]),
        1.0, int(hours * 3600), cfg, torque_ext=tau,
    )  # fmt: skip
    total = rotate_body_to_inertial(q, cfg.inertia_matrix @ w + h)
    expected = rotate_body_to_inertial(q, tau) * hours * 3600.0
    assert np.linalg.norm(total - expected) < 0.01 * np.linalg.norm(expected)
    assert np.linalg.norm(cfg.inertia_matrix @ w) < 0.01 * np.linalg.norm(h)  # nearly all in the wheels
    assert 0.0 < np.abs(q[1:]).max() < 0.01
