"""Time and body positions of one row: its epoch plus elapsed steps [TDB s], and the ephemeris channels of
its table (central body, planets, perturbers; heliocentric or central-body-relative [km], ICRF)."""

from __future__ import annotations

from planetnav_env.core.ephemeris_table import position_kernel, positions_kernel
from planetnav_env.core.layout import (
    F_T0,
    I_K,
    N_CH_PERT0,
    N_CH_PLANET0,
    N_N_PERT,
    N_NP,
    S_SEGMENT_S,
    S_STEP_S,
)  # fmt: skip
from planetnav_env.jit import row_kernel


@row_kernel
def row_time(prm, f, i, n):  # pragma: no cover - compiled
    return f[n, F_T0] + i[n, I_K] * prm.s[S_STEP_S]


@row_kernel
def eval_channel(prm, eph, f, n, t, channel, out) -> bool:  # pragma: no cover - compiled
    if channel < 0:
        out[0] = out[1] = out[2] = 0.0
        return True
    return position_kernel(eph[n], f[n, F_T0], prm.s[S_SEGMENT_S], t, channel, out)


@row_kernel
def planets_at(prm, eph, f, n, t, out) -> bool:  # pragma: no cover - compiled
    c0 = prm.n[N_CH_PLANET0]
    return positions_kernel(eph[n], f[n, F_T0], prm.s[S_SEGMENT_S], t, c0, c0 + prm.n[N_NP], out)


@row_kernel
def perturbers_at(prm, eph, f, n, t, dt, out) -> bool:  # pragma: no cover - compiled
    k = prm.n[N_N_PERT]
    if k == 0:
        return True
    c0 = prm.n[N_CH_PERT0]
    seg = prm.s[S_SEGMENT_S]
    ok = positions_kernel(eph[n], f[n, F_T0], seg, t, c0, c0 + k, out[0])
    ok = ok and positions_kernel(eph[n], f[n, F_T0], seg, t + 0.5 * dt, c0, c0 + k, out[1])
    return ok and positions_kernel(eph[n], f[n, F_T0], seg, t + dt, c0, c0 + k, out[2])
