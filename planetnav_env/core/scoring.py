"""Score of one row after its step: position and velocity errors [km, km/s], NEES, position 1-sigma [km],
reward, termination (divergence, non-finite filter) and truncation (episode length)."""

from __future__ import annotations

import math

from planetnav_env.core.layout import (
    F_NEES,
    F_POS_ERR,
    F_POS_SIGMA,
    F_REWARD,
    F_VEL_ERR,
    F_X,
    F_XE,
    I_K,
    I_TERMINATED,
    I_TRUNCATED,
    MODE_TARGET,
    N_EPISODE_STEPS,
    N_MODE,
    N_OPS,
    N_REWARD_TRUTH,
    S_DIVERGENCE,
    S_REWARD_SCALE,
    S_TORQUE_PENALTY,
    S_TORQUE_SCALE,
)  # fmt: skip
from planetnav_env.core.operations import score_operations
from planetnav_env.estimation.ekf_kernels import (
    nees_kernel,
)
from planetnav_env.jit import row_kernel


@row_kernel
def score_row(prm, f, p, i, n, torque, sc) -> None:  # pragma: no cover - compiled
    """Errors, NEES, 1-sigma, reward, termination and truncation of row ``n`` after its step.

    Operations scenarios (``N_OPS``): the reward is ``-(w * dv_step + sum of the deadline terms reached
    this step) / reward_scale_km`` (:func:`planetnav_env.core.operations.score_operations`), km and m/s."""
    s = prm.s
    x = f[n, F_X : F_X + 6]
    xe = f[n, F_XE : F_XE + 6]
    pm = p[n]
    e0, e1, e2 = xe[0] - x[0], xe[1] - x[1], xe[2] - x[2]
    v0, v1, v2 = xe[3] - x[3], xe[4] - x[4], xe[5] - x[5]
    pos_err = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    f[n, F_POS_ERR] = pos_err
    f[n, F_VEL_ERR] = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    f[n, F_NEES] = nees_kernel(xe, x, pm, sc.tmp, sc.x_new)
    sig = math.sqrt(max(pm[0, 0] + pm[1, 1] + pm[2, 2], 0.0))
    f[n, F_POS_SIGMA] = sig
    # A non-finite covariance shows in its trace; a non-finite estimate in pos_err.
    term = not (math.isfinite(pos_err) and math.isfinite(sig)) or pos_err > s[S_DIVERGENCE]
    i[n, I_TERMINATED] = term
    i[n, I_TRUNCATED] = i[n, I_K] >= prm.n[N_EPISODE_STEPS] and not term
    if prm.n[N_OPS]:
        r = -score_operations(prm, f, p, i, n) / s[S_REWARD_SCALE]
    else:
        err = pos_err if prm.n[N_REWARD_TRUTH] else sig
        r = -err / s[S_REWARD_SCALE]
    if prm.n[N_MODE] != MODE_TARGET and s[S_TORQUE_PENALTY] > 0.0:
        r -= s[S_TORQUE_PENALTY] * s[S_TORQUE_SCALE] ** 2 * (torque[0] ** 2 + torque[1] ** 2 + torque[2] ** 2)
    f[n, F_REWARD] = r if math.isfinite(r) else -s[S_DIVERGENCE] / s[S_REWARD_SCALE]
