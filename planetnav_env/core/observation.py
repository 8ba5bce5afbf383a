"""The observation of one row (layout: :class:`planetnav_env.core.layout.ObservationLayout`), built from
what the spacecraft knows: the filter's estimate and covariance, the star tracker, the reported rates,
the wheels and the ephemerides. Target-block columns are the ``TF_*`` constants of the layout."""

from __future__ import annotations

import math

from numba import njit

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.core.layout import (
    F_DV_LOST,
    F_HW,
    F_INTEGRATED,
    F_QE,
    F_THRUSTING,
    F_WM,
    F_XE,
    I_K,
    I_TARGET,
    OPS_DAYS_SCALE,
    OPS_DV_SCALE,
    REASON_VISIBLE,
    SC_ATTITUDE,
    SC_LOG_SIGMA,
    SC_POSITION,
    SC_RATES,
    SC_VELOCITY,
    SC_WHEEL_MOMENTUM,
    TARGET_FEATURES,
    TF_DIR,
    TF_LOG_DISTANCE,
    TF_LOG_PHASE_SIGMA,
    TF_LOG_SIGMA,
    TF_OBSERVABLE,
    TF_PROGRESS,
    TF_SIZE,
)  # fmt: skip
from planetnav_env.core.row_ephemeris import eval_channel, planets_at, row_time
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS, row_kernel
from planetnav_env.sensors.camera_kernels import (
    V_ALPHA,
    V_REASON,
    CameraModel,
    CameraScratch,
    Occulters,
    visibility_row_kernel,
)
from planetnav_env.sensors.pulsar import (
    pulsar_visibility_row,
)


@row_kernel
def observe_row(prm, f, p, i, eph, obs, n, sc, bodies_ready) -> None:  # pragma: no cover - compiled
    """Write row ``n``'s observation (layout: :class:`planetnav_env.core.layout.ObservationLayout`) from
    what the spacecraft knows: the filter, the star tracker, the reported rates, wheels, ephemerides.

    ``bodies_ready``: ``sc.central`` and ``sc.planets`` already hold the bodies at the row's current
    time (what :func:`step_row` returns); they are evaluated here otherwise."""
    ps = prm.scalars[0]
    o = obs[n]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    qe = f[n, F_QE : F_QE + 4]
    for j in range(3):
        o[SC_POSITION + j] = xe[j] / ps.pos_scale
        o[SC_VELOCITY + j] = xe[3 + j] / ps.vel_scale
        o[SC_LOG_SIGMA + j] = math.log10(math.sqrt(max(pm[j, j], 1e-30))) / 4.0
        o[SC_LOG_SIGMA + 3 + j] = math.log10(math.sqrt(max(pm[3 + j, 3 + j], 1e-30)) * 1e3) / 4.0
        o[SC_RATES + j] = f[n, F_WM + j] / (math.pi / 180.0)
        o[SC_WHEEL_MOMENTUM + j] = f[n, F_HW + j] / prm.h_max[j]
    for j in range(4):
        o[SC_ATTITUDE + j] = qe[j]
    if not bodies_ready:
        t = row_time(prm, f, i, n)
        eval_channel(prm, eph, f, n, t, ps.ch_central, sc.central)
        planets_at(prm, eph, f, n, t, sc.planets)
    for j in range(3):
        sc.dirv[j] = xe[j] + sc.central[j]  # estimated heliocentric position
    _planet_features(prm, sc.dirv, qe, pm, sc)
    base = ps.obs_planets
    for a in range(sc.feat.shape[0]):
        for c in range(TARGET_FEATURES):
            o[base + TARGET_FEATURES * a + c] = sc.feat[a, c]
    n_q = ps.n_pulsars
    if n_q:
        _pulsar_features(prm, f, p, i, n, qe, sc, o, ps.obs_pulsars)
    base = ps.obs_target
    for j in range(ps.n_targets):
        o[base + j] = 0.0
    if i[n, I_TARGET] >= 0:
        o[base + i[n, I_TARGET]] = 1.0
    o[ps.obs_elapsed] = i[n, I_K] / ps.episode_steps
    if ps.obs_in_field >= 0:
        _in_field(prm, sc.dirv, qe, sc, o, ps.obs_in_field)
    if ps.ops:
        # Operations block: time to each deadline [d] (0 once reached), delta-v lost [m/s], thrusting.
        base = ps.obs_ops
        n_dl = ps.ops_n_dl
        elapsed = i[n, I_K] * ps.step_s
        for d in range(n_dl):
            o[base + d] = max(prm.ops_deadlines[d] - elapsed, 0.0) / 86400.0 / OPS_DAYS_SCALE
        o[base + n_dl] = f[n, F_DV_LOST] / OPS_DV_SCALE
        o[base + n_dl + 1] = f[n, F_THRUSTING]


