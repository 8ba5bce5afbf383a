"""Markley's SVD solution of Wahba's problem and Wahba's loss: the checks :func:`q_method` is held to.

Same conventions as :mod:`planetnav_env.attitude.wahba` (scalar-first Hamilton ``q`` of the body frame
relative to the reference frame, ``v_ref = R(q) @ v_body``; observations ``b`` in body components,
references ``r`` in reference components, unit vectors, weights ``a_i``). ``tests/env/test_wahba.py``
compares :func:`planetnav_env.attitude.wahba.q_method` (Davenport, the paper's form) with
:func:`svd_method` and checks its optimality with :func:`wahba_loss`.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.wahba import prepare_observations, quaternion_from_matrix


def svd_method(b: np.ndarray, r: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Markley's SVD solution of the same problem (independent cross-check of :func:`q_method`).

    ``B = sum a_i b_i r_i^T = U S V^T``; ``A = U diag(1, 1, det U det V) V^T`` is the optimal
    reference->body matrix and ``q`` (..., 4, ``q0 >= 0``) is that of ``R = A^T``.
    """
    b, r, w = prepare_observations(b, r, weights)
    bmat = np.einsum("...k,...ki,...kj->...ij", w, b, r)
    u, _, vt = np.linalg.svd(bmat)
    d = np.linalg.det(u) * np.linalg.det(vt)
    u = u.copy()
    u[..., :, 2] *= d[..., None]
    a = u @ vt
    return quaternion_from_matrix(np.swapaxes(a, -1, -2))


def wahba_loss(q: np.ndarray, b: np.ndarray, r: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Criterion (2), ``sum a_i |b_i - R(q)^T r_i|^2`` for unit vectors, shape (...)."""
    b, r, w = prepare_observations(b, r, weights)
    a = qt.dcm_inertial_to_body(np.asarray(q, dtype=float))
    pred = np.einsum("...ij,...kj->...ki", a, r)
    return np.sum(w * np.sum((b - pred) ** 2, axis=-1), axis=-1)
