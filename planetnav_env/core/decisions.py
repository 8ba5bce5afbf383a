"""The decision interface over the physics step: relative target actions and the time since each
target was last measured, over N rows.

One implementation: the environments apply these when their config asks for them
(``EnvConfig.target_actions = "relative"``, ``observe_since_measured``; the ``-v1`` ids), and the
training recipe's layers (:mod:`planetnav_train.features`, :mod:`planetnav_train.batch_wrappers`) call the
same functions for the options they add over a ``-v0`` id.

Why these exist (research/training_log.md, E2 and E3; docs/suite.md "Tasks v1"): the base observation is a
snapshot of the filter, so a feed-forward policy cannot tell how long it has dwelt on a target; and with
absolute actions "keep dwelling" is a different output for every target, while relative actions make it
the single action 0.
"""

from __future__ import annotations

import math

import numpy as np

from planetnav_env.errors import InvalidParameterError
from planetnav_env.numerics.portable_math import log1p

#: Scale of the ``since_measured`` values [steps]: a constant (one cruise day of 60-s steps), not the
#: episode length, so that a policy evaluated on shorter episodes than it was trained on sees the same
#: values.
SINCE_SCALE_STEPS = 1440
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


def advance_image_log(
    log: np.ndarray, fixed: np.ndarray, failed: np.ndarray, target_index: np.ndarray
) -> None:
    """Count one physics step's image in the image log, in place.

    log: (N, 2, P) counts, ``log[:, 0]`` images of each planet in view, ``log[:, 1]`` the fixes they gave.
    fixed: (N,) bool, the camera measured its target this step (``info["sensor"] == "camera"``); failed:
    (N,) bool, the image of a planet in view yielded no fix (``info["visibility"] == "image_failed"``);
    target_index: (N,) int, the planet imaged. Rows with neither (no image, or the planet out of view)
    count nothing.
    """
    n_planets = log.shape[2]
    target_index = np.asarray(target_index)
    on_planet = (target_index >= 0) & (target_index < n_planets)
    for flag, add_fix in ((np.asarray(fixed, dtype=bool), 1.0), (np.asarray(failed, dtype=bool), 0.0)):
        rows = np.flatnonzero(flag & on_planet)
        log[rows, 0, target_index[rows]] += 1.0
        log[rows, 1, target_index[rows]] += add_fix


def image_log_values(log: np.ndarray) -> np.ndarray:
    """The ``image_log`` observation (N, 2, P) float32 from the counts (N, 2, P): row 0 ``(fixes + 1) /
    (images + 2)`` (the mean of a Beta(1, 1) prior updated by the counts), row 1 ``log1p(images) /
    log1p(SINCE_SCALE_STEPS)`` capped at 1 (one value per planet per row, so each row is a per-target
    vector like ``since_measured``)."""
    images, fixes = log[:, 0], log[:, 1]
    mean = (fixes + 1.0) / (images + 2.0)
    scaled = np.minimum(log1p(images) / _SINCE_LOG_SCALE, 1.0)
    return np.stack([mean, scaled], axis=1).astype(np.float32)


#: Cap of the residual log's normalized NIS (the observation is its value / the cap).
RESIDUAL_CAP = 10.0


def advance_residual_log(
    log: np.ndarray, fixed: np.ndarray, nis_norm: np.ndarray, target_index: np.ndarray
) -> None:
    """Add one physics step's fix to the residual log, in place.

    log: (N, 2, T), ``log[:, 0]`` fixes of each target (planets, then pulsars), ``log[:, 1]`` the sum of
    their NIS divided by the measurement's degrees of freedom. fixed: (N,) bool, a sensor measured the
    target this step (an image or a pulsar phase); nis_norm: (N,) that fix's NIS / dof (the filter's, gated
    fixes included); target_index: (N,) the target.
    """
    n_targets = log.shape[2]
    target_index = np.asarray(target_index)
    ok = np.asarray(fixed, dtype=bool) & (target_index >= 0) & (target_index < n_targets)
    ok &= np.isfinite(nis_norm)
    rows = np.flatnonzero(ok)
    log[rows, 0, target_index[rows]] += 1.0
    log[rows, 1, target_index[rows]] += np.asarray(nis_norm)[rows]


def residual_log_values(log: np.ndarray) -> np.ndarray:
    """The ``residual_log`` observation (N, T) float32: ``(sum + 2) / (fixes + 2)`` (the mean normalized
    NIS with a prior of two consistent fixes), capped at :data:`RESIDUAL_CAP`, divided by it."""
    mean = (log[:, 1] + 2.0) / (log[:, 0] + 2.0)
    return (np.minimum(mean, RESIDUAL_CAP) / RESIDUAL_CAP).astype(np.float32)


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
