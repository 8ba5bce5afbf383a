"""The truth's own force model (``world.third_bodies``, ``world.srp``, ``world.truth_ephemeris``) against
independent truth.

The oracle: scipy's DOP853 on the same forces with the bodies' positions read by jplephem from the kernel
itself (DE421, or DE440 when the truth follows it; not the row's Chebyshev table), the third bodies in the
central body's frame (direct minus indirect term) and the cannonball SRP in its closed form
``a = C_R (A/m) (S/c) (1 AU / r)^2`` away from the Sun (on the Mars approach from the Sun's position
relative to Mars, the Sun's pull on Mars untouched by it). The propagator under test is the compiled
truth step itself (``kernels.propagate_truth``, what ``step_row`` calls), run in a loop over the row's own
table.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from jplephem.spk import SPK
from numba import njit
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.astro.bodies import BODIES
from planetnav_env.astro.ephemeris import de421_path, de440_path
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.kernels import propagate_truth
from planetnav_env.core.records import make_scratch
from planetnav_env.core.row_ephemeris import perturbers_at
from planetnav_env.errors import OptionError
from planetnav_env.estimation.ekf_kernels import OrbitModel
from planetnav_env.world import WorldConfig

DAY = 86_400.0
AU_M = 149_597_870_700.0
#: Independent constants of the closed form: total solar irradiance [W/m^2] and c [m/s].
TSI_W_M2 = 1361.0
C_M_S = 299_792_458.0
#: DE421 segment chains (centre, target) from the barycentre; the gas giants as system barycentres.
CHAINS = {
    "sun": ((0, 10),),
    "mercury": ((0, 1), (1, 199)),
    "venus": ((0, 2), (2, 299)),
    "earth": ((0, 3), (3, 399)),
    "moon": ((0, 3), (3, 301)),
    "mars": ((0, 4), (4, 499)),
    "jupiter": ((0, 5),),
    "saturn": ((0, 6),),
}
FORCES = WorldConfig(third_bodies=True, srp=True)


@njit(cache=True)
def _truth_path(prm, eph, f, n, steps, dt, out):  # pragma: no cover - compiled
    """``steps`` truth steps of row ``n`` from its epoch; ``out[s]`` the state after step ``s + 1``."""
    sc = make_scratch(prm)
    t0 = f[n, L.F_T0]
    for s in range(steps):
        t = t0 + s * dt
        perturbers_at(prm, eph, f, n, t, dt, sc.pert)
        orbit = OrbitModel(
            mu=prm.scalars[0].mu,
            p0=sc.pert[0],
            p1=sc.pert[1],
            p2=sc.pert[2],
            mus=prm.mus,
            srp_k=0.0,
            srp_sun=-1,
        )
        propagate_truth(prm, eph, f, n, t, dt, orbit, sc)
        for j in range(6):
            out[s, j] = f[n, L.F_X + j]


def _barycentric(spk: SPK, name: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position [km] and velocity [km/s] of ``name`` from the barycentre at ``t`` [TDB s since J2000]
    (the segments of its chain the kernel holds: DE440's Mars is its system barycentre)."""
    pos = np.zeros((3, t.size))
    vel = np.zeros((3, t.size))
    for c, b in (pair for pair in CHAINS[name] if pair in spk.pairs):
        p, v = spk[c, b].compute_and_differentiate(2451545.0, t / DAY)
        pos += p
        vel += v / DAY
    return pos.T, vel.T


def _reference(
    central: str, bodies: tuple[str, ...], k_srp: float, x0: np.ndarray, t0: float, span: float, path: str
):
    """DOP853 of the same forces, the bodies from jplephem on the kernel at ``path`` (a cubic Hermite
    spline of its positions and velocities at 10-minute nodes: below 1e-9 km); returns the state at
    ``t0 + span``."""
    spk = SPK.open(path)
    try:
        nodes = t0 + np.arange(0.0, span + 601.0, 600.0)
        c_pos, c_vel = _barycentric(spk, central, nodes)
        rel = [_barycentric(spk, b, nodes) for b in bodies]
    finally:
        spk.close()
    pos = np.concatenate([p - c_pos for p, _ in rel], axis=1)
    vel = np.concatenate([v - c_vel for _, v in rel], axis=1)
    spline = CubicHermiteSpline(nodes - t0, pos, vel)
    mus = np.array([BODIES[b].gm for b in bodies])
    mu_c = BODIES[central].gm
    sun_k = bodies.index("sun") if central != "sun" else -1

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        r = y[:3]
        p = spline(t).reshape(-1, 3)
        d = r - p
        acc = -mu_c * r / np.linalg.norm(r) ** 3
        acc -= (
            mus[:, None]
            * (d / np.linalg.norm(d, axis=1)[:, None] ** 3 + p / np.linalg.norm(p, axis=1)[:, None] ** 3)
        ).sum(0)
        s = r if sun_k < 0 else d[sun_k]
        acc += k_srp * s / np.linalg.norm(s) ** 3
        return np.concatenate([y[3:], acc])

    sol = solve_ivp(rhs, (0.0, span), x0, method="DOP853", rtol=1e-13, atol=1e-10)
    assert sol.success
    return sol.y[:, -1]


