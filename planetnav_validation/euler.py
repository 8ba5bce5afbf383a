"""Yaw-pitch-roll (3-2-1) angles of Belokonov & Kramlikh (2007), in the project's quaternion convention.

The paper's sequence (ERRATA 002 item 5; its Symbol-font letters read theta, psi, phi):
the reference frame (its orbital frame O x2 y2 z2) is carried into the body frame O x1 y1 z1 by

1. ``psi`` (yaw) about z2,
2. ``theta`` (pitch) about the once-rotated y axis,
3. ``phi`` (roll) about the twice-rotated x axis, which is the body x1 axis.

In the project convention (``planetnav_env.attitude.quaternion``: scalar first, Hamilton,
``v_ref = R(q) @ v_body``) this is ``q = q_z(psi) * q_y(theta) * q_x(phi)``, i.e.
``R(q) = Rz(psi) Ry(theta) Rx(phi)``; its transpose is the paper's matrix ``M_x1x2`` of eq. (1)
(orbital components -> body components). The paper's quaternion ``v`` is therefore *numerically
the same four numbers* as the project's ``q`` of the body relative to the orbital frame, and the
paper's formula for ``v(psi, theta, phi)`` is reproduced exactly by :func:`quaternion_from_euler321`
(pinned by ``tests/env/test_wahba.py``).

All angles in radians; arrays broadcast over leading batch axes.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.attitude import quaternion as qt


def quaternion_from_euler321(psi: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Quaternion (scalar first, body relative to reference) of yaw ``psi``, pitch ``theta``, roll ``phi``.

    This is the paper's formula for ``v0..v3`` term by term [rad -> shape ``(..., 4)``].
    """
    psi, theta, phi = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (psi, theta, phi)))
    cy, sy = np.cos(0.5 * psi), np.sin(0.5 * psi)
    cp, sp = np.cos(0.5 * theta), np.sin(0.5 * theta)
    cr, sr = np.cos(0.5 * phi), np.sin(0.5 * phi)
    return np.stack(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ],
        axis=-1,
    )


def euler321_from_quaternion(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Yaw, pitch, roll [rad] of unit quaternion(s) ``q`` (..., 4).

    Ranges: ``psi, phi`` in (-pi, pi], ``theta`` in [-pi/2, pi/2]. At ``|theta| = pi/2`` (gimbal lock)
    only ``psi - phi`` (or ``psi + phi``) is defined; the split returned there is arbitrary, which is
    why Euler-angle *differences* are a poor error measure near lock (see docs/gnss_magnetometer.md).
    Invariant under ``q -> -q``.
    """
    q = np.asarray(q, dtype=float)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    psi = np.arctan2(2.0 * (q0 * q3 + q1 * q2), 1.0 - 2.0 * (q2 * q2 + q3 * q3))
    # Clip: rounding can push |sin theta| a hair above 1 at gimbal lock.
    theta = np.arcsin(np.clip(2.0 * (q0 * q2 - q1 * q3), -1.0, 1.0))
    phi = np.arctan2(2.0 * (q0 * q1 + q2 * q3), 1.0 - 2.0 * (q1 * q1 + q2 * q2))
    return psi, theta, phi


def wrap_pi(angle: np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to [-pi, pi) [rad]."""
    return (np.asarray(angle, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def euler321_differences(q_true: np.ndarray, q_est: np.ndarray) -> np.ndarray:
    """``|angle(q_est) - angle(q_true)|`` wrapped to [0, pi] for (psi, theta, phi) [rad], shape (..., 3)."""
    a = np.stack(euler321_from_quaternion(q_true), axis=-1)
    b = np.stack(euler321_from_quaternion(q_est), axis=-1)
    return np.abs(wrap_pi(b - a))


def euler321_error_angles(q_true: np.ndarray, q_est: np.ndarray) -> np.ndarray:
    """|yaw, pitch, roll| [rad] of the error rotation ``dq = conj(q_true) * q_est``, shape (..., 3).

    ``dq`` carries the true body axes into the estimated ones (body-frame error). Unlike
    :func:`euler321_differences` it is well defined at every attitude, including gimbal lock.
    """
    dq = qt.multiply(qt.conjugate(q_true), q_est)
    return np.abs(np.stack(euler321_from_quaternion(dq), axis=-1))
