"""The sensor stages of one row's step: star-tracker fix, rate measurement, camera image with the EKF
update, X-ray pulsar timing. Each stage reads and writes only row ``n`` of the core's arrays; the
formulas are the sensors' own (:mod:`planetnav_env.sensors.star_tracker`,
:mod:`~planetnav_env.sensors.camera`, :mod:`~planetnav_env.sensors.pulsar`) and the filter's
(:mod:`planetnav_env.estimation.ekf_kernels`, :mod:`planetnav_env.estimation.measurement_kernels`)."""

from __future__ import annotations

import math

import numpy as np

from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.core.layout import (
    F_ATT_ERR,
    F_COB,
    F_COB_LAST,
    F_COB_MODEL,
    F_DRIFT,
    F_GB,
    F_INTEGRATED,
    F_NIS,
    F_PIX,
    F_PSR_DRIFT,
    F_Q,
    F_QE,
    F_T0,
    F_W,
    F_WM,
    F_X,
    F_XE,
    I_SKIPPED,
    I_STARS,
    REASON_AMBIGUOUS,
    REASON_INTEGRATING,
    REASON_OUT_OF_FOV,
    REASON_VISIBLE,
)  # fmt: skip
from planetnav_env.core.light_path import (
    DIRECTION,
    R_EST,
    V_EST,
    V_TARGET,
    V_TRUE,
    apparent_point,
    channel_velocity,
    heliocentric_velocity,
)
from planetnav_env.core.row_ephemeris import eval_channel, row_time
from planetnav_env.core.row_noise import (
    NOISE_CAMERA,
    NOISE_DRIFT,
    NOISE_PULSAR0,
    NOISE_RATE,
    NOISE_STAR,
    next_normal,
    noise_begin,
)
from planetnav_env.estimation.ekf_kernels import (
    planet_model_kernel,
    update_kernel,
)
from planetnav_env.estimation.measurement_kernels import measurement_vector_kernel
from planetnav_env.numerics.gauss_markov import gauss_markov_step
from planetnav_env.numerics.jit import row_kernel
from planetnav_env.sensors.camera_config import P_FPX, P_SALPHA, P_SDIR
from planetnav_env.sensors.camera_kernels import (
    CameraFix,
    CameraModel,
    CameraScratch,
    centroid_bias_kernel,
    measure_row_kernel,
    measure_sigmas_row_kernel,
    rotate_in_camera,
    shift_toward,
)
from planetnav_env.sensors.figure import equal_area_radius
from planetnav_env.sensors.image_noise import (
    centroid_sigma_px,
    diameter_sigma_px,
    image_snr,
    planet_electrons,
)
from planetnav_env.sensors.photometry import lambert_cob_offset
from planetnav_env.sensors.pulsar import (
    ambiguity_resolvable_row,
    pulsar_visibility_row,
    resolve_cycle,
    shapiro_range_km,
)
from planetnav_env.sensors.star_tracker import error_angle_kernel, select_stars, star_fix, star_fix_apparent


@row_kernel
def star_fix_stage(prm, st, n, sc):  # pragma: no cover - compiled
    """Star-tracker attitude into QE of row ``n`` of the state ``st``: q-method on the stars in the camera's
    own field, their directions perturbed by the row's random stream. With too few stars or a degenerate
    field the last fix is kept (stale) and ATT_ERR is NaN; ``star_tracker="ideal"`` copies the true
    attitude."""
    f, i, rng = st.f, st.i, st.rng
    q = f[n, F_Q : F_Q + 4]
    qe = f[n, F_QE : F_QE + 4]
    if prm.scalars[0].ideal_star:
        for j in range(4):
            sc.q_fix[j] = q[j]
        i[n, I_STARS] = -1
        f[n, F_ATT_ERR] = _apply_bias(prm, q, sc.q_fix, qe, 0.0)
        return
    tables = prm.stars
    n_stars = select_stars(tables, q, sc.rq, sc.star_idx)
    i[n, I_STARS] = n_stars
    if n_stars < tables.min_stars:
        f[n, F_ATT_ERR] = np.nan
        return
    noise_begin(prm, i, rng, n, NOISE_STAR, sc)
    for a in range(n_stars):  # row-major, as rng.normal(size=(n, 3)) draws them
        for c in range(3):
            sc.star_noise[a, c] = tables.sigma_rad * next_normal(prm, rng, n, sc)
    ps = prm.scalars[0]
    if ps.world_ab:
        # The stars' apparent directions (true velocity); on board, the catalogue aberrated by the
        # estimated velocity when the filter corrects it.
        t = row_time(prm, f, i, n)
        heliocentric_velocity(prm, st.eph, f, n, t, f[n, F_X : F_X + 6], ps.ch_tcentral, sc.light[V_TRUE])
        heliocentric_velocity(prm, st.eph, f, n, t, f[n, F_XE : F_XE + 6], ps.ch_central, sc.light[V_EST])
        err, ok = star_fix_apparent(
            tables, q, sc.rq, sc.star_idx, n_stars, sc.star_noise, sc.light[V_TRUE], sc.light[V_EST],
            ps.onboard_ab != 0, sc.star_work, sc.q_fix,
        )  # fmt: skip
    else:
        err, ok = star_fix(tables, q, sc.rq, sc.star_idx, n_stars, sc.star_noise, sc.star_work, sc.q_fix)
    if ok:
        f[n, F_ATT_ERR] = _apply_bias(prm, q, sc.q_fix, qe, err)
    else:
        f[n, F_ATT_ERR] = np.nan