def _closed_form_k(area_to_mass: float, c_r: float) -> float:
    """The SRP coefficient [km^3/s^2] of ``a = k / r^2`` from the closed form (m/s^2 at 1 AU -> km)."""
    return c_r * area_to_mass * TSI_W_M2 / C_M_S * 1e-3 * (AU_M * 1e-3) ** 2


def _core(world: WorldConfig, scenario: str = "cruise", **kw) -> BatchCore:
    core = BatchCore(EnvConfig(scenario=scenario, world=world, **kw), 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(11)])
    return core


CASES = [
    ("cruise", FORCES, 1440, 60.0, 1e-3),  # one day at the cruise's step: within 1 m
    ("mars-approach", FORCES, 1440, 60.0, 1e-3),  # SRP away from the perturbing Sun
    ("cruise", FORCES, 1440, 3600.0, 0.1),  # sixty days: within 100 m
    ("cruise", WorldConfig(preset="flight"), 1440, 60.0, 1e-3),  # the flight truth: DE440's bodies
    ("mars-approach", WorldConfig(preset="flight"), 1440, 60.0, 1e-3),
]
CASE_IDS = ["cruise-1d", "approach-1d", "cruise-60d", "cruise-flight-de440-1d", "approach-flight-de440-1d"]


def truth_errors(scenario: str, world: WorldConfig, steps: int, dt: float) -> tuple[float, float]:
    """|r_truth - r_DOP853| [km] at the end of ``steps`` truth steps of ``dt`` [s], and the same for the
    matched world's truth (its Sun-only or approach model) against the same reference."""
    core = _core(world, scenario, step_s=dt, episode_steps=steps)
    f = core.f
    x0 = f[0, L.F_X : L.F_X + 6].copy()
    t0 = float(f[0, L.F_T0])
    central = core.plan.central_body
    bodies = core.plan.truth_perturbers
    assert set(bodies) | {central} == set(CHAINS)  # every body of the ephemeris acts
    k = float(f[0, L.F_SRP_K])
    if world.srp_on:
        c_r = k / _closed_form_k(world.area_to_mass_m2_kg, 1.0)
        assert world.reflectivity_range[0] <= c_r <= world.reflectivity_range[1]
    else:
        assert k == 0.0
    out = np.empty((steps, 6))
    _truth_path(core.params, core.eph, f, 0, steps, dt, out)
    path = de440_path() if world.truth_ephemeris_name == "de440" else de421_path()
    ref = _reference(central, bodies, k, x0, t0, steps * dt, path)
    err = float(np.linalg.norm(out[-1, :3] - ref[:3]))
    plain = _core(WorldConfig(), scenario, step_s=dt, episode_steps=steps)
    _truth_path(plain.params, plain.eph, plain.f, 0, steps, dt, out)
    return err, float(np.linalg.norm(out[-1, :3] - ref[:3]))


@pytest.mark.parametrize(("scenario", "world", "steps", "dt", "tol_km"), CASES, ids=CASE_IDS)
def test_truth_trajectory_against_dop853_on_jplephem(scenario, world, steps, dt, tol_km) -> None:
    err, plain_err = truth_errors(scenario, world, steps, dt)
    assert err < tol_km, err
    if scenario == "cruise":
        # The forces matter at this tolerance: the Sun-only truth misses by far more. (Near Mars the
        # added bodies' tides over a day are below the tolerance.)
        assert plain_err > 20 * tol_km, plain_err


