"""Wahba's problem: attitude from pairs of unit vectors (Belokonov & Kramlikh 2007, eqs. (2), (3), (6)).

Conventions
-----------
Every function follows the project convention of ``planetnav_env.attitude.quaternion``: scalar-first Hamilton
quaternion ``q`` of the body frame B relative to a reference frame F (inertial for the star tracker, the
orbital frame O x2 y2 z2 for the paper), acting as ``v_F = R(q) @ v_B``.

Inputs are *observations* ``b_i`` (body components; the paper's ``U_1^i``) and *references* ``r_i``
(reference-frame components; the paper's ``U_2^i``) with weights ``a_i``. Wahba's loss (the paper's
criterion (2)) is

    J(A) = sum_i a_i |b_i - A r_i|^2,   A = R(q)^T   (reference -> body),

so the paper's matrix ``M_x1x2`` of eq. (1) (with m32 corrected, ERRATA 002 item 1) is ``R(v)^T`` and the
paper's quaternion ``v`` *is* the project's ``q`` of the body relative to the orbital frame: same four
numbers, same order (``v0`` scalar). ``tests/env/test_wahba.py`` pins this.

Davenport's q-method, in the paper's form, with the sign convention made explicit
----------------------------------------------------------------------------------
With ``sigma = sum a_i b_i.r_i``, ``z = sum a_i b_i x r_i``, ``S_D = sum a_i (b_i r_i^T + r_i b_i^T)``,
Davenport's matrix in scalar-first order is ``K = [[sigma, z^T], [z, S_D - sigma I]]`` and the optimal
``q`` is its eigenvector of the *largest* eigenvalue (``J = 2 (sum a_i - lambda_max)``). The paper's
matrix (6) is built with ``S = I (b.r) - r b^T - b r^T``, ``Z = -(b x r)``, ``t = -b.r`` in the layout
``[[S, Z], [Z^T, t]]``: that is ``-K`` written in scalar-*last* order (ERRATA items 3, 4), so its eigenvector
of the *smallest* eigenvalue is ``(q1, q2, q3, q0)``. :func:`q_method` builds exactly the paper's matrix,
with the weights ``a_i`` of criterion (2) (not the printed ``1/a_i``, ERRATA item 3), and reorders to
scalar-first.

Arrays broadcast over leading batch axes: vectors ``(..., n, 3)``, weights ``(..., n)``.
"""

from __future__ import annotations

import numpy as np

from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import DegenerateGeometryError, InvalidParameterError, require_finite

#: Relative threshold on the second invariant of a weighted scatter matrix (``sin^2`` of the largest
#: angle between the vectors, over 4): below it the set is treated as collinear. 1e-12 corresponds to
#: two vectors about 0.4 arcsec apart, far below any real sensor geometry.
COLLINEAR_TOL = 1e-12


