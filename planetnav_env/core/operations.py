"""Operations scenarios (``EnvConfig.operations``, docs/tasks/ThrustArc-TCM.md): the thrust arc's mission
attitude, its thrust and execution error, the delta-v lost to imaging, and the knowledge deadlines.

Frames and units: the thrust direction ``u`` is a unit vector in the inertial frame (ICRF axes) of the
orbit state, relative to the central body; accelerations km/s^2, PSDs km^2/s^3, times s, positions km,
velocities km/s, delta-v m/s.

Model (both truth and filter, so the filter is consistent by construction):

* the engine thrusts while the thrust axis (the camera boresight body axis, rotated by the true attitude)
  is within the attitude tolerance of ``u``, checked at the end of every attitude sub-step of length h;
  over one step of length dt this gives the thrusting time ``t_on = sum h`` and the position moment
  ``m = sum h (dt - t_mid)`` of the thrusting sub-steps (t_mid: a sub-step's mid time);
* the nominal thrust ``a u`` is added to the RK4 gravity step as ``dr = a m u``, ``dv = a t_on u``: exact
  for a piecewise-constant acceleration in free flight; the gravity gradient's effect on the thrust
  increment over a step, ~ (mu / r^3) dt^2 ~ 1e-10 at 1 AU for 600 s, is left out in both;
* the filter's model of the execution error (and the matched world's truth) is white acceleration noise of
  PSD ``q_par`` along ``u`` and ``q_perp`` across,
  discretised over the step and scaled by the thrust fraction ``f = t_on / dt``:
  ``Q = f [[dt^3/3 A, dt^2/2 A], [dt^2/2 A, dt A]]`` with ``A = q_perp I + (q_par - q_perp) u u^T``
  (:func:`add_thrust_q`). The truth draws its error from exactly this Q (:func:`thrust_noise`) and the
  filter adds exactly this Q, so NEES stays chi-square. Q depends only on the attitude history, not on
  the measured values: the covariance stays independent of the measurements;
* in the flight world (``world.thrust_gauss_markov``) the truth's execution error is instead the
  documented first-order Gauss-Markov process: the error acceleration ``a (e_m u + e_1 p_1 + e_2 p_2)``
  (``p_1``, ``p_2`` the cross axes of :func:`thrust_axes`) of a fractional magnitude error ``e_m``
  (sigma ``thrust_mag_sigma``) and two pointing errors [rad] (sigma ``thrust_point_sigma_deg``), each a
  process of correlation time ``thrust_corr_time_s`` (``numerics.gauss_markov``), drawn stationary at
  reset (the row's state columns ``F_THR_GM``), held over a step and stepped at its end with a noise
  stream of its own (:func:`step_thrust_error`); the filter keeps the white-noise Q of its PSD
  ``2 sigma^2 tau`` (the process's low-frequency PSD);
* delta-v lost [m/s] = ``a (dt - t_on)`` per step: the thrust the engine would have given on attitude;
* at each deadline epoch t_k (the first step end at or after it) the filter's position knowledge mapped
  to the encounter E by free flight, t_go = E - t: ``sigma_k = sqrt(coasted_position_trace(P, t_go))``
  (:func:`planetnav_env.core.what_if.coasted_position_trace`, the one formula) and the true mapped
  error ``|dr + t_go dv|``.
"""

from __future__ import annotations

import math

from planetnav_env.core.layout import (
    F_DL_ERR,
    F_DL_SIGMA,
    F_DV_LOST,
    F_DV_STEP,
    F_OBJECTIVE,
    F_THR_GM,
    F_X,
    F_XE,
    I_K,
)  # fmt: skip
from planetnav_env.core.row_noise import (
    NOISE_THRUST,
    NOISE_THRUST_GM,
    next_normal,
    next_own_normal,
    noise_begin,
    own_stream_begin,
)
from planetnav_env.core.what_if import coasted_position_trace
from planetnav_env.numerics.gauss_markov import gauss_markov_step
from planetnav_env.numerics.jit import row_kernel

#: A deadline counts as reached at the first step end within this relative tolerance of its epoch.
_EPOCH_RTOL = 1e-12


@row_kernel
def planned_direction(xe, u) -> bool:  # pragma: no cover - compiled
    """``u`` (3,) <- the estimated velocity direction (the planned thrust direction, inertial axes);
    False (``u`` zero) for a zero velocity."""
    vn = math.sqrt(xe[3] * xe[3] + xe[4] * xe[4] + xe[5] * xe[5])
    if vn == 0.0:
        for j in range(3):
            u[j] = 0.0
        return False
    for j in range(3):
        u[j] = xe[3 + j] / vn
    return True


