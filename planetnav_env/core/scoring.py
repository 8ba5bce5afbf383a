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
)  # fmt: skip
from planetnav_env.core.operations import score_operations
from planetnav_env.estimation.ekf_kernels import (
    nees_kernel,
)
from planetnav_env.numerics.jit import row_kernel


@row_kernel
def score_row(prm, st, n, torque, sc) -> None:  # pragma: no cover - compiled
    """Errors, NEES, 1-sigma, reward, termination and truncation of row ``n`` of the state ``st`` after its
    step (``torque``: the step's torque action, fractions of the wheel limit).

    Operations scenarios (``ops``): the reward is ``-(w * dv_step + sum of the deadline terms reached
    this step) / reward_scale_km`` (:func:`planetnav_env.core.operations.score_operations`), km and m/s.
    With a baseline (``reward_base_n`` > 0) the error term less the baseline of the step's bin, ``b_j``
    [km] with ``j = floor((k - 1) L / episode_steps)``, is scaled instead: a function of time only."""
    f, p, i = st.f, st.p, st.i
    ps = prm.scalars[0]
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
    term = not (math.isfinite(pos_err) and math.isfinite(sig)) or pos_err > ps.divergence
    i[n, I_TERMINATED] = term
    i[n, I_TRUNCATED] = i[n, I_K] >= ps.episode_steps and not term
    err = score_operations(prm, f, p, i, n) if ps.ops else (pos_err if ps.reward_truth else sig)
    if ps.reward_base_n > 0:
        # The time-only baseline of this physics step's bin (reward_baseline_km): k = 1..episode_steps.
        j = min(max((i[n, I_K] - 1) * ps.reward_base_n // ps.episode_steps, 0), ps.reward_base_n - 1)
        r = -(err - prm.reward_base[j]) / ps.reward_scale
    else:
        r = -err / ps.reward_scale
    if ps.mode != MODE_TARGET and ps.torque_penalty > 0.0:
        r -= ps.torque_penalty * ps.torque_scale**2 * (torque[0] ** 2 + torque[1] ** 2 + torque[2] ** 2)
    f[n, F_REWARD] = r if math.isfinite(r) else -ps.divergence / ps.reward_scale
