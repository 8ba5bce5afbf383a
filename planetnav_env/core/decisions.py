"""The decision interface over the physics step: relative target actions, over N rows, and the
since-measured values for the training recipe's feature layer.

The environments decode relative actions here (``EnvConfig.target_actions = "relative"``); their
``since_measured`` observation block is the compiled kernel's (:mod:`planetnav_env.core.observation`).
The training recipe's layers (:mod:`planetnav_train.features`, :mod:`planetnav_train.batch_wrappers`) call
:func:`advance_since_measured` and :func:`since_measured_values` for the feature they add over a ``-v0``
id; ``tests/env/test_events.py`` holds the kernel's block to them.

Why these exist (research/training_log.md, E2 and E3; docs/suite.md "Tasks v1"): the base observation is a
snapshot of the filter, so a feed-forward policy cannot tell how long it has dwelt on a target; and with
absolute actions "keep dwelling" is a different output for every target, while relative actions make it
the single action 0.
"""

from __future__ import annotations

__all__ = [
    "RESIDUAL_CAP", "SINCE_SCALE_STEPS", "advance_since_measured", "relative_targets", "relative_to_absolute",
    "since_measured_values",
]  # fmt: skip

import math

import numpy as np

from planetnav_env.core.layout import RESIDUAL_CAP, SINCE_SCALE_STEPS
from planetnav_env.errors import InvalidParameterError
from planetnav_env.numerics.portable_math import log1p

_SINCE_LOG_SCALE = math.log1p(SINCE_SCALE_STEPS)


def advance_since_measured(since: np.ndarray, measured: np.ndarray, target_index: np.ndarray) -> None:
    """Advance the steps since each target was last measured by one physics step, in place.

    since: (N, T) float counts (``inf``: not measured this episode). measured: (N,) bool, the step's
    ``info["measured"]``. target_index: (N,) int, the index (planets, then pulsars) of what was measured;
    anything outside ``0 .. T - 1`` (-1: none) resets nothing.
    """
    since += 1.0
    n_targets = since.shape[1]
    target_index = np.asarray(target_index)
    rows = np.flatnonzero(np.asarray(measured, dtype=bool) & (target_index >= 0) & (target_index < n_targets))
    since[rows, target_index[rows]] = 0.0


def since_measured_values(since: np.ndarray) -> np.ndarray:
    """The ``since_measured`` observation (float32, same shape as ``since``): ``log1p(steps) /
    log1p(SINCE_SCALE_STEPS)`` capped at 1, and 1 for a target not measured this episode."""
    # libm's log1p, not numpy's: numpy's SIMD version differs across CPUs
    # (planetnav_env.numerics.portable_math).
    finite = np.isfinite(since)
    scaled = log1p(np.where(finite, since, 0.0)) / _SINCE_LOG_SCALE
    return np.where(finite, np.minimum(scaled, 1.0), 1.0).astype(np.float32)


def relative_targets(actions: np.ndarray, current: np.ndarray, n_targets: int) -> np.ndarray:
    """Target indices (N,) of *relative* actions (N,): 0 keeps the current target, ``k`` moves ``k``
    places along the target order (``(current + k) mod n``). With no current target (``-1``, the first
    step) the count starts from target 0, so action ``k`` picks target ``k``.

    Raises :class:`~planetnav_env.errors.InvalidParameterError` (a ``ValueError``) naming the row and the
    value for an action outside ``0 .. n_targets - 1``."""
    a = np.asarray(actions).reshape(-1)
    ok = np.isfinite(a) & (a == np.round(a)) & (a >= 0) & (a < n_targets)
    if not ok.all():
        r = int(np.flatnonzero(~ok)[0])
        raise InvalidParameterError(
            f"relative action of row {r} must be an integer in [0, {n_targets}), got {a[r].item()!r}"
        )
    return (np.maximum(np.asarray(current, dtype=np.int64), 0) + a.astype(np.int64)) % n_targets


def relative_to_absolute(action: int, current: int, n_targets: int) -> int:
    """:func:`relative_targets` for one action."""
    return int(relative_targets(np.array([action]), np.array([current]), n_targets)[0])
