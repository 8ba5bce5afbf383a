"""Time and body positions of one row: its epoch plus elapsed steps [TDB s], and the ephemeris channels of
its table (central body, planets, perturbers; heliocentric or central-body-relative [km], ICRF)."""

from __future__ import annotations

from planetnav_env.core.ephemeris_table import position_kernel, positions_kernel
from planetnav_env.core.layout import (
    F_T0,
    I_K,
)  # fmt: skip
from planetnav_env.numerics.jit import row_kernel


@row_kernel
def row_time(prm, f, i, n):  # pragma: no cover - compiled
    return f[n, F_T0] + i[n, I_K] * prm.scalars[0].step_s


@row_kernel
def eval_channel(prm, eph, f, n, t, channel, out) -> bool:  # pragma: no cover - compiled
    if channel < 0:
        out[0] = out[1] = out[2] = 0.0
        return True
    return position_kernel(eph[n], f[n, F_T0], prm.scalars[0].segment_s, t, channel, out)


@row_kernel
def planets_at(prm, eph, f, n, t, out) -> bool:  # pragma: no cover - compiled
    ps = prm.scalars[0]
    c0 = ps.ch_planet0
    return positions_kernel(eph[n], f[n, F_T0], ps.segment_s, t, c0, c0 + ps.n_planets, out)


@row_kernel
def perturbers_at(prm, eph, f, n, t, dt, out) -> bool:  # pragma: no cover - compiled
    """The filter's perturbers (relative to the central body) at ``t``, ``t + dt/2``, ``t + dt`` into
    ``out`` (3, K, 3) [km]."""
    ps = prm.scalars[0]
    return _channels_at(eph, f, n, t, dt, ps.ch_pert0, ps.n_pert, ps.segment_s, out)


@row_kernel
def truth_perturbers_at(prm, eph, f, n, t, dt, out) -> bool:  # pragma: no cover - compiled
    """The truth's own perturbers (its force model apart from the filter's) at the three RK4 epochs into
    ``out`` (3, Kt, 3) [km]."""
    ps = prm.scalars[0]
    return _channels_at(eph, f, n, t, dt, ps.ch_tpert0, ps.n_tpert, ps.segment_s, out)


@row_kernel
def _channels_at(eph, f, n, t, dt, c0, k, seg, out) -> bool:  # pragma: no cover - compiled
    if k == 0:
        return True
    ok = positions_kernel(eph[n], f[n, F_T0], seg, t, c0, c0 + k, out[0])
    ok = ok and positions_kernel(eph[n], f[n, F_T0], seg, t + 0.5 * dt, c0, c0 + k, out[1])
    return ok and positions_kernel(eph[n], f[n, F_T0], seg, t + dt, c0, c0 + k, out[2])


@row_kernel
def truth_bodies_at(prm, eph, f, n, t, sc, with_planets) -> None:  # pragma: no cover - compiled
    """The truth's central body ``sc.tcentral`` and (``with_planets``) planets ``sc.tplanets`` at ``t``
    (heliocentric [km]): from the truth's own channels when it follows an ephemeris of its own
    (``truth_eph``), else copies of the onboard ``sc.central`` and ``sc.planets``, which must then hold
    the bodies at ``t`` already (the same numbers: one ephemeris)."""
    ps = prm.scalars[0]
    if ps.truth_eph != 0:
        eval_channel(prm, eph, f, n, t, ps.ch_tcentral, sc.tcentral)
        if with_planets:
            c0 = ps.ch_tplanet0
            positions_kernel(eph[n], f[n, F_T0], ps.segment_s, t, c0, c0 + ps.n_planets, sc.tplanets)
        return
    for j in range(3):
        sc.tcentral[j] = sc.central[j]
    if with_planets:
        for a in range(sc.planets.shape[0]):
            for j in range(3):
                sc.tplanets[a, j] = sc.planets[a, j]
