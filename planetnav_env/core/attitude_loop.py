"""The flight world's attitude loop in the row step (``world.attitude_world_on``): disturbance torques,
wheels with friction and a speed limit, momentum dumps, and pointing from an attitude estimator.

Each stage reads and writes only row ``n``; the formulas are the attitude modules' own
(:mod:`planetnav_env.attitude.disturbances` for the torques, friction and a dump's delta-v,
:mod:`planetnav_env.attitude.plant` for the wheels and the rigid body, :mod:`planetnav_env.attitude.pointing`
for the PD law). Frames: body axes for torques and rates, the central body's inertial frame (ICRF axes)
for the orbit; units N m, N m s, rad, rad/s, km, km/s.

Truth and onboard, kept apart:

* **Truth.** External torque ``U_ext`` at every sub-step from the true attitude and position: SRP
  from the centre-of-pressure offset (``CoreParams.arms[0]``) with the Sun's direction and distance,
  the central body's gravity gradient, and on the thrust arc the thrust's torque from its offset
  (``arms[1]``) while the engine thrusts. The wheels apply the PD law's command through their limits,
  the speed limit's back EMF and their bearing friction (:func:`~planetnav_env.attitude.plant.
  flight_wheel_torque_kernel`). A dump, when a wheel's |momentum| exceeds the threshold, zeroes the wheel
  momentum (the thrusters take it out of the body while the wheels spin down: the body's rate is
  unchanged) and pushes the centre of mass by the impulse ``dh_i / l`` per axis (thrusters of lever arm
  ``l`` firing along body axis ``i + 1`` to torque about axis ``i``; ``dump_delta_v``), with a magnitude
  and a pointing error drawn per dump.
* **Gyro.** A delta-angle sensor sampled every sub-step: the true rotation over the sub-step plus the
  bias ``b`` times the sub-step (the bias drawn per episode, ``F_GB``, and walking at the rate random
  walk); its angle random walk is added to the estimate once per step (the same distribution at the
  step's end). The reported rates (``F_WM``) carry the bias.
* **Onboard.** A multiplicative extended Kalman filter of the attitude error and the gyro bias (6 states;
  Lefferts, Markley & Shuster, J. Guidance 5(5), 1982): gyro propagation of the quaternion every
  sub-step, the covariance once per step (the step's rotation, Farrenkopf's process noise), and an update
  with every star-tracker fix, whose covariance is the q-method's ``sigma^2 (sum_i (I - b_i b_i^T))^-1``
  over the stars in view (Shuster & Oh 1981). With ``est_on`` the PD law reads its quaternion and the
  bias-corrected gyro rate. A dump's delta-v is applied on board at its nominal value, rotated by the
  estimated attitude, and its error's covariance is added to the filter's.

The error state ``dtheta`` is the rotation from the estimate to the truth in the estimate's body axes,
``q = q_hat (x) dq(dtheta)``, and ``db = b - b_hat``.
"""

from __future__ import annotations

import math

from planetnav_env.attitude.disturbances import (
    dump_delta_v,
    gravity_gradient_torque,
    srp_torque,
    thrust_torque,
)
from planetnav_env.attitude.plant import (
    dcm_body_to_inertial_kernel,
    flight_wheel_torque_kernel,
    rk4_substep_kernel,
)
from planetnav_env.attitude.pointing import pd_torque_kernel
from planetnav_env.core.layout import (
    F_ATT_ERR,
    F_BH,
    F_DUMP_DV,
    F_DUMP_LEFT,
    F_DUMPS,
    F_GB,
    F_HW,
    F_PA,
    F_QE,
    F_QH,
    F_SAT_S,
    F_SRP_CR,
    F_THRUSTING,
    F_X,
    I_STARS,
)  # fmt: skip
from planetnav_env.core.operations import thrust_axis_on
from planetnav_env.core.row_noise import NOISE_DUMP, NOISE_GYRO, next_normal, noise_begin
from planetnav_env.numerics.jit import row_kernel

