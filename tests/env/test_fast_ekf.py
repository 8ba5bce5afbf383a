"""The compiled EKF path agrees with the numpy reference core."""

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM, GM_SUN, body
from planetnav_env.astro.ephemeris import DEEphemeris, KeplerianEphemeris, elements_to_state
from planetnav_env.astro.timescale import tdb_seconds
from planetnav_env.dynamics.orbit import GravityModel
from planetnav_env.errors import InvalidParameterError, NonFiniteError
from planetnav_env.estimation.ekf import FilterConfig, process_noise
from planetnav_env.estimation.ekf_kernels import KIND_CODES, SingleEKF, cycle_batch_kernel
from planetnav_env.estimation.measurements import MeasurementModel, los_basis
from planetnav_validation.navigation import perturb_direction
from planetnav_validation.numpy_ekf import BatchEKF

T0 = tdb_seconds(2021, 1, 1)


def _x0():
    r, v = elements_to_state(1.2 * AU_KM, 0.2, 0.05, 0.3, 1.0, 2.5, GM_SUN)
    return np.concatenate([r, v])


@pytest.mark.parametrize("kind", ["direction", "direction+size", "los", "los+size"])
@pytest.mark.parametrize("stm", ["rk4", "euler"])
def test_single_ekf_matches_numpy_core(kind, stm):
    eph = KeplerianEphemeris()
    perturbers = ("venus", "earth", "jupiter")
    model = GravityModel("sun", perturbers)

    def pert(t):
        return np.stack([eph.position(b, t) for b in perturbers])

    cfg = FilterConfig(accel_psd=1e-16, stm=stm, gate_probability=0.999)
    meas = MeasurementModel(kind, sigma_size=5e-6)
    rng = np.random.default_rng(1)
    x_true = _x0()
    x0 = x_true + rng.normal(size=6) * [500, 500, 500, 1e-3, 1e-3, 1e-3]
    ref = BatchEKF(model, x0, cfg.initial_covariance(), cfg, pert)
    fast = SingleEKF(model, x0, cfg.initial_covariance(), cfg, pert)
    diameter = body("mars").diameter
    for k in range(60):
        t = T0 + 300.0 * k
        ref.predict(t, 300.0)
        fast.predict(t, 300.0)
        planet = eph.position("mars", t + 300.0)
        d = planet - x_true[:3]
        u = perturb_direction(rng, (d / np.linalg.norm(d))[None], meas.sigma_dir)
        basis = None
        if kind.startswith("los"):
            dp = planet - ref.x[0, :3]
            basis = los_basis((dp / np.linalg.norm(dp))[None])
        alpha = np.array([2 * np.arctan(0.5 * diameter / np.linalg.norm(d))]) if meas.uses_size else None
        z = meas.from_unit_vector(u, alpha, basis)
        if k == 30:
            z[0, 0] += 1e-2  # an outlier both must reject
        h, jac, cov = meas.evaluate(ref.x[:, :3], planet, diameter, basis)
        res = ref.update(z, h, jac, cov, meas.angle_mask)
        nis, ok = fast.update_planet(z[0], planet, diameter, meas, None if basis is None else basis[0])
        assert ok == bool(res.accepted[0])
        np.testing.assert_allclose(nis, res.nis[0], rtol=1e-8)
    assert fast.rejected == ref.rejected[0] >= 1
    np.testing.assert_allclose(fast.x, ref.x[0], rtol=1e-10)
    np.testing.assert_allclose(fast.P, ref.P[0], rtol=1e-7, atol=1e-10 * np.abs(ref.P).max())


def test_batch_kernel_matches_single_filters():
    model = GravityModel("sun")
    cfg = FilterConfig(gate_probability=1.0)
    meas = MeasurementModel("direction+size")
    eph = DEEphemeris()
    n = 16
    rng = np.random.default_rng(2)
    x = _x0() + rng.normal(size=(n, 6)) * [800, 800, 800, 1e-3, 1e-3, 1e-3]
    p = np.repeat(cfg.initial_covariance()[None], n, 0)
    singles = [SingleEKF(model, x[i], p[i], cfg) for i in range(n)]
    planet = eph.position("venus", T0 + 60.0)
    planets = np.repeat(planet[None], n, 0)
    z = meas.evaluate(_x0()[None, :3], planet, body("venus").diameter)[0]
    z = np.repeat(z, n, 0) + rng.normal(size=(n, 3)) * 1e-6
    active = np.arange(n) % 3 != 0
    nis = np.empty(n)
    acc = np.empty(n, bool)
    empty = np.zeros((0, 3))
    cycle_batch_kernel(
        x,
        p,
        60.0,
        model.mu_central,
        empty,
        empty,
        empty,
        np.zeros(0),
        process_noise(60.0, cfg.accel_psd),
        False,
        z,
        planets,
        body("venus").diameter,
        KIND_CODES[meas.kind],
        meas.sigma_dir,
        meas.sigma_size,
        np.zeros((n, 2, 3)),
        active,
        np.inf,
        nis,
        acc,
    )
    for i, s in enumerate(singles):
        s.predict(T0, 60.0)
        if active[i]:
            s.update_planet(z[i], planet, body("venus").diameter, meas)
        np.testing.assert_allclose(x[i], s.x, rtol=1e-13)
        np.testing.assert_allclose(p[i], s.P, rtol=1e-12)
    assert np.all(np.isnan(nis[~active])) and np.all(acc[active])


