"""Orbit dynamics: Jacobians vs finite differences, conservation, RK4 vs Kepler, STM accuracy."""

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM, GM_SUN
from planetnav_env.astro.ephemeris import DEEphemeris, elements_to_state, state_to_elements
from planetnav_env.astro.timescale import tdb_seconds
from planetnav_env.dynamics.orbit import GravityModel, rk4_step
from planetnav_env.errors import InvalidParameterError, NonFiniteError, UnknownBodyError
from planetnav_validation.numpy_orbit import (
    angular_momentum,
    euler_stm,
    propagate,
    rk4_step_stm,
    specific_energy,
)

RNG = np.random.default_rng(42)


def _random_states(n, rmin=0.5, rmax=2.0):
    u = RNG.normal(size=(n, 3))
    r = u / np.linalg.norm(u, axis=1, keepdims=True) * RNG.uniform(rmin, rmax, (n, 1)) * AU_KM
    v = RNG.normal(size=(n, 3)) * 20.0
    return np.concatenate([r, v], axis=1)


def _potential(model, r, r_pert, central=True):
    """Force function U with a = grad U: mu/|r| + sum mu_k (1/|r_k - r| - r . r_k / |r_k|^3)."""
    u = model.mu_central / np.linalg.norm(r, axis=-1) if central else 0.0
    for mu, rk in zip(model.mu_perturbers, r_pert, strict=True):
        u = u + mu * (1.0 / np.linalg.norm(rk - r, axis=-1) - r @ rk / np.linalg.norm(rk) ** 3)
    return u


def test_accelerations_are_gradients_of_the_potential():
    eph = DEEphemeris()
    t = tdb_seconds(2021, 3, 1)
    model = GravityModel("mars", ("sun", "earth", "jupiter"))
    r_pert = np.stack([eph.position(b, t) - eph.position("mars", t) for b in model.perturbers])
    # Mars approach geometry: 1e4..1e6 km from Mars.
    r = RNG.normal(size=(20, 3))
    r *= (10 ** RNG.uniform(4, 6, (20, 1))) / np.linalg.norm(r, axis=1, keepdims=True)
    a = model.acceleration(r, r_pert)
    for j in range(3):
        h = 1e-6 * np.linalg.norm(r, axis=1)
        dr = np.zeros_like(r)
        dr[:, j] = h
        fd = (_potential(model, r + dr, r_pert) - _potential(model, r - dr, r_pert)) / (2 * h)
        # The Sun's tidal potential (~600 km^2/s^2) limits central differences to ~1e-6 relative.
        np.testing.assert_allclose(fd, a[:, j], rtol=1e-5, atol=1e-16)
    # Each perturbing term alone, against its own potential (central term left out of both).
    for k, name in enumerate(model.perturbers):
        single = GravityModel("mars", (name,))
        term = single.acceleration(r, r_pert[k : k + 1]) - GravityModel("mars").acceleration(r)
        # The perturbers are > 0.3 AU away: a 1e3 km step keeps truncation ~1e-17 km/s^2
        # while the potential's ~600 km^2/s^2 magnitude leaves round-off ~3e-17 km/s^2.
        h = np.full((len(r), 1), 1e3)
        fd = np.stack(
            [
                (
                    _potential(single, r + h * e, r_pert[k : k + 1], central=False)
                    - _potential(single, r - h * e, r_pert[k : k + 1], central=False)
                )
                / (2 * h[:, 0])
                for e in np.eye(3)
            ],
            axis=-1,
        )
        np.testing.assert_allclose(fd, term, rtol=1e-5, atol=2e-16)


@pytest.mark.parametrize("perturbed", [False, True])
def test_jacobian_matches_finite_differences(perturbed):
    eph = DEEphemeris()
    t = tdb_seconds(2020, 6, 1)
    if perturbed:
        model = GravityModel("sun", ("venus", "earth", "mars", "jupiter"))
        r_pert = np.stack([eph.position(b, t) for b in model.perturbers])
    else:
        model, r_pert = GravityModel("sun"), None
    x = _random_states(50)
    f = model.jacobian(x, r_pert)
    for j in range(6):
        h = 1e-5 * AU_KM if j < 3 else 1e-4
        dx = np.zeros_like(x)
        dx[:, j] = h
        fd = (model.derivative(x + dx, r_pert) - model.derivative(x - dx, r_pert)) / (2 * h)
        scale = np.max(np.abs(f[:, :, j]), axis=1, keepdims=True) + 1e-30
        assert np.max(np.abs(fd - f[:, :, j]) / scale) < 1e-7, j


