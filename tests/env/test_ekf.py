"""EKF: filterpy cross-check, consistency (NEES/NIS), gating, covariance health, bad input."""

import numpy as np
import pytest
from scipy.stats import chi2

from planetnav_env.astro.bodies import AU_KM, GM_SUN, body
from planetnav_env.astro.ephemeris import KeplerianEphemeris, elements_to_state
from planetnav_env.astro.timescale import tdb_seconds
from planetnav_env.dynamics.orbit import GravityModel
from planetnav_env.errors import InvalidParameterError, NonFiniteError
from planetnav_env.estimation.ekf import FilterConfig, process_noise
from planetnav_env.estimation.measurements import MeasurementModel, h_direction, jac_direction
from planetnav_validation.navigation import perturb_direction, simulate_navigation
from planetnav_validation.numpy_ekf import BatchEKF, FilterpyEKF

T0 = tdb_seconds(2020, 9, 1)


def _x0():
    r, v = elements_to_state(1.1 * AU_KM, 0.3, np.deg2rad(2.0), 0.5, 1.0, 2.0, GM_SUN)
    return np.concatenate([r, v])


def test_batched_core_matches_filterpy():
    eph = KeplerianEphemeris()
    model = GravityModel("sun")
    cfg = FilterConfig(accel_psd=1e-16, gate_probability=1.0)
    rng = np.random.default_rng(3)
    x_true = _x0()
    x0 = x_true + np.r_[500.0, -300.0, 200.0, 1e-3, -2e-3, 5e-4]
    p0 = cfg.initial_covariance()
    ours = BatchEKF(model, x0, p0, cfg)
    ref = FilterpyEKF(model, x0, p0, dim_z=2, config=cfg)
    meas = MeasurementModel("direction")
    dt = 60.0
    for k in range(120):
        t = T0 + k * dt
        ours.predict(t, dt)
        ref.predict(t, dt)
        planet = eph.position("venus", t + dt)
        d = planet - x_true[:3]
        z = meas.from_unit_vector(perturb_direction(rng, (d / np.linalg.norm(d))[None], meas.sigma_dir))[0]
        h, jac, cov = meas.evaluate(ours.x[:, :3], planet, 1.0)
        ours.update(z[None], h, jac, cov, meas.angle_mask)
        ref.update(
            z,
            lambda x, p=planet: h_direction(x[None, :3], p)[0],
            lambda x, p=planet: jac_direction(x[None, :3], p)[0],
            meas.evaluate(ref.x[None, :3], planet, 1.0)[2][0],
            meas.angle_mask,
        )
    np.testing.assert_allclose(ours.x[0], ref.x, rtol=1e-9)
    np.testing.assert_allclose(ours.P[0], ref.P, rtol=1e-9, atol=1e-9 * np.abs(ref.P).max())


@pytest.mark.parametrize("kind", ["direction+size", "los"])
def test_nees_and_nis_consistent_over_monte_carlo(kind):
    # 60 runs, matched noise: truth gets the filter's process noise, measurements its R.
    n_runs, n_steps = 60, 150
    cfg = FilterConfig(sigma_pos0=2000.0, sigma_vel0=2e-3, accel_psd=1e-14, gate_probability=1.0)
    meas = MeasurementModel(kind, sigma_dir=np.deg2rad(3.5 / 3600), sigma_size=1e-5)
    res = simulate_navigation(
        x0=_x0(),
        t0=T0,
        dt=600.0,
        n_steps=n_steps,
        schedule=lambda k, t, x: "venus" if k % 2 else "mars",
        ephemeris=KeplerianEphemeris(),
        measurement=meas,
        config=cfg,
        n_runs=n_runs,
        rng=np.random.default_rng(11),
        truth_process_noise=True,
    )
    lo, hi = chi2.ppf([0.025, 0.975], 6 * n_runs) / n_runs
    anees = res.nees.mean(axis=1)
    inside = (anees >= lo) & (anees <= hi)
    assert lo <= anees[-1] <= hi
    assert inside.mean() >= 0.9, f"ANEES inside 95% bounds at {inside.mean():.0%} of steps"
    m = meas.dim
    lo_z, hi_z = chi2.ppf([0.025, 0.975], m * n_runs) / n_runs
    anis = np.nanmean(res.nis, axis=1)
    inside_z = (anis >= lo_z) & (anis <= hi_z)
    assert inside_z.mean() >= 0.9, f"ANIS inside 95% bounds at {inside_z.mean():.0%} of steps"
    # Time-and-run average, with the run count as the (conservative) degrees of freedom.
    assert lo <= anees.mean() <= hi and lo_z <= anis.mean() <= hi_z