def test_single_ekf_bad_input():
    model = GravityModel("sun")
    cfg = FilterConfig()
    ekf = SingleEKF(model, _x0(), cfg.initial_covariance(), cfg)
    with pytest.raises(InvalidParameterError, match="dt"):
        ekf.predict(T0, -1.0)
    with pytest.raises(NonFiniteError):
        ekf.update_planet(np.array([np.nan, 0.0]), np.ones(3) * AU_KM, 1.0, MeasurementModel("direction"))
    with pytest.raises(InvalidParameterError, match="basis"):
        ekf.update_planet(np.zeros(2), np.ones(3) * AU_KM, 1.0, MeasurementModel("los"))
    with pytest.raises(InvalidParameterError, match="perturbers"):
        SingleEKF(GravityModel("sun", ("mars",)), _x0(), cfg.initial_covariance(), cfg).predict(T0, 10.0)
    with pytest.raises(InvalidParameterError, match="positive definite"):
        SingleEKF(model, _x0(), -np.eye(6), cfg)


@pytest.mark.parametrize("kind", ["direction+size", "los"])
def test_navigation_harness_engines_agree(kind):
    from planetnav_validation.navigation import simulate_navigation

    common = dict(
        x0=_x0(),
        t0=T0,
        dt=120.0,
        n_steps=200,
        schedule=lambda k, t, x: "mars" if k < 100 else "venus",
        ephemeris=KeplerianEphemeris(),
        measurement=MeasurementModel(kind),
        config=FilterConfig(),
        n_runs=5,
    )
    a = simulate_navigation(**common, rng=np.random.default_rng(9), engine="numpy")
    b = simulate_navigation(**common, rng=np.random.default_rng(9), engine="compiled")
    np.testing.assert_allclose(b.x_est, a.x_est, rtol=1e-10)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-6, atol=1e-9 * np.abs(a.P).max())
    np.testing.assert_array_equal(b.accepted, a.accepted)


def test_core_what_if_updates_equal_the_numpy_kalman_update():
    """The planning agents' what-if (core.what_if.predicted_*_trace: the core's model and Joseph update on
    copies, R / n, zero innovation) equals the standard-form update P - P H^T S^-1 H P of the numpy
    measurement model (the oracle) for every measurement model and pulsar."""
    import math

    from planetnav_env.core.what_if import predicted_planet_trace, predicted_pulsar_trace
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_env.estimation.measurements import MeasurementModel, los_basis
    from planetnav_env.sensors import pulsar as psr

    rng = np.random.default_rng(5)
    for model in ("direction", "direction+size", "los", "los+size"):
        env = PlanetNavEnv(measurement_model=model, pulsars=("B0531+21",))
        _, info = env.reset(seed=1)
        cfg = env.config
        prm = env.core.params
        x, p = info["filter"]["x"], info["filter"]["P"]
        sigma_dir = math.hypot(
            cfg.camera.sigma_direction_rad, cfg.star_tracker_sigma_arcsec * math.pi / 648000
        )
        mm = MeasurementModel(model, sigma_dir=sigma_dir, sigma_size=cfg.camera.sigma_alpha_rad)
        for _ in range(10):
            i = int(rng.integers(0, 3))
            planet = x[:3] + rng.normal(size=3) * 1e8
            n = int(rng.integers(1, 5))
            d = planet - x[:3]
            basis = los_basis((d / np.linalg.norm(d))[None]) if model.startswith("los") else None
            _, h, r = mm.evaluate(x[:3], planet, 2.0 * prm.radii[i], basis)
            h, r = h[0], r[0] / n
            ph = p @ h.T
            p_new = p - ph @ np.linalg.solve(h @ ph + r, ph.T)
            want = np.trace(p_new[:3, :3])
            got = predicted_planet_trace(prm, x, p, planet, i, float(n))
            assert got == pytest.approx(want, rel=1e-9)
            # greedy's lookahead: the updated covariance coasted T ahead in free flight, A P A^T with
            # A = [[I, T I], [0, I]]
            t = float(rng.uniform(600.0, 43200.0))
            a = np.eye(6)
            a[:3, 3:] = t * np.eye(3)
            coasted = predicted_planet_trace(prm, x, p, planet, i, float(n), t)
            assert coasted == pytest.approx(np.trace((a @ p_new @ a.T)[:3, :3]), rel=1e-9)
            assert coasted > got
        pul = psr.pulsar("B0531+21")
        hrow = np.zeros(6)
        hrow[:3] = pul.direction / pul.wavelength_km
        ph = p @ hrow
        sig = psr.phase_sigma_cycles(pul, cfg.detector)
        want = np.trace((p - np.outer(ph, ph) / (hrow @ ph + sig**2))[:3, :3])
        assert predicted_pulsar_trace(prm, p, 0) == pytest.approx(want, rel=1e-9)
