"""Mars approach: trajectory construction, force model vs potential, RK4 vs DOP853, the mixed-sensor EKF
harness and the optical-pulsar reproduction CLI."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from planetnav_env.astro.bodies import body
from planetnav_env.dynamics.orbit import GravityModel
from planetnav_env.errors import InvalidParameterError, NotVisibleError
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.scenarios.approach import ApproachConfig, MarsApproach, hyperbolic_periapsis_state
from planetnav_env.sensors import pulsar as psr
from planetnav_validation.approach_methods import METHODS, NavConfig, _schedule, run_method, run_methods
from planetnav_validation.reproduce import optical_pulsar

MU_MARS = body("mars").gm
#: Stated bound of the fixed-step RK4 (60 s) against DOP853 (rtol 1e-12) over the 96 h approach down to
#: periapsis: 1 m in position, 2 mm/s in velocity (measured: 0.31 m, 0.66 mm/s).
RK4_POS_BOUND_KM = 1e-3
RK4_VEL_BOUND_KM_S = 2e-6
#: Stated bound of the truth (compiled RK4, see TRUTH_STEP_NEAR_S) against DOP853 over the same arc: 1 mm,
#: 1 um/s.
TRUTH_POS_BOUND_KM = 1e-6
TRUTH_VEL_BOUND_KM_S = 1e-9


@pytest.fixture(scope="module")
def approach():
    return MarsApproach()


def _rhs(approach: MarsApproach):
    """The approach's force model as scipy wants it (the DOP853 oracle's right-hand side)."""
    return lambda t, x: approach.model.derivative(x[None, :], approach.perturber_positions(t))[0]


@pytest.fixture(scope="module")
def dop853(approach):
    """The independent truth on the grid: scipy's DOP853 backwards from periapsis, ephemerides straight from
    DE421 (atol 1e-12: at 1e-9 the velocity's tolerance, not rtol, would set its error, ~3 mm at the
    start)."""
    sol = solve_ivp(
        _rhs(approach), (approach.config.closest_approach_tdb, approach.t0), approach.x_ca, method="DOP853",
        rtol=1e-12, atol=1e-12, dense_output=True,
    )  # fmt: skip
    assert sol.success
    return sol.sol(approach.t).T


@pytest.fixture(scope="module")
def short_approach():
    # The last 6 h down to periapsis: the harness on a cheap span.
    return MarsApproach(ApproachConfig(duration_h=6.0))


def test_periapsis_state_is_the_hyperbola_with_the_given_asymptote():
    v_inf = np.array([1.5, -2.0, 0.7])
    rp = 3796.19
    x = hyperbolic_periapsis_state(v_inf, rp, MU_MARS, np.array([0.0, 0.0, 1.0]))
    r, v = x[:3], x[3:]
    assert np.linalg.norm(r) == pytest.approx(rp, rel=1e-14)
    assert r @ v == pytest.approx(0.0, abs=1e-9)
    assert 0.5 * v @ v - MU_MARS / rp == pytest.approx(0.5 * v_inf @ v_inf, rel=1e-12)
    # Two-body backwards for 60 days: the velocity there points along the incoming v_inf.
    sol = solve_ivp(
        lambda t, y: np.concatenate([y[3:], -MU_MARS * y[:3] / np.linalg.norm(y[:3]) ** 3]),
        (0.0, -60 * 86400.0),
        x,
        method="DOP853",
        rtol=1e-11,
        atol=1e-9,
    )
    v_far = sol.y[3:, -1]
    ang = np.arccos(v_far @ v_inf / np.linalg.norm(v_far) / np.linalg.norm(v_inf))
    # At ~1.7e7 km the residual bending is ~mu / (r v_inf^2) ~ 4e-4 rad.
    assert ang < 1e-3
    with pytest.raises(InvalidParameterError):
        hyperbolic_periapsis_state(v_inf, rp, MU_MARS, v_inf)


def test_truth_reaches_periapsis_at_the_stated_epoch(approach):
    rng_km = approach.range_km()
    assert rng_km[-1] == pytest.approx(body("mars").radius + 400.0, rel=1e-10)
    assert np.all(np.diff(rng_km) < 0.0)  # approaching all the way
    x = approach.x_true[-1]
    assert abs(x[:3] @ x[3:]) / (np.linalg.norm(x[:3]) * np.linalg.norm(x[3:])) < 1e-9
    assert 5e5 < rng_km[0] < 2e6  # "a few days out": ~9.4e5 km for 96 h at 2.65 km/s
    # Forward DOP853 from the start reproduces the periapsis state (the integration is reversible to ~m).
    sol = solve_ivp(
        _rhs(approach),
        (approach.t0, approach.t_end),
        approach.x_true[0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-9,
    )
    np.testing.assert_allclose(sol.y[:3, -1], approach.x_ca[:3], atol=1e-3)


def _potential(mu, rk, r):
    return mu * (1.0 / np.linalg.norm(rk - r, axis=-1) - r @ rk / np.linalg.norm(rk) ** 3)


def test_each_perturbing_acceleration_is_the_gradient_of_its_potential(approach):
    idx = [0, approach.n_steps // 2, approach.n_steps - 60]
    r = approach.x_true[idx, :3]
    for i, k in enumerate(idx):
        pert = approach.perturber_positions(approach.t[k])
        for b, name in enumerate(("sun", "earth", "jupiter")):
            single = GravityModel("mars", (name,))
            a = single.acceleration(r[i : i + 1], pert[b : b + 1]) - GravityModel("mars").acceleration(
                r[i : i + 1]
            )
            h = 1e3
            fd = np.array(
                [
                    (
                        _potential(single.mu_perturbers[0], pert[b], r[i] + h * e)
                        - _potential(single.mu_perturbers[0], pert[b], r[i] - h * e)
                    )
                    / (2 * h)
                    for e in np.eye(3)
                ]
            )
            scale = np.linalg.norm(a)
            np.testing.assert_allclose(a[0], fd, atol=1e-6 * scale + 1e-18)


def test_rk4_against_dop853_within_the_stated_bound(approach, dop853):
    x4 = approach.rk4_trajectory()
    dpos = np.linalg.norm(x4[:, :3] - dop853[:, :3], axis=1)
    dvel = np.linalg.norm(x4[:, 3:] - dop853[:, 3:], axis=1)
    assert dpos.max() < RK4_POS_BOUND_KM
    assert dvel.max() < RK4_VEL_BOUND_KM_S


def test_truth_against_dop853_within_a_millimetre(approach, dop853):
    """The compiled truth (RK4 in steps of at most 2 s near Mars, 20 s before; the same bits on every CPU)
    against scipy's DOP853 (measured: 0.62 mm, 0.007 um/s)."""
    dpos = np.linalg.norm(approach.x_true[:, :3] - dop853[:, :3], axis=1)
    dvel = np.linalg.norm(approach.x_true[:, 3:] - dop853[:, 3:], axis=1)
    assert dpos.max() < TRUTH_POS_BOUND_KM
    assert dvel.max() < TRUTH_VEL_BOUND_KM_S