@row_kernel
def _apply_bias(prm, q, q_fix, qe, err) -> float:  # pragma: no cover - compiled
    """qe = q_fix * q_bias (Hamilton product, scalar first; ``quaternion.multiply`` is its oracle in the
    tests); returns the error angle [rad] of the biased fix (``err`` when there is no bias)."""
    b = prm.q_bias
    if b[0] == 1.0:
        for j in range(4):
            qe[j] = q_fix[j]
        return err
    a0, a1, a2, a3 = q_fix[0], q_fix[1], q_fix[2], q_fix[3]
    qe[0] = a0 * b[0] - a1 * b[1] - a2 * b[2] - a3 * b[3]
    qe[1] = a0 * b[1] + a1 * b[0] + a2 * b[3] - a3 * b[2]
    qe[2] = a0 * b[2] - a1 * b[3] + a2 * b[0] + a3 * b[1]
    qe[3] = a0 * b[3] + a1 * b[2] - a2 * b[1] + a3 * b[0]
    return error_angle_kernel(q, qe)


@row_kernel
def rate_measurement(prm, st, n, sc):  # pragma: no cover - compiled
    """Gyro rates of row ``n`` [rad/s]: the true rates plus white noise of sigma ``rate_noise``, and in the
    flight world's attitude loop the gyro's bias ``F_GB`` (zero unless ``world.gyro_bias_deg_h``)."""
    f, i, rng = st.f, st.i, st.rng
    sig = prm.scalars[0].rate_noise
    noise_begin(prm, i, rng, n, NOISE_RATE, sc)
    for j in range(3):
        f[n, F_WM + j] = f[n, F_W + j] + sig * next_normal(prm, rng, n, sc)
    if prm.scalars[0].att_on:
        for j in range(3):
            f[n, F_WM + j] += f[n, F_GB + j]


@row_kernel
def nearest_in_view(prm, sc) -> int:  # pragma: no cover - compiled
    """Index of the planet nearest the boresight by the true geometry (what the image shows: the truth's
    planets ``sc.tplanets``), or -1."""
    q = sc.q1[0]
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], sc.rq)
    b = prm.boresight
    bx = sc.rq[0, 0] * b[0] + sc.rq[0, 1] * b[1] + sc.rq[0, 2] * b[2]
    by = sc.rq[1, 0] * b[0] + sc.rq[1, 1] * b[1] + sc.rq[1, 2] * b[2]
    bz = sc.rq[2, 0] * b[0] + sc.rq[2, 1] * b[1] + sc.rq[2, 2] * b[2]
    best = -2.0
    idx = -1
    for j in range(sc.tplanets.shape[0]):
        d0 = sc.tplanets[j, 0] - sc.r1[0, 0]
        d1 = sc.tplanets[j, 1] - sc.r1[0, 1]
        d2 = sc.tplanets[j, 2] - sc.r1[0, 2]
        c = (d0 * bx + d1 * by + d2 * bz) / math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if c > best:
            best = c
            idx = j
    return idx if best > prm.scalars[0].cos_half_diag else -1