#: Rows of ``Scratch.att_v``: the external torque, one of its parts, the estimated body rate, work, the
#: total angular momentum in inertial axes [N m s].
_TEXT, _PART, _WHAT, _WORK, _HTOT = 0, 1, 2, 3, 4
#: Rows of ``Scratch.att_q``: the attitude at the step's start, at the sub-step's start, the sub-step's
#: rotation, work.
_Q_STEP, _Q_SUB, _Q_DELTA, _Q_WORK = 0, 1, 2, 3
#: Rows of ``Scratch.dump``: the step's dump delta-v in truth [km/s] and its position moment [km], then
#: the same on board.
_DV_TRUE, _DR_TRUE, _DV_NOM, _DR_NOM = 0, 1, 2, 3


@row_kernel
def quat_multiply(a, b, out) -> None:  # pragma: no cover - compiled
    """Hamilton product ``out = a (x) b`` (scalar first; ``out`` may not alias ``a`` or ``b``)."""
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]


@row_kernel
def rotate_by(q, v0, v1, v2, work) -> None:  # pragma: no cover - compiled
    """``q <- q (x) dq(v)`` in place, ``dq(v)`` the unit quaternion of the rotation vector ``v`` [rad]
    (body axes of ``q``), renormalised; ``work`` (4,) scratch."""
    ang = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if ang == 0.0:
        return
    s = math.sin(0.5 * ang) / ang
    c = math.cos(0.5 * ang)
    a0, a1, a2, a3 = q[0], q[1], q[2], q[3]
    b1, b2, b3 = s * v0, s * v1, s * v2
    work[0] = a0 * c - a1 * b1 - a2 * b2 - a3 * b3
    work[1] = a0 * b1 + a1 * c + a2 * b3 - a3 * b2
    work[2] = a0 * b2 - a1 * b3 + a2 * c + a3 * b1
    work[3] = a0 * b3 + a1 * b2 - a2 * b1 + a3 * c
    nn = math.sqrt(work[0] * work[0] + work[1] * work[1] + work[2] * work[2] + work[3] * work[3])
    for j in range(4):
        q[j] = work[j] / nn


@row_kernel
def error_vector(qa, qb, out) -> None:  # pragma: no cover - compiled
    """The small rotation vector [rad] from ``qa`` to ``qb`` in ``qa``'s body axes: ``qb = qa (x) dq(out)``,
    ``out = 2 vec(conj(qa) (x) qb)`` with the sign of the scalar part (the shorter rotation)."""
    w = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3]
    x = qa[0] * qb[1] - qa[1] * qb[0] - qa[2] * qb[3] + qa[3] * qb[2]
    y = qa[0] * qb[2] + qa[1] * qb[3] - qa[2] * qb[0] - qa[3] * qb[1]
    z = qa[0] * qb[3] - qa[1] * qb[2] + qa[2] * qb[1] - qa[3] * qb[0]
    sg = 2.0 if w >= 0.0 else -2.0
    out[0], out[1], out[2] = sg * x, sg * y, sg * z


@row_kernel
def _to_body(rq, v0, v1, v2, out) -> None:  # pragma: no cover - compiled
    """``out = R^T v`` (inertial -> body for ``rq = R(q)``, body -> inertial)."""
    for k in range(3):
        out[k] = rq[0, k] * v0 + rq[1, k] * v1 + rq[2, k] * v2


