"""Quaternions: the one convention of planetnav.

Convention (pinned by ``tests/env/test_quaternion.py``)
---------------------------------------------------
* Scalar first: ``q = [q0, q1, q2, q3] = [cos(a/2), sin(a/2) * axis]``.
* Hamilton product: ``i*j = k``.
* ``q`` is the attitude of the body frame B relative to the inertial frame I and acts
  as an *active* rotation carrying body-frame components into inertial-frame ones:
  ``v_I = q * v_B * conj(q) = dcm_body_to_inertial(q) @ v_B``.
  The attitude matrix that maps inertial components into body components is its
  transpose, ``dcm_inertial_to_body(q)``.
* Angular velocity ``omega`` is that of B relative to I, in body components, and
  ``q_dot = 0.5 * q * [0, omega] = 0.5 * Omega(omega) @ q`` with the thesis's
  matrix (section 2.4), which is exactly this product for scalar-first q.

All functions take arrays with a leading batch shape ``(..., 4)`` / ``(..., 3)``.
"""

from __future__ import annotations

import numpy as np


def normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternion(s); raises ``ValueError`` on a zero-norm input."""
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n == 0.0) or not np.all(np.isfinite(n)):
        raise ValueError("cannot normalize a zero or non-finite quaternion")
    return q / n


def conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p * q`` (broadcast over leading axes)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    p0, p1, p2, p3 = np.moveaxis(p, -1, 0)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis=-1,
    )


def dcm_body_to_inertial(q: np.ndarray) -> np.ndarray:
    """Rotation matrix R with ``v_I = R @ v_B`` for unit ``q`` (shape ``(..., 3, 3)``)."""
    q = np.asarray(q, dtype=float)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    r[..., 0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    r[..., 0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    r[..., 1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    r[..., 1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    r[..., 1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    r[..., 2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    r[..., 2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    r[..., 2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    return r


def dcm_inertial_to_body(q: np.ndarray) -> np.ndarray:
    """Attitude matrix A with ``v_B = A @ v_I`` (the transpose of :func:`dcm_body_to_inertial`)."""
    return np.swapaxes(dcm_body_to_inertial(q), -1, -2)


def from_dcm_body_to_inertial(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (q0 >= 0) of a body-to-inertial rotation matrix (Shepperd's method)."""
    r = np.asarray(r, dtype=float)
    batch = r.shape[:-2]
    r = r.reshape(-1, 3, 3)
    tr = np.trace(r, axis1=1, axis2=2)
    # Largest of 4 q_i^2 candidates keeps the division well conditioned.
    cand = np.stack([tr, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]], axis=1)
    k = np.argmax(cand, axis=1)
    q = np.empty((r.shape[0], 4))
    for i in range(r.shape[0]):
        m = r[i]
        if k[i] == 0:
            s = 2.0 * np.sqrt(1.0 + tr[i])
            q[i] = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        elif k[i] == 1:
            s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
            q[i] = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
        elif k[i] == 2:
            s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
            q[i] = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
        else:
            s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
            q[i] = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q *= np.where(q[:, :1] < 0.0, -1.0, 1.0)
    return normalize(q).reshape(batch + (4,))


def from_axis_angle(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Quaternion of a rotation by ``angle`` [rad] about unit ``axis`` (right-hand rule)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def rotate_body_to_inertial(q: np.ndarray, v_body: np.ndarray) -> np.ndarray:
    """``v_I = R(q) @ v_B`` for batches."""
    return np.einsum("...ij,...j->...i", dcm_body_to_inertial(q), v_body)


def rotate_inertial_to_body(q: np.ndarray, v_inertial: np.ndarray) -> np.ndarray:
    """``v_B = R(q)^T @ v_I`` for batches."""
    return np.einsum("...ji,...j->...i", dcm_body_to_inertial(q), v_inertial)


def omega_matrix(omega: np.ndarray) -> np.ndarray:
    """The thesis's 4x4 matrix Omega(omega) with ``q_dot = 0.5 * Omega @ q`` (section 2.4)."""
    w = np.asarray(omega, dtype=float)
    wx, wy, wz = np.moveaxis(w, -1, 0)
    z = np.zeros_like(wx)
    return np.stack(
        [
            np.stack([z, -wx, -wy, -wz], axis=-1),
            np.stack([wx, z, wz, -wy], axis=-1),
            np.stack([wy, -wz, z, wx], axis=-1),
            np.stack([wz, wy, -wx, z], axis=-1),
        ],
        axis=-2,
    )


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Total rotation angle [rad] between two attitudes, in [0, pi] (sign-invariant)."""
    d = np.abs(np.sum(normalize(p) * normalize(q), axis=-1))
    return 2.0 * np.arccos(np.clip(d, 0.0, 1.0))