@row_kernel
def measure_planet(prm, st, n, idx, sc):  # pragma: no cover - compiled
    """Camera measurement of planet ``idx`` (visible) from row ``n``, rotated to inertial with the
    star-tracker attitude; EKF update. Returns (measured, rejected)."""
    f, p, i, rng = st.f, st.p, st.i, st.rng
    ps = prm.scalars[0]
    noise_begin(prm, i, rng, n, NOISE_CAMERA, sc)
    for j in range(3):
        sc.noise3[j] = next_normal(prm, rng, n, sc)
    # visibility_row_kernel validated this geometry a moment ago: the status is OK.
    if ps.world_lt or ps.world_ab:
        _truth_apparent(prm, st, n, idx, sc)  # the camera sees the planet's apparent direction
    camera = CameraModel(c2b=prm.c2b, params=prm.cam)
    ws = CameraScratch(m=sc.m, u=sc.u6)
    out = CameraFix(los=sc.los, los_true=sc.los_true, mm=sc.mm, pix=sc.pix)
    if ps.img_on != 0 or ps.oblate != 0:
        # The flight world's image: the outline of the spheroid, and sigmas from the image itself.
        rt = _outline_radius(prm, sc, idx) if ps.oblate != 0 else prm.radii[idx]
        s_dir, s_alpha = prm.cam[P_SDIR], prm.cam[P_SALPHA]
        if ps.img_on != 0:
            s_dir, s_alpha = _image_sigmas(prm, sc, idx, rt)
        _, alpha, alpha_true = measure_sigmas_row_kernel(
            sc.r1, sc.q1, sc.t1, 0, rt, sc.noise3, camera, ws, out, s_dir, s_alpha
        )
    else:
        _, alpha, alpha_true = measure_row_kernel(
            sc.r1, sc.q1, sc.t1, 0, prm.radii[idx], sc.noise3, camera, ws, out
        )
    f[n, F_COB_LAST] = 0.0
    if ps.cob_max > 0.0:
        f[n, F_COB_LAST] = _centroid_bias(sc, idx, alpha_true, f[n, F_COB + idx])
    xe = f[n, F_XE : F_XE + 6]
    if ps.cob_lam != 0:
        # Truth: the Lambertian sphere's centre of brightness at the true phase (true attitude).
        q = sc.q1[0]
        r = sc.r1[0]
        cos_phase = _sun_in_body(sc, sc.tplanets[idx], r[0], r[1], r[2], q[0], q[1], q[2], q[3])
        delta = lambert_cob_offset(cos_phase) * 0.5 * alpha_true
        shift_toward(sc.los, sc.dirv, delta)
        f[n, F_COB_LAST] += delta
    if ps.drift_on != 0:
        rotate_in_camera(sc.los, prm.c2b, f[n, F_DRIFT], f[n, F_DRIFT + 1])
    if ps.cob_fix != 0:
        # On board: the photometric model's offset at the estimated geometry (estimated position and
        # attitude, the sphere's size), scaled by the episode's model error, taken off the image.
        qe = f[n, F_QE : F_QE + 4]
        ox, oy, oz = xe[0] + sc.central[0], xe[1] + sc.central[1], xe[2] + sc.central[2]
        cos_est = _sun_in_body(sc, sc.planets[idx], ox, oy, oz, qe[0], qe[1], qe[2], qe[3])
        pl = sc.planets[idx]
        dx, dy, dz = pl[0] - ox, pl[1] - oy, pl[2] - oz
        rad_est = math.asin(min(1.0, prm.radii[idx] / math.sqrt(dx * dx + dy * dy + dz * dz)))
        shift_toward(sc.los, sc.dirv, -f[n, F_COB_MODEL + idx] * lambert_cob_offset(cos_est) * rad_est)
    f[n, F_PIX] = sc.pix[0]
    f[n, F_PIX + 1] = sc.pix[1]
    kind = ps.kind
    for j in range(3):
        sc.dirv[j] = sc.planets[idx, j] - sc.central[j]  # the planet in the filter's frame
    if ps.onboard_lt or ps.onboard_ab:
        _onboard_apparent(prm, st, n, idx, sc)  # the filter's model: its corrections from its estimate
    m = measurement_vector_kernel(
        sc.los, alpha, f[n, F_QE : F_QE + 4], sc.dirv, xe, kind, sc.z, sc.basis, sc.rq
    )
    planet_model_kernel(
        xe[:3], sc.dirv, 2.0 * prm.radii[idx], kind, ps.sig_dir, ps.sig_size, sc.basis, sc.h, sc.jac,
        sc.rcov,
    )  # fmt: skip
    nis, ok = update_kernel(
        xe, p[n], sc.z, sc.h, sc.jac, sc.rcov, m, 1 if kind <= 1 else -1, prm.gate[m - 1], sc.uw
    )
    f[n, F_NIS] = nis
    return True, not ok