@row_kernel
def external_torque(prm, f, n, y, thrusting, sc, out) -> None:  # pragma: no cover - compiled
    """The truth's external torque [N m, body] on row ``n`` at the attitude ``y[:4]``: SRP from the
    centre-of-pressure offset (the Sun's direction and distance from the true heliocentric position,
    ``sc.central`` the central body's at the step), the central body's gravity gradient, and the thrust's
    torque while ``thrusting``. Uses ``sc.rq`` and ``sc.att_v`` rows ``_PART`` and ``_WORK``."""
    ps = prm.scalars[0]
    for k in range(3):
        out[k] = 0.0
    dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.rq)
    x = f[n, F_X : F_X + 3]
    part = sc.att_v[_PART]
    u = sc.att_v[_WORK]
    if ps.srp_tq:
        s0, s1, s2 = x[0] + sc.central[0], x[1] + sc.central[1], x[2] + sc.central[2]
        r = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        _to_body(sc.rq, -s0 / r, -s1 / r, -s2 / r, u)  # spacecraft -> Sun, body axes
        srp_torque(u, r, ps.srp_area, f[n, F_SRP_CR], prm.arms[0], part)
        for k in range(3):
            out[k] += part[k]
    if ps.gg_on:
        r = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])
        _to_body(sc.rq, -x[0] / r, -x[1] / r, -x[2] / r, u)  # spacecraft -> central body
        gravity_gradient_torque(u, r, ps.mu, prm.jm, part)
        for k in range(3):
            out[k] += part[k]
    if thrusting and ps.thr_tq:
        thrust_torque(ps.thrust_n, prm.boresight, prm.arms[1], part)
        for k in range(3):
            out[k] += part[k]


@row_kernel
def _dump(prm, st, n, y, hw, dh, tau, sc) -> None:  # pragma: no cover - compiled
    """Unload row ``n``'s momentum ``dh`` [N m s, body; the total ``J omega + h_w``]: ``hw <- hw - dh``
    (the body's rate ``y[4:]`` unchanged; ``dh`` may alias ``sc.att_v[_PART]``), the dump's delta-v
    into ``sc.dump`` (truth: with its errors, rotated by the true attitude; on board: nominal, rotated by
    the estimate) and its error's covariance into ``sc.dump_p``, mapped to the step's end ``tau`` [s]
    later. Counts the dump and its nominal delta-v [m/s]; on the thrust arc the engine stops for
    ``dump_dur``."""
    f, i, rng = st.f, st.i, st.rng
    ps = prm.scalars[0]
    l_arm = ps.dump_arm
    v = sc.att_v[_WORK]
    # Thrusters firing along body axis k + 1 at lever arm l along k + 2 torque about axis k; unloading h_k
    # takes the impulse h_k / l along axis k + 1 (dump_delta_v gives each axis's magnitude).
    for k in range(3):
        h = dh[(k + 2) % 3]
        v[k] = math.copysign(dump_delta_v(abs(h), l_arm, ps.mass), h)  # [km/s], body
    for k in range(3):
        hw[k] -= dh[k]
    dv = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if dv == 0.0:
        return
    f[n, F_DUMPS] += 1.0
    f[n, F_DUMP_DV] += dv * 1000.0
    if ps.ops:
        f[n, F_DUMP_LEFT] = ps.dump_dur
    # Two unit axes across the delta-v (body), for its pointing error.
    e0, e1, e2 = v[0] / dv, v[1] / dv, v[2] / dv
    a0, a1, a2 = (
        (1.0, 0.0, 0.0)
        if abs(e0) <= abs(e1) and abs(e0) <= abs(e2)
        else ((0.0, 1.0, 0.0) if abs(e1) <= abs(e2) else (0.0, 0.0, 1.0))
    )
    p0, p1, p2 = e1 * a2 - e2 * a1, e2 * a0 - e0 * a2, e0 * a1 - e1 * a0
    pn = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    p0, p1, p2 = p0 / pn, p1 / pn, p2 / pn
    r0, r1, r2 = e1 * p2 - e2 * p1, e2 * p0 - e0 * p2, e0 * p1 - e1 * p0
    noise_begin(prm, i, rng, n, NOISE_DUMP, sc)
    gm = ps.dump_sig_m * next_normal(prm, rng, n, sc)
    g1 = ps.dump_sig_p * next_normal(prm, rng, n, sc)
    g2 = ps.dump_sig_p * next_normal(prm, rng, n, sc)
    t0 = dv * ((1.0 + gm) * e0 + g1 * p0 + g2 * r0)
    t1 = dv * ((1.0 + gm) * e1 + g1 * p1 + g2 * r1)
    t2 = dv * ((1.0 + gm) * e2 + g1 * p2 + g2 * r2)
    # Truth: the true attitude; on board: the estimate (the filter knows the nominal delta-v only).
    dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.rq)
    for k in range(3):
        w = sc.rq[k, 0] * t0 + sc.rq[k, 1] * t1 + sc.rq[k, 2] * t2
        sc.dump[_DV_TRUE, k] += w
        sc.dump[_DR_TRUE, k] += w * tau
    qh = f[n, F_QH : F_QH + 4]
    dcm_body_to_inertial_kernel(qh[0], qh[1], qh[2], qh[3], sc.rq)
    for k in range(3):
        w = sc.rq[k, 0] * v[0] + sc.rq[k, 1] * v[1] + sc.rq[k, 2] * v[2]
        sc.dump[_DV_NOM, k] += w
        sc.dump[_DR_NOM, k] += w * tau
    # The error's covariance (inertial): dv^2 (sig_m^2 e e^T + sig_p^2 (I - e e^T)), e the nominal
    # direction; mapped to the step's end as position tau * error, velocity error.
    u = sc.att_v[_PART]
    for k in range(3):
        u[k] = sc.rq[k, 0] * e0 + sc.rq[k, 1] * e1 + sc.rq[k, 2] * e2
    sm2, sp2 = ps.dump_sig_m * ps.dump_sig_m, ps.dump_sig_p * ps.dump_sig_p
    for a in range(3):
        for b in range(3):
            c = dv * dv * ((sm2 - sp2) * u[a] * u[b] + (sp2 if a == b else 0.0))
            sc.dump_p[a, b] += tau * tau * c
            sc.dump_p[a, 3 + b] += tau * c
            sc.dump_p[3 + a, b] += tau * c
            sc.dump_p[3 + a, 3 + b] += c


