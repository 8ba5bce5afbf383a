"""Per-row Chebyshev ephemeris tables (planetnav_env.core.ephemeris_table) against DE421 and chebval."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import chebyshev as npcheb

from planetnav_env.astro.ephemeris import DEEphemeris, de421_path
from planetnav_env.astro.timescale import J2000_JD, SECONDS_PER_DAY
from planetnav_env.core import ephemeris_table as et
from planetnav_env.errors import InvalidParameterError, NonFiniteError

DAY = 86400.0
TOL_KM = 1e-3  # the 1 m requirement

# (target, origin) channels: every planet Mercury..Jupiter and the Moon heliocentric, the Sun relative
# to the barycentre, and the approach's perturbers relative to Mars.
CHANNELS = [
    ("mercury", "sun"),
    ("venus", "sun"),
    ("earth", "sun"),
    ("moon", "sun"),
    ("mars", "sun"),
    ("jupiter", "sun"),
    ("sun", "ssb"),
    ("sun", "mars"),
    ("earth", "mars"),
    ("jupiter", "mars"),
]


@pytest.fixture(scope="module")
def eph() -> DEEphemeris:
    return DEEphemeris()


def truth(eph: DEEphemeris, times: np.ndarray) -> np.ndarray:
    """The independent truth (T, C, 3) [km], straight from DEEphemeris (not through body_positions)."""
    out = []
    for target, origin in CHANNELS:
        if origin == "ssb":
            out.append(eph.sun_barycentric_position(times))
        elif origin == "sun":
            out.append(eph.position(target, times))
        else:
            out.append(eph.position(target, times) - eph.position(origin, times))
    return np.stack(out, axis=1)


@pytest.mark.parametrize(
    ("days", "t0"),
    [
        (1.0, 7.0e8),  # 2022
        (4.0, 6.6e8),  # ~95 h approach, 2020-2021
        (95.0 / 24.0, -1.23e8),  # 1996
        (60.0, 8.5e8),  # 2026-2027, 12 segments
    ],
)
def test_accuracy_against_de421(eph, days, t0):
    duration = days * DAY
    coeffs = et.fit_table(lambda t: truth(eph, t), t0, duration, len(CHANNELS))
    spec = et.TableSpec.for_duration(duration, len(CHANNELS))
    assert coeffs.shape == spec.shape
    rng = np.random.default_rng(int(days * 1000))
    times = t0 + rng.uniform(0.0, duration, 2500)
    times = np.concatenate([times, [t0, t0 + duration]])
    got = et.evaluate(coeffs, t0, et.SEGMENT_S, times)
    err = np.abs(got - truth(eph, times)).max(axis=(0, 2))
    assert np.all(err < TOL_KM), dict(zip(CHANNELS, err, strict=True))
    # Far below the requirement in fact (the floor set by time rounding is ~1e-5 km).
    assert err.max() < 1e-4


def test_independent_jplephem_mars(eph):
    """Mars relative to the Sun straight from jplephem's SPK segments (not through DEEphemeris)."""
    from jplephem.spk import SPK

    t0, duration = 6.6e8, 95 * 3600.0
    coeffs = et.fit_table(et.body_positions(eph, [("mars", "sun"), ("sun", "ssb")]), t0, duration, 2)
    times = t0 + np.random.default_rng(3).uniform(0.0, duration, 2000)
    days = times / SECONDS_PER_DAY
    kernel = SPK.open(de421_path())
    try:
        sun = kernel[0, 10].compute(J2000_JD, days)
        mars = kernel[0, 4].compute(J2000_JD, days) + kernel[4, 499].compute(J2000_JD, days)
    finally:
        kernel.close()
    got = et.evaluate(coeffs, t0, et.SEGMENT_S, times)
    assert np.abs(got[:, 0] - (mars - sun).T).max() < TOL_KM
    assert np.abs(got[:, 1] - sun.T).max() < TOL_KM