def test_schedule_gives_each_sensor_its_own_rate():
    k = _schedule(360, 60.0, 1000.0)  # 6 h: TOAs at 1000, 2000, ... s -> first grid point at or after
    np.testing.assert_array_equal(k[:3], [17, 34, 50])
    assert k.size == 21
    np.testing.assert_array_equal(_schedule(360, 60.0, 600.0), np.arange(10, 361, 10))


def test_harness_runs_all_methods_with_common_random_numbers(short_approach):
    res = run_methods(short_approach, tuple(METHODS), runs=4, seed=7)
    assert set(res) == set(METHODS)
    for r in res.values():
        assert r.pos_err.shape == (short_approach.n_steps + 1, 4, 3)
        assert np.all(np.isfinite(r.pos_err)) and np.all(np.isfinite(r.nees))
        # Same initial errors for every method.
        np.testing.assert_array_equal(r.pos_err[0], res["OPN"].pos_err[0])
        s = r.summary()
        assert s["final_pos_err_km"] >= 0.0 and s["rms_pos_err_km_last_half"] >= 0.0
    assert res["OPN"].n_pulsar == 0 and res["PN"].n_optical == 0
    assert res["OPHN"].n_optical == res["OPN"].n_optical > 0
    assert res["OPHN"].n_pulsar == res["PN"].n_pulsar > 0
    # One method alone gives the same numbers as inside the batch.
    alone = run_method(short_approach, "PN", runs=4, seed=7)
    np.testing.assert_array_equal(alone.pos_err, res["PN"].pos_err)
    # Optical images stop when Mars's disk no longer fits the field of view (the last ~2 h).
    assert res["OPN"].n_optical_not_visible > 0