@row_kernel
def _total_momentum(prm, y, hw, sc, out) -> None:  # pragma: no cover - compiled
    """``out = R(q) (J omega + h_w)`` [N m s, inertial] of ``y = (q, omega)`` and ``hw``; uses ``sc.rq``."""
    jm = prm.jm
    dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.rq)
    for a in range(3):
        acc = 0.0
        for b in range(3):
            acc += sc.rq[a, b] * (jm[b, 0] * y[4] + jm[b, 1] * y[5] + jm[b, 2] * y[6] + hw[b])
        out[a] = acc


@row_kernel
def _conserve(prm, y, hw, htot, sc) -> None:  # pragma: no cover - compiled
    """The body's rate from the total angular momentum ``htot`` [N m s, inertial] the external torques
    left: ``omega = J^-1 (R(q)^T H - h_w)``. RK4 conserves the total momentum only to its truncation error
    (1e-8 relative over a day of slews); this projection keeps the invariant to rounding, the attitude
    still RK4's. Uses ``sc.rq`` and ``sc.att_v[_WORK]``."""
    dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.rq)
    hb = sc.att_v[_WORK]
    for k in range(3):
        hb[k] = sc.rq[0, k] * htot[0] + sc.rq[1, k] * htot[1] + sc.rq[2, k] * htot[2] - hw[k]
    ji = prm.jinv
    for k in range(3):
        y[4 + k] = ji[k, 0] * hb[0] + ji[k, 1] * hb[1] + ji[k, 2] * hb[2]


