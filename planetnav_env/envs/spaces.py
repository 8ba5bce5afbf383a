"""Action and observation spaces, action validation and observation decoding, shared by the single and the
vector environment (one place for each rule: both shells call these). An action is decoded (target,
torque) by the compiled row kernels, :mod:`planetnav_env.core.decoding`; here it is only checked, with
named errors."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from planetnav_env.config import EnvConfig
from planetnav_env.core.decoding import decode_actions
from planetnav_env.core.layout import (
    MODE_HYBRID,
    OBSERVATION_BLOCKS,
    TARGET_FEATURES,
    ObservationLayout,
    observation_scales,
)
from planetnav_env.errors import InvalidParameterError, NonFiniteError

_DEG = np.pi / 180.0


def action_space(cfg: EnvConfig) -> spaces.Space:
    """``Discrete(T [+1 idle])`` in target mode, ``Box(-1, 1, (3,))`` in torque mode,
    ``Box(-1, 1, (P + 3,))`` in target+torque mode, ``Box(-1, 1, (P + 1 + 3,))`` in hybrid mode
    (decoded by :mod:`planetnav_env.core.decoding`)."""
    if cfg.action_mode == "target":
        return spaces.Discrete(cfg.n_target_actions)
    if cfg.action_mode == "torque":
        return spaces.Box(-1.0, 1.0, (3,), dtype=np.float32)
    if cfg.action_mode == "hybrid":
        return spaces.Box(-1.0, 1.0, (cfg.n_planets + 1 + 3,), dtype=np.float32)
    return spaces.Box(-1.0, 1.0, (cfg.n_planets + 3,), dtype=np.float32)


def action_size(space: spaces.Space) -> int:
    """Numbers per raw action of ``space`` (:func:`action_space`): 1 for a target index, the Box's size."""
    return 1 if isinstance(space, spaces.Discrete) else int(np.prod(space.shape))


def observation_space(cfg: EnvConfig, layout: ObservationLayout) -> spaces.Space:
    """Flat ``Box`` (``observation="box"``) or ``Dict`` of the layout's blocks, float32."""
    if cfg.observation == "box":
        return spaces.Box(-np.inf, np.inf, (layout.size,), dtype=np.float32)
    bounds = {
        "attitude": (-1.0, 1.0),
        "wheel_momentum": (-1.0, 1.0),
        "target": (0.0, 1.0),
        "elapsed": (0.0, 1.0),
        **{b.name: b.bounds for b in OBSERVATION_BLOCKS},
    }
    return spaces.Dict(
        {
            name: spaces.Box(*bounds.get(name, (-np.inf, np.inf)), shape, np.float32)
            for name, _, _, shape in layout.blocks
        }
    )


def format_observation(cfg: EnvConfig, layout: ObservationLayout, flat: np.ndarray) -> Any:
    """float32 observation(s) in the configured form from the core's float64 rows (..., size)."""
    f = flat.astype(np.float32)
    if cfg.observation == "box":
        return f
    return layout.to_dict(f)


def _is_numeric(a: np.ndarray) -> bool:
    """Numbers or booleans (not text, bytes or arbitrary objects, which NumPy would coerce or carry)."""
    return a.dtype.kind in "biuf"


def _row(r: int, single: bool) -> str:
    """How an error names the offending action: a row of the batch, or the single environment's action."""
    return "action" if single else f"action of row {r}"


def _not_stepped(single: bool) -> str:
    # A vector env validates the whole batch first: say that no row moved, so a caller may retry.
    return "" if single else "; no row was stepped"


def _out_of_range(r: int, single: bool, n_actions: int, value: Any) -> InvalidParameterError:
    return InvalidParameterError(
        f"{_row(r, single)} must be an integer in [0, {n_actions}), got {value!r}{_not_stepped(single)}"
    )


def check_target_actions(
    cfg: EnvConfig, n_actions: int, actions: Any, n_rows: int, *, single: bool = False
) -> np.ndarray:
    """Discrete actions checked: (N,) int64 in ``0 .. n_actions - 1`` (``cfg.n_targets``: the idle action;
    relative targets have none), decoded by the row kernels (:mod:`planetnav_env.core.decoding`). Errors
    name the row (the value alone with ``single=True``, the single environment's wording)."""
    a = np.asarray(actions)
    if not _is_numeric(a):
        what = "target action must be an integer" if single else f"target actions must be {n_rows} integer(s)"
        raise InvalidParameterError(
            f"{what} in [0, {n_actions}), got {actions!r} of type {type(actions).__name__}"
            f"{'' if single else f' (dtype {a.dtype})'}"
        )
    if single and a.size != 1:
        raise InvalidParameterError(
            f"target action must be one integer in [0, {n_actions}), got shape {a.shape}: {actions!r}"
        )
    if not single and a.shape not in ((n_rows,), (n_rows, 1)):
        raise InvalidParameterError(
            f"target actions must be {n_rows} integer(s) (shape ({n_rows},)), "
            f"got shape {a.shape}: {actions!r}"
        )
    a = a.reshape(n_rows)
    if not np.issubdtype(a.dtype, np.integer):
        bad = ~np.isfinite(a)
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise NonFiniteError(f"{_row(r, single)} is not finite: {a[r].item()!r}{_not_stepped(single)}")
        frac = a != np.round(a)
        if frac.any():
            r = int(np.flatnonzero(frac)[0])
            raise _out_of_range(r, single, n_actions, a[r].item())
    idx = a.astype(np.int64)
    out = (idx < 0) | (idx >= n_actions)
    if out.any():
        r = int(np.flatnonzero(out)[0])
        raise _out_of_range(r, single, n_actions, a[r].item())
    return idx