def test_srp_on_the_mars_approach_is_there_and_pushes_away_from_the_sun() -> None:
    """Over a day near Mars the SRP's 4e-8 m/s^2 moves the truth by ~100 m: the same DOP853 without it
    misses the truth by far more than the 1 m the test above holds it to, and the truth moved away from
    the Sun relative to the truth without SRP."""
    steps, dt = 1440, 60.0
    core = _core(FORCES, "mars-approach", step_s=dt, episode_steps=steps)
    f = core.f
    x0, t0 = f[0, L.F_X : L.F_X + 6].copy(), float(f[0, L.F_T0])
    out = np.empty((steps, 6))
    _truth_path(core.params, core.eph, f, 0, steps, dt, out)
    bodies = core.plan.truth_perturbers
    ref = _reference("mars", bodies, 0.0, x0, t0, steps * dt, de421_path())
    shift = out[-1, :3] - ref[:3]
    assert 50e-3 < np.linalg.norm(shift) < 1.0  # km
    spk = SPK.open(de421_path())
    try:
        sun = _barycentric(spk, "sun", np.array([t0]))[0][0] - _barycentric(spk, "mars", np.array([t0]))[0][0]
    finally:
        spk.close()
    away = (x0[:3] - sun) / np.linalg.norm(x0[:3] - sun)
    assert np.dot(shift, away) > 0.7 * np.linalg.norm(shift)


def test_stepped_env_flies_the_truth_path_bit_for_bit() -> None:
    core = _core(FORCES)
    f = core.f.copy()
    steps = 30
    out = np.empty((steps, 6))
    _truth_path(core.params, core.eph, f, 0, steps, 60.0, out)
    for _ in range(steps):
        core.step(np.zeros((1, 1)))
    assert np.array_equal(core.f[0, L.F_X : L.F_X + 6], out[-1])


def test_srp_closed_form_and_the_flight_magnitude() -> None:
    from planetnav_env.dynamics.srp import srp_gm

    for am, cr in [(0.01, 1.3), (0.002, 1.0), (0.05, 2.0)]:
        assert srp_gm(am, cr) == pytest.approx(_closed_form_k(am, cr), rel=1e-12)
    # 0.01 m^2/kg, C_R 1.3 at 0.84 AU: 8.4e-8 m/s^2 (km^3/s^2 / km^2 -> km/s^2 -> m/s^2).
    r_km = 0.84 * AU_M * 1e-3
    a = srp_gm(0.01, 1.3) / r_km**2 * 1e3
    assert a == pytest.approx(1.3 * 0.01 * TSI_W_M2 / C_M_S / 0.84**2, rel=1e-12)
    assert 8.0e-8 < a < 8.6e-8


def test_reflectivity_is_drawn_last_so_the_rest_of_the_episode_is_unchanged() -> None:
    plain, srp = _core(WorldConfig()), _core(WorldConfig(srp=True))
    assert plain.f[0, L.F_SRP_K] == 0.0
    k = srp.f[0, L.F_SRP_K]
    lo, hi = (_closed_form_k(0.01, c) for c in WorldConfig().reflectivity_range)
    assert lo <= k <= hi
    mask = np.ones(L.NF, dtype=bool)
    mask[[L.F_SRP_K, L.F_Q_PSD]] = False
    assert np.array_equal(plain.f[0, mask], srp.f[0, mask], equal_nan=True)
    draws = {float(_core(WorldConfig(srp=True)).f[0, L.F_SRP_K])}
    core = BatchCore(EnvConfig(world=WorldConfig(srp=True)), 1)
    for seed in range(5):
        core.reset_rows(np.array([0]), [np.random.default_rng(seed)])
        draws.add(float(core.f[0, L.F_SRP_K]))
    assert len(draws) == 6  # drawn per episode


def test_matched_world_plans_no_truth_channels() -> None:
    core = BatchCore(EnvConfig(), 1)
    assert core.plan.truth_perturbers == () and core.params.tmus.size == 0
    assert core.params.scalars[0]["truth_own"] == 0
    assert not EnvConfig().world.truth_forces_on and EnvConfig().world.is_matched
    assert not WorldConfig(third_bodies=True).is_matched