@row_kernel
def flight_substeps(
    prm, st, n, use_pd, frame, n_sub, h_dt, dt, loop, ws, u_out, sc
):  # pragma: no cover - compiled
    """``n_sub`` closed-loop sub-steps of ``h_dt`` [s] of row ``n`` in the flight world, in place on
    ``sc.y = (q, omega)`` and the row's wheel momentum: the PD law toward ``frame`` (if ``use_pd``; from
    the estimator's attitude and rate with ``est_on``) plus the agent's ``sc.bias`` -> the flight wheels
    -> RK4 under the external torque; then the gyro's propagation of the estimate, a dump if a wheel
    crossed the threshold, the time at saturation and, on the thrust arc, the engine (off while a dump
    lasts; its torque acts while it thrusts). Returns ``(t_on, moment, on)``: the thrusting time [s], its
    position moment [s^2] (:mod:`planetnav_env.core.operations`) and whether the engine thrusts at the
    end. ``u_out`` receives the last torque the wheels applied to the body [N m]."""
    f = st.f
    ps = prm.scalars[0]
    plant = loop.plant
    y = sc.y
    hw = f[n, F_HW : F_HW + 3]
    qh = f[n, F_QH : F_QH + 4]
    bh = f[n, F_BH : F_BH + 3]
    gb = f[n, F_GB : F_GB + 3]
    wh = sc.att_v[_WHAT]
    text = sc.att_v[_TEXT]
    htot = sc.att_v[_HTOT]
    qs = sc.att_q[_Q_SUB]
    ops = ps.ops != 0
    on = ops and f[n, F_THRUSTING] != 0.0
    t_on = 0.0
    moment = 0.0
    for j in range(n_sub):
        if use_pd:
            if ps.est_on:
                for k in range(3):
                    wh[k] = y[4 + k] + gb[k] - bh[k]  # the gyro's rate, less the estimated bias
                pd_torque_kernel(qh, wh, hw, frame, plant.jm, loop.k_a, loop.k_w, ws.rq, ws.a, ws.u_cmd)
            else:
                pd_torque_kernel(y[:4], y[4:], hw, frame, plant.jm, loop.k_a, loop.k_w, ws.rq, ws.a, ws.u_cmd)
            for k in range(3):
                ws.u_cmd[k] += sc.bias[k]
        else:
            for k in range(3):
                ws.u_cmd[k] = sc.bias[k]
        external_torque(prm, f, n, y, on, sc, text)
        flight_wheel_torque_kernel(
            ws.u_cmd,
            hw,
            h_dt,
            plant.tau_max,
            plant.h_max,
            ps.h_speed,
            ps.fric_c,
            ps.fric_v,
            ps.jw,
            ps.fric_comp,
            u_out,
        )
        for k in range(4):
            qs[k] = y[k]
        # The external torque's impulse on the total momentum (inertial axes, the sub-step's start).
        for a in range(3):
            htot[a] += (sc.rq[a, 0] * text[0] + sc.rq[a, 1] * text[1] + sc.rq[a, 2] * text[2]) * h_dt
        rk4_substep_kernel(y, hw, u_out, text, h_dt, plant.jm, plant.jinv, ws.work)
        _conserve(prm, y, hw, htot, sc)
        # The gyro (a delta-angle sensor): the true rotation over the sub-step, then the bias the estimate
        # has not removed.
        dq = sc.att_q[_Q_DELTA]
        qw = sc.att_q[_Q_WORK]
        for k in range(1, 4):
            qs[k] = -qs[k]
        quat_multiply(qs, y, dq)
        quat_multiply(qh, dq, qw)
        nn = math.sqrt(qw[0] * qw[0] + qw[1] * qw[1] + qw[2] * qw[2] + qw[3] * qw[3])
        for k in range(4):
            qh[k] = qw[k] / nn
        rotate_by(qh, (gb[0] - bh[0]) * h_dt, (gb[1] - bh[1]) * h_dt, (gb[2] - bh[2]) * h_dt, qw)
        if ps.dump_on:
            # The momentum the wheels hold once the body is at rest, J omega + h_w (body axes): a slew moves
            # momentum between body and wheels but does not call for a dump.
            hb = sc.att_v[_PART]
            jm = plant.jm
            for a in range(3):
                hb[a] = jm[a, 0] * y[4] + jm[a, 1] * y[5] + jm[a, 2] * y[6] + hw[a]
            if max(abs(hb[0]), abs(hb[1]), abs(hb[2])) > ps.dump_thr:
                # The thrusters take it out of the total; the wheels end at -J omega, the rate unchanged.
                dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.rq)
                for a in range(3):
                    htot[a] -= sc.rq[a, 0] * hb[0] + sc.rq[a, 1] * hb[1] + sc.rq[a, 2] * hb[2]
                _dump(prm, st, n, y, hw, hb, dt - (j + 1) * h_dt, sc)
        if abs(hw[0]) >= ps.h_sat or abs(hw[1]) >= ps.h_sat or abs(hw[2]) >= ps.h_sat:
            f[n, F_SAT_S] += h_dt
        if ops:
            on = thrust_axis_on(y, prm.boresight, sc.z, ps.ops_cos_tol) and f[n, F_DUMP_LEFT] <= 0.0
            if f[n, F_DUMP_LEFT] > 0.0:
                f[n, F_DUMP_LEFT] = max(0.0, f[n, F_DUMP_LEFT] - h_dt)
            if on:
                t_on += h_dt
                moment += h_dt * (dt - (j + 0.5) * h_dt)
    return t_on, moment, on