def prepare_observations(
    b: np.ndarray, r: np.ndarray, weights: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate, broadcast and normalise observation/reference vectors and weights."""
    b = require_finite("observation vectors b", b)
    r = require_finite("reference vectors r", r)
    if b.ndim < 2 or b.shape[-1] != 3 or r.ndim < 2 or r.shape[-1] != 3:
        raise InvalidParameterError(f"vectors must have shape (..., n, 3); got b {b.shape} and r {r.shape}")
    w = np.ones(1) if weights is None else require_finite("weights", weights)
    if np.any(w < 0.0):
        raise InvalidParameterError(f"weights must be >= 0, got min {w.min()!r}")
    try:
        shape = np.broadcast_shapes(b.shape[:-1], r.shape[:-1], w.shape)
    except ValueError:
        raise InvalidParameterError(
            f"shapes do not broadcast: b {b.shape}, r {r.shape}, weights {w.shape} "
            "(want (..., n, 3) and (..., n))"
        ) from None
    b = np.broadcast_to(b, shape + (3,))
    r = np.broadcast_to(r, shape + (3,))
    w = np.broadcast_to(w, shape)
    n = shape[-1]
    if n < 2:
        raise DegenerateGeometryError(
            f"Wahba's problem needs at least two non-parallel vector pairs; got {n} vector pair(s)"
        )
    nb = np.linalg.norm(b, axis=-1)
    nr = np.linalg.norm(r, axis=-1)
    # A zero vector with a non-zero weight has no direction: that is a caller error, not a
    # solvable case; zero-weight entries (padding) may be anything finite.
    zero = ((nb == 0.0) | (nr == 0.0)) & (w > 0.0)
    if np.any(zero):
        bad = np.argwhere(zero)[:4].tolist()
        raise DegenerateGeometryError(f"zero-length observation or reference vector at index {bad}")
    b = b / np.where(nb == 0.0, 1.0, nb)[..., None]
    r = r / np.where(nr == 0.0, 1.0, nr)[..., None]
    _require_two_directions("observation", b, w)
    _require_two_directions("reference", r, w)
    return b, r, w


def _require_two_directions(name: str, v: np.ndarray, w: np.ndarray) -> None:
    """Raise unless the weighted unit vectors ``v`` span at least a plane (rank >= 2)."""
    m = np.einsum("...k,...ki,...kj->...ij", w, v, v)
    tr = np.trace(m, axis1=-2, axis2=-1)
    # Second invariant c2 = sum of 2x2 principal minors = l1 l2 + l1 l3 + l2 l3; it is zero iff rank <= 1.
    # Cheaper than an eigen-decomposition of every batch member.
    c2 = 0.5 * (tr * tr - np.einsum("...ij,...ji->...", m, m))
    bad = ~(c2 > COLLINEAR_TOL * tr * tr)
    if np.any(bad):
        idx = np.argwhere(bad)[:4].tolist() if bad.ndim else []
        raise DegenerateGeometryError(
            f"{name} vectors with positive weight are all parallel (or fewer than two) at batch index "
            f"{idx}: the rotation about their common direction is undetermined"
        )


def paper_matrix(b: np.ndarray, r: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """The paper's 4x4 matrix (6), with weights ``a_i`` (ERRATA item 3), shape (..., 4, 4).

    Layout scalar-*last*: ``[[S, Z], [Z^T, t]]`` with ``S = sum a (I b.r - r b^T - b r^T)``,
    ``Z = -sum a b x r``, ``t = -sum a b.r``. Equals ``-P K P^T`` with ``K`` = :func:`davenport_k` and ``P``
    the permutation scalar-first -> scalar-last.
    """
    b, r, w = prepare_observations(b, r, weights)
    return _paper_matrix(b, r, w)


def _paper_matrix(b: np.ndarray, r: np.ndarray, w: np.ndarray) -> np.ndarray:
    return paper_matrix_from_profile(np.einsum("...k,...ki,...kj->...ij", w, b, r))


def paper_matrix_from_profile(bmat: np.ndarray) -> np.ndarray:
    """The paper's matrix (6) from the attitude profile matrix ``bmat = sum a_i b_i r_i^T`` (..., 3, 3).

    ``sum a b.r = tr(bmat)`` and ``sum a b x r = (B23 - B32, B31 - B13, B12 - B21)``, so (6) needs nothing
    else; this is the one place the matrix is assembled (:func:`q_method` and the star tracker use it).
    """
    bmat = np.asarray(bmat, dtype=float)
    dot = np.trace(bmat, axis1=-2, axis2=-1)
    m = np.empty(bmat.shape[:-2] + (4, 4))
    m[..., :3, :3] = dot[..., None, None] * np.eye(3) - bmat - np.swapaxes(bmat, -1, -2)
    z = -np.stack(
        [
            bmat[..., 1, 2] - bmat[..., 2, 1],
            bmat[..., 2, 0] - bmat[..., 0, 2],
            bmat[..., 0, 1] - bmat[..., 1, 0],
        ],
        axis=-1,
    )
    m[..., :3, 3] = z
    m[..., 3, :3] = z
    m[..., 3, 3] = -dot
    return m


def q_method_from_profile(bmat: np.ndarray) -> np.ndarray:
    """q-method on a precomputed attitude profile matrix (..., 3, 3); no geometry checks (caller's job).

    Returns ``q`` (..., 4), scalar first, ``q0 >= 0``, body relative to reference.
    """
    _, vec = np.linalg.eigh(paper_matrix_from_profile(bmat))  # ascending: column 0 is the paper's minimum
    v = vec[..., :, 0]
    q = np.concatenate([v[..., 3:], v[..., :3]], axis=-1)  # (q1, q2, q3, q0) -> (q0, q1, q2, q3)
    q = q * np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def davenport_k(b: np.ndarray, r: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Davenport's K in scalar-first order, ``[[sigma, z^T], [z, S_D - sigma I]]``, shape (..., 4, 4).

    Its largest eigenvalue's eigenvector is the optimal ``q`` (project convention) and
    ``q^T K q = sum a_i b_i . (R(q)^T r_i)``.
    """
    b, r, w = prepare_observations(b, r, weights)
    wb = w[..., None] * b
    sigma = np.einsum("...ki,...ki->...", wb, r)
    outer = np.einsum("...ki,...kj->...ij", wb, r)
    k = np.empty(b.shape[:-2] + (4, 4))
    k[..., 0, 0] = sigma
    z = np.sum(np.cross(wb, r), axis=-2)
    k[..., 0, 1:] = z
    k[..., 1:, 0] = z
    k[..., 1:, 1:] = outer + np.swapaxes(outer, -1, -2) - sigma[..., None, None] * np.eye(3)
    return k


def q_method(b: np.ndarray, r: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Davenport's q-method in the paper's form: optimal attitude ``q`` (..., 4), ``q0 >= 0``.

    Parameters
    ----------
    b : (..., n, 3) observed directions in the body frame (any length > 0; normalised here).
    r : (..., n, 3) the same directions in the reference frame.
    weights : (..., n) non-negative weights ``a_i`` of criterion (2); for noisy unit vectors with
        isotropic tangential noise of standard deviation ``sigma_i`` [rad] the maximum-likelihood choice
        is ``a_i = 1 / sigma_i**2``. Zero-weight pairs are ignored (useful for padding).

    Returns
    -------
    q : (..., 4) scalar-first, body relative to reference: ``r_i ~ R(q) @ b_i``.

    Raises
    ------
    DegenerateGeometryError : fewer than two pairs, a zero vector, or all weighted vectors parallel.
    NonFiniteError, InvalidParameterError : NaN/inf input, negative weights, bad shapes.
    """
    b, r, w = prepare_observations(b, r, weights)
    return q_method_from_profile(np.einsum("...k,...ki,...kj->...ij", w, b, r))


def quaternion_from_matrix(rot: np.ndarray) -> np.ndarray:
    """Vectorised Shepperd: ``q`` (..., 4), ``q0 >= 0``, of rotation matrices ``R`` (``v_ref = R v_body``)."""
    rot = np.asarray(rot, dtype=float)
    m = rot
    tr = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    # The four candidates 4 q_i^2; dividing by the largest keeps every branch well conditioned.
    cand = np.stack(
        [
            1.0 + tr,
            1.0 + 2.0 * m[..., 0, 0] - tr,
            1.0 + 2.0 * m[..., 1, 1] - tr,
            1.0 + 2.0 * m[..., 2, 2] - tr,
        ],
        axis=-1,
    )
    k = np.argmax(cand, axis=-1)
    big = 0.5 * np.sqrt(np.maximum(np.take_along_axis(cand, k[..., None], -1)[..., 0], 0.0))
    s = 0.25 / big
    d10, d01 = m[..., 1, 0], m[..., 0, 1]
    d21, d12 = m[..., 2, 1], m[..., 1, 2]
    d02, d20 = m[..., 0, 2], m[..., 2, 0]
    rows = [
        np.stack([big, (d21 - d12) * s, (d02 - d20) * s, (d10 - d01) * s], -1),
        np.stack([(d21 - d12) * s, big, (d01 + d10) * s, (d02 + d20) * s], -1),
        np.stack([(d02 - d20) * s, (d01 + d10) * s, big, (d12 + d21) * s], -1),
        np.stack([(d10 - d01) * s, (d02 + d20) * s, (d12 + d21) * s, big], -1),
    ]
    q = np.choose(k[..., None], rows)
    q = q * np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def attitude_error_angle(q_true: np.ndarray, q_est: np.ndarray) -> np.ndarray:
    """Total rotation angle [rad] in [0, pi] between two attitudes (sign-invariant), shape (...).

    ``2 atan2(|vec(dq)|, |dq0|)`` with ``dq = conj(q_true) * q_est``: accurate for tiny angles, where the
    ``2 acos(|q_true . q_est|)`` form loses everything below ~1e-8 rad (2 mas) to rounding.
    """
    dq = qt.multiply(qt.conjugate(np.asarray(q_true, dtype=float)), np.asarray(q_est, dtype=float))
    return 2.0 * np.arctan2(np.linalg.norm(dq[..., 1:], axis=-1), np.abs(dq[..., 0]))
