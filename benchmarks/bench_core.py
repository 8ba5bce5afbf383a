"""Speed of the physics core and the filter (a benchmark, not a test).

Prints, in one run, microseconds per call of:
  * one EKF cycle (predict + measurement model + update; 6 states, 3 measurements), single filter
    and batched over 1024 filters (per filter);
  * the same cycle on filterpy's ExtendedKalmanFilter (the reference);
  * one truth step: orbit RK4 + attitude (PD law, 60 sub-steps) for one spacecraft.
Targets: batched core <= 2 us per filter cycle; single path no slower than filterpy.

    python benchmarks/bench_core.py [--repeat N]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import KeplerianEphemeris
from planetnav_env.attitude.plant import AttitudeConfig
from planetnav_env.attitude.pointing import propagate_pointing
from planetnav_env.dynamics.orbit import GravityModel, rk4_step
from planetnav_env.estimation.ekf import FilterConfig, process_noise
from planetnav_env.estimation.ekf_kernels import (
    KIND_CODES,
    FixModel,
    PlanetFixes,
    SingleEKF,
    orbit_model,
    predict_batch_kernel,
    predict_batch_parallel,
    rk4_batch_kernel,
    update_batch_kernel,
    update_batch_parallel,
)
from planetnav_env.estimation.measurements import (
    MeasurementModel,
    h_direction,
    h_size,
    jac_direction,
    jac_size,
)
from planetnav_validation.numpy_ekf import BatchEKF, FilterpyEKF
from planetnav_validation.reproduce.angular_size import EPOCH, initial_state


def _time(fn, repeat: int) -> float:
    fn()  # warm-up (JIT, caches)
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        best = min(best, (time.perf_counter() - t0) / repeat)
    return best * 1e6


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=200)
    args = ap.parse_args()
    model = GravityModel("sun")
    cfg = FilterConfig(gate_probability=1.0)
    meas = MeasurementModel("direction+size")
    x0 = initial_state()
    p0 = cfg.initial_covariance()
    planet = KeplerianEphemeris().position("venus", EPOCH)
    diameter = body("venus").diameter
    dt = 60.0
    z1 = np.concatenate([h_direction(x0[None, :3], planet), h_size(x0[None, :3], planet, diameter)], -1)

    def batched(n: int):
        ekf = BatchEKF(model, np.repeat(x0[None], n, 0), p0, cfg)
        z = np.repeat(z1, n, 0)

        def cycle():
            ekf.predict(EPOCH, dt)
            h, jac, cov = meas.evaluate(ekf.x[:, :3], planet, diameter)
            ekf.update(z, h, jac, cov, meas.angle_mask)
            ekf.P[:] = p0  # keep the benchmark stationary

        return cycle

    def compiled_batch(n: int, threads: int):
        x = np.repeat(x0[None], n, 0)
        p = np.repeat(p0[None], n, 0)
        z = np.repeat(z1, n, 0)
        planets = np.repeat(planet[None], n, 0)
        basis = np.zeros((n, 2, 3))
        active = np.ones(n, bool)
        nis = np.empty(n)
        acc = np.empty(n, bool)
        q = process_noise(dt, cfg.accel_psd)
        empty = np.zeros((0, 3))
        mus = np.zeros(0)
        kind = KIND_CODES[meas.kind]
        orbit = orbit_model(model.mu_central, empty, empty, empty, mus)
        fixes = PlanetFixes(z=z, planet=planets, diameter=float(diameter), basis=basis, active=active)
        fix_model = FixModel(
            kind=kind, sig_dir=float(meas.sigma_dir), sig_size=float(meas.sigma_size), gate=np.inf
        )

        def cycle():
            if threads > 1:
                predict_batch_parallel(x, p, dt, orbit, q, False, threads)
                update_batch_parallel(x, p, fixes, fix_model, nis, acc, threads)
            else:
                predict_batch_kernel(x, p, dt, orbit, q, False)
                update_batch_kernel(x, p, fixes, fix_model, nis, acc)
            p[:] = p0

        return cycle

    single = SingleEKF(model, x0, p0, cfg)

    def single_cycle():
        single.predict(EPOCH, dt)
        single.update_planet(z1[0], planet, diameter, meas)
        single.P[:] = p0

    ref = FilterpyEKF(model, x0, p0, dim_z=3, config=cfg)

    def hx(x):
        return np.concatenate([h_direction(x[None, :3], planet), h_size(x[None, :3], planet, diameter)], -1)[
            0
        ]

    def hj(x):
        return np.concatenate(
            [jac_direction(x[None, :3], planet), jac_size(x[None, :3], planet, diameter)], -2
        )[0]

    r_cov = meas.evaluate(x0[None, :3], planet, diameter)[2][0]

    def filterpy_cycle():
        ref.predict(EPOCH, dt)
        ref.update(z1[0], hx, hj, r_cov, meas.angle_mask)
        ref.ekf.P[:] = p0

    rows = []
    t_single_np = _time(batched(1), args.repeat)
    t_single = _time(single_cycle, args.repeat * 5)
    t_batch_np = _time(batched(1024), max(args.repeat // 20, 5)) / 1024
    t_batch_1 = _time(compiled_batch(1024, 1), max(args.repeat // 20, 5)) / 1024
    t_batch = _time(compiled_batch(1024, numba.get_num_threads()), max(args.repeat // 20, 5)) / 1024
    t_fp = _time(filterpy_cycle, args.repeat)
    rows.append(("EKF cycle, single filter (SingleEKF, numba)", t_single))
    rows.append(("EKF cycle, single filter (BatchEKF numpy, N=1)", t_single_np))
    rows.append(("EKF cycle, batched over 1024 (numba, 1 thread), per filter", t_batch_1))
    rows.append(
        (f"EKF cycle, batched over 1024 (numba, {numba.get_num_threads()} threads), per filter", t_batch)
    )
    rows.append(("EKF cycle, batched over 1024 (numpy), per filter", t_batch_np))
    rows.append(("EKF cycle, filterpy ExtendedKalmanFilter", t_fp))

    x = x0[None].copy()
    rows.append(
        ("truth orbit RK4 step (numpy reference)", _time(lambda: rk4_step(model, x, EPOCH, dt), args.repeat))
    )

    # One truth step of the environment: orbit RK4 (compiled) + 60 attitude sub-steps of 1 s with the
    # PD law toward Venus through the wheel limits (the public single-spacecraft API).
    att = AttitudeConfig()
    q = np.array([0.5, 0.5, 0.5, 0.5])
    w = np.zeros(3)
    hw = np.zeros(3)
    empty3 = np.zeros((0, 3))
    direction = planet - x0[:3]

    def truth_step():
        rk4_batch_kernel(x, dt, model.mu_central, empty3, empty3, empty3, np.zeros(0))
        propagate_pointing(q, w, hw, direction, 1.0, 60, att, roll_ref_inertial=x0[:3], k_a=0.02, k_w=1.0)

    rows.append(("truth step: orbit RK4 + 60 attitude sub-steps (compiled)", _time(truth_step, args.repeat)))

    width = max(len(r[0]) for r in rows)
    print(f"{'operation':<{width}}  {'us/call':>10}")
    for name, us in rows:
        print(f"{name:<{width}}  {us:>10.2f}")
    print()
    print(
        f"batched per-filter cycle: {t_batch_1:.2f} us on one thread, {t_batch:.2f} us on all threads "
        f"(target <= 2 us): {'PASS' if min(t_batch, t_batch_1) <= 2.0 else 'MISS'}"
    )
    print("(the threaded kernel waits for every thread in each call: on a busy machine it is the slower one)")
    print(
        f"single vs filterpy: {t_single:.1f} us vs {t_fp:.1f} us, ratio {t_fp / t_single:.1f}x: "
        f"{'PASS' if t_single <= t_fp else 'MISS'}"
    )


if __name__ == "__main__":
    main()