@row_kernel
def _truth_apparent(prm, st, n, idx, sc) -> None:  # pragma: no cover - compiled
    """The truth's target point ``sc.t1[0]`` of planet ``idx`` seen from row ``n``'s true position
    ``sc.r1[0]``: at the geometric range in the apparent direction, with the world's light time and
    aberration by the true heliocentric velocity (:func:`~planetnav_env.core.light_path.apparent_point`).
    Leaves the planet's velocity in ``sc.light[V_TARGET]`` for :func:`_onboard_apparent`."""
    f, ps, lp = st.f, prm.scalars[0], sc.light
    t = row_time(prm, f, st.i, n)
    channel_velocity(prm, st.eph, f, n, t, ps.ch_tplanet0 + idx, lp[V_TARGET])
    heliocentric_velocity(prm, st.eph, f, n, t, f[n, F_X : F_X + 6], ps.ch_tcentral, lp[V_TRUE])
    apparent_point(
        sc.r1[0], lp[V_TRUE], sc.tplanets[idx], lp[V_TARGET], ps.world_lt != 0, ps.world_ab != 0,
        lp[DIRECTION], sc.t1[0],
    )  # fmt: skip


@row_kernel
def _onboard_apparent(prm, st, n, idx, sc) -> None:  # pragma: no cover - compiled
    """The filter's target point ``sc.dirv`` (central-body frame) of planet ``idx``: the apparent point
    computed from row ``n``'s *estimated* position and velocity, so the corrections' error follows the
    estimate's. Aberrating the prediction is the inverse of de-aberrating the measurement (exactly, where
    aberrating the measurement by ``-v`` inverts it only to ``(v/c)^2``). Needs ``sc.light[V_TARGET]``
    from :func:`_truth_apparent` (an onboard correction is on only with its effect), evaluated again from
    the onboard channel when the truth follows an ephemeris of its own."""
    f, ps, lp = st.f, prm.scalars[0], sc.light
    xe = f[n, F_XE : F_XE + 6]
    t = row_time(prm, f, st.i, n)
    if ps.truth_eph != 0:
        channel_velocity(prm, st.eph, f, n, t, ps.ch_planet0 + idx, lp[V_TARGET])
    heliocentric_velocity(prm, st.eph, f, n, t, xe, ps.ch_central, lp[V_EST])
    for j in range(3):
        lp[R_EST, j] = xe[j] + sc.central[j]
    apparent_point(
        lp[R_EST], lp[V_EST], sc.planets[idx], lp[V_TARGET], ps.onboard_lt != 0, ps.onboard_ab != 0,
        lp[DIRECTION], sc.dirv,
    )  # fmt: skip
    for j in range(3):
        sc.dirv[j] -= sc.central[j]


@row_kernel
def _sun_in_body(sc, pl, ox, oy, oz, q0, q1, q2, q3) -> float:  # pragma: no cover - compiled
    """The cosine of the phase angle (Sun-planet-observer) of the planet at the heliocentric point ``pl``
    (3,) [km] (the truth's ``sc.tplanets[idx]`` or the filter's ``sc.planets[idx]``) seen from the
    heliocentric point ``(ox, oy, oz)`` [km]; writes the unit planet-to-Sun direction in the body axes of
    the attitude ``q`` into ``sc.dirv`` (``sc.rq`` as work space)."""
    dcm_body_to_inertial_kernel(q0, q1, q2, q3, sc.rq)
    ps_ = math.sqrt(pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2])
    cx, cy, cz = ox - pl[0], oy - pl[1], oz - pl[2]
    cn = math.sqrt(cx * cx + cy * cy + cz * cz)
    # The Sun is the heliocentric origin: the planet-to-Sun direction is -planet.
    cos_phase = -(pl[0] * cx + pl[1] * cy + pl[2] * cz) / (ps_ * cn)
    for k in range(3):  # planet-to-Sun direction in body axes: R^T (-planet / |planet|)
        sc.dirv[k] = -(sc.rq[0, k] * pl[0] + sc.rq[1, k] * pl[1] + sc.rq[2, k] * pl[2]) / ps_
    return cos_phase


