"""Compiled (numba) EKF cycle for planet measurements: the fast path of the environment.

The numpy core in :mod:`planetnav_env.estimation.ekf` is the reference: it is generic over
measurement functions and easy to read. An RL environment needs one filter cycle in a few
microseconds, which numpy's per-call overhead (~1 us per array operation, ~60 operations per
cycle) cannot give. These kernels run the *same equations* (RK4 state + RK4 variational STM,
``P = Phi P Phi^T + Q``, Joseph update, angle wrapping, chi-square gate) as scalar loops;
``tests/env/test_fast_ekf.py`` holds them to the numpy core at 1e-10 relative.

Measurement kinds (:class:`~planetnav_env.codes.MeasurementKind`; :data:`KIND_CODES` maps the
configuration strings to its ints): 0 direction, 1 direction+size, 2 los, 3 los+size, with the
formulas of :mod:`planetnav_env.estimation.measurements`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from planetnav_env.codes import MeasurementKind
from planetnav_env.errors import InvalidParameterError, NonFiniteError, require_finite, require_positive
from planetnav_env.estimation.ekf import EKFBase
from planetnav_env.estimation.measurements import MeasurementModel
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS, row_kernel
from planetnav_env.numerics.portable_math import remainder

#: Configuration string -> MeasurementKind as an int (what the kernels take).
KIND_CODES = {k.label: int(k) for k in MeasurementKind}


class OrbitModel(NamedTuple):
    """The force field of one RK4 step of ``dt``: the central body and ``K`` perturbers (third bodies)
    at the step's three stage epochs, positions relative to the central body, and the cannonball solar
    radiation pressure ``srp_k s / |s|^3`` away from the Sun (``s`` the spacecraft's position from the
    Sun: the central body's origin, or perturber ``srp_sun``; the truth's alone, the filter's is 0).
    Built by keyword once per step (or once per batch), outside the stage loops."""

    mu: float  # central body's GM [km^3/s^2]
    p0: np.ndarray  # (K, 3) perturbers at t [km]
    p1: np.ndarray  # (K, 3) perturbers at t + dt/2 [km]
    p2: np.ndarray  # (K, 3) perturbers at t + dt [km]
    mus: np.ndarray  # (K,) perturbers' GM [km^3/s^2]
    srp_k: float  # cannonball SRP coefficient [km^3/s^2] (dynamics.srp.srp_gm; 0: none, the filter's)
    srp_sun: int  # the Sun's index among the perturbers (-1: the Sun is the central body)


class PredictScratch(NamedTuple):
    """Work arrays of :func:`predict_kernel` (the kernels allocate nothing: an allocation costs about as
    much as the arithmetic of an RK4 stage)."""

    w6: np.ndarray  # (3, 6, 6) RK4 of the STM
    v6: np.ndarray  # (4, 6) RK4 of the state; v6[3] the new state
    phi: np.ndarray  # (6, 6) state transition matrix
    tmp: np.ndarray  # (6, 6) covariance product


class PlanetFixes(NamedTuple):
    """One planet measurement per filter of a batch of ``N`` (:func:`update_batch_kernel`)."""

    z: np.ndarray  # (N, m) measurements (MeasurementModel's units: rad, or unit-vector components)
    planet: np.ndarray  # (N, 3) planet positions in the filter's frame [km]
    diameter: float  # planet diameter [km]
    basis: np.ndarray  # (N, 2, 3) line-of-sight bases (the los kinds; ignored by the others)
    active: np.ndarray  # (N,) bool: the filters to update (the others get NIS NaN, not accepted)


class FixModel(NamedTuple):
    """The measurement model of a batch of planet fixes and its chi-square gate."""

    kind: int  # MeasurementKind as an int (KIND_CODES)
    sig_dir: float  # direction sigma [rad]
    sig_size: float  # apparent-size sigma [rad]
    gate: float  # NIS above which a fix is rejected [-]


def orbit_model(
    mu: float,
    p0: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    mus: np.ndarray,
    srp_k: float = 0.0,
    srp_sun: int = -1,
) -> OrbitModel:
    """The :class:`OrbitModel` of the arguments (``mu`` and ``srp_k`` as floats, arrays as given)."""
    return OrbitModel(mu=float(mu), p0=p0, p1=p1, p2=p2, mus=mus, srp_k=float(srp_k), srp_sun=int(srp_sun))


@row_kernel
def _accel_grad(r, mu, pert, mus, a, g, grad=True, srp_k=0.0, srp_sun=-1):
    """a = central + third-body acceleration at r; g = its gradient (3x3). pert (K,3) rel. to centre.
    With ``srp_k`` != 0 the cannonball SRP ``srp_k s / |s|^3`` away from the Sun is added (``s = r`` with
    the Sun at the centre, ``srp_sun`` = -1; else ``s = r - pert[srp_sun]``), and its gradient.

    ``grad=False`` skips the gradient (``g`` untouched): the acceleration is computed by the same
    operations either way, so it is bit for bit the same.
    """
    r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    rn = math.sqrt(r2)
    inv3 = 1.0 / (r2 * rn)
    inv5 = inv3 / r2
    for i in range(3):
        a[i] = -mu * r[i] * inv3
        if grad:
            for j in range(3):
                g[i, j] = mu * 3.0 * r[i] * r[j] * inv5
            g[i, i] -= mu * inv3
    for k in range(pert.shape[0]):
        s0 = r[0] - pert[k, 0]
        s1 = r[1] - pert[k, 1]
        s2 = r[2] - pert[k, 2]
        s2n = s0 * s0 + s1 * s1 + s2 * s2
        sn = math.sqrt(s2n)
        si3 = 1.0 / (s2n * sn)
        si5 = si3 / s2n
        k2 = pert[k, 0] ** 2 + pert[k, 1] ** 2 + pert[k, 2] ** 2
        ki3 = 1.0 / (k2 * math.sqrt(k2))
        s = (s0, s1, s2)
        for i in range(3):
            a[i] += -mus[k] * s[i] * si3 - mus[k] * pert[k, i] * ki3
            if grad:
                for j in range(3):
                    g[i, j] += mus[k] * 3.0 * s[i] * s[j] * si5
                g[i, i] -= mus[k] * si3
    if srp_k != 0.0:
        s0, s1, s2 = r[0], r[1], r[2]
        if srp_sun >= 0:
            s0, s1, s2 = s0 - pert[srp_sun, 0], s1 - pert[srp_sun, 1], s2 - pert[srp_sun, 2]
        s2n = s0 * s0 + s1 * s1 + s2 * s2
        si3 = 1.0 / (s2n * math.sqrt(s2n))
        s = (s0, s1, s2)
        for i in range(3):
            a[i] += srp_k * s[i] * si3
            if grad:
                for j in range(3):
                    g[i, j] -= srp_k * 3.0 * s[i] * s[j] * si3 / s2n
                g[i, i] += srp_k * si3


@row_kernel
def _stage(x, phi, orbit, pert, dx, dphi, a, g, stm):
    """Derivative of the state (dx) and, if ``stm``, of Phi (dphi = F Phi with F = [[0, I], [G, 0]])."""
    _accel_grad(x[:3], orbit.mu, pert, orbit.mus, a, g, stm, orbit.srp_k, orbit.srp_sun)
    for i in range(3):
        dx[i] = x[3 + i]
        dx[3 + i] = a[i]
    if stm:
        for j in range(6):
            for i in range(3):
                dphi[i, j] = phi[3 + i, j]
                dphi[3 + i, j] = g[i, 0] * phi[0, j] + g[i, 1] * phi[1, j] + g[i, 2] * phi[2, j]


@row_kernel
def _rk4(x, dt, orbit, x_out, phi_out, w6, v6, stm):
    """RK4 of the state over dt and, if ``stm``, of the variational equations (Phi into ``phi_out``).

    The state's stages never read Phi, so ``stm=False`` gives the same ``x_out`` bit for bit with about a
    third of the work (the truth needs no STM; the filter does).
    """
    ps, dphi = w6[0], w6[1]
    g = w6[2, :3, :3]
    xs, dx = v6[0], v6[1]
    a = v6[2, :3]
    h6 = dt / 6.0
    for i in range(6):
        xs[i] = x[i]
        x_out[i] = x[i]
        if stm:
            for j in range(6):
                ps[i, j] = 1.0 if i == j else 0.0
                phi_out[i, j] = ps[i, j]
    # Stages 1..4: evaluate at (xs, ps), accumulate with weights 1,2,2,1, form the next stage point.
    for stage in range(4):
        pert = orbit.p0 if stage == 0 else (orbit.p1 if stage < 3 else orbit.p2)
        _stage(xs, ps, orbit, pert, dx, dphi, a, g, stm)
        wgt = h6 if (stage == 0 or stage == 3) else 2.0 * h6
        nxt = 0.5 * dt if stage < 2 else dt
        for i in range(6):
            x_out[i] += wgt * dx[i]
            xs[i] = x[i] + nxt * dx[i]
            if stm:
                for j in range(6):
                    phi_out[i, j] += wgt * dphi[i, j]
                    ps[i, j] = (1.0 if i == j else 0.0) + nxt * dphi[i, j]


@row_kernel
def rk4_stm_kernel(x, dt, orbit, x_out, phi_out, w6, v6):
    """RK4 of state and variational equations over ``dt`` [s] in the field ``orbit`` (:class:`OrbitModel`).

    ``w6`` (3, 6, 6) and ``v6`` (3, 6) are scratch space: the kernel allocates nothing, because
    an allocation costs about as much as the arithmetic of a stage.
    """
    _rk4(x, dt, orbit, x_out, phi_out, w6, v6, True)


@row_kernel
def rk4_kernel(x, dt, orbit, x_out, w6, v6):
    """:func:`rk4_stm_kernel` without the STM (the truth propagator): the same ``x_out``, bit for bit.

    ``w6`` (3, 6, 6) and ``v6`` (3, 6) are scratch as there (only ``v6`` and ``w6[2]`` are touched).
    """
    _rk4(x, dt, orbit, x_out, w6[2], w6, v6, False)


@njit(inline="always", **ROW_KERNEL_OPTIONS)  # inlined into numba IR: the callers' constant sizes unroll
def matmul_kernel(a, b, rows, cols, inner, out):
    """``out[:rows, :cols] = a[:rows, :inner] @ b[:inner, :cols]``, summed in index order from 0.0 (the one
    matrix product of the predict and update kernels; loops, because BLAS on 6x6 costs more in overhead)."""
    for i in range(rows):
        for j in range(cols):
            acc = 0.0
            for k in range(inner):
                acc += a[i, k] * b[k, j]
            out[i, j] = acc


@row_kernel
def predict_kernel(x, p, dt, orbit, q, euler_stm, ws):
    """In place over ``dt`` [s] in the field ``orbit`` (:class:`OrbitModel`): x <- RK4(x);
    P <- Phi P Phi^T + Q (symmetric by construction), Phi by RK4 or, if ``euler_stm``, one Euler step.

    ``ws`` (:class:`PredictScratch`) is scratch; ``ws.phi`` holds Phi afterwards.
    """
    w6, v6, phi = ws.w6, ws.v6, ws.phi
    x_new = v6[3]
    rk4_stm_kernel(x, dt, orbit, x_new, phi, w6, v6)
    if euler_stm:
        a = v6[2, :3]
        g = w6[2, :3, :3]
        _accel_grad(x[:3], orbit.mu, orbit.p0, orbit.mus, a, g, True, orbit.srp_k, orbit.srp_sun)
        for i in range(6):
            for j in range(6):
                phi[i, j] = 1.0 if i == j else 0.0
        for i in range(3):
            phi[i, 3 + i] = dt
            for j in range(3):
                phi[3 + i, j] = g[i, j] * dt
    for i in range(6):
        x[i] = x_new[i]
    covariance_predict_kernel(p, phi, q, ws.tmp)


@njit(inline="always", **ROW_KERNEL_OPTIONS)
def covariance_predict_kernel(p, phi, q, tmp):
    """In place: ``P <- Phi P Phi^T + Q`` (6, 6), symmetric by construction (the upper triangle is formed
    and mirrored). ``tmp`` (6, 6) is scratch. The one compiled covariance prediction: callers with a stored
    ``Phi`` (planners' what-if covariances) call it rather than writing the product again.
    """
    # Hand-written loops: BLAS calls on 6x6 matrices cost more in overhead than in arithmetic.
    matmul_kernel(phi, p, 6, 6, 6, tmp)
    for i in range(6):
        for j in range(i, 6):
            acc = 0.0
            for k in range(6):
                acc += tmp[i, k] * phi[j, k]
            p[i, j] = acc + q[i, j]
            p[j, i] = p[i, j]


@row_kernel
def _wrap(a):
    return math.pi - remainder(math.pi - a, 2.0 * math.pi)


@row_kernel
def planet_model_kernel(r, planet, diameter, kind, sig_dir, sig_size, basis, h, jac, rcov):
    """Predicted measurement, Jacobian (m x 6) and R for one planet; returns m."""
    d0 = planet[0] - r[0]
    d1 = planet[1] - r[1]
    d2 = planet[2] - r[2]
    rho2 = d0 * d0 + d1 * d1 + d2 * d2
    rho = math.sqrt(rho2)
    m = 3 if (kind == 1 or kind == 3) else 2
    for i in range(m):
        for j in range(6):
            jac[i, j] = 0.0
        for j in range(m):
            rcov[i, j] = 0.0
    if kind <= 1:
        rxy2 = d0 * d0 + d1 * d1
        rxy = math.sqrt(rxy2)
        h[0] = math.asin(d2 / rho)
        h[1] = math.atan2(d1, d0)
        jac[0, 0] = d0 * d2 / (rho2 * rxy)
        jac[0, 1] = d1 * d2 / (rho2 * rxy)
        jac[0, 2] = -rxy / rho2
        jac[1, 0] = d1 / rxy2
        jac[1, 1] = -d0 / rxy2
        rcov[0, 0] = sig_dir * sig_dir
        c = math.cos(h[0])
        rcov[1, 1] = sig_dir * sig_dir / (c * c)
    else:
        u0, u1, u2 = d0 / rho, d1 / rho, d2 / rho
        for i in range(2):
            e0, e1, e2 = basis[i, 0], basis[i, 1], basis[i, 2]
            h[i] = e0 * u0 + e1 * u1 + e2 * u2
            eu = h[i]
            jac[i, 0] = -(e0 - eu * u0) / rho
            jac[i, 1] = -(e1 - eu * u1) / rho
            jac[i, 2] = -(e2 - eu * u2) / rho
            rcov[i, i] = sig_dir * sig_dir
    if m == 3:
        h[2] = 2.0 * math.atan(0.5 * diameter / rho)
        f = diameter / (rho * (rho2 + 0.25 * diameter * diameter))
        jac[2, 0] = f * d0
        jac[2, 1] = f * d1
        jac[2, 2] = f * d2
        rcov[2, 2] = sig_size * sig_size
    return m


@row_kernel
def update_kernel(x, p, z, h, jac, rcov, m, wrap_index, gate, uw):
    """Joseph-form update in place for an m-dimensional measurement; returns (nis, accepted).

    ``uw`` (5, 6, 6) is scratch space (no allocation in the hot loop).
    """
    ikh, tmp = uw[0], uw[1]
    pht, kr = uw[2, :, :3], uw[2, :, 3:]
    kg, s = uw[3, :, :3], uw[3, :3, 3:]
    s_inv = uw[4, :3, :3]
    y = uw[4, 3, :3]
    for i in range(m):
        y[i] = z[i] - h[i]
    if wrap_index >= 0:
        y[wrap_index] = _wrap(y[wrap_index])
    for i in range(6):
        for j in range(m):
            acc = 0.0
            for k in range(6):
                acc += p[i, k] * jac[j, k]
            pht[i, j] = acc
    for i in range(m):
        for j in range(m):
            acc = rcov[i, j]
            for k in range(6):
                acc += jac[i, k] * pht[k, j]
            s[i, j] = acc
    _inv_small(s, m, s_inv)
    nis = 0.0
    for i in range(m):
        for j in range(m):
            nis += y[i] * s_inv[i, j] * y[j]
    if not nis <= gate:
        return nis, False
    matmul_kernel(pht, s_inv, 6, m, m, kg)
    # Joseph form: P+ = (I - K H) P (I - K H)^T + K R K^T.
    for i in range(6):
        for j in range(6):
            acc = -1.0 if i == j else 0.0
            for k in range(m):
                acc += kg[i, k] * jac[k, j]
            ikh[i, j] = -acc
    matmul_kernel(ikh, p, 6, 6, 6, tmp)
    matmul_kernel(kg, rcov, 6, m, m, kr)
    for i in range(6):
        acc = 0.0
        for j in range(m):
            acc += kg[i, j] * y[j]
        x[i] += acc
    for i in range(6):
        for j in range(i, 6):
            acc = 0.0
            for k in range(6):
                acc += tmp[i, k] * ikh[j, k]
            for k in range(m):
                acc += kr[i, k] * kg[j, k]
            p[i, j] = acc
            p[j, i] = acc
    return nis, True


@row_kernel
def _inv_small(s, m, out):
    """Inverse of a symmetric positive-definite m x m (m <= 3) matrix by cofactors, into ``out``."""
    if m == 1:
        out[0, 0] = 1.0 / s[0, 0]
    elif m == 2:
        det = s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]
        out[0, 0] = s[1, 1] / det
        out[1, 1] = s[0, 0] / det
        out[0, 1] = -s[0, 1] / det
        out[1, 0] = -s[1, 0] / det
    else:
        c00 = s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1]
        c01 = s[1, 2] * s[2, 0] - s[1, 0] * s[2, 2]
        c02 = s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]
        det = s[0, 0] * c00 + s[0, 1] * c01 + s[0, 2] * c02
        out[0, 0] = c00 / det
        out[1, 0] = c01 / det
        out[2, 0] = c02 / det
        out[0, 1] = (s[0, 2] * s[2, 1] - s[0, 1] * s[2, 2]) / det
        out[1, 1] = (s[0, 0] * s[2, 2] - s[0, 2] * s[2, 0]) / det
        out[2, 1] = (s[0, 1] * s[2, 0] - s[0, 0] * s[2, 1]) / det
        out[0, 2] = (s[0, 1] * s[1, 2] - s[0, 2] * s[1, 1]) / det
        out[1, 2] = (s[0, 2] * s[1, 0] - s[0, 0] * s[1, 2]) / det
        out[2, 2] = (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]) / det


@row_kernel  # no reference counting: it allocates nothing (the records hold the caller's arrays)
def predict_arrays_kernel(x, p, dt, mu, p0, p1, p2, mus, q, euler_stm, w6, v6, phi, tmp):
    """:func:`predict_kernel` for a caller in Python (:class:`SingleEKF`), with the fields of
    :class:`OrbitModel` and :class:`PredictScratch` as separate arguments; the records are built here.

    Kept positional on purpose: numba's dispatcher types a tuple argument in Python (arrays and scalars
    in C), so two records passed from Python would cost every cycle of :class:`SingleEKF` their typing.
    Compiled callers pass the records to :func:`predict_kernel`."""
    orbit = OrbitModel(mu=mu, p0=p0, p1=p1, p2=p2, mus=mus, srp_k=0.0, srp_sun=-1)
    ws = PredictScratch(w6=w6, v6=v6, phi=phi, tmp=tmp)
    predict_kernel(x, p, dt, orbit, q, euler_stm, ws)


@njit(cache=True)
def _predict_range(x, p, dt, orbit, q, euler_stm, lo, hi):
    """Predict filters lo..hi-1 of a batch in place (one scratch set for the chunk)."""
    ws = PredictScratch(
        w6=np.empty((3, 6, 6)), v6=np.empty((4, 6)), phi=np.empty((6, 6)), tmp=np.empty((6, 6))
    )
    for n in range(lo, hi):
        predict_kernel(x[n], p[n], dt, orbit, q, euler_stm, ws)


@njit(cache=True)
def _update_range(x, p, fixes, model, nis_out, acc_out, lo, hi):
    """Update filters lo..hi-1 of a batch in place, one planet measurement each."""
    h = np.empty(3)
    jac = np.empty((3, 6))
    rcov = np.empty((3, 3))
    uw = np.empty((5, 6, 6))
    kind = model.kind
    wrap_index = 1 if kind <= 1 else -1
    for n in range(lo, hi):
        if fixes.active[n]:
            m = planet_model_kernel(
                x[n, :3], fixes.planet[n], fixes.diameter, kind, model.sig_dir, model.sig_size,
                fixes.basis[n], h, jac, rcov,
            )  # fmt: skip
            nis_out[n], acc_out[n] = update_kernel(
                x[n], p[n], fixes.z[n], h, jac, rcov, m, wrap_index, model.gate, uw
            )
        else:
            nis_out[n] = np.nan
            acc_out[n] = False


@njit(cache=True)
def predict_batch_kernel(x, p, dt, orbit, q, euler_stm):
    """Predict N filters (leading axis) in place over ``dt`` [s] in the field ``orbit``
    (:class:`OrbitModel`, shared by every filter), process noise ``q`` (6, 6), on the calling thread."""
    _predict_range(x, p, dt, orbit, q, euler_stm, 0, x.shape[0])


@njit(cache=True, inline="always")
def _chunk_count(n_total: int, n_chunks: int) -> int:
    """The chunks a parallel batch kernel runs: ``n_chunks`` clipped to [1, n_total]."""
    return max(1, min(n_chunks, n_total))


@njit(cache=True, inline="always")
def _chunk_bounds(c: int, n_total: int, n_chunks: int) -> tuple[int, int]:
    """Rows ``lo .. hi - 1`` of chunk ``c``: the rows split as evenly as integers allow."""
    return c * n_total // n_chunks, (c + 1) * n_total // n_chunks


@njit(cache=True, parallel=True)
def predict_batch_parallel(x, p, dt, orbit, q, euler_stm, n_chunks):
    """:func:`predict_batch_kernel` in ``n_chunks`` chunks over the CPU's threads (pass
    ``numba.get_num_threads()``; filters are independent, so the result does not depend on it).

    Worth it for large batches on an idle machine only: each parallel region waits for every
    thread, which a busy machine may not schedule for a while.
    """
    n_chunks = _chunk_count(x.shape[0], n_chunks)
    for c in prange(n_chunks):
        lo, hi = _chunk_bounds(c, x.shape[0], n_chunks)
        _predict_range(x, p, dt, orbit, q, euler_stm, lo, hi)


@njit(cache=True)
def rk4_batch_kernel(x, dt, mu, p0, p1, p2, mus):
    """RK4 state step of N trajectories in place (the truth propagator; same stages as the filter);
    ``mu`` [km^3/s^2], perturbers ``p0``/``p1``/``p2`` (K, 3) [km] at t, t + dt/2, t + dt, their ``mus``."""
    orbit = OrbitModel(mu=mu, p0=p0, p1=p1, p2=p2, mus=mus, srp_k=0.0, srp_sun=-1)
    w6 = np.empty((3, 6, 6))
    v6 = np.empty((4, 6))
    x_new = np.empty(6)
    for n in range(x.shape[0]):
        rk4_kernel(x[n], dt, orbit, x_new, w6, v6)
        x[n, :] = x_new


@njit(cache=True)
def rk4_path_kernel(x0, times, mu, pert, mus, keep, out):
    """RK4 of one truth trajectory from ``x0`` (6,) [km, km/s] at ``times[0]`` through ``times`` (S + 1,)
    [TDB s], one step per interval (decreasing times integrate backwards), the same stages as
    :func:`rk4_kernel`.

    ``pert`` (2 S + 1, K, 3) [km]: the perturbers relative to the central body at ``times[s]`` (row 2 s) and
    at the middle of step s (row 2 s + 1); ``mus`` (K,) their GMs, ``mu`` the central body's [km^3/s^2].
    ``out[i]`` receives the state at ``times[keep[i]]`` (``keep`` increasing).
    """
    w6 = np.empty((3, 6, 6))
    v6 = np.empty((4, 6))
    x = x0.copy()
    x_new = np.empty(6)
    k = 0
    if keep[0] == 0:
        out[0, :] = x
        k = 1
    for s in range(times.shape[0] - 1):
        orbit = OrbitModel(
            mu=mu, p0=pert[2 * s], p1=pert[2 * s + 1], p2=pert[2 * s + 2], mus=mus, srp_k=0.0, srp_sun=-1
        )
        rk4_kernel(x, times[s + 1] - times[s], orbit, x_new, w6, v6)
        x[:] = x_new
        if k < keep.shape[0] and keep[k] == s + 1:
            out[k, :] = x
            k += 1


@njit(cache=True)
def update_batch_kernel(x, p, fixes, model, nis_out, acc_out):
    """Update N filters in place, one planet measurement each (``fixes``: :class:`PlanetFixes`, ``model``:
    :class:`FixModel`); NIS into ``nis_out`` (N,), acceptance into ``acc_out`` (N,) bool."""
    _update_range(x, p, fixes, model, nis_out, acc_out, 0, x.shape[0])


@njit(cache=True, parallel=True)
def update_batch_parallel(x, p, fixes, model, nis_out, acc_out, n_chunks):
    """:func:`update_batch_kernel` in chunks over the CPU's threads (see :func:`predict_batch_parallel`)."""
    n_chunks = _chunk_count(x.shape[0], n_chunks)
    for c in prange(n_chunks):
        lo, hi = _chunk_bounds(c, x.shape[0], n_chunks)
        _update_range(x, p, fixes, model, nis_out, acc_out, lo, hi)