def test_covariance_stays_symmetric_positive_definite():
    res = simulate_navigation(
        x0=_x0(),
        t0=T0,
        dt=60.0,
        n_steps=400,
        schedule=lambda k, t, x: "venus",
        ephemeris=KeplerianEphemeris(),
        measurement=MeasurementModel("direction+size"),
        config=FilterConfig(),
        n_runs=4,
        rng=np.random.default_rng(5),
    )
    p = res.P
    np.testing.assert_array_equal(p, np.swapaxes(p, -1, -2))
    assert np.all(np.linalg.eigvalsh(p) > 0)


def test_gating_rejects_and_counts_outliers():
    model = GravityModel("sun")
    cfg = FilterConfig(gate_probability=0.9999)
    x = _x0()
    ekf = BatchEKF(model, np.stack([x, x]), cfg.initial_covariance(), cfg)
    ekf.predict(T0, 60.0)
    planet = KeplerianEphemeris().position("mars", T0 + 60.0)
    meas = MeasurementModel("direction")
    h, jac, cov = meas.evaluate(ekf.x[:, :3], np.broadcast_to(planet, (2, 3)), 1.0)
    z = h.copy()
    z[1, 0] += np.deg2rad(1.0)  # a 1 degree outlier in the second filter
    x_before = ekf.x.copy()
    res = ekf.update(z, h, jac, cov, meas.angle_mask)
    assert list(res.accepted) == [True, False]
    assert list(ekf.rejected) == [0, 1]
    np.testing.assert_array_equal(ekf.x[1], x_before[1])
    assert res.nis[1] > cfg.gate_threshold(2)


def test_process_noise_matches_white_acceleration_integral():
    dt, q = 100.0, 1e-12
    qd = process_noise(dt, q)
    # Integrate Phi(s) G q G^T Phi(s)^T ds for the double integrator numerically.
    s = np.linspace(0.0, dt, 20001)
    pos = 0.5 * (s[1:] + s[:-1])
    ds = dt / 20000
    assert np.isclose(qd[0, 0], q * np.sum(pos**2) * ds, rtol=1e-6)
    assert np.isclose(qd[0, 3], q * np.sum(pos) * ds, rtol=1e-6)
    assert np.isclose(qd[3, 3], q * dt)


def test_bad_inputs():
    model = GravityModel("sun")
    cfg = FilterConfig()
    with pytest.raises(InvalidParameterError, match="sigma_pos0"):
        FilterConfig(sigma_pos0=-1.0)
    with pytest.raises(InvalidParameterError, match="stm"):
        FilterConfig(stm="magic")
    with pytest.raises(InvalidParameterError, match="positive definite"):
        BatchEKF(model, _x0(), -np.eye(6), cfg)
    with pytest.raises(NonFiniteError, match="initial estimate"):
        BatchEKF(model, np.full(6, np.nan), np.eye(6), cfg)
    ekf = BatchEKF(model, _x0(), cfg.initial_covariance(), cfg)
    with pytest.raises(InvalidParameterError, match="dt"):
        ekf.predict(T0, 0.0)
    planet = KeplerianEphemeris().position("mars", T0)
    h, jac, cov = MeasurementModel("direction").evaluate(ekf.x[:, :3], planet, body("mars").diameter)
    with pytest.raises(NonFiniteError, match="measurement"):
        ekf.update(np.array([[np.nan, 0.0]]), h, jac, cov)