@row_kernel
def _centroid_bias(sc, idx, alpha_true, scale) -> float:  # pragma: no cover - compiled
    """Displace the body-frame line of sight ``sc.los`` of planet ``idx`` (the truth's ``sc.tplanets[idx]``,
    seen from ``sc.r1[0]`` at the true attitude ``sc.q1[0]``) by its uniform-disk centre-of-brightness
    offset (:func:`~planetnav_env.sensors.camera_kernels.centroid_bias_kernel`); uses ``sc.dirv`` and
    ``sc.rq`` as work space. Returns the offset [rad]."""
    q, r = sc.q1[0], sc.r1[0]
    cos_phase = _sun_in_body(sc, sc.tplanets[idx], r[0], r[1], r[2], q[0], q[1], q[2], q[3])
    return centroid_bias_kernel(sc.los, sc.dirv, cos_phase, alpha_true, scale)


@row_kernel
def _outline_radius(prm, sc, idx) -> float:  # pragma: no cover - compiled
    """The radius [km] of the circle of the area of planet ``idx``'s spheroidal outline seen along the true
    line of sight ``sc.r1[0]`` -> ``sc.t1[0]`` (:func:`~planetnav_env.sensors.figure.equal_area_radius`;
    ``sc.dirv`` as work space): what a limb fit of the true outline gives for its size."""
    n2 = 0.0
    for k in range(3):
        sc.dirv[k] = sc.t1[0, k] - sc.r1[0, k]
        n2 += sc.dirv[k] * sc.dirv[k]
    inv = 1.0 / math.sqrt(n2)
    for k in range(3):
        sc.dirv[k] *= inv
    fig = prm.figure[idx]
    return equal_area_radius(prm.radii[idx], fig[0], sc.dirv, fig[1:4])


@row_kernel
def _image_sigmas(prm, sc, idx, rt) -> tuple[float, float]:  # pragma: no cover - compiled
    """The truth's sigmas of this image of planet ``idx`` (apparent radius ``rt`` [km], true target
    ``sc.t1[0]`` from ``sc.r1[0]``, the truth's planet ``sc.tplanets[idx]`` for its phase): per axis
    across the line of sight and of the angular diameter [rad],
    from the disk's size in pixels and the image's SNR (:mod:`planetnav_env.sensors.image_noise`)."""
    ps = prm.scalars[0]
    f_px = prm.cam[P_FPX]
    dx, dy, dz = sc.t1[0, 0] - sc.r1[0, 0], sc.t1[0, 1] - sc.r1[0, 1], sc.t1[0, 2] - sc.r1[0, 2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    d_px = 2.0 * math.asin(rt / dist) * f_px
    pl = sc.tplanets[idx]
    sun = math.sqrt(pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2])
    cos_phase = (pl[0] * dx + pl[1] * dy + pl[2] * dz) / (sun * dist)  # (-pl) . (r - pl), r - pl ~ -d
    e = planet_electrons(prm.figure[idx, 4], rt, sun, dist, cos_phase, ps.img_collect)
    snr = image_snr(e, d_px, ps.img_psf, ps.img_fw, ps.img_rn)
    s_c = centroid_sigma_px(d_px, snr, ps.img_psf, ps.img_floor, ps.img_limb)
    s_d = diameter_sigma_px(d_px, snr, ps.img_psf, ps.img_floor, ps.img_limb)
    return s_c / f_px, s_d / f_px


@row_kernel
def drift_reset(prm, st, n, sc) -> None:  # pragma: no cover - compiled
    """The boresight drift of row ``n`` at reset: its stationary distribution, ``drift_sigma`` times a
    standard normal per camera axis, from the stream ``NOISE_DRIFT``."""
    f, i, rng = st.f, st.i, st.rng
    sigma = prm.scalars[0].drift_sigma
    noise_begin(prm, i, rng, n, NOISE_DRIFT, sc)
    for j in range(2):
        f[n, F_DRIFT + j] = sigma * next_normal(prm, rng, n, sc)


@row_kernel
def drift_step(prm, st, n, sc) -> None:  # pragma: no cover - compiled
    """The boresight drift of row ``n`` one physics step (``step_s``) on: the exact Gauss-Markov
    transition of :func:`~planetnav_env.numerics.gauss_markov.gauss_markov_step` per camera axis, driven
    by the stream ``NOISE_DRIFT``."""
    f, i, rng = st.f, st.i, st.rng
    ps = prm.scalars[0]
    noise_begin(prm, i, rng, n, NOISE_DRIFT, sc)
    for j in range(2):
        w = next_normal(prm, rng, n, sc)
        f[n, F_DRIFT + j] = gauss_markov_step(f[n, F_DRIFT + j], ps.drift_sigma, ps.drift_tau, ps.step_s, w)