@njit(cache=True)
def cycle_batch_kernel(x, p, dt, mu, p0, p1, p2, mus, q, euler_stm, *update_args):
    """Predict + update for N filters (leading axis): :func:`predict_batch_kernel` with the arguments up
    to ``euler_stm`` (the orbit model by its parts ``mu``, ``p0``, ``p1``, ``p2``, ``mus``: the fields of
    :class:`OrbitModel`), then :func:`update_batch_kernel` on the same ``x``, ``p`` with the rest (``z`` to
    ``acc_out``: the fields of :class:`PlanetFixes` and :class:`FixModel`, then the outputs, in that order,
    as ``tests/env/test_fast_ekf.py`` calls it). The measurement and basis must
    not depend on the prediction."""
    predict_batch_kernel(
        x, p, dt, OrbitModel(mu=mu, p0=p0, p1=p1, p2=p2, mus=mus, srp_k=0.0, srp_sun=-1), q, euler_stm
    )
    z, planet, diameter, kind, sig_dir, sig_size, basis, active, gate, nis_out, acc_out = update_args
    fixes = PlanetFixes(z=z, planet=planet, diameter=diameter, basis=basis, active=active)
    model = FixModel(kind=kind, sig_dir=sig_dir, sig_size=sig_size, gate=gate)
    update_batch_kernel(x, p, fixes, model, nis_out, acc_out)