def test_two_body_year_conserves_energy_and_angular_momentum():
    # 1 year at dt = 600 s on a 1 AU x 0.3 eccentric orbit. RK4's per-orbit energy drift scales as
    # dt^4; measured ~1e-12 relative. Bound: 1e-10 relative (energy), 1e-10 (|h|).
    r, v = elements_to_state(1.2 * AU_KM, 0.3, 0.4, 0.3, 1.0, 0.0, GM_SUN)
    x0 = np.concatenate([r, v])[None]
    model = GravityModel("sun")
    traj = propagate(model, x0, 0.0, 600.0, int(365.25 * 86400 / 600))
    e = specific_energy(traj[:, 0], GM_SUN)
    h = angular_momentum(traj[:, 0])
    assert np.max(np.abs(e / e[0] - 1.0)) < 1e-10
    assert np.max(np.linalg.norm(h - h[0], axis=-1)) / np.linalg.norm(h[0]) < 1e-10


def test_rk4_matches_kepler_closed_form():
    a, e = 1.3 * AU_KM, 0.2
    r0, v0 = elements_to_state(a, e, 0.1, 1.0, 2.0, 0.5, GM_SUN)
    model = GravityModel("sun")
    dt, n = 3600.0, 24 * 100  # 100 days
    traj = propagate(model, np.concatenate([r0, v0])[None], 0.0, dt, n)
    n_mean = np.sqrt(GM_SUN / a**3)
    r_kep, v_kep = elements_to_state(a, e, 0.1, 1.0, 2.0, 0.5 + n_mean * dt * n, GM_SUN)
    # RK4 global error at dt = 1 h over 100 days: measured ~1e-3 km; bound 1 km / 1e-6 km/s.
    assert np.linalg.norm(traj[-1, 0, :3] - r_kep) < 1.0
    assert np.linalg.norm(traj[-1, 0, 3:] - v_kep) < 1e-6
    el = state_to_elements(traj[-1, 0, :3], traj[-1, 0, 3:], GM_SUN)
    assert abs(el["a"] / a - 1) < 1e-9


def _flow_jacobian(model, x, t, dt, perturbers=None, steps=1):
    jac = np.zeros((6, 6))
    for j in range(6):
        h = 1.0 if j < 3 else 1e-6
        dx = np.zeros(6)
        dx[j] = h
        xp, xm = x + dx, x - dx
        for _ in range(steps):
            xp = rk4_step(model, xp[None], t, dt, perturbers)[0]
            xm = rk4_step(model, xm[None], t, dt, perturbers)[0]
        jac[:, j] = (xp - xm) / (2 * h)
    return jac


@pytest.mark.parametrize(
    ("central", "radius_km", "dt"), [("sun", 0.7 * AU_KM, 86400.0), ("mars", 2.0e4, 600.0)]
)
def test_rk4_stm_is_the_flow_jacobian_and_beats_euler(central, radius_km, dt):
    model = GravityModel(central)
    mu = model.mu_central
    v_circ = np.sqrt(mu / radius_km)
    x = np.array([radius_km, 0.0, 0.0, 0.0, 1.1 * v_circ, 0.1 * v_circ])
    fd = _flow_jacobian(model, x, 0.0, dt)
    _, phi = rk4_step_stm(model, x[None], 0.0, dt)
    phi_e = euler_stm(model, x[None], 0.0, dt)[0]
    scale = np.max(np.abs(fd), axis=0)  # per column: entries differ by 10 orders of magnitude
    err_rk4 = np.max(np.abs(phi[0] - fd) / scale)
    err_eul = np.max(np.abs(phi_e - fd) / scale)
    assert err_rk4 < 1e-6
    # The thesis's I + F dt drops the G dt^2/2 position terms: orders of magnitude worse.
    assert err_eul > 100 * err_rk4


def test_bad_inputs():
    model = GravityModel("sun")
    x = _random_states(1)
    with pytest.raises(InvalidParameterError, match="dt"):
        rk4_step(model, x, 0.0, 0.0)
    with pytest.raises(InvalidParameterError, match="dt"):
        rk4_step(model, x, 0.0, -5.0)
    bad = x.copy()
    bad[0, 2] = np.nan
    with pytest.raises(NonFiniteError, match="orbit state"):
        rk4_step(model, bad, 0.0, 10.0)
    with pytest.raises(UnknownBodyError, match="nibiru"):
        GravityModel("sun", ("nibiru",))
    with pytest.raises(InvalidParameterError, match="perturbers"):
        rk4_step(GravityModel("sun", ("mars",)), x, 0.0, 10.0)
    with pytest.raises(InvalidParameterError, match="n_steps"):
        propagate(model, x, 0.0, 10.0, -1)