@row_kernel
def pointing_error_kernel(q, boresight, direction, rq) -> float:  # pragma: no cover - compiled
    """Angle [rad] between the body ``boresight`` turned by ``q`` (body -> inertial) and the unit inertial
    ``direction`` (atan2 of the cross and dot products: full precision at small angles); ``rq`` (3, 3)
    scratch."""
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], rq)
    b0 = rq[0, 0] * boresight[0] + rq[0, 1] * boresight[1] + rq[0, 2] * boresight[2]
    b1 = rq[1, 0] * boresight[0] + rq[1, 1] * boresight[1] + rq[1, 2] * boresight[2]
    b2 = rq[2, 0] * boresight[0] + rq[2, 1] * boresight[1] + rq[2, 2] * boresight[2]
    c0 = b1 * direction[2] - b2 * direction[1]
    c1 = b2 * direction[0] - b0 * direction[2]
    c2 = b0 * direction[1] - b1 * direction[0]
    dot = b0 * direction[0] + b1 * direction[1] + b2 * direction[2]
    return math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), dot)


@row_kernel
def begin_step(prm, f, n, sc) -> None:  # pragma: no cover - compiled
    """Before row ``n``'s sub-steps: the attitude and the total angular momentum at the step's start, no
    dump yet."""
    for k in range(4):
        sc.att_q[_Q_STEP, k] = sc.y[k]
    _total_momentum(prm, sc.y, f[n, F_HW : F_HW + 3], sc, sc.att_v[_HTOT])
    for a in range(4):
        for b in range(3):
            sc.dump[a, b] = 0.0
    for a in range(6):
        for b in range(6):
            sc.dump_p[a, b] = 0.0


@row_kernel
def apply_dumps(f, n, x, xe, pm, sc) -> None:  # pragma: no cover - compiled
    """The step's dumps after the orbit step: their delta-v [km/s] and its moment [km] on the true state
    ``x`` and (nominal) on the estimate ``xe``, and their error's covariance on ``pm``."""
    for k in range(3):
        x[k] += sc.dump[_DR_TRUE, k]
        x[3 + k] += sc.dump[_DV_TRUE, k]
        xe[k] += sc.dump[_DR_NOM, k]
        xe[3 + k] += sc.dump[_DV_NOM, k]
    for a in range(6):
        for b in range(6):
            pm[a, b] += sc.dump_p[a, b]


@row_kernel
def fix_covariance(prm, st, n, sc, out) -> bool:  # pragma: no cover - compiled
    """The q-method's attitude covariance [rad^2, body axes] of row ``n``'s last star fix into ``out``
    (3, 3): ``sigma^2 (sum_i (I - b_i b_i^T))^-1`` over the stars in view (``sc.star_idx``), their body
    directions from the fix ``F_QE``. False without a fix (or an ideal tracker: a tiny covariance)."""
    f, i = st.f, st.i
    tables = prm.stars
    n_stars = i[n, I_STARS]
    if n_stars < 0:
        for a in range(3):
            for b in range(3):
                out[a, b] = 1e-20 if a == b else 0.0
        return True
    if not math.isfinite(f[n, F_ATT_ERR]):
        return False
    qe = f[n, F_QE : F_QE + 4]
    dcm_body_to_inertial_kernel(qe[0], qe[1], qe[2], qe[3], sc.rq)
    m = sc.a
    for a in range(3):
        for b in range(3):
            m[a, b] = n_stars if a == b else 0.0
    bb = sc.att_v[_WORK]
    for s in range(n_stars):
        d = tables.dirs[sc.star_idx[s]]
        _to_body(sc.rq, d[0], d[1], d[2], bb)
        for a in range(3):
            for b in range(3):
                m[a, b] -= bb[a] * bb[b]
    det = (
        m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
        - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
        + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0])
    )
    if not det > 0.0:
        return False
    s2 = tables.sigma_rad * tables.sigma_rad / det
    out[0, 0] = s2 * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
    out[0, 1] = s2 * (m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2])
    out[0, 2] = s2 * (m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1])
    out[1, 0] = out[0, 1]
    out[1, 1] = s2 * (m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0])
    out[1, 2] = s2 * (m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2])
    out[2, 0] = out[0, 2]
    out[2, 1] = out[1, 2]
    out[2, 2] = s2 * (m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0])
    return True