@row_kernel
def _planet_features(prm, r_est, qe, pm, sc) -> None:  # pragma: no cover - compiled
    """Per-planet block from the estimate: direction in body axes (3), log10(distance / AU), apparent
    diameter / sigma_alpha, observable if pointed at (the camera's own rules for the attitude that
    centres the planet; the disk must fit the field), log10(position 1-sigma across the LOS [km]) / 4."""
    ps = prm.scalars[0]
    out = sc.feat
    dcm_body_to_inertial_kernel(qe[0], qe[1], qe[2], qe[3], sc.rq)
    r = sc.rq
    tr = pm[0, 0] + pm[1, 1] + pm[2, 2]
    b0, b1, b2 = prm.boresight[0], prm.boresight[1], prm.boresight[2]
    for a in range(sc.planets.shape[0]):
        d0 = sc.planets[a, 0] - r_est[0]
        d1 = sc.planets[a, 1] - r_est[1]
        d2 = sc.planets[a, 2] - r_est[2]
        dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        u0, u1, u2 = d0 / dist, d1 / dist, d2 / dist
        for c in range(3):  # R^T u
            out[a, TF_DIR + c] = r[0, c] * u0 + r[1, c] * u1 + r[2, c] * u2
        out[a, TF_LOG_DISTANCE] = math.log10(dist / AU_KM)
        alpha = 2.0 * math.asin(min(prm.radii[a] / dist, 1.0))
        along = (
            u0 * (pm[0, 0] * u0 + pm[0, 1] * u1 + pm[0, 2] * u2)
            + u1 * (pm[1, 0] * u0 + pm[1, 1] * u1 + pm[1, 2] * u2)
            + u2 * (pm[2, 0] * u0 + pm[2, 1] * u1 + pm[2, 2] * u2)
        )
        out[a, TF_LOG_SIGMA] = math.log10(math.sqrt(max(tr - along, 1e-12))) / 4.0
        # Shortest arc from the boresight b to u: q = [1 + b.u, b x u] / norm (u opposite b: a
        # perpendicular axis).
        w = 1.0 + b0 * u0 + b1 * u1 + b2 * u2
        c0, c1, c2 = b1 * u2 - b2 * u1, b2 * u0 - b0 * u2, b0 * u1 - b1 * u0
        if w < 1e-12:
            w, c0, c1, c2 = 0.0, -b1, b0, 0.0 if abs(b2) < 0.9 else b0
        nq = math.sqrt(w * w + c0 * c0 + c1 * c1 + c2 * c2)
        sc.q_tile[a, 0], sc.q_tile[a, 1], sc.q_tile[a, 2], sc.q_tile[a, 3] = w / nq, c0 / nq, c1 / nq, c2 / nq
        visible = _camera_sees(prm, r_est, a, sc)
        out[a, TF_OBSERVABLE] = 1.0 if (visible and alpha < ps.alpha_max) else 0.0
        out[a, TF_SIZE] = alpha / ps.sigma_alpha


