"""The decision interface over the physics step: relative target actions, over N rows.

The row kernels decode relative actions (``EnvConfig.target_actions = "relative"``,
:func:`planetnav_env.core.decoding.relative_target`); here they are checked, and the same rule serves Python
callers. The ``since_measured`` observation block is the compiled kernel's
(:mod:`planetnav_env.core.observation`).

Why relative actions exist (docs/suite.md "Tasks v1"): with absolute actions "keep dwelling" is a
different output for every target, while relative actions make it the single action 0.
"""

from __future__ import annotations

__all__ = ["RESIDUAL_CAP", "SINCE_SCALE_STEPS", "check_relative", "relative_targets", "relative_to_absolute"]


import numpy as np

from planetnav_env.core.decoding import decode_actions
from planetnav_env.core.layout import MODE_TARGET, RESIDUAL_CAP, SINCE_SCALE_STEPS
from planetnav_env.errors import InvalidParameterError


def check_relative(actions: np.ndarray, n_targets: int) -> None:
    """Raise :class:`~planetnav_env.errors.InvalidParameterError` (a ``ValueError``) naming the row and the
    value for a *relative* action (N,) outside ``0 .. n_targets - 1``."""
    a = np.asarray(actions).reshape(-1)
    ok = np.isfinite(a) & (a == np.round(a)) & (a >= 0) & (a < n_targets)
    if not ok.all():
        r = int(np.flatnonzero(~ok)[0])
        raise InvalidParameterError(
            f"relative action of row {r} must be an integer in [0, {n_targets}), got {a[r].item()!r}"
        )


def relative_targets(actions: np.ndarray, current: np.ndarray, n_targets: int) -> np.ndarray:
    """Target indices (N,) of *relative* actions (N,) from the current targets (N,) by the row kernels'
    rule (:func:`planetnav_env.core.decoding.relative_target`): 0 keeps the current target, ``k`` moves
    ``k`` places along the target order (``(current + k) mod n``). With no current target (``-1``, the
    first step) the count starts from target 0, so action ``k`` picks target ``k``.

    Raises :class:`~planetnav_env.errors.InvalidParameterError` (a ``ValueError``) naming the row and the
    value for an action outside ``0 .. n_targets - 1`` (:func:`check_relative`)."""
    check_relative(actions, n_targets)
    raw = np.asarray(actions, dtype=float).reshape(-1, 1)
    cur = np.ascontiguousarray(np.broadcast_to(np.asarray(current, dtype=np.int64), (raw.shape[0],)))
    return decode_actions(MODE_TARGET, True, 0, n_targets, raw, cur)[0]


def relative_to_absolute(action: int, current: int, n_targets: int) -> int:
    """:func:`relative_targets` for one action."""
    return int(relative_targets(np.array([action]), np.array([current]), n_targets)[0])