@row_kernel
def _star_update(f, n, r, sc) -> None:  # pragma: no cover - compiled
    """The attitude filter's update of row ``n`` with its star fix ``F_QE`` of covariance ``r`` (3, 3):
    residual ``z = dtheta(q_hat -> q_fix)``, ``H = [I 0]``, ``K = P H^T S^-1``; the estimate is corrected
    multiplicatively (``q_hat <- q_hat (x) dq(K z)[:3]``, ``b_hat += (K z)[3:]``), ``P <- P - K S K^T``."""
    pa = f[n, F_PA : F_PA + 36]
    qh = f[n, F_QH : F_QH + 4]
    bh = f[n, F_BH : F_BH + 3]
    z = sc.att_v[_WORK]
    error_vector(qh, f[n, F_QE : F_QE + 4], z)
    s = sc.att_m[1]
    for a in range(3):
        for b in range(3):
            s[a, b] = pa[6 * a + b] + r[a, b]
    det = (
        s[0, 0] * (s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1])
        - s[0, 1] * (s[1, 0] * s[2, 2] - s[1, 2] * s[2, 0])
        + s[0, 2] * (s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0])
    )
    si = sc.att_m[2]
    si[0, 0] = (s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1]) / det
    si[0, 1] = (s[0, 2] * s[2, 1] - s[0, 1] * s[2, 2]) / det
    si[0, 2] = (s[0, 1] * s[1, 2] - s[0, 2] * s[1, 1]) / det
    si[1, 0] = (s[1, 2] * s[2, 0] - s[1, 0] * s[2, 2]) / det
    si[1, 1] = (s[0, 0] * s[2, 2] - s[0, 2] * s[2, 0]) / det
    si[1, 2] = (s[0, 2] * s[1, 0] - s[0, 0] * s[1, 2]) / det
    si[2, 0] = (s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]) / det
    si[2, 1] = (s[0, 1] * s[2, 0] - s[0, 0] * s[2, 1]) / det
    si[2, 2] = (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]) / det
    k = sc.att_m[3]  # K (6 x 3) in the first three columns
    for a in range(6):
        for b in range(3):
            acc = 0.0
            for c in range(3):
                acc += pa[6 * a + c] * si[c, b]
            k[a, b] = acc
    dx = sc.att_m[0, 0]
    for a in range(6):
        dx[a] = k[a, 0] * z[0] + k[a, 1] * z[1] + k[a, 2] * z[2]
    rotate_by(qh, dx[0], dx[1], dx[2], sc.att_q[_Q_WORK])
    for a in range(3):
        bh[a] += dx[3 + a]
    # P <- P - K H P: (K H P)_ab = sum_c K_ac P_cb over the attitude rows c; symmetrised.
    kp = sc.att_m[1]
    for a in range(6):
        for b in range(6):
            kp[a, b] = k[a, 0] * pa[b] + k[a, 1] * pa[6 + b] + k[a, 2] * pa[12 + b]
    for a in range(6):
        for b in range(a, 6):
            v = 0.5 * ((pa[6 * a + b] - kp[a, b]) + (pa[6 * b + a] - kp[b, a]))
            pa[6 * a + b] = v
            pa[6 * b + a] = v


