"""The compiled step of the batch core: one row kernel per stage, one loop over the rows.

Every environment row ``n`` is advanced by :func:`step_row` and observed by :func:`observe_row`; the
batch functions loop over a range of rows; :class:`~planetnav_env.core.batch.BatchCore` runs chunks of
rows on Python threads (the kernels release the GIL). A row reads and writes
only its own slices of the state arrays (``f``, ``p``, ``i``, ``rng``, ``eph``, ``obs``; columns in
:mod:`planetnav_env.core.layout`), and its parameters are shared read-only: rows are independent, so
the result does not depend on the batch size, the chunking or the thread, and the single environment
(a batch of one) equals row ``n`` of the vector environment bit for bit.

No Python objects and no allocation inside the row kernels (scratch space is allocated once per chunk
and passed down as :class:`Scratch`): the same row kernels could run one row per GPU thread
(docs/architecture.md says how). They are compiled with :data:`planetnav_env.jit.row_kernel`, without
numba's reference counting (the module says why); only ``step_range`` and ``reset_rows``, which
allocate the scratch, keep it.

The physics is not written here: each stage calls the module that owns the formula (attitude
sub-steps: :mod:`planetnav_env.attitude.pointing`; orbit RK4, STM and the EKF:
:mod:`planetnav_env.estimation.fast`; camera: :mod:`planetnav_env.sensors.camera`; star tracker:
:mod:`planetnav_env.sensors.star_tracker`; pulsar timing: :mod:`planetnav_env.sensors.pulsar`;
ephemerides: :mod:`planetnav_env.core.ephemeris_table`; random numbers: :mod:`planetnav_env.core.rng`).
This module wires them together in the order of one step and builds the observation.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from planetnav_env.attitude.pointing import error_matrix_kernel, frame_kernel, substeps_kernel
from planetnav_env.bodies import AU_KM
from planetnav_env.core import rng as crng
from planetnav_env.core.ephemeris_table import position_kernel, positions_kernel
from planetnav_env.core.layout import (
    F_ATT_ERR,
    F_HW,
    F_INTEGRATED,
    F_NEES,
    F_NIS,
    F_PIX,
    F_POS_ERR,
    F_POS_SIGMA,
    F_Q,
    F_QE,
    F_REWARD,
    F_T0,
    F_U,
    F_VEL_ERR,
    F_W,
    F_WM,
    F_X,
    F_XE,
    I_K,
    I_MEASURED,
    I_REASON,
    I_REJECTED,
    I_SENSOR,
    I_SETTLED,
    I_SKIPPED,
    I_SLEWING,
    I_STARS,
    I_STATUS,
    I_TARGET,
    I_TERMINATED,
    I_TRUNCATED,
    MODE_TARGET,
    MODE_TORQUE,
    N_APPROACH,
    N_CH_CENTRAL,
    N_CH_PERT0,
    N_CH_PLANET0,
    N_CH_SSB,
    N_EPISODE_STEPS,
    N_EULER,
    N_IDEAL_STAR,
    N_KIND,
    N_MODE,
    N_N_COARSE,
    N_N_PERT,
    N_N_SUB,
    N_NOISE_PER_STEP,
    N_NP,
    N_NQ,
    N_NT,
    N_OBS_ELAPSED,
    N_OBS_PLANETS,
    N_OBS_PULSARS,
    N_OBS_TARGET,
    N_REWARD_TRUTH,
    REASON_AMBIGUOUS,
    REASON_INTEGRATING,
    REASON_NONE,
    REASON_OCCULTED,
    REASON_OUT_OF_FOV,
    REASON_SUN_EXCLUSION,
    REASON_TOO_LARGE,
    REASON_VISIBLE,
    S_ALPHA_MAX,
    S_AMBIG_K,
    S_CENTRAL_RADIUS,
    S_COARSE_S,
    S_COS_HALF_DIAG,
    S_DET_HALF_FOV,
    S_DIVERGENCE,
    S_GATE1,
    S_K_A,
    S_K_W,
    S_MU,
    S_POS_SCALE,
    S_PSR_INT_S,
    S_RATE_NOISE,
    S_REWARD_SCALE,
    S_SEGMENT_S,
    S_SETTLE_ANGLE,
    S_SETTLE_RATE,
    S_SIG_DIR,
    S_SIG_SIZE,
    S_SIGMA_ALPHA,
    S_STEP_S,
    S_SUBSTEP_S,
    S_SUN_AVOID,
    S_TORQUE_PENALTY,
    S_TORQUE_SCALE,
    S_VEL_SCALE,
    SENSOR_CAMERA,
    SENSOR_NONE,
    SENSOR_XRAY,
    STATUS_ATTITUDE_NONFINITE,
    STATUS_CAMERA,
    STATUS_OK,
)  # fmt: skip
from planetnav_env.dynamics.attitude import dcm_body_to_inertial_kernel, store_state_kernel
from planetnav_env.estimation.fast import (
    nees_kernel,
    planet_model_kernel,
    predict_kernel,
    rk4_kernel,
    update_kernel,
)
from planetnav_env.jit import row_kernel
from planetnav_env.sensors.camera import (
    N_VIS_SLOTS,
    V_ALPHA,
    V_REASON,
    measure_row_kernel,
    visibility_row_kernel,
)
from planetnav_env.sensors.pulsar import ambiguity_resolvable_kernel, resolve_cycle_kernel
from planetnav_env.sensors.star_tracker import FIX_WORK_SHAPE, error_angle_kernel, select_stars, star_fix


class CoreParams(NamedTuple):
    """Everything a row kernel needs that is the same for every row, built once from an ``EnvConfig``
    by :func:`planetnav_env.core.params.build_params`. Scalars sit in ``s`` (float) and ``n`` (int) at
    the ``S_*``/``N_*`` slots of :mod:`planetnav_env.core.layout`."""

    s: np.ndarray  # (NS,) float64
    n: np.ndarray  # (NN,) int64
    jm: np.ndarray  # (3, 3) inertia [kg m^2]
    jinv: np.ndarray  # (3, 3)
    tau_max: np.ndarray  # (3,) wheel torque limits [N m]
    h_max: np.ndarray  # (3,) wheel momentum capacities [N m s]
    boresight: np.ndarray  # (3,) camera boresight, body axes
    radii: np.ndarray  # (P,) planet radii [km]
    mus: np.ndarray  # (K,) perturbers' GM [km^3/s^2]
    psr: np.ndarray  # (Q, 5) pulsar direction (3), wavelength [km], phase sigma [cycles]
    c2b: np.ndarray  # (3, 3) camera -> body
    cam: np.ndarray  # (11,) camera parameters (CameraConfig._params)
    qproc: np.ndarray  # (6, 6) process noise over one step
    stars: tuple  # star_tracker.StarFixTables
    q_bias: np.ndarray  # (4,) fixed star-tracker misalignment composed with every fix (identity: none)


class Scratch(NamedTuple):
    """Work arrays of one chunk of rows (allocated once per call, reused by every row)."""

    work: np.ndarray  # (8, 7) attitude RK4
    rq: np.ndarray  # (3, 3)
    a: np.ndarray  # (3, 3)
    frame: np.ndarray  # (3, 3)
    y: np.ndarray  # (7,)
    u_cmd: np.ndarray  # (3,)
    bias: np.ndarray  # (3,)
    zero3: np.ndarray  # (3,)
    w6: np.ndarray  # (3, 6, 6) orbit RK4
    v6: np.ndarray  # (4, 6)
    phi: np.ndarray  # (6, 6)
    tmp: np.ndarray  # (6, 6)
    x_new: np.ndarray  # (6,)
    uw: np.ndarray  # (5, 6, 6) EKF update
    h: np.ndarray  # (3,)
    jac: np.ndarray  # (3, 6)
    rcov: np.ndarray  # (3, 3)
    z: np.ndarray  # (3,)
    basis: np.ndarray  # (2, 3)
    m: np.ndarray  # (3, 3) camera
    u6: np.ndarray  # (6,)
    vals: np.ndarray  # (N_VIS_SLOTS,)
    los: np.ndarray  # (3,)
    los_true: np.ndarray  # (3,)
    mm: np.ndarray  # (2,)
    pix: np.ndarray  # (2,)
    r1: np.ndarray  # (1, 3) one-element batches for the camera kernels
    q1: np.ndarray  # (1, 4)
    t1: np.ndarray  # (1, 3)
    central: np.ndarray  # (3,) central body, heliocentric
    ssb: np.ndarray  # (3,) central body relative to the barycentre
    dirv: np.ndarray  # (3,)
    roll: np.ndarray  # (3,)
    pert: np.ndarray  # (3, K, 3) perturbers at t, t + dt/2, t + dt
    planets: np.ndarray  # (P, 3)
    r_tile: np.ndarray  # (P, 3)
    q_tile: np.ndarray  # (P, 4)
    feat: np.ndarray  # (P, 7)
    noise3: np.ndarray  # (3,)
    star_idx: np.ndarray  # (max_stars,) int64 catalogue indices in view
    star_noise: np.ndarray  # (max_stars, 3) per-star direction noise [rad]
    star_work: np.ndarray  # FIX_WORK_SHAPE
    q_fix: np.ndarray  # (4,)
    sub: np.ndarray  # (4,) uint64: a per-step noise stream (noise_streams "per_step")


@njit(cache=True)
def make_scratch(prm: CoreParams) -> Scratch:  # pragma: no cover - compiled
    n_p = prm.radii.shape[0]
    n_k = prm.mus.shape[0]
    n_s = prm.stars.max_stars
    return Scratch(
        np.empty((8, 7)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(7), np.empty(3),
        np.empty(3), np.zeros(3), np.empty((3, 6, 6)), np.empty((4, 6)), np.empty((6, 6)), np.empty((6, 6)),
        np.empty(6), np.empty((5, 6, 6)), np.empty(3), np.empty((3, 6)), np.empty((3, 3)), np.empty(3),
        np.zeros((2, 3)), np.empty((3, 3)), np.empty(6), np.empty(N_VIS_SLOTS), np.empty(3), np.empty(3),
        np.empty(2), np.empty(2), np.empty((1, 3)), np.empty((1, 4)), np.empty((1, 3)), np.empty(3),
        np.empty(3), np.empty(3), np.empty(3), np.empty((3, n_k, 3)), np.empty((n_p, 3)), np.empty((n_p, 3)),
        np.empty((n_p, 4)), np.empty((n_p, 7)), np.empty(3), np.empty(n_s, np.int64), np.empty((n_s, 3)),
        np.empty(FIX_WORK_SHAPE), np.empty(4), np.empty(crng.STATE_WORDS, np.uint64),
    )  # fmt: skip


# ------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------
@row_kernel
def _time(prm, f, i, n):  # pragma: no cover - compiled
    return f[n, F_T0] + i[n, I_K] * prm.s[S_STEP_S]


#: Stream ids of the per-step noise (``noise_streams: per_step``): one per sensor; pulsar j uses
#: ``NOISE_PULSAR0 + j``.
NOISE_STAR, NOISE_RATE, NOISE_CAMERA, NOISE_PULSAR0 = 1, 2, 3, 16


@row_kernel
def _noise_begin(prm, i, rng, n, stream, sc) -> None:  # pragma: no cover - compiled
    """Start drawing sensor ``stream``'s noise at the row's current step. With per-step streams this
    derives ``sc.sub`` from the row's key (``rng[n]``, then never advanced), the step index and the
    stream id; with the sequential stream it does nothing (draws continue ``rng[n]``)."""
    if prm.n[N_NOISE_PER_STEP]:
        crng.substream(rng[n], i[n, I_K], stream, sc.sub)


@row_kernel
def _normal(prm, rng, n, sc) -> float:  # pragma: no cover - compiled
    """The next N(0, 1) of the noise begun by :func:`_noise_begin`."""
    if prm.n[N_NOISE_PER_STEP]:
        return crng.standard_normal(sc.sub)
    return crng.standard_normal(rng[n])


@row_kernel
def _eval(prm, eph, f, n, t, channel, out) -> bool:  # pragma: no cover - compiled
    if channel < 0:
        out[0] = out[1] = out[2] = 0.0
        return True
    return position_kernel(eph[n], f[n, F_T0], prm.s[S_SEGMENT_S], t, channel, out)


@row_kernel
def _planets_at(prm, eph, f, n, t, out) -> bool:  # pragma: no cover - compiled
    c0 = prm.n[N_CH_PLANET0]
    return positions_kernel(eph[n], f[n, F_T0], prm.s[S_SEGMENT_S], t, c0, c0 + prm.n[N_NP], out)


@row_kernel
def _perturbers(prm, eph, f, n, t, dt, out) -> bool:  # pragma: no cover - compiled
    k = prm.n[N_N_PERT]
    if k == 0:
        return True
    c0 = prm.n[N_CH_PERT0]
    seg = prm.s[S_SEGMENT_S]
    ok = positions_kernel(eph[n], f[n, F_T0], seg, t, c0, c0 + k, out[0])
    ok = ok and positions_kernel(eph[n], f[n, F_T0], seg, t + 0.5 * dt, c0, c0 + k, out[1])
    return ok and positions_kernel(eph[n], f[n, F_T0], seg, t + dt, c0, c0 + k, out[2])


@row_kernel
def los_basis_kernel(planet, x_est, basis) -> None:  # pragma: no cover - compiled
    """Rows of ``basis`` (2, 3): ``e1 = d x (axis least aligned with d)``, ``e2 = d x e1`` for the predicted
    line of sight ``d`` from ``x_est`` to ``planet`` (``measurements.los_basis`` is its numpy oracle)."""
    d0, d1, d2 = planet[0] - x_est[0], planet[1] - x_est[1], planet[2] - x_est[2]
    dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    d0, d1, d2 = d0 / dn, d1 / dn, d2 / dn
    k = 0
    smallest = abs(d0)
    if abs(d1) < smallest:
        k = 1
        smallest = abs(d1)
    if abs(d2) < smallest:
        k = 2
    a0, a1, a2 = (1.0 if k == 0 else 0.0), (1.0 if k == 1 else 0.0), (1.0 if k == 2 else 0.0)
    e10, e11, e12 = d1 * a2 - d2 * a1, d2 * a0 - d0 * a2, d0 * a1 - d1 * a0
    en = math.sqrt(e10 * e10 + e11 * e11 + e12 * e12)
    e10, e11, e12 = e10 / en, e11 / en, e12 / en
    basis[0, 0], basis[0, 1], basis[0, 2] = e10, e11, e12
    basis[1, 0], basis[1, 1], basis[1, 2] = d1 * e12 - d2 * e11, d2 * e10 - d0 * e12, d0 * e11 - d1 * e10


@row_kernel
def measurement_vector_kernel(los_body, alpha, q_est, planet, x_est, kind, z, basis, r):  # pragma: no cover
    """Filter measurement ``z`` from a body-frame line of sight rotated to inertial by the *star-tracker*
    attitude ``q_est`` (what a real filter does: it never sees the true attitude).

    kind 0/1: (declination, right ascension[, alpha]); kind 2/3: the LOS projected on the basis
    orthogonal to the *predicted* line of sight from ``x_est`` to ``planet`` (written into ``basis``:
    ``e1 = d x (axis least aligned with d)``, ``e2 = d x e1``, the construction of
    :func:`planetnav_env.estimation.measurements.los_basis`, which is its numpy oracle). ``r`` (3, 3) is
    scratch. Returns m.
    """
    dcm_body_to_inertial_kernel(q_est[0], q_est[1], q_est[2], q_est[3], r)
    u0 = r[0, 0] * los_body[0] + r[0, 1] * los_body[1] + r[0, 2] * los_body[2]
    u1 = r[1, 0] * los_body[0] + r[1, 1] * los_body[1] + r[1, 2] * los_body[2]
    u2 = r[2, 0] * los_body[0] + r[2, 1] * los_body[1] + r[2, 2] * los_body[2]
    if kind <= 1:
        z[0] = math.asin(min(max(u2, -1.0), 1.0))
        z[1] = math.atan2(u1, u0)
    else:
        los_basis_kernel(planet, x_est, basis)
        z[0] = basis[0, 0] * u0 + basis[0, 1] * u1 + basis[0, 2] * u2
        z[1] = basis[1, 0] * u0 + basis[1, 1] * u1 + basis[1, 2] * u2
    if kind == 1 or kind == 3:
        z[2] = alpha
        return 3
    return 2


@row_kernel
def _star_fix(prm, f, i, rng, n, sc):  # pragma: no cover - compiled
    """Star-tracker attitude into QE: q-method on the stars in the camera's own field, their directions
    perturbed by the row's random stream. With too few stars or a degenerate field the last fix is kept
    (stale) and ATT_ERR is NaN; ``star_tracker="ideal"`` copies the true attitude."""
    q = f[n, F_Q : F_Q + 4]
    qe = f[n, F_QE : F_QE + 4]
    if prm.n[N_IDEAL_STAR]:
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
    _noise_begin(prm, i, rng, n, NOISE_STAR, sc)
    for a in range(n_stars):  # row-major, as rng.normal(size=(n, 3)) draws them
        for c in range(3):
            sc.star_noise[a, c] = tables.sigma_rad * _normal(prm, rng, n, sc)
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
def _rate_measurement(prm, f, i, rng, n, sc):  # pragma: no cover - compiled
    sig = prm.s[S_RATE_NOISE]
    _noise_begin(prm, i, rng, n, NOISE_RATE, sc)
    for j in range(3):
        f[n, F_WM + j] = f[n, F_W + j] + sig * _normal(prm, rng, n, sc)


@row_kernel
def _pointing_settled(prm, f, n, sc) -> bool:  # pragma: no cover - compiled
    """The boresight is within SETTLE_ANGLE of the PD frame's axis and the rates below SETTLE_RATE:
    the closed loop is then near its equilibrium, and coarse sub-steps integrate it accurately."""
    q = f[n, F_Q : F_Q + 4]
    error_matrix_kernel(q, sc.frame, sc.rq, sc.a)
    s0 = sc.a[1, 2] - sc.a[2, 1]
    s1 = sc.a[2, 0] - sc.a[0, 2]
    s2 = sc.a[0, 1] - sc.a[1, 0]
    sin_err = 0.5 * math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    tr = sc.a[0, 0] + sc.a[1, 1] + sc.a[2, 2]
    w = f[n, F_W : F_W + 3]
    rate = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    # tr > 1 rules out the 180-degree equilibria, where S also vanishes.
    return tr > 1.0 and sin_err < prm.s[S_SETTLE_ANGLE] and rate < prm.s[S_SETTLE_RATE]


# ------------------------------------------------------------------------------------------------
# One step of one row
# ------------------------------------------------------------------------------------------------
@row_kernel
def step_row(prm, f, p, i, rng, eph, n, target, torque, sc) -> bool:  # pragma: no cover - compiled
    """Advance row ``n`` by one step with the decoded action: ``target`` (planet/pulsar index, -1 for
    none) and ``torque`` (3,) as a fraction of the wheel limit (ignored in ``target`` mode).

    Returns True when ``sc.central`` and ``sc.planets`` hold the bodies at the row's new time (the
    camera branch evaluated them), so that :func:`observe_row` need not evaluate them again."""
    s, nn = prm.s, prm.n
    mode = nn[N_MODE]
    dt = s[S_STEP_S]
    k = i[n, I_K]
    t = _time(prm, f, i, n)
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    n_p = nn[N_NP]
    i[n, I_STATUS] = STATUS_OK

    # --- attitude: PD law toward the estimated direction of the target, and/or the agent's torque ---
    _eval(prm, eph, f, n, t, nn[N_CH_CENTRAL], sc.central)
    use_pd = target >= 0 and mode != MODE_TORQUE
    prev = i[n, I_TARGET]
    if use_pd:
        if target < n_p:
            _planets_at(prm, eph, f, n, t, sc.planets)
            for j in range(3):
                sc.dirv[j] = sc.planets[target, j] - (xe[j] + sc.central[j])
        else:
            for j in range(3):
                sc.dirv[j] = prm.psr[target - n_p, j]
        for j in range(3):
            sc.roll[j] = xe[j] + sc.central[j]  # roll reference: the estimated heliocentric position
        frame_kernel(sc.dirv, sc.roll, sc.frame)
    scale = s[S_TORQUE_SCALE]
    for j in range(3):
        sc.bias[j] = torque[j] * scale * prm.tau_max[j] if mode != MODE_TARGET else 0.0
    slewing = use_pd and target != prev and prev >= 0
    if target != prev:
        f[n, F_INTEGRATED] = 0.0  # an X-ray integration is lost when the detector leaves its pulsar
    if use_pd:
        i[n, I_TARGET] = target
    elif mode == MODE_TARGET:
        i[n, I_TARGET] = -1
    # Held target, settled attitude, no agent torque: coarse sub-steps (the loop is near equilibrium).
    coarse = use_pd and mode == MODE_TARGET and target == prev and i[n, I_SETTLED] == 1 and nn[N_N_COARSE] > 0
    n_sub = nn[N_N_COARSE] if coarse else nn[N_N_SUB]
    h_dt = s[S_COARSE_S] if coarse else s[S_SUBSTEP_S]
    q = f[n, F_Q : F_Q + 4]
    w = f[n, F_W : F_W + 3]
    hw = f[n, F_HW : F_HW + 3]
    for j in range(4):
        sc.y[j] = q[j]
    for j in range(3):
        sc.y[4 + j] = w[j]
    substeps_kernel(
        sc.y, hw, use_pd, sc.frame, sc.bias, sc.zero3, n_sub, h_dt, prm.jm, prm.jinv, prm.tau_max,
        prm.h_max, s[S_K_A], s[S_K_W], sc.work, sc.rq, sc.a, sc.u_cmd, f[n, F_U : F_U + 3],
    )  # fmt: skip
    if not store_state_kernel(sc.y, hw, q, w, hw):
        i[n, I_STATUS] = STATUS_ATTITUDE_NONFINITE
        i[n, I_TERMINATED] = 1
        return False
    i[n, I_SETTLED] = 1 if (use_pd and mode == MODE_TARGET and _pointing_settled(prm, f, n, sc)) else 0

    # --- orbit truth (state only: it needs no STM) and filter prediction (same dynamics, perturbers from
    # the row's table) ---
    _perturbers(prm, eph, f, n, t, dt, sc.pert)
    rk4_kernel(x, dt, s[S_MU], sc.pert[0], sc.pert[1], sc.pert[2], prm.mus, sc.x_new, sc.w6, sc.v6)
    for j in range(6):
        x[j] = sc.x_new[j]
    predict_kernel(
        xe, pm, dt, s[S_MU], sc.pert[0], sc.pert[1], sc.pert[2], prm.mus, prm.qproc, nn[N_EULER] != 0,
        sc.w6, sc.v6, sc.phi, sc.tmp,
    )  # fmt: skip
    k += 1
    i[n, I_K] = k
    t = t + dt

    # --- sensors ---
    _star_fix(prm, f, i, rng, n, sc)
    _rate_measurement(prm, f, i, rng, n, sc)
    measured = False
    rejected = False
    reason = REASON_NONE
    sensor = SENSOR_NONE
    f[n, F_NIS] = np.nan
    _eval(prm, eph, f, n, t, nn[N_CH_CENTRAL], sc.central)
    if target >= n_p:
        measured, rejected, reason = _time_pulsar(prm, f, p, i, rng, eph, n, target - n_p, t, sc)
        sensor = SENSOR_XRAY if measured else SENSOR_NONE
    else:
        _planets_at(prm, eph, f, n, t, sc.planets)
        for j in range(3):
            sc.r1[0, j] = x[j] + sc.central[j]
        for j in range(4):
            sc.q1[0, j] = q[j]
        idx = target if mode != MODE_TORQUE else _nearest_in_view(prm, sc)
        if mode == MODE_TORQUE:
            i[n, I_TARGET] = idx
        if idx >= 0:
            for j in range(3):
                sc.t1[0, j] = sc.planets[idx, j]
            st = visibility_row_kernel(
                sc.r1, sc.q1, sc.t1, 0, prm.radii[idx], sc.planets, prm.radii, True, prm.c2b, prm.cam,
                sc.m, sc.u6, sc.vals,
            )  # fmt: skip
            if st != 0:
                i[n, I_STATUS] = STATUS_CAMERA
                i[n, I_TERMINATED] = 1
                return False
            reason = int(sc.vals[V_REASON])
            # A disk wider than the sensor's field gives neither its centre nor its diameter.
            if reason == REASON_VISIBLE and sc.vals[V_ALPHA] > s[S_ALPHA_MAX]:
                reason = REASON_TOO_LARGE
            if reason == REASON_VISIBLE:
                measured, rejected = _measure_planet(prm, f, p, i, rng, n, idx, sc)
                sensor = SENSOR_CAMERA
    i[n, I_MEASURED] = measured
    i[n, I_REJECTED] = rejected
    i[n, I_REASON] = reason
    i[n, I_SLEWING] = slewing
    i[n, I_SENSOR] = sensor
    _score(prm, f, p, i, n, torque, sc)
    return target < n_p  # the camera branch evaluated the planets at t (the pulsar branch does not)


@row_kernel
def _nearest_in_view(prm, sc) -> int:  # pragma: no cover - compiled
    """Index of the planet nearest the boresight by the true geometry (what the image shows), or -1."""
    q = sc.q1[0]
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], sc.rq)
    b = prm.boresight
    bx = sc.rq[0, 0] * b[0] + sc.rq[0, 1] * b[1] + sc.rq[0, 2] * b[2]
    by = sc.rq[1, 0] * b[0] + sc.rq[1, 1] * b[1] + sc.rq[1, 2] * b[2]
    bz = sc.rq[2, 0] * b[0] + sc.rq[2, 1] * b[1] + sc.rq[2, 2] * b[2]
    best = -2.0
    idx = -1
    for j in range(sc.planets.shape[0]):
        d0 = sc.planets[j, 0] - sc.r1[0, 0]
        d1 = sc.planets[j, 1] - sc.r1[0, 1]
        d2 = sc.planets[j, 2] - sc.r1[0, 2]
        c = (d0 * bx + d1 * by + d2 * bz) / math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if c > best:
            best = c
            idx = j
    return idx if best > prm.s[S_COS_HALF_DIAG] else -1


@row_kernel
def _measure_planet(prm, f, p, i, rng, n, idx, sc):  # pragma: no cover - compiled
    """Camera measurement of planet ``idx`` (visible), rotated to inertial with the star-tracker attitude;
    EKF update. Returns (measured, rejected)."""
    s = prm.s
    _noise_begin(prm, i, rng, n, NOISE_CAMERA, sc)
    for j in range(3):
        sc.noise3[j] = _normal(prm, rng, n, sc)
    # visibility_row_kernel validated this geometry a moment ago: the status is OK.
    _, alpha, _ = measure_row_kernel(
        sc.r1, sc.q1, sc.t1, 0, prm.radii[idx], sc.noise3, prm.c2b, prm.cam, sc.m, sc.u6, sc.los,
        sc.los_true, sc.mm, sc.pix,
    )  # fmt: skip
    f[n, F_PIX] = sc.pix[0]
    f[n, F_PIX + 1] = sc.pix[1]
    xe = f[n, F_XE : F_XE + 6]
    kind = prm.n[N_KIND]
    for j in range(3):
        sc.dirv[j] = sc.planets[idx, j] - sc.central[j]  # the planet in the filter's frame
    m = measurement_vector_kernel(
        sc.los, alpha, f[n, F_QE : F_QE + 4], sc.dirv, xe, kind, sc.z, sc.basis, sc.rq
    )
    planet_model_kernel(
        xe[:3], sc.dirv, 2.0 * prm.radii[idx], kind, s[S_SIG_DIR], s[S_SIG_SIZE], sc.basis, sc.h, sc.jac,
        sc.rcov,
    )  # fmt: skip
    nis, ok = update_kernel(
        xe, p[n], sc.z, sc.h, sc.jac, sc.rcov, m, 1 if kind <= 1 else -1, s[S_GATE1 + m - 1], sc.uw
    )
    f[n, F_NIS] = nis
    return True, not ok


@row_kernel
def pulsar_visibility_row(
    r_helio, nvec, sun_avoid, central, central_radius, approach
) -> int:  # pragma: no cover
    """REASON code for timing a pulsar along unit ``nvec`` from heliocentric ``r_helio``: Sun within
    ``sun_avoid`` [rad] of the pulsar, or the central body (``central`` heliocentric, radius [km], on
    approach only) across the line of sight ahead of the spacecraft."""
    rn = math.sqrt(r_helio[0] ** 2 + r_helio[1] ** 2 + r_helio[2] ** 2)
    c = -(r_helio[0] * nvec[0] + r_helio[1] * nvec[1] + r_helio[2] * nvec[2]) / rn
    if math.acos(min(max(c, -1.0), 1.0)) < sun_avoid:
        return REASON_SUN_EXCLUSION
    if approach:
        d0, d1, d2 = central[0] - r_helio[0], central[1] - r_helio[1], central[2] - r_helio[2]
        along = d0 * nvec[0] + d1 * nvec[1] + d2 * nvec[2]
        miss2 = d0 * d0 + d1 * d1 + d2 * d2 - along * along
        if along > 0.0 and miss2 < central_radius * central_radius:
            return REASON_OCCULTED
    return REASON_VISIBLE


@row_kernel
def _time_pulsar(prm, f, p, i, rng, eph, n, j, t, sc):  # pragma: no cover - compiled
    """Accumulate X-ray photons from pulsar ``j`` while the detector points at it; after the integration
    time a phase (range along the pulsar's direction from the barycentre) updates the filter, with the
    cycle count resolved against the prediction only when it can be trusted. Returns
    (measured, rejected, reason)."""
    s, nn = prm.s, prm.n
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    nvec = prm.psr[j, 0:3]
    lam = prm.psr[j, 3]
    sigma = prm.psr[j, 4]
    for k in range(3):
        sc.r1[0, k] = x[k] + sc.central[k]
    q = f[n, F_Q : F_Q + 4]
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], sc.rq)
    b = prm.boresight
    cb = 0.0
    for k in range(3):
        cb += (sc.rq[k, 0] * b[0] + sc.rq[k, 1] * b[1] + sc.rq[k, 2] * b[2]) * nvec[k]
    off = math.acos(min(max(cb, -1.0), 1.0))
    reason = pulsar_visibility_row(
        sc.r1[0], nvec, s[S_SUN_AVOID], sc.central, s[S_CENTRAL_RADIUS], nn[N_APPROACH] != 0
    )
    if reason != REASON_VISIBLE:
        f[n, F_INTEGRATED] = 0.0
        return False, False, reason
    if off > s[S_DET_HALF_FOV]:
        f[n, F_INTEGRATED] = 0.0
        return False, False, REASON_OUT_OF_FOV
    f[n, F_INTEGRATED] += s[S_STEP_S]
    if f[n, F_INTEGRATED] + 1e-9 < s[S_PSR_INT_S]:
        return False, False, REASON_INTEGRATING
    f[n, F_INTEGRATED] = 0.0
    _eval(prm, eph, f, n, t, nn[N_CH_SSB], sc.ssb)
    total = 0.0
    h = 0.0
    for k in range(3):
        total += nvec[k] * (x[k] + sc.ssb[k])
        h += nvec[k] * (xe[k] + sc.ssb[k])
    _noise_begin(prm, i, rng, n, NOISE_PULSAR0 + j, sc)
    total = total / lam + sigma * _normal(prm, rng, n, sc)
    h /= lam
    frac = total - math.floor(total)  # what the detector delivers: the phase within a cycle
    for k in range(6):
        sc.jac[0, k] = nvec[k] / lam if k < 3 else 0.0
    var = sigma * sigma
    pm = p[n]
    for a in range(3):
        for c in range(3):
            var += sc.jac[0, a] * pm[a, c] * sc.jac[0, c]
    if not ambiguity_resolvable_kernel(math.sqrt(var), s[S_AMBIG_K]):
        i[n, I_SKIPPED] += 1  # the whole number of cycles cannot be trusted: skip, count
        return False, False, REASON_AMBIGUOUS
    sc.z[0] = resolve_cycle_kernel(frac, h)
    sc.h[0] = h
    sc.rcov[0, 0] = sigma * sigma
    nis, ok = update_kernel(xe, pm, sc.z, sc.h, sc.jac, sc.rcov, 1, -1, s[S_GATE1], sc.uw)
    f[n, F_NIS] = nis
    return True, not ok, REASON_VISIBLE


@row_kernel
def _score(prm, f, p, i, n, torque, sc) -> None:  # pragma: no cover - compiled
    """Errors, NEES, 1-sigma, reward, termination and truncation of row ``n`` after its step."""
    s = prm.s
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    e0, e1, e2 = xe[0] - x[0], xe[1] - x[1], xe[2] - x[2]
    v0, v1, v2 = xe[3] - x[3], xe[4] - x[4], xe[5] - x[5]
    pos_err = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    f[n, F_POS_ERR] = pos_err
    f[n, F_VEL_ERR] = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    f[n, F_NEES] = nees_kernel(xe, x, pm, sc.tmp, sc.x_new)
    sig = math.sqrt(max(pm[0, 0] + pm[1, 1] + pm[2, 2], 0.0))
    f[n, F_POS_SIGMA] = sig
    # A non-finite covariance shows in its trace; a non-finite estimate in pos_err.
    term = not (math.isfinite(pos_err) and math.isfinite(sig)) or pos_err > s[S_DIVERGENCE]
    i[n, I_TERMINATED] = term
    i[n, I_TRUNCATED] = i[n, I_K] >= prm.n[N_EPISODE_STEPS] and not term
    err = pos_err if prm.n[N_REWARD_TRUTH] else sig
    r = -err / s[S_REWARD_SCALE]
    if prm.n[N_MODE] != MODE_TARGET and s[S_TORQUE_PENALTY] > 0.0:
        r -= s[S_TORQUE_PENALTY] * s[S_TORQUE_SCALE] ** 2 * (torque[0] ** 2 + torque[1] ** 2 + torque[2] ** 2)
    f[n, F_REWARD] = r if math.isfinite(r) else -s[S_DIVERGENCE] / s[S_REWARD_SCALE]


# ------------------------------------------------------------------------------------------------
# Observation of one row
# ------------------------------------------------------------------------------------------------
@row_kernel
def observe_row(prm, f, p, i, eph, obs, n, sc, bodies_ready) -> None:  # pragma: no cover - compiled
    """Write row ``n``'s observation (layout: :class:`planetnav_env.core.layout.ObservationLayout`) from
    what the spacecraft knows: the filter, the star tracker, the reported rates, wheels, ephemerides.

    ``bodies_ready``: ``sc.central`` and ``sc.planets`` already hold the bodies at the row's current
    time (what :func:`step_row` returns); they are evaluated here otherwise."""
    s, nn = prm.s, prm.n
    o = obs[n]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    qe = f[n, F_QE : F_QE + 4]
    for j in range(3):
        o[j] = xe[j] / s[S_POS_SCALE]
        o[3 + j] = xe[3 + j] / s[S_VEL_SCALE]
        o[6 + j] = math.log10(math.sqrt(max(pm[j, j], 1e-30))) / 4.0
        o[9 + j] = math.log10(math.sqrt(max(pm[3 + j, 3 + j], 1e-30)) * 1e3) / 4.0
        o[16 + j] = f[n, F_WM + j] / (math.pi / 180.0)
        o[19 + j] = f[n, F_HW + j] / prm.h_max[j]
    for j in range(4):
        o[12 + j] = qe[j]
    if not bodies_ready:
        t = _time(prm, f, i, n)
        _eval(prm, eph, f, n, t, nn[N_CH_CENTRAL], sc.central)
        _planets_at(prm, eph, f, n, t, sc.planets)
    for j in range(3):
        sc.dirv[j] = xe[j] + sc.central[j]  # estimated heliocentric position
    _planet_features(prm, sc.dirv, qe, pm, sc)
    base = nn[N_OBS_PLANETS]
    for a in range(sc.feat.shape[0]):
        for c in range(7):
            o[base + 7 * a + c] = sc.feat[a, c]
    n_q = nn[N_NQ]
    if n_q:
        _pulsar_features(prm, f, p, i, n, qe, sc, o, nn[N_OBS_PULSARS])
    base = nn[N_OBS_TARGET]
    for j in range(nn[N_NT]):
        o[base + j] = 0.0
    if i[n, I_TARGET] >= 0:
        o[base + i[n, I_TARGET]] = 1.0
    o[nn[N_OBS_ELAPSED]] = i[n, I_K] / nn[N_EPISODE_STEPS]


@row_kernel
def _planet_features(prm, r_est, qe, pm, sc) -> None:  # pragma: no cover - compiled
    """Per-planet block from the estimate: direction in body axes (3), log10(distance / AU), apparent
    diameter / sigma_alpha, observable if pointed at (the camera's own rules for the attitude that
    centres the planet; the disk must fit the field), log10(position 1-sigma across the LOS [km]) / 4."""
    s = prm.s
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
            out[a, c] = r[0, c] * u0 + r[1, c] * u1 + r[2, c] * u2
        out[a, 3] = math.log10(dist / AU_KM)
        alpha = 2.0 * math.asin(min(prm.radii[a] / dist, 1.0))
        along = (
            u0 * (pm[0, 0] * u0 + pm[0, 1] * u1 + pm[0, 2] * u2)
            + u1 * (pm[1, 0] * u0 + pm[1, 1] * u1 + pm[1, 2] * u2)
            + u2 * (pm[2, 0] * u0 + pm[2, 1] * u1 + pm[2, 2] * u2)
        )
        out[a, 6] = math.log10(math.sqrt(max(tr - along, 1e-12))) / 4.0
        # Shortest arc from the boresight b to u: q = [1 + b.u, b x u] / norm (u opposite b: a
        # perpendicular axis).
        w = 1.0 + b0 * u0 + b1 * u1 + b2 * u2
        c0, c1, c2 = b1 * u2 - b2 * u1, b2 * u0 - b0 * u2, b0 * u1 - b1 * u0
        if w < 1e-12:
            w, c0, c1, c2 = 0.0, -b1, b0, 0.0 if abs(b2) < 0.9 else b0
        nq = math.sqrt(w * w + c0 * c0 + c1 * c1 + c2 * c2)
        sc.q_tile[a, 0], sc.q_tile[a, 1], sc.q_tile[a, 2], sc.q_tile[a, 3] = w / nq, c0 / nq, c1 / nq, c2 / nq
        for c in range(3):
            sc.r_tile[a, c] = r_est[c]
        st = visibility_row_kernel(
            sc.r_tile, sc.q_tile, sc.planets, a, prm.radii[a], sc.planets, prm.radii, True, prm.c2b,
            prm.cam, sc.m, sc.u6, sc.vals,
        )  # fmt: skip
        visible = st == 0 and int(sc.vals[V_REASON]) == REASON_VISIBLE
        out[a, 5] = 1.0 if (visible and alpha < s[S_ALPHA_MAX]) else 0.0
        out[a, 4] = alpha / s[S_SIGMA_ALPHA]


@row_kernel
def _pulsar_features(prm, f, p, i, n, qe, sc, o, base) -> None:  # pragma: no cover - compiled
    """Per-pulsar block: direction in body axes (star-tracker attitude), integration progress (current
    target only), log10 predicted phase 1-sigma [cycles], observable from the estimate (Sun, occultation),
    log10(position 1-sigma along the pulsar [km]) / 4."""
    s, nn = prm.s, prm.n
    n_p = nn[N_NP]
    pm = p[n]
    dcm_body_to_inertial_kernel(qe[0], qe[1], qe[2], qe[3], sc.rq)
    for j in range(nn[N_NQ]):
        nv = prm.psr[j, 0:3]
        off = base + 7 * j
        for c in range(3):
            o[off + c] = sc.rq[0, c] * nv[0] + sc.rq[1, c] * nv[1] + sc.rq[2, c] * nv[2]
        o[off + 3] = f[n, F_INTEGRATED] / s[S_PSR_INT_S] if i[n, I_TARGET] == n_p + j else 0.0
        var = 0.0
        for a in range(3):
            for c in range(3):
                var += nv[a] * pm[a, c] * nv[c]
        lam, sig = prm.psr[j, 3], prm.psr[j, 4]
        o[off + 4] = math.log10(math.sqrt(var / (lam * lam) + sig * sig))
        vis = pulsar_visibility_row(
            sc.dirv, nv, s[S_SUN_AVOID], sc.central, s[S_CENTRAL_RADIUS], nn[N_APPROACH] != 0
        )
        o[off + 5] = 1.0 if vis == REASON_VISIBLE else 0.0
        o[off + 6] = math.log10(math.sqrt(max(var, 1e-12))) / 4.0


# ------------------------------------------------------------------------------------------------
# Reset of one row (after the Python side drew the episode and the initial state)
# ------------------------------------------------------------------------------------------------
@row_kernel
def reset_row(prm, f, p, i, rng, eph, obs, n, sc) -> None:  # pragma: no cover - compiled
    """First star fix, rate measurement, errors and observation of a freshly drawn row."""
    i[n, I_K] = 0
    i[n, I_TARGET] = -1
    i[n, I_SKIPPED] = 0
    i[n, I_SETTLED] = 0
    i[n, I_MEASURED] = 0
    i[n, I_REJECTED] = 0
    i[n, I_REASON] = REASON_NONE
    i[n, I_SLEWING] = 0
    i[n, I_SENSOR] = SENSOR_NONE
    i[n, I_STATUS] = STATUS_OK
    f[n, F_INTEGRATED] = 0.0
    f[n, F_NIS] = np.nan
    f[n, F_PIX] = np.nan
    f[n, F_PIX + 1] = np.nan
    for j in range(4):
        f[n, F_QE + j] = f[n, F_Q + j]  # a stale fix to keep if the first one fails
    _star_fix(prm, f, i, rng, n, sc)
    _rate_measurement(prm, f, i, rng, n, sc)
    _score(prm, f, p, i, n, sc.zero3, sc)
    i[n, I_TERMINATED] = 0
    i[n, I_TRUNCATED] = 0
    f[n, F_REWARD] = 0.0
    observe_row(prm, f, p, i, eph, obs, n, sc, False)


# ------------------------------------------------------------------------------------------------
# Batch loops
# ------------------------------------------------------------------------------------------------
@row_kernel
def _step_rows(prm, f, p, i, rng, eph, obs, targets, torques, active, lo, hi, sc) -> None:  # pragma: no cover
    # The row loop itself is a row kernel: with reference counting, taking the view torques[n] would
    # touch the count of the torques array, shared by every thread, twice per row.
    for n in range(lo, hi):
        if active[n]:
            bodies_ready = step_row(prm, f, p, i, rng, eph, n, targets[n], torques[n], sc)
            if i[n, I_STATUS] == STATUS_OK:
                observe_row(prm, f, p, i, eph, obs, n, sc, bodies_ready)


@njit(cache=True, nogil=True)
def step_range(prm, f, p, i, rng, eph, obs, targets, torques, active, lo, hi) -> None:  # pragma: no cover
    """Step the ``active`` rows ``lo .. hi - 1`` (releases the GIL: chunks run on Python threads)."""
    _step_rows(prm, f, p, i, rng, eph, obs, targets, torques, active, lo, hi, make_scratch(prm))


@njit(cache=True, nogil=True)
def step_batch(prm, f, p, i, rng, eph, obs, targets, torques, active) -> None:  # pragma: no cover
    """Step every ``active`` row on the calling thread."""
    step_range(prm, f, p, i, rng, eph, obs, targets, torques, active, 0, f.shape[0])


@njit(cache=True, nogil=True)
def reset_rows(prm, f, p, i, rng, eph, obs, rows) -> None:  # pragma: no cover - compiled
    sc = make_scratch(prm)
    for r in range(rows.shape[0]):
        reset_row(prm, f, p, i, rng, eph, obs, rows[r], sc)


# ------------------------------------------------------------------------------------------------
# What-if updates for planning agents (the core's own model and update on copies)
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def coasted_position_trace(p, lookahead_s) -> float:  # pragma: no cover - compiled
    """``trace`` [km^2] of the position covariance ``lookahead_s`` [s] ahead in free flight (r + T v):
    ``trace(P_rr) + 2 T trace(P_rv) + T^2 trace(P_vv)``; exactly ``trace(P_rr)`` for T = 0. A scoring
    horizon for planning agents, not the filter's propagation: the gravity gradient's share, ~mu T^2 /
    r^3, is below 1e-4 at 1 AU for T up to 12 h."""
    tr = p[0, 0] + p[1, 1] + p[2, 2]
    if lookahead_s != 0.0:
        t = lookahead_s
        tr += 2.0 * t * (p[0, 3] + p[1, 4] + p[2, 5]) + t * t * (p[3, 3] + p[4, 4] + p[5, 5])
    return tr


@njit(cache=True)
def predicted_planet_trace(prm, x, p, planet, idx, n_meas, lookahead_s=0.0) -> float:  # pragma: no cover
    """``trace(P_rr)`` [km^2] after ``n_meas`` images of planet ``idx`` (at ``planet``, the filter's frame)
    from estimate ``x`` (6,) and covariance ``p`` (6, 6), neither modified: the core's measurement model
    and Joseph update, with R / n_meas (n identical measurements of a nearly static state equal one with
    R / n) and zero innovation (the covariance does not depend on it). Ungated. With ``lookahead_s`` > 0,
    the trace of the updated position covariance coasted that far ahead (:func:`coasted_position_trace`)."""
    s = prm.s
    kind = prm.n[N_KIND]
    xc = x.copy()
    pc = p.copy()
    basis = np.zeros((2, 3))
    if kind >= 2:
        los_basis_kernel(planet, xc, basis)
    h = np.empty(3)
    jac = np.empty((3, 6))
    rcov = np.empty((3, 3))
    m = planet_model_kernel(
        xc[:3], planet, 2.0 * prm.radii[idx], kind, s[S_SIG_DIR], s[S_SIG_SIZE], basis, h, jac, rcov
    )
    for a in range(m):
        for c in range(m):
            rcov[a, c] /= n_meas
    update_kernel(xc, pc, h.copy(), h, jac, rcov, m, 1 if kind <= 1 else -1, np.inf, np.empty((5, 6, 6)))
    return coasted_position_trace(pc, lookahead_s)


@njit(cache=True)
def predicted_pulsar_trace(prm, p, j, lookahead_s=0.0) -> float:  # pragma: no cover - compiled
    """``trace(P_rr)`` [km^2] after one phase of pulsar ``j`` (``H = n / lambda`` on the position,
    ``R = sigma_phase^2``): the core's scalar update on a copy of ``p`` (coasted ``lookahead_s`` ahead, as
    in :func:`predicted_planet_trace`)."""
    pc = p.copy()
    x = np.zeros(6)
    jac = np.zeros((3, 6))
    for k in range(3):
        jac[0, k] = prm.psr[j, k] / prm.psr[j, 3]
    rcov = np.zeros((3, 3))
    rcov[0, 0] = prm.psr[j, 4] ** 2
    h = np.zeros(3)
    update_kernel(x, pc, h.copy(), h, jac, rcov, 1, -1, np.inf, np.empty((5, 6, 6)))
    return coasted_position_trace(pc, lookahead_s)