@row_kernel
def nees_kernel(x_est, x_true, p, lo, y):  # pragma: no cover - compiled
    """NEES ``e^T P^-1 e`` with ``e = x_est - x_true`` (6,), by Cholesky of the symmetric positive-definite
    ``P`` (6, 6); NaN if the factorisation fails. ``lo`` (6, 6) and ``y`` (6,) are scratch (no allocation).

    The one compiled implementation (the environments' core and the Monte Carlo harnesses call it;
    ``planetnav_validation.numpy_ekf.nees`` is its numpy oracle in the tests).
    """
    n = 6
    for i in range(n):
        for j in range(i + 1):
            acc = p[i, j]
            for k in range(j):
                acc -= lo[i, k] * lo[j, k]
            if i == j:
                if not acc > 0.0:
                    return np.nan
                lo[i, i] = math.sqrt(acc)
            else:
                lo[i, j] = acc / lo[j, j]
    total = 0.0
    for i in range(n):  # forward substitution L y = e (y[k] for k < i already computed)
        acc = x_est[i] - x_true[i]
        for k in range(i):
            acc -= lo[i, k] * y[k]
        y[i] = acc / lo[i, i]
        total += y[i] * y[i]
    return total


@njit(cache=True, nogil=True)
def nees_batch_kernel(x_est, x_true, p, out):  # pragma: no cover - compiled
    """:func:`nees_kernel` for every row: x_est, x_true (N, 6), p (N, 6, 6) -> out (N,)."""
    lo = np.empty((6, 6))
    y = np.empty(6)
    for n in range(x_est.shape[0]):
        out[n] = nees_kernel(x_est[n], x_true[n], p[n], lo, y)