def test_segment_boundaries_continuous(eph):
    # t0 = 0 (J2000) so that 1e-9 s is representable next to the boundaries.
    t0, duration = 0.0, 60 * DAY
    coeffs = et.fit_table(lambda t: truth(eph, t), t0, duration, len(CHANNELS))
    n_seg = coeffs.shape[0]
    assert n_seg == 12
    out_l = np.empty((len(CHANNELS), 3))
    out_r = np.empty((len(CHANNELS), 3))
    out_b = np.empty((len(CHANNELS), 3))
    c = len(CHANNELS)
    for s in range(1, n_seg):
        tb = t0 + s * et.SEGMENT_S
        assert et.positions_kernel(coeffs, t0, et.SEGMENT_S, tb - 1e-9, 0, c, out_l)
        assert et.positions_kernel(coeffs, t0, et.SEGMENT_S, tb, 0, c, out_b)
        assert et.positions_kernel(coeffs, t0, et.SEGMENT_S, tb + 1e-9, 0, c, out_r)
        # 2e-9 s at <= 60 km/s moves a body by 1.2e-7 km; the two segments must agree to that, up to the
        # rounding of Clenshaw's sums of ~1e8 km terms (a few ulps, ~1e-14 relative).
        np.testing.assert_allclose(out_l, out_r, rtol=2e-14, atol=1e-6)
        np.testing.assert_allclose(out_b, out_r, rtol=2e-14, atol=1e-6)
        assert np.abs(out_b - truth(eph, np.array([tb]))[0]).max() < 1e-5
        # The two polynomials' end values themselves (Lobatto fit: both interpolate the same sample).
        left = coeffs[s - 1].sum(axis=-1)  # T_j(1) = 1
        right = (coeffs[s] * (-1.0) ** np.arange(coeffs.shape[-1])).sum(axis=-1)  # T_j(-1) = (-1)^j
        np.testing.assert_allclose(left, right, rtol=1e-12, atol=1e-6)


def test_boundaries_at_late_epoch(eph):
    """At t ~ 8.5e8 s the ulp of t is 1.2e-7 s: adjacent representable times straddling a boundary."""
    t0 = 8.5e8
    coeffs = et.fit_table(lambda t: truth(eph, t), t0, 20 * DAY, len(CHANNELS))
    c = len(CHANNELS)
    out_l, out_r = np.empty((c, 3)), np.empty((c, 3))
    for s in range(1, coeffs.shape[0]):
        tb = t0 + s * et.SEGMENT_S
        assert et.positions_kernel(coeffs, t0, et.SEGMENT_S, np.nextafter(tb, -np.inf), 0, c, out_l)
        assert et.positions_kernel(coeffs, t0, et.SEGMENT_S, np.nextafter(tb, np.inf), 0, c, out_r)
        assert np.abs(out_l - out_r).max() < 2e-5


def test_span_ends_and_outside():
    rng = np.random.default_rng(5)
    coeffs = rng.normal(size=(3, 2, 3, et.DEGREE + 1))
    t0, seg = 7.0e8, et.SEGMENT_S
    out = np.full(3, -7.0)
    end = t0 + 3 * seg
    assert et.position_kernel(coeffs, t0, seg, t0, 1, out)
    np.testing.assert_allclose(out, [npcheb.chebval(-1.0, coeffs[0, 1, k]) for k in range(3)], rtol=1e-12)
    assert et.position_kernel(coeffs, t0, seg, end, 1, out)  # the end point itself is allowed
    np.testing.assert_allclose(out, [npcheb.chebval(1.0, coeffs[2, 1, k]) for k in range(3)], rtol=1e-12)
    assert et.position_kernel(coeffs, t0, seg, end + 0.5 * et.SPAN_TOL_S, 1, out)  # rounding of t
    out[:] = -7.0
    for bad_t in (end + 1e-3, t0 - 1e-3, end + 1.0, t0 - seg, np.nan, np.inf, -np.inf):
        assert not et.position_kernel(coeffs, t0, seg, bad_t, 0, out)
    assert np.all(out == -7.0)  # untouched on failure
    for bad_c in (-1, 2):
        assert not et.position_kernel(coeffs, t0, seg, t0 + 10.0, bad_c, out)
    out2 = np.empty((2, 3))
    assert not et.positions_kernel(coeffs, t0, seg, t0 + 10.0, 0, 3, out2)  # c_hi > C
    assert not et.positions_kernel(coeffs, t0, seg, t0 + 10.0, 1, 0, out2)  # c_lo > c_hi
    assert not et.positions_kernel(coeffs, t0, seg, t0 + 10.0, 0, 2, np.empty((1, 3)))  # out too small
    assert not et.positions_kernel(coeffs, t0, seg, end + 1.0, 0, 2, out2)
    with pytest.raises(InvalidParameterError, match="outside"):
        et.evaluate(coeffs, t0, seg, np.array([t0, end + 1.0]))