def check_box_actions(
    cfg: EnvConfig, shape: tuple[int, ...], actions: Any, n_rows: int, *, single: bool = False
) -> np.ndarray:
    """Box actions of ``shape`` per row checked: (N, A) float64 as given (finite; values outside [-1, 1]
    are clipped by the decoding, as SB3 does), decoded by the row kernels
    (:mod:`planetnav_env.core.decoding`: the target and torque of each action mode, the hybrid option).
    NaN/inf raise naming the row (the values alone with ``single=True``, the single environment's wording).
    """
    want = shape if single else (n_rows, *shape)
    try:
        raw = np.asarray(actions)
    except (TypeError, ValueError):  # ragged nested sequences
        raw = None
    if raw is None or not _is_numeric(raw):
        # Checked before the shape: asarray(..., dtype=float) would turn '1' into 1.0, and a str's
        # shape () would be blamed instead of its type.
        raise InvalidParameterError(
            f"{'action' if single else 'actions'} must be numbers of shape {want}, "
            f"got {actions!r} of type {type(actions).__name__}"
        )
    a = raw.astype(float, copy=False)
    if a.shape != (n_rows, *shape) and not (n_rows == 1 and a.shape == shape):
        raise InvalidParameterError(
            f"{'action' if single else 'actions'} must have shape {want}, got shape {a.shape}: {actions!r}"
        )
    a = a.reshape(n_rows, *shape)
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise NonFiniteError(
            f"{_row(r, single)} contains NaN or infinite values: {a[r].tolist()}{_not_stepped(single)}"
        )
    return np.ascontiguousarray(a)


def decode_hybrid(actions: np.ndarray, n_planets: int) -> tuple[np.ndarray, np.ndarray]:
    """(targets (N,), torques (N, 3)) of checked ``hybrid`` Box actions (N, P + 1 + 3) by the row kernels'
    own rule (:func:`planetnav_env.core.decoding.decode_action`): option ``k = argmax(clip(a[:P + 1]))``;
    ``k < P`` -> target k with zero torque (the PD law slews), ``k = P`` -> target -1 with torque
    ``clip(a[P + 1:])`` (the agent drives the wheels). For agents and tests that encode with it in mind."""
    a = np.ascontiguousarray(actions, dtype=float)
    n = a.shape[0]
    return decode_actions(MODE_HYBRID, False, n_planets, n_planets, a, np.full(n, -1, dtype=np.int64))


def decode_observation(cfg: EnvConfig, layout: ObservationLayout, observation: Any) -> dict[str, Any]:
    """Named arrays in physical units from one ``box`` or ``dict`` observation: position_km,
    velocity_km_s (relative to the central body), log_sigma (6,), q (star tracker), rates_rad_s,
    wheel_fraction, planets (P, 7) and pulsars (Q, 7) as in the layout, target (index or -1), elapsed,
    and each optional block the layout has (``core.layout.OBSERVATION_BLOCKS``, e.g. ``in_field`` with
    ``observe_in_field``) under its name, as the observation holds it (a block of flags, such as
    ``in_field``, as bool)."""
    if isinstance(observation, dict):
        try:
            flat = layout.from_dict(observation)
        except (KeyError, ValueError) as exc:
            raise InvalidParameterError(
                f"observation does not match this environment's layout: {exc}"
            ) from None
    else:
        flat = np.asarray(observation, dtype=float).reshape(-1)
    if flat.size != layout.size:
        raise InvalidParameterError(
            f"observation has {flat.size} values; this environment's have {layout.size}"
        )
    b = layout.to_dict(flat)
    pos_scale, vel_scale = observation_scales(cfg.scenario)
    target_vec = b["target"]
    extra = {blk.name: (b[blk.name] > 0.5 if blk.flags else b[blk.name]) for blk in OBSERVATION_BLOCKS
             if blk.name in b}  # fmt: skip
    return {
        **extra,
        "position_km": b["position"] * pos_scale,
        "velocity_km_s": b["velocity"] * vel_scale,
        "log_sigma": b["log_sigma"],
        "q": b["attitude"] / np.linalg.norm(b["attitude"]),
        "rates_rad_s": b["rates"] * _DEG,
        "wheel_fraction": b["wheel_momentum"],
        "planets": b["planets"],
        "pulsars": b.get("pulsars", np.zeros((0, TARGET_FEATURES))),
        "target": int(np.argmax(target_vec)) if np.any(target_vec > 0.5) else -1,
        "elapsed": float(b["elapsed"][0]),
        **_decode_operations(layout, b),
    }


def _decode_operations(layout: ObservationLayout, b: dict[str, np.ndarray]) -> dict[str, Any]:
    """The operations block in physical units (none without one): ``deadline_time_d`` (D,) time to each
    deadline [d] (0 once reached), ``dv_lost_m_s`` [m/s], ``thrusting`` (bool)."""
    if layout.n_deadlines is None:
        return {}
    from planetnav_env.core.layout import OPS_DAYS_SCALE, OPS_DV_SCALE

    ops, n_dl = b["operations"], layout.n_deadlines
    return {
        "deadline_time_d": ops[:n_dl] * OPS_DAYS_SCALE,
        "dv_lost_m_s": float(ops[n_dl]) * OPS_DV_SCALE,
        "thrusting": bool(ops[n_dl + 1] > 0.5),
    }
