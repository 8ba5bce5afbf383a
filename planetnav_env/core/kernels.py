"""The compiled step of the batch core: one row kernel per stage, one loop over the rows.

Every environment row ``n`` is advanced one decision at a time by :func:`decide_row` (the decision
rule: ``decision_steps`` physics steps of :func:`step_row`, each observed by :func:`observe_row`); the
batch functions loop over a range of rows; :class:`~planetnav_env.batch.BatchCore` runs chunks of
rows on Python threads (the kernels release the GIL). A row reads and writes
only its own slices of the state arrays (the record ``st``, :class:`~planetnav_env.core.records.RowState`:
``f``, ``p``, ``i``, ``rng``, ``eph``, ``obs``; columns in :mod:`planetnav_env.core.layout`), and its
parameters (``prm``, :class:`~planetnav_env.core.records.CoreParams`) are shared read-only: rows are
independent, so the result does not depend on the batch size, the chunking or the thread, and the
single environment (a batch of one) equals row ``n`` of the vector environment bit for bit.

No Python objects and no allocation inside the row kernels (scratch space is allocated once per chunk
and passed down as :class:`Scratch`): the same row kernels could run one row per GPU thread
(docs/architecture.md says how). They are compiled with :data:`planetnav_env.numerics.jit.row_kernel`, without
numba's reference counting (the module says why); only ``step_range`` and ``reset_rows``, which
allocate the scratch, keep it.

The physics is not written here: each stage calls the module that owns the formula (attitude
sub-steps: :mod:`planetnav_env.attitude.pointing`; orbit RK4, STM and the EKF:
:mod:`planetnav_env.estimation.ekf_kernels`; camera: :mod:`planetnav_env.sensors.camera`; star tracker:
:mod:`planetnav_env.sensors.star_tracker`; pulsar timing: :mod:`planetnav_env.sensors.pulsar`;
ephemerides: :mod:`planetnav_env.core.ephemeris_table`; random numbers: :mod:`planetnav_env.core.rng`).
This module wires them together in the order of one step and builds the observation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from planetnav_env.attitude.plant import Plant, store_state_kernel
from planetnav_env.attitude.pointing import (
    LoopScratch,
    PdLoop,
    error_matrix_kernel,
    frame_kernel,
    substeps_kernel,
)
from planetnav_env.core.attitude_loop import (
    apply_dumps,
    begin_step,
    filter_step,
    flight_substeps,
    pointing_error_kernel,
    reset_filter,
)
from planetnav_env.core.decoding import decode_row
from planetnav_env.core.layout import (
    F_DV_LOST,
    F_DV_STEP,
    F_HOLD_REWARD,
    F_HW,
    F_IMG_P,
    F_INTEGRATED,
    F_NIS,
    F_PIX,
    F_POINT_ERR,
    F_Q,
    F_Q_PSD,
    F_QE,
    F_REWARD,
    F_SRP_K,
    F_THRUSTING,
    F_U,
    F_W,
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
    I_STATUS,
    I_TARGET,
    I_TERMINATED,
    I_TRUNCATED,
    MODE_HYBRID,
    MODE_TARGET,
    MODE_TORQUE,
    REASON_IMAGE_FAILED,
    REASON_NONE,
    REASON_TOO_LARGE,
    REASON_VISIBLE,
    SENSOR_CAMERA,
    SENSOR_NONE,
    SENSOR_XRAY,
    STATUS_ATTITUDE_NONFINITE,
    STATUS_CAMERA,
    STATUS_OK,
)  # fmt: skip
from planetnav_env.core.observation import camera_visibility, clear_counters, count_row, observe_row
from planetnav_env.core.operations import (
    add_thrust_q,
    apply_thrust,
    apply_thrust_error,
    planned_direction,
    reset_operations,
    step_thrust_error,
    thrust_axis_on,
    thrust_noise,
)
from planetnav_env.core.records import Actions, RowState, make_scratch, scratch_row
from planetnav_env.core.row_ephemeris import (
    eval_channel,
    perturbers_at,
    planets_at,
    row_time,
    truth_bodies_at,
    truth_perturbers_at,
)
from planetnav_env.core.row_noise import NOISE_IMAGE, next_uniform, noise_begin
from planetnav_env.core.scoring import score_row
from planetnav_env.core.sensing import (
    drift_reset,
    drift_step,
    measure_planet,
    nearest_in_view,
    rate_measurement,
    star_fix_stage,
    time_pulsar,
)
from planetnav_env.estimation.ekf_kernels import (
    OrbitModel,
    PredictScratch,
    predict_kernel,
    rk4_kernel,
)
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS, row_kernel
from planetnav_env.sensors.camera_kernels import V_ALPHA, V_REASON

#: No torque [N m] (and no torque action): the environment's external torque on the spacecraft, and the
#: reset's torque action. A module constant, not scratch: numba freezes a global array into the compiled
#: code (constant memory on a device), so no thread ever reads it from memory it has not written.
NO_TORQUE = np.zeros(3)


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
    return tr > 1.0 and sin_err < prm.scalars[0].settle_angle and rate < prm.scalars[0].settle_rate


@row_kernel
def propagate_truth(prm, eph, f, n, t, dt, orbit, sc) -> None:  # pragma: no cover - compiled
    """The true orbit state of row ``n`` (``f[n, F_X:F_X + 6]`` [km, km/s], central-body frame) advanced
    in place by one RK4 step of ``dt`` [s] from ``t`` [TDB s]. The matched world's truth flies the
    filter's field ``orbit``; with its own force model (``truth_own``) it flies that: its perturbers
    (every planet as a third body, from the row's table, fitted from the truth's ephemeris), and with SRP
    the row's cannonball coefficient ``F_SRP_K`` (``dynamics.srp.srp_gm``) pushing away from the Sun: the
    central body on the heliocentric scenarios, the perturber ``srp_sun`` on a planetary approach (where
    the Sun's pull on the central body, the indirect term, feels no light pressure)."""
    ps = prm.scalars[0]
    x = f[n, F_X : F_X + 6]
    if ps.truth_own != 0:
        truth_perturbers_at(prm, eph, f, n, t, dt, sc.tpert)
        k_srp = f[n, F_SRP_K] if ps.srp_on != 0 else 0.0
        truth = OrbitModel(
            mu=ps.mu, p0=sc.tpert[0], p1=sc.tpert[1], p2=sc.tpert[2], mus=prm.tmus, srp_k=k_srp,
            srp_sun=ps.srp_sun,
        )  # fmt: skip
        rk4_kernel(x, dt, truth, sc.x_new, sc.w6, sc.v6)
    else:
        rk4_kernel(x, dt, orbit, sc.x_new, sc.w6, sc.v6)
    for j in range(6):
        x[j] = sc.x_new[j]


@row_kernel
def step_row(prm, st, n, target, torque, sc) -> bool:  # pragma: no cover - compiled
    """Advance row ``n`` of the state ``st`` by one step with the decoded action: ``target`` (planet/pulsar
    index, -1 for none) and ``torque`` (3,) as a fraction of the wheel limit (ignored in ``target`` mode).

    With an operations scenario (``ops``), target -1 is "stay at the mission attitude": the PD law points
    the thrust axis (the boresight) along the planned direction (the estimated velocity), and the thrust,
    its execution error and the filter's matching prediction follow :mod:`planetnav_env.core.operations`.

    Returns True when ``sc.central`` and ``sc.planets`` hold the bodies at the row's new time (the
    camera branch evaluated them), so that :func:`observe_row` need not evaluate them again."""
    f, p, i, rng, eph = st.f, st.p, st.i, st.rng, st.eph
    ps = prm.scalars[0]
    mode = ps.mode
    dt = ps.step_s
    k = i[n, I_K]
    t = row_time(prm, f, i, n)
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    n_p = ps.n_planets
    i[n, I_STATUS] = STATUS_OK

    # --- attitude: PD law toward the estimated direction of the target, and/or the agent's torque ---
    eval_channel(prm, eph, f, n, t, ps.ch_central, sc.central)
    ops = ps.ops != 0
    if ops:
        planned_direction(xe, sc.z)  # the planned thrust direction u (inertial), fixed over the step
    use_pd = (target >= 0 or ops) and mode != MODE_TORQUE
    prev = i[n, I_TARGET]
    if use_pd:
        if target < 0:
            for j in range(3):
                sc.dirv[j] = sc.z[j]
        elif target < n_p:
            planets_at(prm, eph, f, n, t, sc.planets)
            for j in range(3):
                sc.dirv[j] = sc.planets[target, j] - (xe[j] + sc.central[j])
        else:
            for j in range(3):
                sc.dirv[j] = prm.psr[target - n_p, j]
        for j in range(3):
            sc.roll[j] = xe[j] + sc.central[j]  # roll reference: the estimated heliocentric position
        frame_kernel(sc.dirv, sc.roll, sc.frame)
    scale = ps.torque_scale
    for j in range(3):
        sc.bias[j] = torque[j] * scale * prm.tau_max[j] if mode != MODE_TARGET else 0.0
    slewing = use_pd and target != prev and (prev >= 0 or ops)
    if target != prev:
        f[n, F_INTEGRATED] = 0.0  # an X-ray integration is lost when the detector leaves its pulsar
    if use_pd:
        i[n, I_TARGET] = target
    elif mode == MODE_TARGET:
        i[n, I_TARGET] = -1
    # Held target, settled attitude, no agent torque: coarse sub-steps (the loop is near equilibrium).
    coarse = use_pd and mode == MODE_TARGET and target == prev and i[n, I_SETTLED] == 1 and ps.n_coarse > 0
    n_sub = ps.n_coarse if coarse else ps.n_sub
    h_dt = ps.coarse_s if coarse else ps.substep_s
    q = f[n, F_Q : F_Q + 4]
    w = f[n, F_W : F_W + 3]
    hw = f[n, F_HW : F_HW + 3]
    for j in range(4):
        sc.y[j] = q[j]
    for j in range(3):
        sc.y[4 + j] = w[j]
    # The closed loop's records, built by keyword once per row step (views of prm and sc: no copies).
    loop = PdLoop(
        plant=Plant(jm=prm.jm, jinv=prm.jinv, tau_max=prm.tau_max, h_max=prm.h_max), k_a=ps.k_a, k_w=ps.k_w
    )
    ws = LoopScratch(work=sc.work, rq=sc.rq, a=sc.a, u_cmd=sc.u_cmd)
    u_out = f[n, F_U : F_U + 3]  # the last applied wheel torque [N m]
    t_on = 0.0  # thrusting time [s] and its position moment [s^2] (operations)
    moment = 0.0
    if ps.att_on != 0:
        # The flight world's attitude loop: disturbance torques, flight wheels, dumps, the estimator.
        begin_step(prm, f, n, sc)
        t_on, moment, on = flight_substeps(prm, st, n, use_pd, sc.frame, n_sub, h_dt, dt, loop, ws, u_out, sc)
        if ops:
            f[n, F_THRUSTING] = 1.0 if on else 0.0
            dv_step = ps.ops_acc * (dt - t_on) * 1000.0  # [m/s]
            f[n, F_DV_STEP] = dv_step
            f[n, F_DV_LOST] += dv_step
    elif ops:
        # One sub-step at a time (the same loop as one call with n_sub), checking the thrust axis.
        on = False
        for j in range(n_sub):
            substeps_kernel(sc.y, hw, use_pd, sc.frame, sc.bias, NO_TORQUE, 1, h_dt, loop, ws, u_out)
            on = thrust_axis_on(sc.y, prm.boresight, sc.z, ps.ops_cos_tol)
            if on:
                t_on += h_dt
                moment += h_dt * (dt - (j + 0.5) * h_dt)
        f[n, F_THRUSTING] = 1.0 if on else 0.0
        dv_step = ps.ops_acc * (dt - t_on) * 1000.0  # [m/s]
        f[n, F_DV_STEP] = dv_step
        f[n, F_DV_LOST] += dv_step
    else:
        substeps_kernel(sc.y, hw, use_pd, sc.frame, sc.bias, NO_TORQUE, n_sub, h_dt, loop, ws, u_out)
    if not store_state_kernel(sc.y, hw, q, w, hw):
        i[n, I_STATUS] = STATUS_ATTITUDE_NONFINITE
        i[n, I_TERMINATED] = 1
        return False
    i[n, I_SETTLED] = 1 if (use_pd and mode == MODE_TARGET and _pointing_settled(prm, f, n, sc)) else 0

    # --- orbit truth (state only: it needs no STM) and filter prediction (perturbers from the row's
    # table) ---
    perturbers_at(prm, eph, f, n, t, dt, sc.pert)
    orbit = OrbitModel(
        mu=ps.mu, p0=sc.pert[0], p1=sc.pert[1], p2=sc.pert[2], mus=prm.mus, srp_k=0.0, srp_sun=-1
    )
    propagate_truth(prm, eph, f, n, t, dt, orbit, sc)
    pws = PredictScratch(w6=sc.w6, v6=sc.v6, phi=sc.phi, tmp=sc.tmp)
    if ps.q_tuned != 0:
        # The row's process noise, tuned at reset to what the filter's force model omits.
        for a in range(6):
            for b in range(6):
                sc.qrow[a, b] = prm.qunit[a, b] * f[n, F_Q_PSD]
        predict_kernel(xe, pm, dt, orbit, sc.qrow, ps.euler != 0, pws)
    else:
        predict_kernel(xe, pm, dt, orbit, prm.qproc, ps.euler != 0, pws)
    if ops and t_on > 0.0:
        # Truth: nominal thrust + execution error, drawn from frac * Q_thrust in the matched world and the
        # Gauss-Markov process in the flight world; filter: nominal thrust and the white-noise Q (the filter
        # knows when the engine was on: it commands it).
        frac = t_on / dt
        apply_thrust(x, ps.ops_acc, sc.z, t_on, moment)
        if ps.thr_gm != 0:
            apply_thrust_error(f, n, x, ps.ops_acc, sc.z, t_on, moment, sc)
        else:
            thrust_noise(prm, i, rng, n, x, dt, frac, ps.ops_q_par, ps.ops_q_perp, sc.z, sc)
        apply_thrust(xe, ps.ops_acc, sc.z, t_on, moment)
        add_thrust_q(pm, dt, frac, ps.ops_q_par, ps.ops_q_perp, sc.z)
    if ops and ps.thr_gm != 0:
        step_thrust_error(prm, f, i, rng, n, dt, sc)  # the process runs whether the engine thrusts or not
    if ps.att_on != 0:
        apply_dumps(f, n, x, xe, pm, sc)
    k += 1
    i[n, I_K] = k
    t = t + dt
    if ps.drift_on != 0:
        drift_step(prm, st, n, sc)  # the planet camera's boresight drift, one step on

    # --- sensors ---
    star_fix_stage(prm, st, n, sc)
    rate_measurement(prm, st, n, sc)
    if ps.att_on != 0:
        filter_step(prm, st, n, dt, sc)
    # The camera's true pointing error against the PD law's direction (a diagnostic column, both worlds).
    f[n, F_POINT_ERR] = pointing_error_kernel(q, prm.boresight, sc.frame[0], sc.rq) if use_pd else np.nan
    measured = False
    rejected = False
    reason = REASON_NONE
    sensor = SENSOR_NONE
    f[n, F_NIS] = np.nan
    eval_channel(prm, eph, f, n, t, ps.ch_central, sc.central)
    if target >= n_p:
        truth_bodies_at(prm, eph, f, n, t, sc, False)
        measured, rejected, reason = time_pulsar(prm, st, n, target - n_p, t, sc)
        sensor = SENSOR_XRAY if measured else SENSOR_NONE
    else:
        planets_at(prm, eph, f, n, t, sc.planets)
        truth_bodies_at(prm, eph, f, n, t, sc, True)  # what the camera sees: the truth's ephemeris
        for j in range(3):
            sc.r1[0, j] = x[j] + sc.tcentral[j]
        for j in range(4):
            sc.q1[0, j] = q[j]
        # Torque and hybrid modes (either option): the camera measures the visible planet nearest its
        # boresight, whatever drives the wheels (the two tasks share one camera rule); otherwise the target.
        direct = mode == MODE_TORQUE or mode == MODE_HYBRID
        idx = nearest_in_view(prm, sc) if direct else target
        if direct:
            i[n, I_TARGET] = idx
        if idx >= 0:
            for j in range(3):
                sc.t1[0, j] = sc.tplanets[idx, j]
            vis_status = camera_visibility(prm, sc.r1, sc.q1, sc.t1, 0, prm.radii[idx], sc.tplanets, sc)
            if vis_status != 0:
                i[n, I_STATUS] = STATUS_CAMERA
                i[n, I_TERMINATED] = 1
                return False
            reason = int(sc.vals[V_REASON])
            # A disk wider than the sensor's field gives neither its centre nor its diameter.
            if reason == REASON_VISIBLE and sc.vals[V_ALPHA] > ps.alpha_max:
                reason = REASON_TOO_LARGE
            if reason == REASON_VISIBLE and ps.img_min < 1.0:
                # Image processing fails with the planet's episode probability (the filter does not model
                # it: it simply gets no measurement). Drawn only with the option on, so v0/v1 draw nothing.
                noise_begin(prm, i, rng, n, NOISE_IMAGE, sc)
                if next_uniform(prm, rng, n, sc) >= f[n, F_IMG_P + idx]:
                    reason = REASON_IMAGE_FAILED
            if reason == REASON_VISIBLE:
                measured, rejected = measure_planet(prm, st, n, idx, sc)
                sensor = SENSOR_CAMERA
    i[n, I_MEASURED] = measured
    i[n, I_REJECTED] = rejected
    i[n, I_REASON] = reason
    i[n, I_SLEWING] = slewing
    i[n, I_SENSOR] = sensor
    score_row(prm, st, n, torque, sc)
    return target < n_p  # the camera branch evaluated the planets at t (the pulsar branch does not)


@row_kernel
def reset_row(prm, st, n, sc) -> None:  # pragma: no cover - compiled
    """First star fix, rate measurement, errors and observation of the freshly drawn row ``n``."""
    f, i = st.f, st.i
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
    if prm.scalars[0].ops:
        reset_operations(f, n)
    star_fix_stage(prm, st, n, sc)
    rate_measurement(prm, st, n, sc)
    f[n, F_POINT_ERR] = np.nan
    if prm.scalars[0].att_on:
        reset_filter(prm, st, n, sc)
    score_row(prm, st, n, NO_TORQUE, sc)
    if prm.scalars[0].drift_on != 0:
        drift_reset(prm, st, n, sc)  # the boresight drift's stationary start
    i[n, I_TERMINATED] = 0
    i[n, I_TRUNCATED] = 0
    f[n, F_REWARD] = 0.0
    clear_counters(prm, f, n)
    count_row(prm, f, i, n)  # a reset's first observation counts, as a step without a measurement
    observe_row(prm, f, st.p, i, st.eph, st.obs, n, sc, False)


@njit(inline="always", **ROW_KERNEL_OPTIONS)
def step_active_row(prm, st, act, n, sc) -> None:  # pragma: no cover - compiled
    """One physics step of row ``n`` if ``act`` marks it active, counted in its history counters and
    observed: each step of :func:`decide_row`, into which it is inlined."""
    if act.active[n]:
        bodies_ready = step_row(prm, st, n, act.targets[n], act.torques[n], sc)
        if st.i[n, I_STATUS] == STATUS_OK:
            count_row(prm, st.f, st.i, n)
            observe_row(prm, st.f, st.p, st.i, st.eph, st.obs, n, sc, bodies_ready)


@njit(inline="always", **ROW_KERNEL_OPTIONS)
def decide_row(prm, st, act, n, sc, first, steps) -> None:  # pragma: no cover - compiled
    """The decision rule of row ``n`` (if ``act`` marks it active): ``steps`` physics steps of its
    decision (:func:`step_active_row` each) with the same action (decoded from ``act.raw`` when the call
    starts the decision, :func:`~planetnav_env.core.decoding.decode_row`), stopping once the episode ends
    (terminated or truncated) inside the hold; with ``decision_steps`` > 1 the reward column holds the
    sum of the decision's rewards so far (from 0.0, in step order). ``first``: the call starts the
    decision (its first physics step runs whatever the flags, and the sum starts). A whole decision is
    ``first=True, steps=decision_steps``; the CPU's per-physics-step callback runs it one step a call.
    Inlined into the CPU's row loop and the device's thread."""
    if not act.active[n]:
        return
    if first:
        decode_row(prm, st, act, n)  # the raw action, read with the row's target at the decision's start
    f, i = st.f, st.i
    hold = prm.scalars[0].decision_steps > 1
    for s in range(steps):
        start = first and s == 0
        if not start and (i[n, I_TERMINATED] != 0 or i[n, I_TRUNCATED] != 0):
            return
        step_active_row(prm, st, act, n, sc)
        if hold:
            total = (0.0 if start else f[n, F_HOLD_REWARD]) + f[n, F_REWARD]
            f[n, F_HOLD_REWARD] = total
            f[n, F_REWARD] = total


@row_kernel
def _step_rows(prm, st, act, lo, hi, first, steps, sc) -> None:  # pragma: no cover - compiled
    # The row loop itself is a row kernel: with reference counting, taking the view torques[n] would
    # touch the count of the torques array, shared by every thread, twice per row.
    for n in range(lo, hi):
        decide_row(prm, st, act, n, sc, first, steps)


@njit(cache=True, nogil=True)
def step_range(prm, st, act, lo, hi) -> None:  # pragma: no cover - compiled
    """One decision (:func:`decide_row`, ``decision_steps`` physics steps) of the rows ``lo .. hi - 1``
    of the state ``st`` (:class:`~planetnav_env.core.records.RowState`) that ``act``
    (:class:`~planetnav_env.core.records.Actions`) marks active (releases the GIL: chunks run on Python
    threads)."""
    _step_rows(prm, st, act, lo, hi, True, prm.scalars[0].decision_steps, make_scratch(prm))


@njit(cache=True, nogil=True)
def step_batch(prm, st, act) -> None:  # pragma: no cover - compiled
    """One decision of every active row on the calling thread."""
    step_range(prm, st, act, 0, st.f.shape[0])


@njit(cache=True, nogil=True)
def step_range_arrays(
    prm, f, p, i, rng, eph, obs, raw, targets, torques, active, lo, hi, first, steps
) -> None:  # pragma: no cover
    """:func:`decide_row` of the rows ``lo .. hi - 1`` for callers in Python (``first``, ``steps``: a
    whole decision is ``True, decision_steps``): the state and the actions as plain arrays (``raw`` (N, A)
    float64 the validated actions; ``targets`` (N,), ``torques`` (N, 3) the decoding's buffers, written
        when ``first`` and read by the later calls of the same decision), the records built here. Numba
    types a named-tuple argument from Python far more slowly than arrays (several µs per call, most of a
    one-row step), so the Python-facing entry takes the arrays."""
    st = RowState(f=f, p=p, i=i, rng=rng, eph=eph, obs=obs)
    act = Actions(raw=raw, targets=targets, torques=torques, active=active)
    _step_rows(prm, st, act, lo, hi, first, steps, make_scratch(prm))


@njit(cache=True, nogil=True)
def reset_rows(prm, st, rows) -> None:  # pragma: no cover - compiled
    """:func:`reset_row` for each of ``rows`` (int64 indices into the state ``st``)."""
    sc = make_scratch(prm)
    for r in range(rows.shape[0]):
        reset_row(prm, st, rows[r], sc)


# --- one row per thread (the device's layout): scratch as per-row slices of (N, ...) arrays ---------------
# What a CUDA thread runs (planetnav_env.core.cuda_entry wraps each in a kernel of one thread per row); on
# the CPU the same functions run in a loop over the rows, which tests/env/test_cuda_ptx.py compares with the
# chunked step above, bit for bit.


@row_kernel
def step_thread(prm, st, act, rows, n) -> None:  # pragma: no cover - compiled
    """One decision (:func:`decide_row`, ``decision_steps`` physics steps) of row ``n`` with its own
    scratch, ``rows``' slices ``n`` (:func:`~planetnav_env.core.records.scratch_rows`, one row of scratch
    per state row)."""
    decide_row(prm, st, act, n, scratch_row(rows, n), True, prm.scalars[0].decision_steps)


@row_kernel
def reset_thread(prm, st, reset, rows, j) -> None:  # pragma: no cover - compiled
    """:func:`reset_row` of row ``reset[j]`` with that row's scratch (``rows``' slices ``reset[j]``)."""
    n = reset[j]
    reset_row(prm, st, n, scratch_row(rows, n))