def test_hybrid_beats_each_sensor_alone_in_covariance(short_approach):
    nav = NavConfig(
        pulsars=("B1937+21",), filter=FilterConfig(sigma_pos0=20.0, sigma_vel0=1e-4, accel_psd=1e-16)
    )
    res = run_methods(short_approach, tuple(METHODS), runs=3, seed=1, nav=nav)
    mid = short_approach.n_steps // 2
    sig = {m: res[m].sigma_pos[mid].mean() for m in METHODS}
    assert sig["OPHN"] < sig["OPN"] and sig["OPHN"] < sig["PN"]


def test_unresolvable_cycle_ambiguity_is_skipped_and_counted(short_approach):
    # B1937+21: lambda = 467 km; a 100 km-per-axis prior gives 3 sigma > lambda / 2 along its line of sight.
    nav = NavConfig(pulsars=("B1937+21",))
    r = run_method(short_approach, "PN", runs=2, seed=0, nav=nav)
    epochs = _schedule(short_approach.n_steps, short_approach.dt, nav.detector.integration_time_s).size
    # Skipped (and counted) nearly everywhere; the flyby's last minutes can squeeze the predicted spread
    # along the pulsar below the threshold, where the rule lets a phase through.
    assert r.n_ambiguity_skipped >= 0.9 * 2 * epochs
    assert r.n_pulsar <= 0.1 * epochs


def test_bad_input(short_approach):
    with pytest.raises(InvalidParameterError):
        run_method(short_approach, "XNAV")
    with pytest.raises(InvalidParameterError):
        run_methods(short_approach, ("PN", "PN"))
    with pytest.raises(InvalidParameterError):
        run_method(short_approach, "PN", runs=0)
    with pytest.raises(psr.UnknownPulsarError):
        NavConfig(pulsars=("B0000+00",))
    with pytest.raises(InvalidParameterError):
        NavConfig(detector=psr.XrayDetector(area_cm2=0.0))
    with pytest.raises(InvalidParameterError):
        ApproachConfig(dt_s=61.7)
    with pytest.raises(InvalidParameterError):
        ApproachConfig(duration_h=-1.0)
    # B1821-24 is ~11 deg from the Sun as seen from Mars in February 2021: Sun-blocked for the whole approach.
    r_helio = short_approach.mars_helio + short_approach.x_true[:, :3]
    ang = np.degrees(psr.pulsar_visibility(r_helio, ["B1821-24"]).sun_angle_rad)
    assert np.all(ang < 30.0)
    with pytest.raises(NotVisibleError, match="B1821-24 is blocked by the Sun"):
        run_method(short_approach, "PN", runs=1, nav=NavConfig(pulsars=("B1821-24",)))
    # Optical-only does not need the pulsar: no error.
    run_method(short_approach, "OPN", runs=1, nav=NavConfig(pulsars=("B1821-24",)))


def test_cli_writes_json_with_sane_values(tmp_path, capsys):
    out = tmp_path / "op.json"
    rc = optical_pulsar.main(["--runs", "2", "--json", str(out), "--plots", str(tmp_path / "plots")])
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["runs"] == 2
    assert set(data["methods"]) == {"OPN", "PN", "OPHN"}
    duration = data["scenario"]["duration_h"]
    for m, s in data["methods"].items():
        for key in ("final_pos_err_km", "rms_pos_err_km_last_half"):
            assert np.isfinite(s[key]) and 0.0 <= s[key] < 1e4, (m, key, s[key])
        t10 = s["time_to_10km_h"]
        assert t10 is None or 0.0 <= t10 <= duration
    # More information, smaller covariance: the hybrid's final 3-sigma is below the single pulsar's.
    assert data["methods"]["OPHN"]["final_3sigma_km"] < data["methods"]["PN"]["final_3sigma_km"]
    assert (tmp_path / "plots" / "optical_pulsar_errors.png").stat().st_size > 0
    assert "OPHN" in capsys.readouterr().out


@pytest.mark.parametrize("args", [["--area-m2", "0"], ["--t-obs", "-5"], ["--pulsar", "B9999+99"]])
def test_cli_reports_bad_input(args, capsys):
    assert optical_pulsar.main(["--runs", "1", *args]) == 2
    assert "error:" in capsys.readouterr().err