def test_bad_force_options_get_named_errors_through_make_vec_and_yaml(tmp_path) -> None:
    cases = [
        ({"area_to_mass_m2_kg": -0.01}, "world.area_to_mass_m2_kg"),
        ({"area_to_mass_m2_kg": float("nan")}, "world.area_to_mass_m2_kg"),
        ({"reflectivity_range": [0.8, 1.3]}, "world.reflectivity_range"),
        ({"reflectivity_range": [1.5, 2.1]}, "world.reflectivity_range"),
        ({"reflectivity_range": [1.5, 1.2]}, "world.reflectivity_range"),
        ({"reflectivity_range": [1.2]}, "world.reflectivity_range"),
        ({"third_bodies": 1}, "world.third_bodies"),
        ({"process_noise": "inflated"}, "world.process_noise"),
        ({"truth_ephemeris": "de430"}, "world.truth_ephemeris"),
        ({"thrust_gauss_markov": "yes"}, "world.thrust_gauss_markov"),
        ({"pulsar_shapiro": 1.0}, "world.pulsar_shapiro"),
    ]
    for value, match in cases:
        with pytest.raises(OptionError, match=match):
            gym.make("planetnav/Cruise-Target-v2", world=value)
        with pytest.raises(OptionError, match=match):
            gym.make_vec("planetnav/Cruise-Target-v2", num_envs=2, world=value)
    # SRP is modelled on every scenario: on the Mars approach too (the Sun among the truth's bodies).
    approach = EnvConfig(scenario="mars-approach", world=WorldConfig(srp=True))
    core = BatchCore(approach, 1)
    assert "sun" in core.plan.truth_perturbers and core.params.scalars[0]["srp_sun"] >= 0
    path = tmp_path / "env.yaml"
    path.write_text("env:\n  world: {area_to_mass_m2_kg: -1.0}\n")
    with pytest.raises(OptionError, match=r"world\.area_to_mass_m2_kg"):
        EnvConfig.from_yaml(path)
    path.write_text("env:\n  world: {third_bodies: true, srp: true, reflectivity_range: [1.1, 1.9]}\n")
    world = EnvConfig.from_yaml(path).world
    assert world.truth_forces_on and world.reflectivity_range == (1.1, 1.9)


def _omitted_oracle(core: BatchCore, c_r: float) -> np.ndarray:
    """The truth's third bodies and SRP (``c_r``) minus the filter's field at the row's initial state,
    from jplephem on the truth's kernel and the closed forms (the cruise: the filter is Sun-only)."""
    t0 = np.array([float(core.f[0, L.F_T0])])
    r = core.f[0, L.F_X : L.F_X + 3]
    spk = SPK.open(de440_path() if core.config.world.truth_ephemeris_apart else de421_path())
    try:
        sun = _barycentric(spk, "sun", t0)[0][0]
        acc = np.zeros(3)
        for b in core.plan.truth_perturbers:
            p = _barycentric(spk, b, t0)[0][0] - sun
            d = r - p
            acc -= BODIES[b].gm * (d / np.linalg.norm(d) ** 3 + p / np.linalg.norm(p) ** 3)
    finally:
        spk.close()
    k = _closed_form_k(core.config.world.area_to_mass_m2_kg, c_r)
    return acc + k * r / np.linalg.norm(r) ** 3


def test_tuned_process_noise_is_the_omitted_acceleration_squared_times_the_span() -> None:
    core = _core(WorldConfig(preset="flight"))
    world, cfg = core.config.world, core.config
    assert world.process_noise_tuned and world.truth_forces_on
    a = _omitted_oracle(core, world.reflectivity_range[1])
    span = (cfg.episode_steps + 1) * cfg.step_s
    q = core.f[0, L.F_Q_PSD]
    assert q == pytest.approx(float(a @ a) * span, rel=1e-6)
    assert q > 1e3 * cfg.filter.accel_psd  # the configured 1e-20 stands for far less than is omitted
    # The filter flies that q: the same covariance as a filter configured with accel_psd = q.
    fixed = EnvConfig(
        world=WorldConfig(preset="flight", process_noise="filter"),
        filter=dataclasses.replace(cfg.filter, accel_psd=float(q)),
    )
    other = BatchCore(fixed, 1)
    other.reset_rows(np.array([0]), [np.random.default_rng(11)])
    assert other.f[0, L.F_Q_PSD] == 0.0
    for _ in range(5):
        core.step(np.zeros((1, 1)))
        other.step(np.zeros((1, 1)))
    assert np.array_equal(core.p, other.p)
    assert not WorldConfig().process_noise_tuned
    assert not WorldConfig(preset="flight", process_noise="filter").process_noise_tuned


if __name__ == "__main__":  # python tests/env/test_truth_forces.py: the validation's figures
    for (scenario, world, steps, dt, tol), name in zip(CASES, CASE_IDS, strict=True):
        err, plain_err = truth_errors(scenario, world, steps, dt)
        print(
            f"{name}: truth vs DOP853 {err * 1e3:.2e} m (tolerance {tol * 1e3:g} m); "
            f"matched-world truth vs the same reference {plain_err:.3e} km"
        )
    for scenario in ("cruise", "random-cruise", "mars-approach"):  # SRP included on every one
        core = _core(WorldConfig(preset="flight"), scenario)
        a = np.linalg.norm(core.omitted_acceleration(core.f[0, L.F_T0], core.f[0, L.F_X : L.F_X + 6]))
        print(
            f"{scenario} (flight, seed 11): omitted acceleration {a * 1e3:.3e} m/s^2, tuned q "
            f"{core.f[0, L.F_Q_PSD]:.2e} km^2/s^3 (filter.accel_psd {core.config.filter.accel_psd:.0e})"
        )