@row_kernel
def time_pulsar(prm, st, n, j, t, sc):  # pragma: no cover - compiled
    """Row ``n`` at time ``t`` [TDB s]: accumulate X-ray photons from pulsar ``j`` while the detector
    points at it; after the integration time a phase (range along the pulsar's direction from the
    barycentre) updates the filter, with the cycle count resolved against the prediction only when it can
    be trusted. Returns (measured, rejected, reason)."""
    f, p, i, rng, eph = st.f, st.p, st.i, st.rng, st.eph
    ps = prm.scalars[0]
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    nvec = prm.psr[j, 0:3]
    lam = prm.psr[j, 3]
    sigma = prm.psr[j, 4]
    for k in range(3):
        sc.r1[0, k] = x[k] + sc.tcentral[k]  # the truth's heliocentric position (its own ephemeris)
    q = f[n, F_Q : F_Q + 4]
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], sc.rq)
    b = prm.boresight
    cb = 0.0
    for k in range(3):
        cb += (sc.rq[k, 0] * b[0] + sc.rq[k, 1] * b[1] + sc.rq[k, 2] * b[2]) * nvec[k]
    off = math.acos(min(max(cb, -1.0), 1.0))
    reason = pulsar_visibility_row(
        sc.r1[0], nvec, ps.sun_avoid, sc.tcentral, ps.central_radius, ps.approach != 0
    )
    if reason != REASON_VISIBLE:
        f[n, F_INTEGRATED] = 0.0
        return False, False, reason
    if off > ps.det_half_fov:
        f[n, F_INTEGRATED] = 0.0
        return False, False, REASON_OUT_OF_FOV
    f[n, F_INTEGRATED] += ps.step_s
    if f[n, F_INTEGRATED] + 1e-9 < ps.psr_int_s:
        return False, False, REASON_INTEGRATING
    f[n, F_INTEGRATED] = 0.0
    # Truth: the barycentric position from the truth's ephemeris (ch_tssb), and the Sun's Shapiro delay
    # (world_shapiro); the filter: from DE421 (ch_ssb) and its estimate, with the delay when it models it.
    eval_channel(prm, eph, f, n, t, ps.ch_tssb, sc.ssb)
    total = 0.0
    for k in range(3):
        total += nvec[k] * (x[k] + sc.ssb[k])
    if ps.world_shapiro != 0:
        for k in range(3):
            sc.dirv[k] = sc.tcentral[k] - sc.ssb[k]  # the barycentre, heliocentric
        total += shapiro_range_km(sc.r1[0], sc.dirv, nvec)
    if ps.truth_eph != 0:
        eval_channel(prm, eph, f, n, t, ps.ch_ssb, sc.ssb)
    h = 0.0
    for k in range(3):
        h += nvec[k] * (xe[k] + sc.ssb[k])
    if ps.onboard_shapiro != 0:
        for k in range(3):
            sc.dirv[k] = sc.central[k] - sc.ssb[k]
            sc.roll[k] = xe[k] + sc.central[k]  # the estimated heliocentric position
        h += shapiro_range_km(sc.roll, sc.dirv, nvec)
    noise_begin(prm, i, rng, n, NOISE_PULSAR0 + j, sc)
    total = total / lam + sigma * next_normal(prm, rng, n, sc)
    if ps.psr_df_max > 0.0:
        # The on-board timing model's frequency error (world.pulsar_frequency_error_max): the phase
        # runs off by nu * delta * (t - start) cycles, i.e. c * delta * (t - start) / lambda.
        total += f[n, F_PSR_DRIFT + j] * (t - f[n, F_T0]) / lam
    h /= lam
    frac = total - math.floor(total)  # what the detector delivers: the phase within a cycle
    for k in range(6):
        sc.jac[0, k] = nvec[k] / lam if k < 3 else 0.0
    var = sigma * sigma
    pm = p[n]
    for a in range(3):
        for c in range(3):
            var += sc.jac[0, a] * pm[a, c] * sc.jac[0, c]
    if not ambiguity_resolvable_row(math.sqrt(var), ps.ambig_k):
        i[n, I_SKIPPED] += 1  # the whole number of cycles cannot be trusted: skip, count
        return False, False, REASON_AMBIGUOUS
    sc.z[0] = resolve_cycle(frac, h)
    sc.h[0] = h
    sc.rcov[0, 0] = sigma * sigma
    nis, ok = update_kernel(xe, pm, sc.z, sc.h, sc.jac, sc.rcov, 1, -1, prm.gate[0], sc.uw)
    f[n, F_NIS] = nis
    return True, not ok, REASON_VISIBLE