@row_kernel
def thrust_axis_on(q, boresight, u, cos_tol) -> bool:  # pragma: no cover - compiled
    """True when the thrust axis (body ``boresight`` rotated by ``q``, scalar first, body -> inertial) is
    within the tolerance (its cosine ``cos_tol``) of the unit direction ``u``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    b0, b1, b2 = boresight[0], boresight[1], boresight[2]
    # R(q) b for a unit quaternion (the same rotation as dcm_body_to_inertial_kernel).
    r0 = (1.0 - 2.0 * (y * y + z * z)) * b0 + 2.0 * (x * y - w * z) * b1 + 2.0 * (x * z + w * y) * b2
    r1 = 2.0 * (x * y + w * z) * b0 + (1.0 - 2.0 * (x * x + z * z)) * b1 + 2.0 * (y * z - w * x) * b2
    r2 = 2.0 * (x * z - w * y) * b0 + 2.0 * (y * z + w * x) * b1 + (1.0 - 2.0 * (x * x + y * y)) * b2
    return r0 * u[0] + r1 * u[1] + r2 * u[2] >= cos_tol


@row_kernel
def apply_thrust(x, acc, u, t_on, moment) -> None:  # pragma: no cover - compiled
    """In place on the state ``x`` (6,): the nominal thrust of acceleration ``acc`` [km/s^2] along ``u``
    for ``t_on`` [s] with position moment ``moment`` [s^2]: r += acc moment u, v += acc t_on u."""
    for j in range(3):
        x[j] += acc * moment * u[j]
        x[3 + j] += acc * t_on * u[j]


@row_kernel
def add_thrust_q(p, dt, frac, q_par, q_perp, u) -> None:  # pragma: no cover - compiled
    """``p += frac * Q_thrust(dt)`` (6, 6): white acceleration noise of PSD ``q_par`` along the unit
    vector ``u`` and ``q_perp`` across it [km^2/s^3], discretised over ``dt`` [s] (module docstring)."""
    c_rr = frac * dt * dt * dt / 3.0
    c_rv = frac * dt * dt / 2.0
    c_vv = frac * dt
    dq = q_par - q_perp
    for a in range(3):
        for b in range(3):
            g = dq * u[a] * u[b] + (q_perp if a == b else 0.0)
            p[a, b] += c_rr * g
            p[a, 3 + b] += c_rv * g
            p[3 + a, b] += c_rv * g
            p[3 + a, 3 + b] += c_vv * g


@row_kernel
def _sqrt_a(g0, g1, g2, sq_par, sq_perp, u, j) -> float:  # pragma: no cover - compiled
    """Component ``j`` of ``A^(1/2) g``, ``A^(1/2) = sqrt(q_perp) I + (sqrt(q_par) - sqrt(q_perp)) u u^T``."""
    ug = u[0] * g0 + u[1] * g1 + u[2] * g2
    gj = g0 if j == 0 else (g1 if j == 1 else g2)
    return sq_perp * gj + (sq_par - sq_perp) * ug * u[j]


@row_kernel
def thrust_noise(prm, i, rng, n, x, dt, frac, q_par, q_perp, u, sc) -> None:  # pragma: no cover - compiled
    """Add to the true state ``x`` (6,) a draw of N(0, frac Q_thrust(dt)) (the Q of :func:`add_thrust_q`):
    ``dr = sqrt(f dt^3/3) A^(1/2) g1``, ``dv = sqrt(f) (sqrt(3 dt)/2 A^(1/2) g1 + sqrt(dt)/2 A^(1/2) g2)``,
    g1, g2 ~ N(0, I3) from the row's noise (stream ``NOISE_THRUST`` with per-step streams)."""
    noise_begin(prm, i, rng, n, NOISE_THRUST, sc)
    g10 = next_normal(prm, rng, n, sc)
    g11 = next_normal(prm, rng, n, sc)
    g12 = next_normal(prm, rng, n, sc)
    g20 = next_normal(prm, rng, n, sc)
    g21 = next_normal(prm, rng, n, sc)
    g22 = next_normal(prm, rng, n, sc)
    sq_par = math.sqrt(q_par)
    sq_perp = math.sqrt(q_perp)
    sf = math.sqrt(frac)
    c_r = sf * math.sqrt(dt * dt * dt / 3.0)
    c_v1 = sf * 0.5 * math.sqrt(3.0 * dt)
    c_v2 = sf * 0.5 * math.sqrt(dt)
    for j in range(3):
        a1 = _sqrt_a(g10, g11, g12, sq_par, sq_perp, u, j)
        a2 = _sqrt_a(g20, g21, g22, sq_par, sq_perp, u, j)
        x[j] += c_r * a1
        x[3 + j] += c_v1 * a1 + c_v2 * a2