_EMPTY = np.zeros((0, 3))


class SingleEKF(EKFBase):
    """One EKF on the compiled kernels (the environment's filter).

    Same settings and equations as :class:`~planetnav_validation.numpy_ekf.BatchEKF` (its oracle) and the
    same construction (:class:`~planetnav_env.estimation.ekf.EKFBase`); ``x`` (6,) [km, km/s] and
    ``P`` (6, 6) are public.
    """

    def _start(self, x: np.ndarray, p: np.ndarray) -> None:
        if x.shape != (6,) or p.shape != (6, 6):
            raise InvalidParameterError(f"one filter needs x0 (6,) and P0 (6, 6), got {x.shape}, {p.shape}")
        self.x, self.P = x, p
        self._mus = np.asarray(self.model.mu_perturbers, dtype=float)
        self._gate = {m: self.config.gate_threshold(m) for m in (1, 2, 3)}
        self.rejected = 0
        self._h = np.empty(3)
        self._jac = np.empty((3, 6))
        self._r = np.empty((3, 3))
        # The predict scratch as plain attributes (not a PredictScratch): SingleEKF.predict passes them
        # from Python, where the dispatcher types arrays in C and a tuple in Python.
        self._w6 = np.empty((3, 6, 6))
        self._v6 = np.empty((4, 6))
        self._phi = np.empty((6, 6))
        self._tmp = np.empty((6, 6))
        self._uw = np.empty((5, 6, 6))

    def _pert(self, t: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not self.model.n_perturbers:
            return _EMPTY, _EMPTY, _EMPTY
        if self.perturbers is None:
            raise InvalidParameterError("the gravity model has perturbers: pass their positions function")
        return (
            np.ascontiguousarray(self.perturbers(t), dtype=float),
            np.ascontiguousarray(self.perturbers(t + 0.5 * dt), dtype=float),
            np.ascontiguousarray(self.perturbers(t + dt), dtype=float),
        )

    def predict(self, t: float, dt: float, perturber_positions: tuple | None = None) -> None:
        """Advance from ``t`` to ``t + dt`` [s]; ``perturber_positions`` may pass the three (K, 3)
        arrays at t, t+dt/2, t+dt when the caller has them cached."""
        dt = require_positive("dt", dt)
        p0, p1, p2 = perturber_positions if perturber_positions is not None else self._pert(t, dt)
        predict_arrays_kernel(
            self.x, self.P, dt, self.model.mu_central, p0, p1, p2, self._mus, self.q(dt),
            self.config.stm == "euler", self._w6, self._v6, self._phi, self._tmp,
        )  # fmt: skip

    def update_scalar(self, z: float, h: float, jac_row: np.ndarray, variance: float) -> tuple[float, bool]:
        """Update with one scalar measurement ``z`` of prediction ``h``, Jacobian row (6,) and noise
        variance (e.g. a pulsar phase after its cycle ambiguity is resolved); returns (NIS, accepted)."""
        if not (math.isfinite(z) and math.isfinite(h)):
            raise NonFiniteError(f"scalar measurement or prediction is not finite: z={z!r}, h={h!r}")
        self._h[0] = h
        self._jac[0] = jac_row
        self._r[0, 0] = require_positive("measurement variance", variance)
        zz = np.array([float(z)])
        nis, ok = update_kernel(
            self.x, self.P, zz, self._h, self._jac, self._r, 1, -1, self._gate[1], self._uw
        )
        if not ok:
            self.rejected += 1
        return float(nis), bool(ok)

    def update_planet(
        self,
        z: np.ndarray,
        planet: np.ndarray,
        diameter: float,
        measurement: MeasurementModel,
        basis: np.ndarray | None = None,
    ) -> tuple[float, bool]:
        """Update with one planet measurement ``z`` (m,) of ``measurement.kind``; returns (NIS, accepted)."""
        kind = KIND_CODES[measurement.kind]
        z = np.asarray(z, dtype=float)
        if not all(math.isfinite(v) for v in z):  # cheaper than np.all for <= 3 values
            require_finite("measurement z", z)  # raises NonFiniteError naming the entries
        if kind >= 2 and basis is None:
            raise InvalidParameterError(f"model {measurement.kind!r} needs the line-of-sight basis")
        b = basis if basis is not None else np.zeros((2, 3))
        m = planet_model_kernel(
            self.x[:3],
            np.asarray(planet, float),
            float(diameter),
            kind,
            measurement.sigma_dir,
            measurement.sigma_size,
            b,
            self._h,
            self._jac,
            self._r,
        )
        nis, ok = update_kernel(
            self.x, self.P, z, self._h, self._jac, self._r, m, 1 if kind <= 1 else -1, self._gate[m], self._uw
        )
        if not ok:
            self.rejected += 1
        return float(nis), bool(ok)