def _oracle(coeffs, t0, seg, t):
    """numpy evaluation: segment by floor, x by the affine map, chebval per component (C, 3)."""
    s = min(int(np.floor((t - t0) / seg)), coeffs.shape[0] - 1)
    x = 2.0 * ((t - t0) - s * seg) / seg - 1.0
    return npcheb.chebval(x, coeffs[s].reshape(-1, coeffs.shape[-1]).T).reshape(coeffs.shape[1], 3)


@pytest.mark.parametrize("degree", [1, 2, 5, 12, 20])
def test_kernel_matches_chebval_oracle(degree):
    rng = np.random.default_rng(degree)
    n_seg, n_ch = 4, 3
    # Coefficients decaying like a smooth function's, with a large constant term like a position.
    coeffs = rng.normal(size=(n_seg, n_ch, 3, degree + 1)) * 10.0 ** -np.arange(degree + 1)
    coeffs[..., 0] += 1e8
    t0, seg = -3.3e8, 1234.5
    out = np.empty((n_ch, 3))
    one = np.empty(3)
    for t in t0 + rng.uniform(0.0, n_seg * seg, 500):
        ref = _oracle(coeffs, t0, seg, t)
        assert et.positions_kernel(coeffs, t0, seg, t, 0, n_ch, out)
        np.testing.assert_allclose(out, ref, rtol=1e-9, atol=0.0)
        assert et.position_kernel(coeffs, t0, seg, t, 2, one)
        np.testing.assert_array_equal(one, out[2])
        sub = np.empty((2, 3))
        assert et.positions_kernel(coeffs, t0, seg, t, 1, 3, sub)
        np.testing.assert_array_equal(sub, out[1:3])


@pytest.mark.parametrize("degree", [1, 3, 12])
def test_fit_recovers_a_polynomial_exactly(degree):
    """Fitting a channel that *is* a piecewise polynomial of the table's degree returns its coefficients."""
    rng = np.random.default_rng(10 + degree)
    n_ch, seg, t0 = 2, 1000.0, 5.0e5
    truth_c = rng.normal(size=(n_ch, 3, degree + 1))

    def positions(times):
        x = 2.0 * (times - t0) / seg - 1.0  # one segment
        return np.moveaxis(npcheb.chebval(x, truth_c.reshape(-1, degree + 1).T).reshape(n_ch, 3, -1), -1, 0)

    coeffs = et.fit_table(positions, t0, seg, n_ch, segment_s=seg, degree=degree)
    assert coeffs.shape == (1, n_ch, 3, degree + 1)
    np.testing.assert_allclose(coeffs[0], truth_c, atol=1e-12)


def test_fit_calls_positions_once_with_shared_boundaries():
    calls = []

    def positions(times):
        calls.append(times.copy())
        return np.stack([np.stack([times, 2 * times, -times], axis=1)], axis=1)

    coeffs = et.fit_table(positions, 100.0, 2500.0, 1, segment_s=1000.0, degree=6)
    assert len(calls) == 1
    assert coeffs.shape == (3, 1, 3, 7)
    assert len(calls[0]) == 3 * 6 + 1 and np.all(np.diff(calls[0]) > 0)
    assert calls[0][0] == 100.0 and calls[0][-1] == 3100.0
    # A linear function: only T_0 and T_1 survive.
    np.testing.assert_allclose(coeffs[..., 2:], 0.0, atol=1e-9)
    np.testing.assert_allclose(
        et.evaluate(coeffs, 100.0, 1000.0, np.array([1234.0]))[0, 0], [1234, 2468, -1234]
    )


