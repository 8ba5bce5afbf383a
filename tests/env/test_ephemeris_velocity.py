"""The ephemeris table's velocity (the derivative of its Chebyshev series) against DE421's own velocities
and against a finite difference of the table's positions."""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.core import ephemeris_table as et

DAY = 86400.0
BODIES = ("venus", "earth", "mars", "jupiter")


@pytest.fixture(scope="module")
def eph() -> DEEphemeris:
    return DEEphemeris()


@pytest.mark.parametrize(("days", "t0"), [(1.0, 6.5e8), (60.0, 8.5e8)])
def test_velocity_matches_de421(eph, days, t0):
    duration = days * DAY
    coeffs = et.fit_table(et.body_positions(eph, [(b, "sun") for b in BODIES]), t0, duration, len(BODIES))
    times = np.concatenate([t0 + np.random.default_rng(5).uniform(0.0, duration, 300), [t0, t0 + duration]])
    out = np.empty(3)
    worst = 0.0
    for t in times:
        for c, name in enumerate(BODIES):
            assert et.velocity_kernel(coeffs, t0, et.SEGMENT_S, t, c, out)
            worst = max(worst, float(np.abs(out - eph.state(name, t)[1]).max()))
    assert worst < 1e-8  # km/s: 10 um/s, against 13-47 km/s


def test_velocity_is_the_derivative_of_the_positions(eph):
    t0 = 7.0e8
    coeffs = et.fit_table(et.body_positions(eph, [("mars", "sun")]), t0, DAY, 1)
    a, b, v = np.empty(3), np.empty(3), np.empty(3)
    h = 10.0
    for t in t0 + np.linspace(100.0, DAY - 100.0, 25):
        et.position_kernel(coeffs, t0, et.SEGMENT_S, t + h, 0, a)
        et.position_kernel(coeffs, t0, et.SEGMENT_S, t - h, 0, b)
        et.velocity_kernel(coeffs, t0, et.SEGMENT_S, t, 0, v)
        # The difference quotient carries the positions' rounding: ~3e-8 km / 20 s = 1.5e-9 km/s.
        assert v == pytest.approx((a - b) / (2.0 * h), abs=5e-9)


def test_velocity_outside_the_span_or_channel_fails():
    coeffs = np.zeros((1, 2, 3, et.DEGREE + 1))
    out = np.full(3, 7.0)
    assert not et.velocity_kernel(coeffs, 0.0, et.SEGMENT_S, -1.0, 0, out)
    assert not et.velocity_kernel(coeffs, 0.0, et.SEGMENT_S, 10.0, 2, out)
    assert not et.velocity_kernel(coeffs, 0.0, et.SEGMENT_S, np.nan, 0, out)
    assert np.all(out == 7.0)
