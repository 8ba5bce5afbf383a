"""Body angular rate from a series of attitude quaternions (Belokonov & Kramlikh 2007, eq. (3)).

Quaternions in the convention of :mod:`planetnav_env.attitude.quaternion` (scalar first, Hamilton, body
relative to the reference frame); rates in body components [rad/s]. Pinned by ``tests/env/test_wahba.py``.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.errors import InvalidParameterError, require_finite


def enforce_sign_continuity(q: np.ndarray) -> np.ndarray:
    """The paper's sign rule for a time series ``q`` (..., T, 4) of quaternions known up to sign.

    The paper asks for ``v0^(k) > 0`` and ``sum_i v_i^(k-1) v_i^(k) > 0``. Both cannot always hold (a
    rotation through ``q0 = 0`` must change one of them); differentiating the series needs the second, so
    the first sample gets ``q0 >= 0`` and every later sample the sign that makes its dot product with the
    (already corrected) previous one non-negative.
    """
    q = require_finite("quaternion series", q)
    if q.ndim < 2 or q.shape[-1] != 4:
        raise InvalidParameterError(f"quaternion series must have shape (..., T, 4), got {q.shape}")
    dots = np.sum(q[..., 1:, :] * q[..., :-1, :], axis=-1)
    step = np.where(dots < 0.0, -1.0, 1.0)
    first = np.where(q[..., :1, 0] < 0.0, -1.0, 1.0)
    sign = np.concatenate([first, first * np.cumprod(step, axis=-1)], axis=-1)
    return q * sign[..., None]


def body_rate_from_quaternion_rate(q: np.ndarray, q_dot: np.ndarray) -> np.ndarray:
    """Eq. (3) with its second line corrected (ERRATA item 2): ``omega = 2 Xi(q)^T q_dot`` [rad/s].

    ``q`` (..., 4) body relative to reference, ``q_dot`` (..., 4) its time derivative [1/s]. Returns the
    angular velocity of the body relative to the *reference* frame, in body components (..., 3). For the
    paper's orbital reference frame this is the rate relative to the orbital frame; the absolute rate
    the paper names needs the orbital rate added (``omega_abs = omega + R(q)^T omega_orb``).
    """
    q = np.asarray(q, dtype=float)
    e = np.asarray(q_dot, dtype=float)
    v0, v1, v2, v3 = np.moveaxis(q, -1, 0)
    e0, e1, e2, e3 = np.moveaxis(e, -1, 0)
    return 2.0 * np.stack(
        [
            v0 * e1 - v1 * e0 + v3 * e2 - v2 * e3,
            v0 * e2 - v2 * e0 + v1 * e3 - v3 * e1,
            v0 * e3 - v3 * e0 + v2 * e1 - v1 * e2,
        ],
        axis=-1,
    )


def rate_from_quaternions(q: np.ndarray, dt: float) -> np.ndarray:
    """Body angular rate [rad/s] from attitude estimates ``q`` (..., T, 4) sampled every ``dt`` [s].

    Applies :func:`enforce_sign_continuity` first (estimates are known up to sign), differentiates
    numerically (second-order central differences inside, second-order one-sided at the ends when
    ``T >= 3``, first order when ``T == 2``), then eq. (3). Returns (..., T, 3) in body components.
    """
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0.0:
        raise InvalidParameterError(f"dt must be a positive finite number of seconds, got {dt!r}")
    q = enforce_sign_continuity(q)
    t = q.shape[-2]
    if t < 2:
        raise InvalidParameterError(f"need at least 2 quaternions to differentiate, got {t}")
    q_dot = np.gradient(q, dt, axis=-2, edge_order=2 if t >= 3 else 1)
    return body_rate_from_quaternion_rate(q, q_dot)
