"""The thesis's PD law that points the camera (body +x) at a planet (section 2.4).

Reference frame
---------------
The camera's optical axis is the body axis O'X (+x). The thesis's reference frame, built from the
spacecraft's heliocentric position X and the planet's R (inertial components)::

    P = R - X            (spacecraft -> planet: the desired boresight)
    P_n = P x X,   P_tau = P x P_n,   each normalised

is right-handed (``P x P_n = P_tau``) and ``P_n`` is normal to the Sun-spacecraft-planet plane. The thesis
leaves the roll about the boresight free ("the other axes are immaterial"); this choice fixes it.
:func:`reference_frame` returns ``B`` with the vectors as **rows**, ``B = [P; P_n; P_tau]``, so that
``B @ v_I`` gives reference-frame components.

Degenerate geometry: when P is parallel to X (the planet exactly on the Sun line as seen from the
spacecraft; ``|P x X| <= 1e-8 |P| |X|``) or X = 0, ``P_n`` is built from the inertial basis axis least
aligned with P instead (smallest ``|P_k|``, lowest k on ties). Only the roll reference changes.

Control law (as implemented)
----------------------------
With the reference at rest (``omega_0 = omega_0_dot = 0``, the thesis's case; the planet's direction turns
at ~1e-7 rad/s, negligible over a slew)::

    C = R(q)^T                       (inertial -> body: the direction-cosine matrix from the quaternion)
    A = C B^T = R(q)^T [P P_n P_tau] (reference -> body; A_ij = body axis i . reference axis j)
    S = (A23 - A32, A31 - A13, A12 - A21)
    U = omega x (J omega + h_w) - k_a S - k_w omega

``U`` is the torque the wheels are commanded to apply to the body (body axes). The thesis writes the
gyroscopic term ``omega x J omega`` for a body without wheel momentum; with wheels it must be the total
momentum ``J omega + h_w`` to cancel the gyroscopic torque of the dynamics (``h_w = None`` gives the thesis's
formula exactly).

Why this orientation of C, B and A (the thesis does not state it)
-----------------------------------------------------------------
The quaternion gives either ``R(q)`` (body->inertial) or ``R(q)^T`` (inertial->body) as "C" (which one
also depends on the quaternion convention: ``R(conj q) = R(q)^T``), and ``B``'s vectors may be its rows or
its columns: four readings of ``A = C B^T``. Only ``C = R(q)^T`` with rows makes ``A`` a composition of
frame maps, ``A = (inertial->body)(ref->inertial) = ref->body``, whose identity means "body axes = P, P_n,
P_tau". If the body is turned from the reference by the small rotation ``theta`` (body components),
``A ~ I - [theta]x`` and ``S = 2 theta``; exactly, ``S = 2 sin(phi) e`` for the error's eigen-axis ``e`` and
angle ``phi`` (``S = 4 dq0 dq_vec`` for the error quaternion). Then ``A_dot = -[omega]x A`` gives
``d/dt trace(A) = -omega . S``, so ``V = 0.5 omega.J omega + k_a (3 - trace A)`` has
``V_dot = -k_w |omega|^2 <= 0`` in closed loop (``J omega_dot = -k_a S - k_w omega`` once the gyroscopic
term cancels): A = I is asymptotically stable (LaSalle; the other equilibria, 180-degree errors where
S = 0, are unstable). The thesis's ``omega_rel = omega - A omega_0`` also needs ``A`` to take reference
components (``omega_0``) into body ones, which only this reading does.

The other readings fail (``tests/env/test_pointing.py`` simulates all four from 1 degree off the target):
``C = R^T`` with columns has a stable equilibrium at the wrong attitude (body axes = the rows of
``M = [P P_n P_tau]``; ~49 degrees off in the test geometry); ``C = R`` with either layout feeds ``S`` back
in the wrong axes (with columns, near the right attitude ``S ~ -2 M theta``) and the spacecraft wanders
off by tens of degrees.

Gains, units, saturation
------------------------
S is dimensionless (~2x the error angle in rad for small errors), so ``k_a`` is in N m (read "N m per
rad of S"; the small-angle stiffness is ``2 k_a`` N m/rad) and ``k_w`` in N m s (per rad/s). The thesis's
values are ``k_a = k_w = 1``. With the default inertia diag(10, 12, 8) kg m^2 the linearised loop
``J theta_ddot = -2 k_a theta - k_w theta_dot`` has natural frequencies 0.41-0.50 rad/s and damping ratios
0.10-0.13: underdamped, with an envelope decaying as ``exp(-k_w t / (2 J_i))``. It asks for up to
``2 k_a`` = 2 N m at a large error, two hundred times the default wheel torque; clipped, the law
switches torque on the line ``k_a S + k_w omega = 0``, far too late to brake, and overshoots for many
cycles (see docs/attitude.md for the measured times; ``k_a = 0.02, k_w = 1`` converges ~10x faster under
the default limits).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.plant import (
    STATUS_NONFINITE_INPUT,
    STATUS_NONFINITE_RESULT,
    STATUS_OK,
    STATUS_ZERO_DIRECTION,
    STATUS_ZERO_Q,
    AttitudeConfig,
    AttitudeRows,
    Plant,
    all_finite_kernel,
    as_state_arrays,
    attitude_rows,
    dcm_body_to_inertial_kernel,
    finish_rows,
    load_row_kernel,
    normalize_quaternion_kernel,
    plant_of,
    plant_substep_kernel,
    raise_state_error,
    require_substeps,
    rows_finite_kernel,
    store_row_kernel,
)
from planetnav_env.errors import InvalidParameterError, require_finite, require_positive
from planetnav_env.numerics.jit import row_kernel

__all__ = [
    "BORESIGHT_BODY",
    "DEGENERATE_SIN",
    "attitude_error_matrix",
    "frame_from_direction",
    "pd_torque",
    "pointing_error",
    "propagate_pointing",
    "reference_frame",
]

BORESIGHT_BODY = np.array([1.0, 0.0, 0.0])
"""Camera optical axis in body axes (the thesis's O'X)."""
BORESIGHT_BODY.setflags(write=False)

DEGENERATE_SIN = 1e-8
"""Below this sine of the angle between P and the roll reference, the fallback axis is used."""


# ---------------------------------------------------------------------------------------------------------
# Numba kernels (the one implementation of each formula)
# ---------------------------------------------------------------------------------------------------------


@row_kernel
def frame_kernel(p: np.ndarray, x: np.ndarray, out: np.ndarray) -> bool:
    """Rows P, P_n, P_tau of the reference frame for direction ``p`` and roll reference ``x``.

    Returns False (``out`` untouched) when ``p`` has zero length.
    """
    pn = math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
    if pn == 0.0:
        return False
    px, py, pz = p[0] / pn, p[1] / pn, p[2] / pn
    xx, xy, xz = x[0], x[1], x[2]
    xn = math.sqrt(xx * xx + xy * xy + xz * xz)
    nx, ny, nz = py * xz - pz * xy, pz * xx - px * xz, px * xy - py * xx
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if xn == 0.0 or nn <= DEGENERATE_SIN * xn:
        ax, ay, az = abs(px), abs(py), abs(pz)
        xx, xy, xz = 0.0, 0.0, 0.0
        if ax <= ay and ax <= az:
            xx = 1.0
        elif ay <= az:
            xy = 1.0
        else:
            xz = 1.0
        nx, ny, nz = py * xz - pz * xy, pz * xx - px * xz, px * xy - py * xx
        nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    # When P and X are nearly parallel the cross product has lost ~log10(1/sin) digits of orthogonality
    # to P; one Gram-Schmidt pass restores it to rounding level.
    d = (nx * px + ny * py + nz * pz) / nn
    nx, ny, nz = nx / nn - d * px, ny / nn - d * py, nz / nn - d * pz
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / nn, ny / nn, nz / nn
    tx, ty, tz = py * nz - pz * ny, pz * nx - px * nz, px * ny - py * nx
    tn = math.sqrt(tx * tx + ty * ty + tz * tz)
    out[0, 0], out[0, 1], out[0, 2] = px, py, pz
    out[1, 0], out[1, 1], out[1, 2] = nx, ny, nz
    out[2, 0], out[2, 1], out[2, 2] = tx / tn, ty / tn, tz / tn
    return True


@row_kernel
def error_matrix_kernel(q: np.ndarray, frame: np.ndarray, rq: np.ndarray, out: np.ndarray) -> None:
    """A = R(q)^T B^T (reference -> body) for unit ``q`` and frame rows ``B``; ``rq`` is (3, 3) scratch."""
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], rq)
    for i in range(3):
        for j in range(3):
            out[i, j] = rq[0, i] * frame[j, 0] + rq[1, i] * frame[j, 1] + rq[2, i] * frame[j, 2]


@row_kernel
def pd_torque_kernel(
    q: np.ndarray,
    w: np.ndarray,
    h_w: np.ndarray,
    frame: np.ndarray,
    jm: np.ndarray,
    k_a: float,
    k_w: float,
    rq: np.ndarray,
    a: np.ndarray,
    out: np.ndarray,
) -> None:
    """Commanded wheel torque on the body [N m] (module docstring); ``rq``, ``a``: (3, 3) scratch."""
    error_matrix_kernel(q, frame, rq, a)
    s0 = a[1, 2] - a[2, 1]
    s1 = a[2, 0] - a[0, 2]
    s2 = a[0, 1] - a[1, 0]
    hx = jm[0, 0] * w[0] + jm[0, 1] * w[1] + jm[0, 2] * w[2] + h_w[0]
    hy = jm[1, 0] * w[0] + jm[1, 1] * w[1] + jm[1, 2] * w[2] + h_w[1]
    hz = jm[2, 0] * w[0] + jm[2, 1] * w[1] + jm[2, 2] * w[2] + h_w[2]
    out[0] = (w[1] * hz - w[2] * hy) - k_a * s0 - k_w * w[0]
    out[1] = (w[2] * hx - w[0] * hz) - k_a * s1 - k_w * w[1]
    out[2] = (w[0] * hy - w[1] * hx) - k_a * s2 - k_w * w[2]


@njit(cache=True)
def frame_batch(p: np.ndarray, x: np.ndarray, out: np.ndarray) -> int:
    """:func:`frame_kernel` for every row: directions ``p`` (N, 3) and roll references ``x`` (N, 3), inertial
    axes (any length > 0), into ``out`` (N, 3, 3); returns 1 + the first row whose direction has zero
    length, else 0. No other check: the caller passes finite, C-contiguous float64 arrays."""
    for b in range(p.shape[0]):
        if not frame_kernel(p[b], x[b], out[b]):
            return b + 1
    return 0


@njit(cache=True)
def _error_matrix_batch(q: np.ndarray, frame: np.ndarray, out: np.ndarray) -> int:
    """A for every row; returns STATUS_ZERO_Q on a zero quaternion, else STATUS_OK."""
    rq = np.empty((3, 3))
    qn = np.empty(4)
    for b in range(q.shape[0]):
        if not normalize_quaternion_kernel(q[b], qn):
            return STATUS_ZERO_Q
        error_matrix_kernel(qn, frame[b], rq, out[b])
    return STATUS_OK


@njit(cache=True)
def pd_torque_batch(
    q: np.ndarray,
    w: np.ndarray,
    h_w: np.ndarray,
    frame: np.ndarray,
    jm: np.ndarray,
    k_a: float,
    k_w: float,
    out: np.ndarray,
) -> int:
    """:func:`pd_torque_kernel` for every row: attitudes ``q`` (N, 4, body -> inertial, scalar first, any
    norm > 0), body rates ``w`` (N, 3) [rad/s], wheel momenta ``h_w`` (N, 3) [N m s], reference frames
    ``frame`` (N, 3, 3) of :func:`frame_batch`, inertia ``jm`` (3, 3) [kg m^2] and gains ``k_a``, ``k_w``
    into ``out`` (N, 3), the commanded wheel torque on the body [N m]; returns STATUS_ZERO_Q on a zero
    quaternion, else STATUS_OK. No other check: the caller passes finite, C-contiguous float64 arrays."""
    rq = np.empty((3, 3))
    a = np.empty((3, 3))
    qn = np.empty(4)
    for b in range(q.shape[0]):
        if not normalize_quaternion_kernel(q[b], qn):
            return STATUS_ZERO_Q
        pd_torque_kernel(qn, w[b], h_w[b], frame[b], jm, k_a, k_w, rq, a, out[b])
    return STATUS_OK


class PdLoop(NamedTuple):
    """The closed loop's constants: the plant a sub-step integrates and the PD law's gains (module
    docstring). Built by keyword once per call of a batch or per row step, outside the sub-step loop."""

    plant: Plant  # inertia, its inverse, wheel torque and momentum limits
    k_a: float  # angle gain [N m per unit of S]
    k_w: float  # rate gain [N m s]


class LoopScratch(NamedTuple):
    """Work arrays of :func:`substeps_kernel` (no allocation in the sub-step loop)."""

    work: np.ndarray  # (8, 7) attitude RK4 stages
    rq: np.ndarray  # (3, 3) R(q)
    a: np.ndarray  # (3, 3) error matrix A
    u_cmd: np.ndarray  # (3,) commanded torque [N m]


@row_kernel
def substeps_kernel(
    y: np.ndarray,
    h: np.ndarray,
    use_pd: bool,
    frame: np.ndarray,
    u_bias: np.ndarray,
    u_ext: np.ndarray,
    n_substeps: int,
    dt: float,
    loop: PdLoop,
    ws: LoopScratch,
    u: np.ndarray,
) -> None:
    """``n_substeps`` closed-loop sub-steps of ``dt`` [s] of one spacecraft, in place on ``y = (q, omega)``
    and ``h`` [N m s]: command = PD torque toward ``frame`` (if ``use_pd``) + ``u_bias`` [N m] -> wheel
    limits -> RK4 under the external torque ``u_ext`` [N m] (the one closed-loop sub-step loop:
    :func:`propagate_pointing` and the environment both run it; the plant's sub-step is
    :func:`~planetnav_env.attitude.plant.plant_substep_kernel`). ``u`` holds the last applied wheel
    torque [N m]."""
    plant = loop.plant
    for _ in range(n_substeps):
        if use_pd:
            pd_torque_kernel(y[:4], y[4:], h, frame, plant.jm, loop.k_a, loop.k_w, ws.rq, ws.a, ws.u_cmd)
            for i in range(3):
                ws.u_cmd[i] += u_bias[i]
        else:
            for i in range(3):
                ws.u_cmd[i] = u_bias[i]
        plant_substep_kernel(
            y, h, ws.u_cmd, u_ext, dt, plant.jm, plant.jinv, plant.tau_max, plant.h_max, ws.work, u
        )


@njit(cache=True)
def propagate_batch_kernel(
    rows: AttitudeRows,
    use_pd: bool,
    direction: np.ndarray,
    roll_ref: np.ndarray,
    u_bias: np.ndarray,
    dt: float,
    n_substeps: int,
    plant: Plant,
    k_a: float,
    k_w: float,
) -> int:
    """:func:`substeps_kernel` for every row ``b`` of ``rows``: the PD law toward ``direction[b]`` (if
    ``use_pd``; ``direction`` and ``roll_ref`` are ignored otherwise) plus the constant command
    ``u_bias[b]`` -> wheel limits -> RK4 (the closed loop of :func:`propagate_pointing`; the open loop
    is :func:`planetnav_env.attitude.plant.propagate_open_loop_batch`). Returns a status code.

    The gains come as scalars and the :class:`PdLoop` is built here, in compiled code: numba's dispatcher
    types a tuple argument in Python (arrays and scalars in C), so a PdLoop passed from Python would cost
    every call the typing of a nested tuple."""
    if not (
        rows_finite_kernel(rows, u_bias) and all_finite_kernel(direction) and all_finite_kernel(roll_ref)
    ):
        return STATUS_NONFINITE_INPUT
    loop = PdLoop(plant=plant, k_a=k_a, k_w=k_w)
    ws = LoopScratch(work=np.empty((8, 7)), rq=np.empty((3, 3)), a=np.empty((3, 3)), u_cmd=np.empty(3))
    frame, y, h, u = np.empty((3, 3)), np.empty(7), np.empty(3), np.empty(3)
    for b in range(rows.q.shape[0]):
        if not load_row_kernel(rows, b, y, h):
            return STATUS_ZERO_Q
        if use_pd and not frame_kernel(direction[b], roll_ref[b], frame):
            return STATUS_ZERO_DIRECTION
        substeps_kernel(y, h, use_pd, frame, u_bias[b], rows.u_ext[b], n_substeps, dt, loop, ws, u)
        if not store_row_kernel(rows, b, y, h):
            return STATUS_NONFINITE_RESULT
    return STATUS_OK


@njit(cache=True)
def propagate_batch_arrays(
    q, omega, h_w, u_ext, q_out, w_out, h_out, use_pd, direction, roll_ref, u_bias, dt, n_substeps,
    jm, jinv, tau_max, h_max, k_a, k_w,
):  # fmt: skip
    """:func:`propagate_batch_kernel` for callers in Python: the fields of :class:`AttitudeRows` and
    :class:`Plant` as plain arrays (``*rows``, ``*plant``), the records built here (numba types a named
    tuple passed from Python far more slowly than the arrays it holds)."""
    rows = AttitudeRows(q=q, omega=omega, h_w=h_w, u_ext=u_ext, q_out=q_out, w_out=w_out, h_out=h_out)
    plant = Plant(jm=jm, jinv=jinv, tau_max=tau_max, h_max=h_max)
    return propagate_batch_kernel(rows, use_pd, direction, roll_ref, u_bias, dt, n_substeps, plant, k_a, k_w)


# ---------------------------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------------------------


def _roll_ref_or_default(roll_ref_inertial: np.ndarray | None) -> np.ndarray:
    # A fresh array each call: a shared module constant could be mutated by a caller.
    return np.array([0.0, 0.0, 1.0]) if roll_ref_inertial is None else roll_ref_inertial


def frame_from_direction(
    direction_inertial: np.ndarray, roll_ref_inertial: np.ndarray | None = None
) -> np.ndarray:
    """Reference frame ``B = [P; P_n; P_tau]`` (rows, inertial components), shape (..., 3, 3).

    ``P`` = unit ``direction_inertial`` (the desired boresight), ``P_n = P x roll_ref`` and
    ``P_tau = P x P_n`` (normalised). ``roll_ref_inertial`` defaults to inertial +z (the J2000 pole); the
    thesis uses the spacecraft's heliocentric position (see :func:`reference_frame`). Degenerate roll
    references fall back as described in the module docstring. Raises :class:`InvalidParameterError` for a
    zero direction and :class:`NonFiniteError` for NaN/inf.
    """
    batch, (p, x) = as_state_arrays(
        [
            ("direction_inertial", direction_inertial, 3),
            ("roll_ref_inertial", _roll_ref_or_default(roll_ref_inertial), 3),
        ]
    )
    require_finite("direction_inertial", p)
    require_finite("roll_ref_inertial", x)
    out = np.empty((p.shape[0], 3, 3))
    bad = frame_batch(p, x, out)
    if bad:
        raise InvalidParameterError(
            "direction_inertial has zero length (target at the spacecraft) at row "
            f"{bad - 1}: {p[bad - 1].tolist()}"
        )
    return out.reshape(batch + (3, 3))


def reference_frame(r_sc: np.ndarray, r_target: np.ndarray) -> np.ndarray:
    """The thesis's frame ``B = [P; P_n; P_tau]`` (rows) with ``P = R - X``, ``P_n = P x X``; (..., 3, 3).

    ``r_sc`` (X) and ``r_target`` (R) are heliocentric inertial positions [km] of the spacecraft and of the
    planet. ``B @ v_I`` gives reference-frame components of an inertial vector.
    """
    r_sc = require_finite("r_sc", r_sc)
    r_target = require_finite("r_target", r_target)
    return frame_from_direction(r_target - r_sc, r_sc)


def attitude_error_matrix(q: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """The thesis's ``A = C B^T`` with ``C = R(q)^T``: reference -> body direction cosines, shape (..., 3, 3).

    ``A = I`` when the body axes coincide with the reference frame ``frame`` (rows P, P_n, P_tau).
    """
    q = np.asarray(q, dtype=float)
    frame = require_finite("frame", frame)
    if frame.shape[-2:] != (3, 3):
        raise InvalidParameterError(f"frame must have shape (..., 3, 3), got {frame.shape}")
    batch, (qa, fa) = as_state_arrays([("q", q, 4), ("frame", frame.reshape(frame.shape[:-2] + (9,)), 9)])
    require_finite("q", qa)
    out = np.empty((qa.shape[0], 3, 3))
    status = _error_matrix_batch(qa, np.ascontiguousarray(fa.reshape(-1, 3, 3)), out)
    raise_state_error(status, [("q", qa)])
    return out.reshape(batch + (3, 3))


def pd_torque(
    q: np.ndarray,
    omega: np.ndarray,
    target_dir_inertial: np.ndarray,
    config: AttitudeConfig,
    *,
    h_w: np.ndarray | None = None,
    roll_ref_inertial: np.ndarray | None = None,
    k_a: float = 1.0,
    k_w: float = 1.0,
) -> np.ndarray:
    """Commanded wheel torque on the body [N m, body axes] of the thesis's PD law, batched (..., 3).

    Parameters
    ----------
    q, omega:
        Attitude (body->inertial, scalar first) and body rate [rad/s].
    target_dir_inertial:
        Desired boresight direction (spacecraft -> planet), inertial, any length > 0.
    config:
        Supplies the inertia J.
    h_w:
        Wheel momentum [N m s]; ``None`` = zero (the thesis's ``omega x J omega`` term).
    roll_ref_inertial:
        X of the thesis (the spacecraft's heliocentric position) or any vector fixing the roll; default +z.
    k_a, k_w:
        Attitude gain [N m] and rate gain [N m s]; the thesis uses 1 and 1.

    The torque is not clipped: the wheel model does that
    (:func:`~planetnav_env.attitude.plant.applied_wheel_torque`).
    """
    k_a = require_positive("k_a", k_a)
    k_w = require_positive("k_w", k_w)
    frame = frame_from_direction(target_dir_inertial, roll_ref_inertial)
    if h_w is None:
        h_w = np.zeros(3)
    batch, (qa, wa, ha, fa) = as_state_arrays(
        [
            ("q", q, 4),
            ("omega", omega, 3),
            ("h_w", h_w, 3),
            ("frame", frame.reshape(frame.shape[:-2] + (9,)), 9),
        ]
    )
    for name, a in (("q", qa), ("omega", wa), ("h_w", ha)):
        require_finite(name, a)
    out = np.empty_like(wa)
    status = pd_torque_batch(
        qa, wa, ha, np.ascontiguousarray(fa.reshape(-1, 3, 3)), config.inertia_matrix, k_a, k_w, out
    )
    raise_state_error(status, [("q", qa)])
    return out.reshape(batch + (3,))


def pointing_error(q: np.ndarray, target_dir_inertial: np.ndarray) -> np.ndarray:
    """Angle [rad] between the camera boresight ``R(q) e_x`` and the target direction, shape (...)."""
    target = require_finite("target_dir_inertial", target_dir_inertial)
    b = qt.rotate_body_to_inertial(qt.normalize(require_finite("q", q)), BORESIGHT_BODY)
    # atan2 of |cross| and dot keeps full precision at the small angles that matter here.
    return np.arctan2(np.linalg.norm(np.cross(b, target), axis=-1), np.sum(b * target, axis=-1))


def propagate_pointing(
    q: np.ndarray,
    omega: np.ndarray,
    h_w: np.ndarray,
    target_dir_inertial: np.ndarray,
    dt: float,
    n_substeps: int,
    config: AttitudeConfig,
    *,
    roll_ref_inertial: np.ndarray | None = None,
    k_a: float = 1.0,
    k_w: float = 1.0,
    torque_ext: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-loop pointing: ``n_substeps`` steps of ``dt`` [s], each PD torque -> wheel limits -> RK4.

    The PD law (:func:`pd_torque` with the current ``h_w``) is evaluated at the start of every sub-step and
    held over it; the reference frame is built once from ``target_dir_inertial`` / ``roll_ref_inertial``
    (held fixed over the call). Batched like
    :func:`~planetnav_env.attitude.plant.propagate_attitude`; returns ``(q, omega, h_w)``.
    """
    dt = require_positive("dt", dt)
    n = require_substeps(n_substeps)
    k_a = require_positive("k_a", k_a)
    k_w = require_positive("k_w", k_w)
    if torque_ext is None:
        torque_ext = np.zeros(3)
    named = [
        ("q", q, 4),
        ("omega", omega, 3),
        ("h_w", h_w, 3),
        ("target_dir_inertial", target_dir_inertial, 3),
        ("roll_ref_inertial", _roll_ref_or_default(roll_ref_inertial), 3),
        ("torque_ext", torque_ext, 3),
    ]
    batch, arrays, rows = attitude_rows(named)
    _, _, _, pa, xa, ea = arrays
    plant = plant_of(config)
    status = propagate_batch_arrays(*rows, True, pa, xa, np.zeros_like(ea), dt, n, *plant, k_a, k_w)
    return finish_rows(batch, rows, status, [name for name, _, _ in named], arrays)