@row_kernel
def filter_step(prm, st, n, dt, sc) -> None:  # pragma: no cover - compiled
    """Row ``n``'s attitude filter at the end of a step of ``dt`` [s] (after the star fix): the gyro's
    angle random walk on the estimate and the bias's random walk in truth (``NOISE_GYRO``), the
    covariance propagated over the step (``Phi = [[C^T, -dt (I + C^T) / 2], [0, I]]`` with ``C`` the
    step's rotation, Farrenkopf's process noise), then the update with the star fix."""
    f, i, rng = st.f, st.i, st.rng
    ps = prm.scalars[0]
    qh = f[n, F_QH : F_QH + 4]
    gb = f[n, F_GB : F_GB + 3]
    pa = f[n, F_PA : F_PA + 36]
    sv, su = ps.g_arw, ps.g_rrw
    if sv > 0.0 or su > 0.0:
        noise_begin(prm, i, rng, n, NOISE_GYRO, sc)
        a0 = sv * math.sqrt(dt) * next_normal(prm, rng, n, sc)
        a1 = sv * math.sqrt(dt) * next_normal(prm, rng, n, sc)
        a2 = sv * math.sqrt(dt) * next_normal(prm, rng, n, sc)
        rotate_by(qh, a0, a1, a2, sc.att_q[_Q_WORK])
        for k in range(3):
            gb[k] += su * math.sqrt(dt) * next_normal(prm, rng, n, sc)
    # C^T: the step's rotation carries error vectors from the old body axes into the new ones.
    q0 = sc.att_q[_Q_STEP]
    y = sc.y
    dcm_body_to_inertial_kernel(q0[0], q0[1], q0[2], q0[3], sc.rq)
    dcm_body_to_inertial_kernel(y[0], y[1], y[2], y[3], sc.a)
    phi = sc.att_m[0]
    for a in range(6):
        for b in range(6):
            phi[a, b] = 1.0 if a == b else 0.0
    for a in range(3):
        for b in range(3):
            # (R1^T R0)_ab: the new body axis a against the old body axis b.
            c = sc.a[0, a] * sc.rq[0, b] + sc.a[1, a] * sc.rq[1, b] + sc.a[2, a] * sc.rq[2, b]
            phi[a, b] = c
            phi[a, 3 + b] = -0.5 * dt * (c + (1.0 if a == b else 0.0))
    tmp = sc.att_m[1]
    for a in range(6):
        for b in range(6):
            acc = 0.0
            for c in range(6):
                acc += phi[a, c] * pa[6 * c + b]
            tmp[a, b] = acc
    qv = sv * sv * dt + su * su * dt * dt * dt / 3.0
    qc = -su * su * dt * dt / 2.0
    qb = su * su * dt
    for a in range(6):
        for b in range(a, 6):
            acc = 0.0
            for c in range(6):
                acc += tmp[a, c] * phi[b, c]
            if a == b:
                acc += qv if a < 3 else qb
            elif b == a + 3:
                acc += qc
            pa[6 * a + b] = acc
            pa[6 * b + a] = acc
    if fix_covariance(prm, st, n, sc, sc.att_m[2]):
        for a in range(3):
            for b in range(3):
                sc.rcov[a, b] = sc.att_m[2, a, b]
        _star_update(f, n, sc.rcov, sc)


@row_kernel
def reset_filter(prm, st, n, sc) -> None:  # pragma: no cover - compiled
    """Row ``n``'s attitude filter at reset (after the first star fix): the estimate is the fix, the bias
    estimate zero; the covariance the fix's (a large one without a fix) and the bias's prior 1-sigma."""
    f = st.f
    for k in range(4):
        f[n, F_QH + k] = f[n, F_QE + k]
    pa = f[n, F_PA : F_PA + 36]
    for a in range(36):
        pa[a] = 0.0
    ok = fix_covariance(prm, st, n, sc, sc.att_m[2])
    for a in range(3):
        for b in range(3):
            pa[6 * a + b] = sc.att_m[2, a, b] if ok else (1.0 if a == b else 0.0)
    g = prm.scalars[0].g_bias
    for a in range(3):
        f[n, F_BH + a] = 0.0
        pa[6 * (3 + a) + 3 + a] = max(g * g, 1e-30)
