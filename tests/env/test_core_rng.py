"""Per-row xoshiro256** streams (planetnav_env.core.rng): reference match, distributions, independence."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy import stats

from planetnav_env.core import rng as prng
from planetnav_env.errors import InvalidParameterError

MASK = (1 << 64) - 1
N = 200_000


# --------------------------------------------------------------------------------------------------------
# Pure-Python reference (Python ints masked to 64 bits), written from the published algorithm.
# --------------------------------------------------------------------------------------------------------
def _rotl(x: int, k: int) -> int:
    return ((x << k) | (x >> (64 - k))) & MASK


class Reference:
    def __init__(self, state) -> None:
        self.s = [int(w) for w in state]

    def next(self) -> int:
        s = self.s
        result = (_rotl((s[1] * 5) & MASK, 7) * 9) & MASK
        t = (s[1] << 17) & MASK
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = _rotl(s[3], 45)
        return result

    def uniform(self) -> float:
        return (self.next() >> 11) / 2.0**53

    def box_muller(self) -> tuple[float, float]:
        r = math.sqrt(-2.0 * math.log(1.0 - self.uniform()))
        a = 2.0 * math.pi * self.uniform()
        return r * math.cos(a), r * math.sin(a)


@njit(cache=True)
def _draw_u64(s, n):
    out = np.empty(n, dtype=np.uint64)
    for i in range(n):
        out[i] = prng.next_u64(s)
    return out


@njit(cache=True)
def _draw_uniform(s, n):
    out = np.empty(n)
    for i in range(n):
        out[i] = prng.uniform(s)
    return out


@njit(cache=True)
def _draw_normal(s, n):
    out = np.empty(n)
    for i in range(n):
        out[i] = prng.standard_normal(s)
    return out


@njit(cache=True)
def _batch_normals(states, out):
    """How the core uses the kernels: one loop over rows, each with its own stream."""
    for i in range(states.shape[0]):
        prng.normal_fill(states[i], out[i])


def state(seed: int) -> np.ndarray:
    return prng.seed_state(np.random.default_rng(seed))


@pytest.mark.parametrize("seed", [0, 1, 12345, 2**40 + 7])
def test_matches_pure_python_reference(seed):
    s = state(seed)
    ref = Reference(s)
    got = _draw_u64(s, 1000)
    assert got.dtype == np.uint64
    assert [int(v) for v in got] == [ref.next() for _ in range(1000)]
    # The state itself too (it advanced in place, exactly like the reference's).
    assert [int(w) for w in s] == ref.s
    # Single calls from Python (the kernels' own dispatch) and the float kernels.
    assert int(prng.next_u64(s)) == ref.next()
    for _ in range(50):
        assert prng.uniform(s) == ref.uniform()
    for _ in range(50):
        assert prng.standard_normal(s) == pytest.approx(ref.box_muller()[0], rel=1e-13, abs=1e-15)
    out = np.empty(7)
    prng.normal_fill(s, out)
    expect = [z for _ in range(4) for z in ref.box_muller()][:7]
    np.testing.assert_allclose(out, expect, rtol=1e-13, atol=1e-15)
    assert [int(w) for w in s] == ref.s


def test_known_values_from_a_fixed_state():
    """Hand-set states (no numpy seeding involved), including words with the top bit set; the first output
    of [1, 2, 3, 4] computed by hand: s1 = 2 -> rotl(2 * 5, 7) * 9 = 1280 * 9 = 11520."""
    s = np.array([1, 2, 3, 4], dtype=np.uint64)
    assert int(prng.next_u64(s)) == 11520
    ref = Reference([1, 2, 3, 4])
    ref.next()
    assert [int(w) for w in s] == ref.s
    big = np.array([MASK, MASK - 1, 2**63, 12345678901234567890], dtype=np.uint64)
    ref = Reference(big)
    assert [int(v) for v in _draw_u64(big, 200)] == [ref.next() for _ in range(200)]


def test_uniform_distribution():
    u = _draw_uniform(state(7), N)
    assert u.min() >= 0.0 and u.max() < 1.0
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    se_mean = math.sqrt(1.0 / 12.0 / N)
    assert abs(u.mean() - 0.5) < 5 * se_mean
    assert abs(u.var() - 1.0 / 12.0) < 5 * math.sqrt(1.0 / 180.0 / N)  # var of (u - 1/2)^2 is 1/180
    # 53-bit resolution: values are multiples of 2^-53, and the low bits are used (not only 32).
    assert np.all(u * 2.0**53 == np.floor(u * 2.0**53))
    assert np.any((u * 2.0**53) % 2.0**21 != 0)


def normal_failures(x: np.ndarray) -> set[str]:
    """Which of the distribution checks a supposedly N(0, 1) sample fails (5-sigma tolerances)."""
    n = len(x)
    failed = set()
    if stats.kstest(x, "norm").pvalue <= 1e-3:
        failed.add("ks")
    if abs(x.mean()) > 5 * math.sqrt(1.0 / n):
        failed.add("mean")
    if abs(np.mean(x**2) - 1.0) > 5 * math.sqrt(2.0 / n):  # var(x^2) = 2
        failed.add("variance")
    if abs(np.mean(x**4) - 3.0) > 5 * math.sqrt(96.0 / n):  # var(x^4) = 105 - 9
        failed.add("fourth_moment")
    return failed


def test_standard_normal_distribution():
    z = _draw_normal(state(11), N)
    assert normal_failures(z) == set()
    assert np.abs(z).max() < 8.58  # the Box-Muller truncation with 53-bit uniforms


def test_normal_checks_can_fail():
    """The tolerances above are tight enough to reject a wrong variance (1.1), a wrong tail shape (same
    variance, fourth moment off) and a small bias."""
    z = _draw_normal(state(11), N)
    assert {"ks", "variance", "fourth_moment"} <= normal_failures(z * math.sqrt(1.1))
    assert {"ks", "mean"} <= normal_failures(z + 0.02)
    # Uniform on [-sqrt(3), sqrt(3)]: mean 0, variance 1, but kurtosis 1.8.
    u = (2.0 * _draw_uniform(state(12), N) - 1.0) * math.sqrt(3.0)
    assert {"ks", "fourth_moment"} <= normal_failures(u)


def test_normal_fill_distribution_and_shapes():
    s = state(21)
    out = np.empty((N // 4, 4))
    prng.normal_fill(s, out)
    assert normal_failures(out.ravel()) == set()
    # Cosine and sine branches of the same pair are uncorrelated.
    assert abs(np.corrcoef(out[:, 0], out[:, 1])[0, 1]) < 5 / math.sqrt(len(out))
    # Non-contiguous view: written in place, untouched elements stay.
    base = np.zeros((6, 5))
    view = base[::2, 1:4]
    s1, s2 = state(3), state(3)
    prng.normal_fill(s1, view)
    dense = np.empty(9)
    prng.normal_fill(s2, dense)
    np.testing.assert_array_equal(view.ravel(), dense)
    assert np.all(base[1::2] == 0.0) and np.all(base[:, 0] == 0.0) and np.all(base[:, 4] == 0.0)
    np.testing.assert_array_equal(s1, s2)  # 2 * ceil(9 / 2) = 10 steps each


def test_rows_uncorrelated():
    parent = np.random.default_rng(2024)
    a, b = prng.seed_state(parent), prng.seed_state(parent)  # consecutive rows of one batch
    c = state(2025)  # a row from another seed
    n = 100_000
    ua, ub, uc = (_draw_uniform(x, n) for x in (a, b, c))
    lim = 5 / math.sqrt(n)
    assert abs(np.corrcoef(ua, ub)[0, 1]) < lim
    assert abs(np.corrcoef(ua, uc)[0, 1]) < lim
    assert abs(np.corrcoef(ua[:-1], ua[1:])[0, 1]) < lim  # lag 1 within a stream
    # Seeds differing in one bit.
    za, zb = _draw_normal(state(100), n), _draw_normal(state(101), n)
    assert abs(np.corrcoef(za, zb)[0, 1]) < lim


def test_determinism_and_in_place_advance():
    s1, s2 = state(99), state(99)
    np.testing.assert_array_equal(s1, s2)
    before = s1.copy()
    x1 = _draw_u64(s1, 100)
    assert not np.array_equal(s1, before)  # advanced in place
    x2 = _draw_u64(s2, 100)
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(s1, s2)
    # One step per uniform, two per standard normal.
    t1, t2 = state(5), state(5)
    prng.uniform(t1)
    prng.next_u64(t2)
    np.testing.assert_array_equal(t1, t2)
    prng.standard_normal(t1)
    prng.next_u64(t2)
    prng.next_u64(t2)
    np.testing.assert_array_equal(t1, t2)
    assert not np.array_equal(state(99), state(98))


def test_batch_loop_equals_per_row_calls():
    states = prng.seed_states(np.random.default_rng(8), 5)
    assert states.shape == (5, prng.STATE_WORDS) and states.dtype == np.uint64
    copy = states.copy()
    out = np.empty((5, 3, 2))
    _batch_normals(states, out)
    for i in range(5):
        row = np.empty((3, 2))
        prng.normal_fill(copy[i], row)
        np.testing.assert_array_equal(out[i], row)
    np.testing.assert_array_equal(states, copy)
    # A row's stream does not depend on the others: the same row alone gives the same numbers.
    alone = prng.seed_states(np.random.default_rng(8), 5)[2]
    row = np.empty((3, 2))
    prng.normal_fill(alone, row)
    np.testing.assert_array_equal(row, out[2])


def test_seed_state_never_zero_and_validates():
    class ZerosThenOnes:
        calls = 0

        def integers(self, low, high, size, dtype, endpoint):
            self.calls += 1
            return np.zeros(size, dtype) if self.calls == 1 else np.ones(size, dtype)

    s = prng.seed_state(ZerosThenOnes())
    assert s.dtype == np.uint64 and s.shape == (4,) and np.all(s == 1)

    class AlwaysZero:
        def integers(self, low, high, size, dtype, endpoint):
            return np.zeros(size, dtype)

    with pytest.raises(InvalidParameterError, match="all-zero"):
        prng.seed_state(AlwaysZero())
    with pytest.raises(InvalidParameterError, match="Generator"):
        prng.seed_state(42)
    with pytest.raises(InvalidParameterError, match="n_rows"):
        prng.seed_states(np.random.default_rng(0), -1)
    # Full 64-bit words are drawn (high bits set somewhere).
    many = prng.seed_states(np.random.default_rng(0), 64)
    assert np.any(many >= np.uint64(2**63))