def test_bad_inputs_raise():
    ok = lambda t: np.zeros((len(t), 2, 3))  # noqa: E731
    for bad_t0 in (np.nan, np.inf, -np.inf, "x", None):
        with pytest.raises(InvalidParameterError, match="t0"):
            et.fit_table(ok, bad_t0, DAY, 2)
    for bad in (0.0, -1.0, np.nan, np.inf):
        with pytest.raises(InvalidParameterError, match="duration_s"):
            et.fit_table(ok, 0.0, bad, 2)
        with pytest.raises(InvalidParameterError, match="segment_s"):
            et.fit_table(ok, 0.0, DAY, 2, segment_s=bad)
    for bad_deg in (0, -3, 2.5, True):
        with pytest.raises(InvalidParameterError, match="degree"):
            et.fit_table(ok, 0.0, DAY, 2, degree=bad_deg)
    with pytest.raises(InvalidParameterError, match="n_channels"):
        et.fit_table(ok, 0.0, DAY, 0)
    with pytest.raises(InvalidParameterError, match="shape"):
        et.fit_table(ok, 0.0, DAY, 3)
    with pytest.raises(NonFiniteError, match="non-finite"):
        et.fit_table(lambda t: np.full((len(t), 2, 3), np.nan), 0.0, DAY, 2)
    with pytest.raises(InvalidParameterError):
        et.TableSpec(0.0, 12, 1, 1)
    with pytest.raises(InvalidParameterError):
        et.body_positions(None, [])


def test_spec_bytes_and_segments():
    cruise = et.TableSpec.for_duration(DAY, 3)
    approach = et.TableSpec.for_duration(95 * 3600.0 + 60.0, 5)
    long = et.TableSpec.for_duration(60 * DAY, 3)
    assert (cruise.n_segments, approach.n_segments, long.n_segments) == (1, 1, 12)
    assert cruise.nbytes == 936 and approach.nbytes == 1560 and long.nbytes == 11232
    assert et.TableSpec.for_duration(10 * DAY, 1).n_segments == 2  # exactly two segments
    assert et.TableSpec.for_duration(10 * DAY + 1.0, 1).n_segments == 3
    coeffs, t0 = approach.allocate(4)
    assert coeffs.shape == (4, 1, 5, 3, 13) and t0.shape == (4,)
    assert coeffs[0].nbytes == approach.nbytes


def test_batch_fit_and_kernel(eph):
    t0s = np.array([6.6e8, 6.7e8, -1.0e8])
    duration = 95 * 3600.0
    chans = [("mars", "sun"), ("sun", "mars"), ("earth", "mars"), ("jupiter", "mars"), ("mars", "ssb")]
    pos = et.body_positions(eph, chans)
    coeffs, t0, spec = et.fit_batch(lambda i, t: pos(t), t0s, duration, len(chans))
    assert coeffs.shape == (3, *spec.shape)
    t = t0 + np.array([0.0, 1e5, duration])
    out = np.empty((3, 3, 3))
    ok = np.zeros(3, dtype=np.bool_)
    assert et.positions_batch_kernel(coeffs, t0, spec.segment_s, t, 1, 4, out, ok)
    assert ok.all()
    for i in range(3):
        ref = pos(np.array([t[i]]))[0]
        assert np.abs(out[i] - ref[1:4]).max() < TOL_KM
        assert np.abs(ref[4] - (eph.position("mars", t[i]) + eph.sun_barycentric_position(t[i]))).max() < 1e-6
    t[1] += 2 * duration
    assert not et.positions_batch_kernel(coeffs, t0, spec.segment_s, t, 1, 4, out, ok)
    assert list(ok) == [True, False, True]
