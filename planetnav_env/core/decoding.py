"""The one decoding of a row's raw action into the physics step's target and torque, compiled.

The environments validate an action (its type, shape, finiteness and range: named errors in
:mod:`planetnav_env.envs.spaces`) and hand the row kernels the action as given, as float64 numbers
(``Actions.raw``); :func:`decode_row` turns it into the step's target and torque at the start of each
decision. The single environment, the CPU vector environment and the device environment run this code
(the device's threads inline it), and Python helpers that need the rule call the same functions.

Action modes (``CoreParams.scalars.mode``, :data:`planetnav_env.core.layout.MODE_CODES`), with ``P``
planets and ``T`` targets (planets + pulsars):

* ``target``: ``a[0]`` is a target index; ``T`` (the idle action) is no target (-1). With relative
  targets (``scalars.relative``) action ``k`` moves ``k`` places from the current target
  (:func:`relative_target`). Torque 0.
* ``torque``: no target; torque ``clip(a[:3], -1, 1)``.
* ``target+torque``: target ``argmax(a[:P])`` and residual torque ``a[P:P + 3]`` (clipped).
* ``hybrid``: option ``k = argmax(a[:P + 1])``: ``k < P`` is planet ``k`` by the PD law with zero torque,
  ``k = P`` is no target with the torque ``a[P + 1:P + 4]`` (clipped).

Values are clipped to [-1, 1] before the argmax (as SB3 clips a policy's Box action); the first maximum
wins a tie. Torques are fractions of ``torque_action_scale`` x the wheel limit (the step scales them).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planetnav_env.core.layout import I_TARGET, MODE_HYBRID, MODE_TARGET, MODE_TORQUE
from planetnav_env.numerics.jit import row_kernel


def raw_action_size(mode: int, n_planets: int) -> int:
    """Numbers in one raw action of action ``mode`` with ``n_planets`` planets: the target index (1),
    the torque (3), planet scores and torque (P + 3), hybrid options and torque (P + 1 + 3)."""
    return {MODE_TARGET: 1, MODE_TORQUE: 3, MODE_HYBRID: n_planets + 4}.get(mode, n_planets + 3)


@row_kernel
def relative_target(action: int, current: int, n_targets: int) -> int:  # pragma: no cover - compiled
    """The target index of a *relative* action: 0 keeps ``current``, ``k`` moves ``k`` places along the
    target order (``(current + k) mod n_targets``); with no current target (``-1``) action ``k`` picks
    target ``k``. The action is in ``0 .. n_targets - 1`` (the environment checked it)."""
    return (max(current, 0) + action) % n_targets


@row_kernel
def _clipped(v: float) -> float:  # pragma: no cover - compiled
    # np.clip's result for a finite value, -0.0 kept.
    if v < -1.0:
        return -1.0
    if v > 1.0:
        return 1.0
    return v


@row_kernel
def _argmax_clipped(a, lo: int, hi: int) -> int:  # pragma: no cover - compiled
    # The first maximum of clip(a[lo:hi]) (np.argmax's tie rule), as an index from lo.
    best = 0
    top = _clipped(a[lo])
    for j in range(lo + 1, hi):
        v = _clipped(a[j])
        if v > top:
            top = v
            best = j - lo
    return best


@row_kernel
def decode_action(mode: int, relative: bool, n_planets: int, n_targets: int, a, current: int,
                  torque) -> int:  # fmt: skip  # pragma: no cover - compiled
    """The target (planet/pulsar index, -1 for none) of the raw action ``a`` (the row's action, float64)
    in action ``mode``, its torque fractions written into ``torque`` (3,); ``current``: the row's current
    target (relative targets count from it). The rules are the module docstring's."""
    if mode == MODE_TARGET:
        for j in range(3):
            torque[j] = 0.0
        idx = int(a[0])
        if relative:
            return relative_target(idx, current, n_targets)
        return -1 if idx == n_targets else idx
    if mode == MODE_TORQUE:
        for j in range(3):
            torque[j] = _clipped(a[j])
        return -1
    if mode == MODE_HYBRID:
        option = _argmax_clipped(a, 0, n_planets + 1)
        direct = option == n_planets
        for j in range(3):
            torque[j] = _clipped(a[n_planets + 1 + j]) if direct else 0.0
        return -1 if direct else option
    for j in range(3):
        torque[j] = _clipped(a[n_planets + j])
    return _argmax_clipped(a, 0, n_planets)


@row_kernel
def decode_row(prm, st, act, n) -> None:  # pragma: no cover - compiled
    """Row ``n``'s raw action ``act.raw[n]`` decoded into ``act.targets[n]`` and ``act.torques[n]`` with
    the row's current target (the start of a decision: the decision rule then holds them)."""
    ps = prm.scalars[0]
    act.targets[n] = decode_action(
        ps.mode, ps.relative != 0, ps.n_planets, ps.n_targets, act.raw[n], st.i[n, I_TARGET], act.torques[n]
    )


@njit(cache=True)
def decode_actions(
    mode: int, relative: bool, n_planets: int, n_targets: int, raw, current
):  # pragma: no cover - compiled
    """:func:`decode_action` of every row of ``raw`` (N, A) float64 with current targets ``current`` (N,)
    int64: (targets (N,) int64, torques (N, 3) float64), for Python callers that need the rule."""
    n = raw.shape[0]
    targets = np.empty(n, np.int64)
    torques = np.empty((n, 3))
    for r in range(n):
        targets[r] = decode_action(mode, relative, n_planets, n_targets, raw[r], current[r], torques[r])
    return targets, torques
