"""The observation of one row (layout: :class:`planetnav_env.core.layout.ObservationLayout`), built from
what the spacecraft knows: the filter's estimate and covariance, the star tracker, the reported rates,
the wheels, the ephemerides and the row's own history of measurements. Target-block columns are the
``TF_*`` constants of the layout.

Every block is written here, by compiled row kernels, for every environment (the single env, the CPU
vector env and the device env run the same code). :func:`observe_row` writes the observation;
:func:`count_row` advances, after each physics step and at reset, the counters of the optional blocks
that keep a history (state columns ``F_SINCE``, ``F_IMG_LOG``, ``F_RES_LOG``), which
:func:`clear_counters` clears at reset. An optional block (``layout.OBSERVATION_BLOCKS``) is written at
``prm.obs_blocks[OB_<NAME>]``, -1 when the configuration leaves it out.
"""

from __future__ import annotations

import math

from numba import float32, njit

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.core.layout import (
    F_DV_LOST,
    F_HW,
    F_IMG_LOG,
    F_INTEGRATED,
    F_NIS,
    F_QE,
    F_RES_LOG,
    F_SINCE,
    F_THRUSTING,
    F_WM,
    F_XE,
    I_K,
    I_MEASURED,
    I_REASON,
    I_SENSOR,
    I_TARGET,
    MAX_PLANETS,
    MAX_TARGETS,
    OB_IMAGE_LOG,
    OB_IN_FIELD,
    OB_MOMENTUM,
    OB_POSITION_CORRELATION,
    OB_RESIDUAL_LOG,
    OB_SINCE_MEASURED,
    OPS_DAYS_SCALE,
    OPS_DV_SCALE,
    REASON_IMAGE_FAILED,
    REASON_VISIBLE,
    RESIDUAL_CAP,
    SC_ATTITUDE,
    SC_LOG_SIGMA,
    SC_POSITION,
    SC_RATES,
    SC_VELOCITY,
    SC_WHEEL_MOMENTUM,
    SENSOR_CAMERA,
    SENSOR_NONE,
    SINCE_SCALE_STEPS,
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

#: log1p(SINCE_SCALE_STEPS), the divisor of the scaled counts (computed once, by the C library's log1p).
_SINCE_LOG_SCALE = math.log1p(SINCE_SCALE_STEPS)


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
    if ps.ops:
        # Operations block: time to each deadline [d] (0 once reached), delta-v lost [m/s], thrusting.
        base = ps.obs_ops
        n_dl = ps.ops_n_dl
        elapsed = i[n, I_K] * ps.step_s
        for d in range(n_dl):
            o[base + d] = max(prm.ops_deadlines[d] - elapsed, 0.0) / 86400.0 / OPS_DAYS_SCALE
        o[base + n_dl] = f[n, F_DV_LOST] / OPS_DV_SCALE
        o[base + n_dl + 1] = f[n, F_THRUSTING]
    # The optional blocks (layout.OBSERVATION_BLOCKS), each at its start (-1: not in this observation).
    blocks = prm.obs_blocks
    if blocks[OB_IN_FIELD] >= 0:
        _in_field(prm, sc.dirv, qe, sc, o, blocks[OB_IN_FIELD])
    if blocks[OB_SINCE_MEASURED] >= 0:
        _since_measured(prm, f, n, o, blocks[OB_SINCE_MEASURED])
    if blocks[OB_IMAGE_LOG] >= 0:
        _image_log(prm, f, n, o, blocks[OB_IMAGE_LOG])
    if blocks[OB_RESIDUAL_LOG] >= 0:
        _residual_log(prm, f, n, o, blocks[OB_RESIDUAL_LOG])
    if blocks[OB_POSITION_CORRELATION] >= 0:
        _position_correlation(pm, o, blocks[OB_POSITION_CORRELATION])
    if blocks[OB_MOMENTUM] >= 0:
        _momentum(prm, f, n, qe, sc, o, blocks[OB_MOMENTUM])
    if ps.obs_unit:
        # Every column to order 1 (observation_scaling 'unit'): (value - offset) / scale, fixed constants.
        aff = prm.obs_affine
        for c in range(aff.shape[1]):
            o[c] = (o[c] - aff[0, c]) / aff[1, c]


@row_kernel
def clear_counters(prm, f, n) -> None:  # pragma: no cover - compiled
    """Start row ``n``'s history counters of a new episode: no target measured (inf steps), no image, no
    fix (every counter slot, whichever blocks are on: the columns are the row's own)."""
    for j in range(MAX_TARGETS):
        f[n, F_SINCE + j] = math.inf
    for j in range(2 * MAX_PLANETS):
        f[n, F_IMG_LOG + j] = 0.0
    for j in range(2 * MAX_TARGETS):
        f[n, F_RES_LOG + j] = 0.0


@row_kernel
def count_row(prm, f, i, n) -> None:  # pragma: no cover - compiled
    """Count row ``n``'s last physics step (or its reset, as a step without a measurement) in the counters
    of the optional blocks that keep a history, from the step's outcome in ``i`` (target, measured, sensor,
    reason) and ``f`` (the fix's NIS)."""
    blocks = prm.obs_blocks
    if blocks[OB_SINCE_MEASURED] >= 0:
        _count_since_measured(prm, f, i, n)
    if blocks[OB_IMAGE_LOG] >= 0:
        _count_image_log(prm, f, i, n)
    if blocks[OB_RESIDUAL_LOG] >= 0:
        _count_residual_log(prm, f, i, n)


@row_kernel
def _scaled_count(count) -> float:  # pragma: no cover - compiled
    """A count [steps] as ``log1p(count) / log1p(SINCE_SCALE_STEPS)``, capped at 1."""
    return min(math.log1p(count) / _SINCE_LOG_SCALE, 1.0)


@row_kernel
def _count_since_measured(prm, f, i, n) -> None:  # pragma: no cover - compiled
    """One more physics step since each target was measured; 0 for the one measured now."""
    n_t = prm.scalars[0].n_targets
    for j in range(n_t):
        f[n, F_SINCE + j] += 1.0
    t = i[n, I_TARGET]
    if i[n, I_MEASURED] != 0 and 0 <= t < n_t:
        f[n, F_SINCE + t] = 0.0


@row_kernel
def _since_measured(prm, f, n, o, base) -> None:  # pragma: no cover - compiled
    """The ``since_measured`` block (float32 values): per target the scaled steps since it was last
    measured, 1 when not measured this episode."""
    for j in range(prm.scalars[0].n_targets):
        s = f[n, F_SINCE + j]
        o[base + j] = float32(_scaled_count(s) if math.isfinite(s) else 1.0)


@row_kernel
def _count_image_log(prm, f, i, n) -> None:  # pragma: no cover - compiled
    """Count the step's image of a planet in view: a fix (the camera measured it) or a failed image
    (``REASON_IMAGE_FAILED``); anything else (no image, the planet out of view) counts nothing."""
    t = i[n, I_TARGET]
    if 0 <= t < prm.scalars[0].n_planets:
        if i[n, I_SENSOR] == SENSOR_CAMERA:
            f[n, F_IMG_LOG + t] += 1.0
            f[n, F_IMG_LOG + MAX_PLANETS + t] += 1.0
        if i[n, I_REASON] == REASON_IMAGE_FAILED:
            f[n, F_IMG_LOG + t] += 1.0


@row_kernel
def _image_log(prm, f, n, o, base) -> None:  # pragma: no cover - compiled
    """The ``image_log`` block (float32 values), two rows of one per planet: ``(fixes + 1) / (images + 2)``
    (the mean of a Beta(1, 1) prior updated by the counts), then the scaled image count."""
    n_p = prm.scalars[0].n_planets
    for a in range(n_p):
        images = f[n, F_IMG_LOG + a]
        fixes = f[n, F_IMG_LOG + MAX_PLANETS + a]
        o[base + a] = float32((fixes + 1.0) / (images + 2.0))
        o[base + n_p + a] = float32(_scaled_count(images))


@row_kernel
def _count_residual_log(prm, f, i, n) -> None:  # pragma: no cover - compiled
    """Add the step's fix of its target (an image or a pulsar phase, gated fixes included) to the residual
    log: one more fix, and its NIS divided by the measurement's degrees of freedom (a planet image 3 with
    the apparent size, else 2; a pulsar phase 1)."""
    ps = prm.scalars[0]
    t = i[n, I_TARGET]
    if i[n, I_SENSOR] == SENSOR_NONE or not 0 <= t < ps.n_targets:
        return
    dof = 1.0 if t >= ps.n_planets else (3.0 if ps.kind % 2 == 1 else 2.0)  # kinds 1, 3: "+size"
    nis_norm = f[n, F_NIS] / dof
    if math.isfinite(nis_norm):
        f[n, F_RES_LOG + t] += 1.0
        f[n, F_RES_LOG + MAX_TARGETS + t] += nis_norm


@row_kernel
def _residual_log(prm, f, n, o, base) -> None:  # pragma: no cover - compiled
    """The ``residual_log`` block (float32 values), per target: ``(sum + 2) / (fixes + 2)`` (the mean
    normalized NIS with a prior of two consistent fixes), capped at RESIDUAL_CAP, divided by it."""
    for j in range(prm.scalars[0].n_targets):
        mean = (f[n, F_RES_LOG + MAX_TARGETS + j] + 2.0) / (f[n, F_RES_LOG + j] + 2.0)
        o[base + j] = float32(min(mean, RESIDUAL_CAP) / RESIDUAL_CAP)


@row_kernel
def _position_correlation(pm, o, base) -> None:  # pragma: no cover - compiled
    """The ``position_correlation`` block: rho_xy, rho_xz, rho_yz of the position covariance ``pm[:3, :3]``,
    clipped to [-1, 1] (NaN kept)."""
    s0, s1, s2 = math.sqrt(pm[0, 0]), math.sqrt(pm[1, 1]), math.sqrt(pm[2, 2])
    o[base] = _clip_unit(_ratio(pm[0, 1], s0 * s1))
    o[base + 1] = _clip_unit(_ratio(pm[0, 2], s0 * s2))
    o[base + 2] = _clip_unit(_ratio(pm[1, 2], s1 * s2))


@row_kernel
def _momentum(prm, f, n, qe, sc, o, base) -> None:  # pragma: no cover - compiled
    """The ``momentum`` block: the largest wheel |momentum| over the dump threshold (the capacity without
    dumping), then the total angular momentum ``R(q_e) (J omega_m + h_w)`` in inertial axes over the
    capacity, from the star-tracker attitude and the reported rates; each clipped to [-10, 10]."""
    ps = prm.scalars[0]
    cap = prm.h_max[0]
    scale = ps.dump_thr if ps.dump_on else cap
    top = max(abs(f[n, F_HW]), abs(f[n, F_HW + 1]), abs(f[n, F_HW + 2]))
    o[base] = min(top / scale, 10.0)
    dcm_body_to_inertial_kernel(qe[0], qe[1], qe[2], qe[3], sc.rq)
    jm = prm.jm
    for a in range(3):
        acc = 0.0
        for b in range(3):
            hb = (
                jm[b, 0] * f[n, F_WM] + jm[b, 1] * f[n, F_WM + 1] + jm[b, 2] * f[n, F_WM + 2] + f[n, F_HW + b]
            )
            acc += sc.rq[a, b] * hb
        o[base + 1 + a] = max(-10.0, min(10.0, acc / cap))


@row_kernel
def _ratio(a, b) -> float:  # pragma: no cover - compiled
    """``a / b`` with IEEE semantics for ``b == 0`` (inf of the quotient's sign, NaN for 0 / 0), on both
    targets: numba's CPU error model would raise there."""
    if b == 0.0:
        if a == 0.0 or math.isnan(a):
            return math.nan
        return math.copysign(math.inf, a) * math.copysign(1.0, b)
    return a / b


@row_kernel
def _clip_unit(x) -> float:  # pragma: no cover - compiled
    """``np.clip(x, -1, 1)`` of a float: NaN stays NaN."""
    if x < -1.0:
        return -1.0
    if x > 1.0:
        return 1.0
    return x


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
def camera_visibility(prm, r, q, t, i, rt, planets, sc) -> int:  # pragma: no cover - compiled
    """The camera's visibility rule for target ``t[i]`` (radius ``rt`` [km]) from ``r[i]`` at attitude
    ``q[i]``, the ``planets`` (P, 3) (the truth's or the onboard model's, heliocentric [km]) and the Sun as
    occulters: the one place the core builds the camera's records. Its values (``V_*``) go to
    ``sc.vals``; returns the kernel's status (0: geometry valid)."""
    occulters = Occulters(pos=planets, radii=prm.radii, sun=True)
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
    st = camera_visibility(prm, sc.r_tile, sc.q_tile, sc.planets, a, prm.radii[a], sc.planets, sc)
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