# Inlined: a call that passes the parameter and scratch records by value costs a few % of a settled step.
@njit(inline="always", **ROW_KERNEL_OPTIONS)
def camera_visibility(prm, r, q, t, i, rt, sc) -> int:  # pragma: no cover - compiled
    """The camera's visibility rule for target ``t[i]`` (radius ``rt`` [km]) from ``r[i]`` at attitude
    ``q[i]``, the row's planets and the Sun as occulters: the one place the core builds the camera's
    records. Its values (``V_*``) go to ``sc.vals``; returns the kernel's status (0: geometry valid)."""
    occulters = Occulters(pos=sc.planets, radii=prm.radii, sun=True)
    camera = CameraModel(c2b=prm.c2b, params=prm.cam)
    ws = CameraScratch(m=sc.m, u=sc.u6)
    return visibility_row_kernel(r, q, t, i, rt, occulters, camera, ws, sc.vals)


@row_kernel
def _camera_sees(prm, r_est, a, sc) -> bool:  # pragma: no cover - compiled
    """The camera's own visibility rule (field of view, occultation, Sun exclusion, detection threshold)
    for planet ``a`` from the estimated heliocentric position ``r_est`` [km] at the attitude already in
    ``sc.q_tile[a]``; its values (``V_*``, e.g. the apparent diameter) are left in ``sc.vals``."""
    for c in range(3):
        sc.r_tile[a, c] = r_est[c]
    st = camera_visibility(prm, sc.r_tile, sc.q_tile, sc.planets, a, prm.radii[a], sc)
    return st == 0 and int(sc.vals[V_REASON]) == REASON_VISIBLE


@row_kernel
def _in_field(prm, r_est, qe, sc, o, base) -> None:  # pragma: no cover - compiled
    """The in-field block (``EnvConfig.observe_in_field``) from ``base``: per planet, 1.0 when the camera's
    own visibility rule (:func:`~planetnav_env.sensors.camera.visibility_row_kernel`: field of view,
    occultation, Sun exclusion, detection threshold) passes at the star-tracker attitude ``qe`` from the
    estimated heliocentric position ``r_est`` [km], and the disk is not wider than the field (the step's
    rule, ``alpha_max``); else 0.0. ``sc.planets`` holds the planets at the row's time."""
    for a in range(sc.planets.shape[0]):
        for c in range(4):
            sc.q_tile[a, c] = qe[c]
        ok = _camera_sees(prm, r_est, a, sc) and sc.vals[V_ALPHA] <= prm.scalars[0].alpha_max
        o[base + a] = 1.0 if ok else 0.0


@row_kernel
def _pulsar_features(prm, f, p, i, n, qe, sc, o, base) -> None:  # pragma: no cover - compiled
    """Per-pulsar block: direction in body axes (star-tracker attitude), integration progress (current
    target only), log10 predicted phase 1-sigma [cycles], observable from the estimate (Sun, occultation),
    log10(position 1-sigma along the pulsar [km]) / 4."""
    ps = prm.scalars[0]
    n_p = ps.n_planets
    pm = p[n]
    dcm_body_to_inertial_kernel(qe[0], qe[1], qe[2], qe[3], sc.rq)
    for j in range(ps.n_pulsars):
        nv = prm.psr[j, 0:3]
        off = base + TARGET_FEATURES * j
        for c in range(3):
            o[off + TF_DIR + c] = sc.rq[0, c] * nv[0] + sc.rq[1, c] * nv[1] + sc.rq[2, c] * nv[2]
        o[off + TF_PROGRESS] = f[n, F_INTEGRATED] / ps.psr_int_s if i[n, I_TARGET] == n_p + j else 0.0
        var = 0.0
        for a in range(3):
            for c in range(3):
                var += nv[a] * pm[a, c] * nv[c]
        lam, sig = prm.psr[j, 3], prm.psr[j, 4]
        o[off + TF_LOG_PHASE_SIGMA] = math.log10(math.sqrt(var / (lam * lam) + sig * sig))
        vis = pulsar_visibility_row(
            sc.dirv, nv, ps.sun_avoid, sc.central, ps.central_radius, ps.approach != 0
        )
        o[off + TF_OBSERVABLE] = 1.0 if vis == REASON_VISIBLE else 0.0
        o[off + TF_LOG_SIGMA] = math.log10(math.sqrt(max(var, 1e-12))) / 4.0
