"""Compiled planet measurement vector of the filter (numba row kernels): the body-frame line of sight turned
into ``z`` for each :class:`~planetnav_env.codes.MeasurementKind`. The numpy oracle is
:mod:`planetnav_env.estimation.measurements`; the Jacobian and noise are
:func:`planetnav_env.estimation.ekf_kernels.planet_model_kernel`."""

from __future__ import annotations

import math

from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.numerics.jit import row_kernel


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
