"""Rigid spacecraft with three reaction wheels: Euler's equations, quaternion kinematics, RK4.

Frames and conventions
----------------------
* ``q`` (scalar first, Hamilton) is the attitude of the body frame B relative to the inertial frame I
  (ICRF/J2000 equatorial); it carries body components into inertial ones, ``v_I = R(q) v_B``
  (see :mod:`planetnav_env.attitude.quaternion`).
* ``omega`` [rad/s]: angular velocity of B relative to I, body components.
* ``h_w`` [N m s]: total angular momentum of the wheels *relative to the body*, body components. The
  three wheels spin about the body axes x, y, z, so ``h_w[i]`` is wheel i's momentum.
* Torques [N m] are in body components.

Equations (the thesis, section 2.4, extended with the wheels' momentum)
-----------------------------------------------------------------------
::

    q_dot      = 0.5 * Omega(omega) @ q
    J omega_dot + omega x (J omega + h_w) = U + U_ext
    h_w_dot    = -U

``U`` is the *wheel torque on the body*: the thesis's "control torque U from the flywheels". The wheels
receive the reaction ``-U``, so their momentum changes by ``-U dt``; the total momentum
``R(q) (J omega + h_w)`` then changes only by the external torque ``U_ext``. With ``h_w = 0`` this is the
thesis's ``J omega_dot + omega x J omega = U``. ``J`` includes the wheels' mass (the whole vehicle's inertia
with the wheel rotors locked).

Wheel (actuator) model
----------------------
The commanded torque ``torque_cmd`` is held constant over each integration step (zero-order hold) and
turned into the applied torque ``U`` per axis by

1. clipping to ``[-torque_limit, +torque_limit]``;
2. momentum saturation: a wheel may not be pushed beyond ``+-momentum_capacity``. Since ``h_w_dot = -U`` is
   constant over the step, the torque is limited to the part that brings the wheel exactly to its limit at
   the end of the step; a wheel already at its limit applies zero torque in the direction that would load
   it further and any torque that unloads it. A wheel that starts beyond its capacity (allowed, e.g. a
   user-set initial state) can only be unloaded.

``numpy.inf`` for either limit means "unlimited" (the thesis models neither).

Implementation
--------------
Every formula lives once, in a numba kernel (``*_kernel`` functions below). The public functions validate
their input and loop the kernels over the batch; a single spacecraft is a batch of one and skips the
broadcasting. The kernels mirror :mod:`planetnav_env.attitude.quaternion` (``Omega`` and ``R(q)``) because
numba cannot call its numpy code; ``tests/env/test_attitude.py`` pins the two to each other and carries an
independent vectorised numpy reference of the integrator.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numba import njit

from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.disturbances import wheel_friction
from planetnav_env.codes import AttitudeStatus
from planetnav_env.errors import (
    InvalidParameterError,
    NonFiniteError,
    require_count,
    require_finite,
    require_positive,
)
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS, row_kernel

__all__ = [
    "AttitudeConfig",
    "WheelConfig",
    "applied_wheel_torque",
    "attitude_rk4_step",
    "inertial_angular_momentum",
    "kinetic_energy",
    "propagate_attitude",
]

# ---------------------------------------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------------------------------------


def _per_axis(owner: str, name: str, value: float | Sequence[float]) -> tuple[float, float, float]:
    """Three positive limits (``inf`` allowed: no limit) from a scalar or a length-3 sequence."""
    try:
        a = np.broadcast_to(np.asarray(value, dtype=float), (3,))
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(
            f"{owner}.{name} must be a number or 3 numbers (one per body axis), got {value!r}"
        ) from exc
    if np.any(np.isnan(a)) or np.any(a <= 0.0):
        raise InvalidParameterError(
            f"{owner}.{name} must be positive (inf = unlimited) on every axis, got {value!r}"
        )
    return (float(a[0]), float(a[1]), float(a[2]))


@dataclass(frozen=True)
class WheelConfig:
    """Three reaction wheels along the body axes x, y, z.

    Attributes
    ----------
    torque_limit:
        Maximum torque per wheel [N m], scalar (all axes) or one per body axis. Default 0.01 N m: a small
        commercial wheel; the thesis gives no value. ``inf`` disables the limit.
    momentum_capacity:
        Maximum stored momentum per wheel [N m s], scalar or per axis. Default 0.5 N m s (same class of
        wheel, our guess). ``inf`` disables the limit.
    """

    torque_limit: float | Sequence[float] = 0.01
    momentum_capacity: float | Sequence[float] = 0.5

    def __post_init__(self) -> None:
        # Stored as tuples so the frozen config stays hashable and comparable.
        object.__setattr__(self, "torque_limit", _per_axis("WheelConfig", "torque_limit", self.torque_limit))
        object.__setattr__(
            self, "momentum_capacity", _per_axis("WheelConfig", "momentum_capacity", self.momentum_capacity)
        )

    @classmethod
    def unlimited(cls) -> WheelConfig:
        """Ideal actuator (no torque or momentum limit): the thesis's assumption."""
        return cls(torque_limit=math.inf, momentum_capacity=math.inf)

    @cached_property
    def torque_limit_array(self) -> np.ndarray:
        """``torque_limit`` as a read-only float array of shape (3,) [N m]."""
        return _readonly(np.array(self.torque_limit))

    @cached_property
    def momentum_capacity_array(self) -> np.ndarray:
        """``momentum_capacity`` as a read-only float array of shape (3,) [N m s]."""
        return _readonly(np.array(self.momentum_capacity))


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class AttitudeConfig:
    """Mass properties and actuators of the spacecraft.

    Attributes
    ----------
    inertia:
        Inertia tensor about the centre of mass in body axes [kg m^2]: 3 principal moments (diagonal) or a
        full symmetric positive-definite 3x3 matrix. The principal moments must satisfy the triangle
        inequality (a real mass distribution). Default diag(10, 12, 8) kg m^2: a guess for a small
        (~50-100 kg) spacecraft; the thesis gives no inertia.
    wheels:
        The reaction wheels (:class:`WheelConfig`).
    """

    inertia: Sequence[float] | Sequence[Sequence[float]] | np.ndarray = (10.0, 12.0, 8.0)
    wheels: WheelConfig = field(default_factory=WheelConfig)

    def __post_init__(self) -> None:
        try:
            j = np.array(self.inertia, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InvalidParameterError(
                f"AttitudeConfig.inertia must be 3 moments or a 3x3 matrix [kg m^2], got {self.inertia!r}"
            ) from exc
        if j.shape == (3,):
            j = np.diag(j)
        if j.shape != (3, 3):
            raise InvalidParameterError(
                f"AttitudeConfig.inertia must be 3 moments or a 3x3 matrix [kg m^2], got shape {j.shape}"
            )
        if not np.all(np.isfinite(j)):
            raise InvalidParameterError(f"AttitudeConfig.inertia must be finite, got {self.inertia!r}")
        scale = np.max(np.abs(j))
        if not np.allclose(j, j.T, rtol=0.0, atol=1e-12 * scale):
            raise InvalidParameterError(f"AttitudeConfig.inertia must be symmetric, got {j.tolist()}")
        j = 0.5 * (j + j.T)
        eig = np.linalg.eigvalsh(j)
        if scale == 0.0 or eig[0] <= 1e-12 * scale:
            raise InvalidParameterError(
                f"AttitudeConfig.inertia must be positive definite, got principal moments {eig.tolist()} "
                f"from {self.inertia!r}"
            )
        # eig is sorted: only the largest moment can violate I_max <= I_1 + I_2.
        if eig[2] > (eig[0] + eig[1]) * (1.0 + 1e-12):
            raise InvalidParameterError(
                f"AttitudeConfig.inertia principal moments {eig.tolist()} violate the triangle inequality "
                "(no physical body has them)"
            )
        if not isinstance(self.wheels, WheelConfig):
            raise InvalidParameterError(f"AttitudeConfig.wheels must be a WheelConfig, got {self.wheels!r}")
        object.__setattr__(self, "inertia", tuple(tuple(float(x) for x in row) for row in j))

    @cached_property
    def inertia_matrix(self) -> np.ndarray:
        """J as a read-only (3, 3) array [kg m^2]."""
        return _readonly(np.array(self.inertia))

    @cached_property
    def inertia_inverse(self) -> np.ndarray:
        """J^-1 as a read-only (3, 3) array [1/(kg m^2)]."""
        return _readonly(np.linalg.inv(self.inertia_matrix))


# ---------------------------------------------------------------------------------------------------------
# Numba kernels (the one implementation of each formula)
# ---------------------------------------------------------------------------------------------------------


@row_kernel
def dcm_body_to_inertial_kernel(q0: float, q1: float, q2: float, q3: float, out: np.ndarray) -> None:
    """R(q) into ``out`` (3, 3); numba mirror of
    :func:`planetnav_env.attitude.quaternion.dcm_body_to_inertial`."""
    out[0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    out[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    out[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    out[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    out[1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    out[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    out[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    out[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    out[2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@row_kernel
def wheel_torque_kernel(
    u_cmd: np.ndarray, h_w: np.ndarray, dt: float, tau_max: np.ndarray, h_max: np.ndarray, out: np.ndarray
) -> None:
    """Applied wheel torque on the body [N m] from the command (see the module's wheel model)."""
    for i in range(3):
        # h_w(t + dt) = h_w - U dt must stay in [-h_max, h_max]; the min/max with 0 keep a wheel that is
        # already beyond its capacity from being driven by this bound (it may only unload).
        lo = max(-tau_max[i], min(0.0, (h_w[i] - h_max[i]) / dt))
        hi = min(tau_max[i], max(0.0, (h_w[i] + h_max[i]) / dt))
        out[i] = min(max(u_cmd[i], lo), hi)


@row_kernel
def flight_wheel_torque_kernel(
    u_cmd: np.ndarray,
    h_w: np.ndarray,
    dt: float,
    tau_max: np.ndarray,
    h_max: np.ndarray,
    h_speed: float,
    coulomb: float,
    viscous: float,
    j_wheel: float,
    compensation: float,
    out: np.ndarray,
) -> None:
    """The flight world's wheels: the torque [N m] they apply to the body over a sub-step of ``dt`` [s]
    under the command ``u_cmd`` [N m], held over it (zero-order hold).

    1. the wheel limits of :func:`wheel_torque_kernel` (torque clip, momentum capacity);
    2. the speed limit (back EMF): the motor's torque toward a higher wheel speed is at most
       ``tau_max (1 - |h| / h_speed)`` (``h_speed = J_w * no-load speed`` [N m s]; inf: none); a wheel
       spins up when the torque on the body opposes its momentum (``h_dot = -U``);
    3. bearing friction (:func:`~planetnav_env.attitude.disturbances.wheel_friction`, Coulomb ``coulomb``
       [N m] and viscous ``viscous`` [N m s] with the wheel inertia ``j_wheel`` [kg m^2]) at the wheel's
       momentum at the sub-step's start, no more than stops the wheel within the sub-step: the wheel
       receives ``tau_f``, the body ``-tau_f``, so the torque on the body is ``U - tau_f`` and
       ``h_dot = -(U - tau_f)`` (internal: the total momentum is unchanged); the drive's friction
       feed-forward adds ``compensation * tau_f`` to the motor's torque, so ``(1 - compensation) tau_f``
       remains."""
    wheel_torque_kernel(u_cmd, h_w, dt, tau_max, h_max, out)
    for i in range(3):
        h = h_w[i]
        if h_speed < math.inf and h != 0.0:
            avail = tau_max[i] * max(0.0, 1.0 - abs(h) / h_speed)
            if h > 0.0:
                out[i] = max(out[i], -avail)
            else:
                out[i] = min(out[i], avail)
        if h != 0.0 and (coulomb > 0.0 or viscous > 0.0):
            tf = wheel_friction(h, j_wheel, coulomb, viscous)
            stop = abs(h) / dt
            tf = max(-stop, min(stop, tf))
            out[i] -= (1.0 - compensation) * tf


@row_kernel
def _rates(
    y: np.ndarray, h: np.ndarray, m: np.ndarray, jm: np.ndarray, jinv: np.ndarray, dy: np.ndarray
) -> None:
    """d/dt of y = (q0..q3, wx, wy, wz) for wheel momentum h and non-gyroscopic torque m = U + U_ext."""
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    wx, wy, wz = y[4], y[5], y[6]
    # 0.5 * Omega(omega) @ q, the thesis's matrix written out.
    dy[0] = 0.5 * (-wx * q1 - wy * q2 - wz * q3)
    dy[1] = 0.5 * (wx * q0 + wz * q2 - wy * q3)
    dy[2] = 0.5 * (wy * q0 - wz * q1 + wx * q3)
    dy[3] = 0.5 * (wz * q0 + wy * q1 - wx * q2)
    hx = jm[0, 0] * wx + jm[0, 1] * wy + jm[0, 2] * wz + h[0]
    hy = jm[1, 0] * wx + jm[1, 1] * wy + jm[1, 2] * wz + h[1]
    hz = jm[2, 0] * wx + jm[2, 1] * wy + jm[2, 2] * wz + h[2]
    rx = m[0] - (wy * hz - wz * hy)
    ry = m[1] - (wz * hx - wx * hz)
    rz = m[2] - (wx * hy - wy * hx)
    dy[4] = jinv[0, 0] * rx + jinv[0, 1] * ry + jinv[0, 2] * rz
    dy[5] = jinv[1, 0] * rx + jinv[1, 1] * ry + jinv[1, 2] * rz
    dy[6] = jinv[2, 0] * rx + jinv[2, 1] * ry + jinv[2, 2] * rz


@row_kernel
def rk4_substep_kernel(
    y: np.ndarray,
    h_w: np.ndarray,
    u: np.ndarray,
    u_ext: np.ndarray,
    dt: float,
    jm: np.ndarray,
    jinv: np.ndarray,
    work: np.ndarray,
) -> None:
    """One RK4 step in place of y = (q, omega) and h_w with applied wheel torque ``u`` held over ``dt``.

    ``work`` is a (8, 7) scratch array. ``h_w`` is integrated exactly (it is linear in time under a
    zero-order hold) and evaluated at each stage time; q is normalised after the step.
    """
    k1, k2, k3, k4, tmp = work[0], work[1], work[2], work[3], work[4]
    m = work[5, :3]
    hs = work[6, :3]
    for i in range(3):
        m[i] = u[i] + u_ext[i]
        hs[i] = h_w[i]
    _rates(y, hs, m, jm, jinv, k1)
    for i in range(3):
        hs[i] = h_w[i] - 0.5 * dt * u[i]
    for i in range(7):
        tmp[i] = y[i] + 0.5 * dt * k1[i]
    _rates(tmp, hs, m, jm, jinv, k2)
    for i in range(7):
        tmp[i] = y[i] + 0.5 * dt * k2[i]
    _rates(tmp, hs, m, jm, jinv, k3)
    for i in range(3):
        hs[i] = h_w[i] - dt * u[i]
    for i in range(7):
        tmp[i] = y[i] + dt * k3[i]
    _rates(tmp, hs, m, jm, jinv, k4)
    for i in range(7):
        y[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    n = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
    for i in range(4):
        y[i] /= n
    for i in range(3):
        h_w[i] = hs[i]


@row_kernel
def all_finite_kernel(a: np.ndarray) -> bool:
    """True if every entry of the 2-D array ``a`` is finite."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@row_kernel
def normalize_quaternion_kernel(q: np.ndarray, out: np.ndarray) -> bool:
    """out[:4] = q / |q|; False (out untouched) for a zero quaternion."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n == 0.0:
        return False
    for i in range(4):
        out[i] = q[i] / n
    return True


@row_kernel
def load_state_kernel(q: np.ndarray, omega: np.ndarray, y: np.ndarray) -> bool:
    """y = (q / |q|, omega); False (y undefined) for a zero quaternion."""
    if not normalize_quaternion_kernel(q, y):
        return False
    for i in range(3):
        y[4 + i] = omega[i]
    return True


@row_kernel
def store_state_kernel(
    y: np.ndarray, h: np.ndarray, q_out: np.ndarray, w_out: np.ndarray, h_out: np.ndarray
) -> bool:
    """Copy y = (q, omega) and h out; False if any of them is non-finite (the step blew up)."""
    ok = True
    for i in range(4):
        q_out[i] = y[i]
        ok = ok and math.isfinite(y[i])
    for i in range(3):
        w_out[i] = y[4 + i]
        h_out[i] = h[i]
        ok = ok and math.isfinite(y[4 + i]) and math.isfinite(h[i])
    return ok


# Status codes of the batch kernels (AttitudeStatus as ints: numba folds int globals), turned into
# exceptions by raise_state_error.
STATUS_OK = int(AttitudeStatus.OK)
STATUS_NONFINITE_INPUT = int(AttitudeStatus.NONFINITE_INPUT)
STATUS_ZERO_Q = int(AttitudeStatus.ZERO_Q)
STATUS_NONFINITE_RESULT = int(AttitudeStatus.NONFINITE_RESULT)
STATUS_ZERO_DIRECTION = int(AttitudeStatus.ZERO_DIRECTION)


@njit(inline="always", **ROW_KERNEL_OPTIONS)
def plant_substep_kernel(
    y: np.ndarray,
    h_w: np.ndarray,
    u_cmd: np.ndarray,
    u_ext: np.ndarray,
    dt: float,
    jm: np.ndarray,
    jinv: np.ndarray,
    tau_max: np.ndarray,
    h_max: np.ndarray,
    work: np.ndarray,
    u: np.ndarray,
) -> None:
    """One sub-step of ``dt`` [s] of the plant under the command ``u_cmd`` [N m, body] held over it: wheel
    limits -> RK4, in place on ``y = (q, omega)`` and ``h_w``; ``u`` receives the applied wheel torque.

    Every sub-step loop (open loop here, closed loop in :mod:`planetnav_env.attitude.pointing`) calls it,
    so the plant is written once and the controller only chooses the command. Numba inlines it into its
    callers (``inline="always"``, at numba's IR level: the arithmetic is the same): compiled as a function
    of its own, it would add one call level to every sub-step of every slewing or torque step."""
    wheel_torque_kernel(u_cmd, h_w, dt, tau_max, h_max, u)
    rk4_substep_kernel(y, h_w, u, u_ext, dt, jm, jinv, work)


class Plant(NamedTuple):
    """The plant's constants a sub-step reads (:func:`plant_of` builds it from an :class:`AttitudeConfig`)."""

    jm: np.ndarray  # (3, 3) inertia J [kg m^2]
    jinv: np.ndarray  # (3, 3) J^-1 [1/(kg m^2)]
    tau_max: np.ndarray  # (3,) wheel torque limits [N m]
    h_max: np.ndarray  # (3,) wheel momentum capacities [N m s]


class AttitudeRows(NamedTuple):
    """A batch of ``N`` spacecraft for the batch kernels: the inputs (read) and the outputs (written)."""

    q: np.ndarray  # (N, 4) attitude, body -> inertial, scalar first
    omega: np.ndarray  # (N, 3) body rate [rad/s]
    h_w: np.ndarray  # (N, 3) wheel momentum [N m s]
    u_ext: np.ndarray  # (N, 3) external torque [N m]
    q_out: np.ndarray  # (N, 4)
    w_out: np.ndarray  # (N, 3)
    h_out: np.ndarray  # (N, 3)


def plant_of(config: AttitudeConfig) -> Plant:
    """The :class:`Plant` record of ``config`` (its read-only arrays, not copies)."""
    wheels = config.wheels
    return Plant(
        jm=config.inertia_matrix,
        jinv=config.inertia_inverse,
        tau_max=wheels.torque_limit_array,
        h_max=wheels.momentum_capacity_array,
    )


def attitude_rows(named: Sequence[tuple[str, object, int]]) -> tuple[tuple[int, ...], list, AttitudeRows]:
    """:func:`as_state_arrays` of ``named``, whose first three entries are ``q``, ``omega``, ``h_w`` and last
    one ``torque_ext``, and the :class:`AttitudeRows` record over them with fresh output arrays. Returns
    the batch shape, the arrays (in the order of ``named``) and the record."""
    batch, arrays = as_state_arrays(named)
    qa, wa, ha, ea = arrays[0], arrays[1], arrays[2], arrays[-1]
    rows = AttitudeRows(
        q=qa,
        omega=wa,
        h_w=ha,
        u_ext=ea,
        q_out=np.empty_like(qa),
        w_out=np.empty_like(wa),
        h_out=np.empty_like(ha),
    )
    return batch, arrays, rows


@row_kernel
def rows_finite_kernel(rows: AttitudeRows, u: np.ndarray) -> bool:
    """True if every input of ``rows`` and the (N, 3) command ``u`` are finite."""
    return (
        all_finite_kernel(rows.q)
        and all_finite_kernel(rows.omega)
        and all_finite_kernel(rows.h_w)
        and all_finite_kernel(rows.u_ext)
        and all_finite_kernel(u)
    )


@row_kernel
def load_row_kernel(rows: AttitudeRows, b: int, y: np.ndarray, h: np.ndarray) -> bool:
    """y = (q / |q|, omega) and h = h_w of row ``b``; False for a zero quaternion."""
    for j in range(3):
        h[j] = rows.h_w[b, j]
    return load_state_kernel(rows.q[b], rows.omega[b], y)


@row_kernel
def store_row_kernel(rows: AttitudeRows, b: int, y: np.ndarray, h: np.ndarray) -> bool:
    """:func:`store_state_kernel` into the outputs of row ``b``."""
    return store_state_kernel(y, h, rows.q_out[b], rows.w_out[b], rows.h_out[b])


def finish_rows(
    batch: tuple[int, ...],
    rows: AttitudeRows,
    status: int,
    names: Sequence[str],
    arrays: Sequence[np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raise the error of a batch kernel's ``status`` (:func:`raise_state_error` on the inputs ``arrays``
    named ``names``), else return the outputs of ``rows`` as ``(q, omega, h_w)`` of the batch shape. The
    name-array pairs are built only on an error: this runs on every call of the public propagators."""
    if status:
        raise_state_error(status, list(zip(names, arrays, strict=True)))
    return (
        rows.q_out.reshape(batch + (4,)),
        rows.w_out.reshape(batch + (3,)),
        rows.h_out.reshape(batch + (3,)),
    )


@njit(cache=True)
def propagate_open_loop_batch(
    rows: AttitudeRows, u_cmd: np.ndarray, dt: float, n_substeps: int, plant: Plant
) -> int:
    """``n_substeps`` :func:`plant_substep_kernel` steps of ``dt`` [s] of every row ``b`` under the constant
    command ``u_cmd[b]`` [N m]; returns a status code (``STATUS_*``)."""
    if not rows_finite_kernel(rows, u_cmd):
        return STATUS_NONFINITE_INPUT
    work = np.empty((8, 7))
    y, h, u = np.empty(7), np.empty(3), np.empty(3)
    for b in range(rows.q.shape[0]):
        if not load_row_kernel(rows, b, y, h):
            return STATUS_ZERO_Q
        for _ in range(n_substeps):
            plant_substep_kernel(
                y, h, u_cmd[b], rows.u_ext[b], dt, plant.jm, plant.jinv, plant.tau_max, plant.h_max, work, u
            )
        if not store_row_kernel(rows, b, y, h):
            return STATUS_NONFINITE_RESULT
    return STATUS_OK


@njit(cache=True)
def open_loop_batch_arrays(
    q, omega, h_w, u_ext, q_out, w_out, h_out, u_cmd, dt, n_substeps, jm, jinv, tau_max, h_max
):
    """:func:`propagate_open_loop_batch` for callers in Python: the fields of :class:`AttitudeRows` and
    :class:`Plant` as plain arrays (``*rows``, ``*plant``), the records built here. Numba types a named
    tuple passed from Python about 0.5 us per array slower than the array itself."""
    rows = AttitudeRows(q=q, omega=omega, h_w=h_w, u_ext=u_ext, q_out=q_out, w_out=w_out, h_out=h_out)
    plant = Plant(jm=jm, jinv=jinv, tau_max=tau_max, h_max=h_max)
    return propagate_open_loop_batch(rows, u_cmd, dt, n_substeps, plant)


@njit(cache=True)
def _wheel_torque_batch(
    u_cmd: np.ndarray, h_w: np.ndarray, dt: float, tau_max: np.ndarray, h_max: np.ndarray, out: np.ndarray
) -> None:
    for b in range(u_cmd.shape[0]):
        wheel_torque_kernel(u_cmd[b], h_w[b], dt, tau_max, h_max, out[b])


# ---------------------------------------------------------------------------------------------------------
# Input handling shared with planetnav_env.attitude.pointing (which imports this module, never the reverse)
# ---------------------------------------------------------------------------------------------------------


def require_substeps(n_substeps: int) -> int:
    """``n_substeps`` as a positive int, or :class:`InvalidParameterError` naming it."""
    return require_count("n_substeps", n_substeps)


def as_state_arrays(
    named: Sequence[tuple[str, object, int]],
) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """Validate and broadcast (name, array, last-axis length) triples to one batch shape.

    Returns the common batch shape and the arrays as C-contiguous float64 of shape (N, last-axis length).
    Raises :class:`InvalidParameterError` for a wrong last axis or incompatible batch shapes. Finiteness is
    checked by the kernels (cheaper), see :func:`raise_state_error`.
    """
    # Fast path for the env's case, a single spacecraft as 1-D float arrays: broadcasting costs ~20 us.
    fast = []
    for _, value, width in named:
        if not (
            type(value) is np.ndarray
            and value.shape == (width,)
            and value.dtype == np.float64
            and value.flags.c_contiguous
            and value.flags.writeable
        ):
            break
        fast.append(value.reshape(1, width))
    else:
        return (), fast
    arrays = []
    for name, value, width in named:
        a = np.asarray(value, dtype=float)
        if a.ndim == 0 or a.shape[-1] != width:
            raise InvalidParameterError(f"{name} must have shape (..., {width}), got {a.shape}")
        arrays.append(a)
    try:
        batch = np.broadcast_shapes(*(a.shape[:-1] for a in arrays))
    except ValueError as exc:
        shapes = {name: a.shape for (name, _, _), a in zip(named, arrays, strict=True)}
        raise InvalidParameterError(f"incompatible batch shapes {shapes}") from exc
    n = math.prod(batch)
    # Always a fresh writable C array: numba compiles one specialisation per array type (layout and
    # read-only flag), and a single type keeps the cold-start compile to one.
    out = [
        np.array(np.broadcast_to(a, batch + a.shape[-1:]).reshape(n, a.shape[-1]), order="C") for a in arrays
    ]
    return batch, out


def raise_state_error(status: int, named: Sequence[tuple[str, np.ndarray]]) -> None:
    """Turn a batch kernel's status code into the specific exception naming the offending input.

    ``named`` lists the kernel's inputs as (name, array); the first one must be ``q``.
    """
    if status == STATUS_OK:
        return
    if status == STATUS_NONFINITE_INPUT:
        for name, a in named:
            require_finite(name, a)
    if status == STATUS_ZERO_Q:
        q = named[0][1]
        rows = np.flatnonzero(np.all(q == 0.0, axis=-1)).tolist()
        raise InvalidParameterError(f"q must be a non-zero quaternion, got zeros in batch row(s) {rows[:4]}")
    if status == STATUS_NONFINITE_RESULT:
        raise NonFiniteError(
            "attitude propagation produced a non-finite state: the rates are too large for dt "
            "(reduce dt or check the inputs)"
        )
    if status == STATUS_ZERO_DIRECTION:
        raise InvalidParameterError("target_dir_inertial has zero length (target at the spacecraft)")
    raise RuntimeError(f"unexpected attitude kernel status {status}")  # pragma: no cover


# ---------------------------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------------------------


def propagate_attitude(
    q: np.ndarray,
    omega: np.ndarray,
    h_w: np.ndarray,
    torque_cmd: np.ndarray,
    dt: float,
    n_substeps: int,
    config: AttitudeConfig,
    torque_ext: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Advance the attitude state by ``n_substeps`` RK4 steps of ``dt`` [s] under a constant command.

    Parameters
    ----------
    q:
        Attitude quaternion(s) body->inertial, scalar first, shape (..., 4); normalised on entry.
    omega:
        Body rate [rad/s], body axes, shape (..., 3).
    h_w:
        Wheel momentum [N m s], body axes, shape (..., 3).
    torque_cmd:
        Commanded wheel torque on the body [N m], body axes, shape (..., 3), held over all sub-steps; the
        wheel limits are applied at every sub-step (see the module docstring).
    dt:
        Sub-step [s], > 0.
    n_substeps:
        Number of sub-steps, >= 1.
    config:
        Inertia and wheel limits.
    torque_ext:
        External (disturbance) torque [N m], body axes, shape (..., 3); default zero.

    Returns
    -------
    (q, omega, h_w) after ``n_substeps * dt`` seconds, with the broadcast batch shape of the inputs.

    Raises
    ------
    InvalidParameterError: ``dt``, ``n_substeps``, a shape or a zero quaternion.
    NonFiniteError: a NaN/inf input (named), or a non-finite result.
    """
    dt = require_positive("dt", dt)
    n = require_substeps(n_substeps)
    if torque_ext is None:
        torque_ext = np.zeros(3)
    names = ("q", "omega", "h_w", "torque_cmd", "torque_ext")
    raw = (q, omega, h_w, torque_cmd, torque_ext)
    batch, arrays, rows = attitude_rows(list(zip(names, raw, (4, 3, 3, 3, 3), strict=True)))
    status = open_loop_batch_arrays(*rows, arrays[3], dt, n, *plant_of(config))
    return finish_rows(batch, rows, status, names, arrays)


def attitude_rk4_step(
    q: np.ndarray,
    omega: np.ndarray,
    h_w: np.ndarray,
    torque_cmd: np.ndarray,
    dt: float,
    config: AttitudeConfig,
    torque_ext: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One RK4 step of ``dt`` [s] (batched): :func:`propagate_attitude` with ``n_substeps=1``."""
    return propagate_attitude(q, omega, h_w, torque_cmd, dt, 1, config, torque_ext)


def applied_wheel_torque(
    torque_cmd: np.ndarray, h_w: np.ndarray, dt: float, wheels: WheelConfig
) -> np.ndarray:
    """Torque [N m, body axes] the wheels actually apply to the body over a step of ``dt`` [s].

    The same limits as inside the integrator (torque clip, then momentum saturation); batched.
    """
    dt = require_positive("dt", dt)
    batch, (ua, ha) = as_state_arrays([("torque_cmd", torque_cmd, 3), ("h_w", h_w, 3)])
    require_finite("torque_cmd", ua)
    require_finite("h_w", ha)
    out = np.empty_like(ua)
    _wheel_torque_batch(ua, ha, dt, wheels.torque_limit_array, wheels.momentum_capacity_array, out)
    return out.reshape(batch + (3,))


def inertial_angular_momentum(
    q: np.ndarray, omega: np.ndarray, h_w: np.ndarray, config: AttitudeConfig
) -> np.ndarray:
    """Total angular momentum of body and wheels in inertial axes, ``R(q) (J omega + h_w)`` [N m s].

    Constant without external torque whatever the wheels do (they only exchange momentum with the body).
    """
    omega = np.asarray(omega, dtype=float)
    h_body = np.einsum("ij,...j->...i", config.inertia_matrix, omega) + np.asarray(h_w, dtype=float)
    return qt.rotate_body_to_inertial(qt.normalize(q), h_body)


def kinetic_energy(omega: np.ndarray, config: AttitudeConfig) -> np.ndarray:
    """Rotational kinetic energy of the rigid body ``0.5 omega . J omega`` [J].

    Excludes the wheels' spin energy (their axial inertia is not modelled); it is therefore constant only
    for torque-free motion with idle wheels (``h_w`` constant).
    """
    omega = np.asarray(omega, dtype=float)
    return 0.5 * np.einsum("...i,ij,...j->...", omega, config.inertia_matrix, omega)