@row_kernel
def thrust_axes(u, p1, p2) -> None:  # pragma: no cover - compiled
    """The cross axes of the unit thrust direction ``u``: ``p1`` = z x u normalized (x x u when ``u`` is
    within 1e-6 rad of the ICRF z axis), ``p2`` = u x p1; (u, p1, p2) is right-handed orthonormal."""
    c0, c1, c2 = -u[1], u[0], 0.0  # z x u
    cn = math.sqrt(c0 * c0 + c1 * c1)
    if cn < 1e-6:
        c0, c1, c2 = 0.0, -u[2], u[1]  # x x u
        cn = math.sqrt(c1 * c1 + c2 * c2)
    p1[0], p1[1], p1[2] = c0 / cn, c1 / cn, c2 / cn
    p2[0] = u[1] * p1[2] - u[2] * p1[1]
    p2[1] = u[2] * p1[0] - u[0] * p1[2]
    p2[2] = u[0] * p1[1] - u[1] * p1[0]


@row_kernel
def apply_thrust_error(f, n, x, acc, u, t_on, moment, sc) -> None:  # pragma: no cover - compiled
    """In place on the true state ``x`` (6,): the Gauss-Markov execution error of row ``n`` (its columns
    ``F_THR_GM``: magnitude fraction, two pointing angles [rad]) as the acceleration
    ``acc (e_m u + e_1 p1 + e_2 p2)`` over the thrusting time ``t_on`` [s] with moment ``moment`` [s^2],
    as :func:`apply_thrust` the nominal thrust. Uses ``sc.roll`` and ``sc.dirv`` for the cross axes."""
    thrust_axes(u, sc.roll, sc.dirv)
    e_m, e_1, e_2 = f[n, F_THR_GM], f[n, F_THR_GM + 1], f[n, F_THR_GM + 2]
    for j in range(3):
        err = acc * (e_m * u[j] + e_1 * sc.roll[j] + e_2 * sc.dirv[j])
        x[j] += err * moment
        x[3 + j] += err * t_on


@row_kernel
def step_thrust_error(prm, f, i, rng, n, dt, sc) -> None:  # pragma: no cover - compiled
    """Step row ``n``'s Gauss-Markov execution error (columns ``F_THR_GM``) over ``dt`` [s]:
    ``numerics.gauss_markov.gauss_markov_step`` of each component with its sigma (``ops_sig_mag``, then
    ``ops_sig_point`` twice) and the correlation time ``ops_tau``, driven by the stream
    ``NOISE_THRUST_GM`` of its own (three draws a step)."""
    ps = prm.scalars[0]
    own_stream_begin(i, rng, n, NOISE_THRUST_GM, sc)
    for c in range(3):
        sig = ps.ops_sig_mag if c == 0 else ps.ops_sig_point
        f[n, F_THR_GM + c] = gauss_markov_step(f[n, F_THR_GM + c], sig, ps.ops_tau, dt, next_own_normal(sc))


@row_kernel
def reset_operations(f, n) -> None:  # pragma: no cover - compiled
    """A fresh episode's bookkeeping: no delta-v lost, J = 0, no deadline reached (its sigma and error 0:
    a reached deadline's are > 0)."""
    f[n, F_DV_STEP] = 0.0
    f[n, F_DV_LOST] = 0.0
    f[n, F_OBJECTIVE] = 0.0
    for d in range(F_DL_ERR - F_DL_SIGMA):
        f[n, F_DL_SIGMA + d] = 0.0
        f[n, F_DL_ERR + d] = 0.0


@row_kernel
def score_operations(prm, f, p, i, n) -> float:  # pragma: no cover - compiled
    """The step's cost [km] of row ``n`` after its step: ``w * dv_step`` plus the term of each deadline
    reached at this step (sigma_k with ``reward: covariance``, the true mapped error with ``truth``);
    records the deadlines' sigma and error and adds the cost to the objective J."""
    ps = prm.scalars[0]
    elapsed = i[n, I_K] * ps.step_s
    cost = ps.ops_weight * f[n, F_DV_STEP]
    pm = p[n]
    for d in range(ps.ops_n_dl):
        t_d = prm.ops_deadlines[d]
        # Reached at the first step end at or after its epoch: this step, if the previous end was before it.
        t_hit = t_d * (1.0 - _EPOCH_RTOL)
        if elapsed < t_hit or elapsed - ps.step_s >= t_hit:
            continue
        t_go = max(ps.ops_encounter - elapsed, 0.0)
        sig = math.sqrt(max(coasted_position_trace(pm, t_go), 0.0))
        e2 = 0.0
        for j in range(3):
            dj = (f[n, F_XE + j] - f[n, F_X + j]) + t_go * (f[n, F_XE + 3 + j] - f[n, F_X + 3 + j])
            e2 += dj * dj
        err = math.sqrt(e2)
        f[n, F_DL_SIGMA + d] = sig
        f[n, F_DL_ERR + d] = err
        cost += err if ps.reward_truth else sig
    f[n, F_OBJECTIVE] += cost
    return cost
