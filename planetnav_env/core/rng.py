"""Per-row random streams for compiled (numba) kernels: xoshiro256** on a 4-word uint64 state.

Why: the core steps N environment rows in one compiled loop (possibly on threads, later one row per GPU
thread), where numpy ``Generator`` objects cannot be used. Each row instead owns a state array ``(4,)``
uint64 (a batch: ``(N, 4)``), seeded from that row's Gymnasium ``np_random`` by :func:`seed_state`, and
the kernels below advance it *in place*. A row's stream is therefore reproducible from its seed alone and
independent of how many rows there are, of their order and of threading.

Generator: xoshiro256** (D. Blackman and S. Vigna, "Scrambled linear pseudorandom number generators",
public domain), period 2^256 - 1, 64-bit outputs; written here from the published algorithm. Numba typing
note: mixing uint64 with a Python int or an int64 promotes to float64 and would silently ruin the
generator, so every constant below is an ``np.uint64`` (shifts and rotation counts included).

Kernels (``@njit(cache=True, nogil=True)``, no allocation, one row's state ``s`` per call):

* :func:`next_u64` - the next raw 64-bit output (exactly one state step);
* :func:`uniform` - a float64 in [0, 1) with 53 random bits (one step);
* :func:`standard_normal` - N(0, 1) by the Box-Muller transform (always exactly two steps: a fixed
  number of draws per call keeps streams aligned and avoids the data-dependent loop of the polar or
  ziggurat methods, which would make GPU threads diverge); it returns the cosine branch only;
* :func:`normal_fill` - fills a 1-D or 2-D float64 array (row-major order) with N(0, 1) values, two per
  Box-Muller pair (cosine then sine branch), i.e. exactly ``2 * ceil(size / 2)`` steps. For size 1 it
  equals :func:`standard_normal`; for larger sizes it is *not* the same sequence as repeated calls of
  :func:`standard_normal` (which discard the sine branch);
* :func:`substream` - a fresh state derived from a row's *key* (its 4 words, left unadvanced), a step
  index and a stream id: the per-step noise streams (``EnvConfig.noise_streams = "per_step"``).

Per-step streams (common random numbers). A sequential stream hands out numbers in the order they are
asked for, so two policies run on the same seed share their sensor noise only until their first
different choice: one more star in the field or one more camera measurement shifts every later draw. With
per-step streams the noise of sensor ``stream`` at step ``k`` is drawn from :func:`substream` ``(key, k,
stream)``, whatever happened before; two policies that make the same measurement at the same step see the
same noise, which is what makes their paired difference small (common random numbers, a textbook
variance reduction). The derivation is SplitMix64 (G. Steele, D. Lea, C. Flood, "Fast splittable
pseudorandom number generators", 2014), the seeding the xoshiro authors recommend: the key words, ``k``
and ``stream`` pass through its finaliser in a chain, then four SplitMix64 outputs make the state.

The Box-Muller radius uses ``1 - uniform`` in (0, 1], so ``log`` never sees 0; the largest normal
magnitude it can produce is ``sqrt(2 * 53 * ln 2) = 8.57`` (a truncation at 8.57 sigma, probability 1e-17).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from planetnav_env.errors import InvalidParameterError
from planetnav_env.numerics.jit import row_kernel

#: Number of uint64 words in one row's state.
STATE_WORDS = 4

# uint64 constants (see the module docstring: no Python ints may meet a uint64 inside the kernels).
_U5 = np.uint64(5)
_U7 = np.uint64(7)
_U9 = np.uint64(9)
_U11 = np.uint64(11)
_U17 = np.uint64(17)
_U45 = np.uint64(45)
_U64 = np.uint64(64)
#: 2^-53: a 53-bit integer times this is a float64 in [0, 1), exactly representable.
_TWO_M53 = 1.0 / 9007199254740992.0
_TWO_PI = 2.0 * math.pi
# SplitMix64 constants (the golden-ratio increment and the finaliser's two multipliers).
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_U27 = np.uint64(27)
_U30 = np.uint64(30)
_U31 = np.uint64(31)
_U40 = np.uint64(40)


def seed_state(generator: np.random.Generator) -> np.ndarray:
    """A fresh row state ``(4,)`` uint64 drawn from ``generator`` (e.g. a Gymnasium env's ``np_random``).

    The 256 bits come straight from the numpy generator (themselves well mixed, so no extra scrambling
    is needed); the all-zero state, the one fixed point of xoshiro, is redrawn (probability 2^-256).
    """
    if not hasattr(generator, "integers"):
        raise InvalidParameterError(f"generator must be a numpy Generator, got {generator!r}")
    for _ in range(64):
        state = np.asarray(
            generator.integers(0, 2**64, size=STATE_WORDS, dtype=np.uint64, endpoint=False), dtype=np.uint64
        )
        if state.shape == (STATE_WORDS,) and np.any(state != 0):
            return np.ascontiguousarray(state)
    raise InvalidParameterError(f"generator {generator!r} produced only all-zero xoshiro states")


def seed_states(generator: np.random.Generator, n_rows: int) -> np.ndarray:
    """States ``(n_rows, 4)`` uint64 for a batch, drawn row by row with :func:`seed_state`."""
    if isinstance(n_rows, bool) or not isinstance(n_rows, int | np.integer) or n_rows < 0:
        raise InvalidParameterError(f"n_rows must be an integer >= 0, got {n_rows!r}")
    out = np.empty((int(n_rows), STATE_WORDS), dtype=np.uint64)
    for i in range(int(n_rows)):
        out[i] = seed_state(generator)
    return out


@njit(cache=True, nogil=True, inline="always")
def _rotl(x, k):
    return (x << k) | (x >> (_U64 - k))


@row_kernel
def next_u64(s):
    """Next 64-bit output (uint64) of the xoshiro256** stream in ``s`` (4,) uint64, advanced in place."""
    s0 = s[0]
    s1 = s[1]
    s2 = s[2]
    s3 = s[3]
    result = _rotl(s1 * _U5, _U7) * _U9  # uint64 products wrap modulo 2^64, as the algorithm requires
    t = s1 << _U17
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, _U45)
    s[0] = s0
    s[1] = s1
    s[2] = s2
    s[3] = s3
    return result


@row_kernel
def uniform(s):
    """A float64 uniform on [0, 1): the top 53 bits of one output times 2^-53 (the low bits of xoshiro
    outputs are the weakest, so they are the ones dropped)."""
    return float(next_u64(s) >> _U11) * _TWO_M53


@row_kernel
def _box_muller(s):
    # 1 - u is in (0, 1]: log() is finite. The angle uses the second draw.
    r = math.sqrt(-2.0 * math.log(1.0 - uniform(s)))
    a = _TWO_PI * uniform(s)
    return r * math.cos(a), r * math.sin(a)


@row_kernel
def standard_normal(s):
    """A N(0, 1) float64 (Box-Muller, cosine branch; exactly two state steps per call)."""
    z0, _ = _box_muller(s)
    return z0


@njit(cache=True, nogil=True)
def normal_fill(s, out):
    """Fill ``out`` (1-D or 2-D float64, any strides) with N(0, 1) values in row-major order, in place.

    Uses both Box-Muller branches: ``2 * ceil(out.size / 2)`` state steps; no allocation.
    """
    n = out.size
    flat = out.flat  # an iterator view, not a copy: writes land in ``out`` whatever its strides
    i = 0
    while i < n:
        z0, z1 = _box_muller(s)
        flat[i] = z0
        if i + 1 < n:
            flat[i + 1] = z1
        i += 2


@njit(cache=True, nogil=True, inline="always")
def _mix64(z):
    z = (z ^ (z >> _U30)) * _MIX1
    z = (z ^ (z >> _U27)) * _MIX2
    return z ^ (z >> _U31)


@row_kernel
def substream(key, k, stream, out):
    """Fill ``out`` (4,) uint64 with the xoshiro state of sensor ``stream`` at step ``k`` of the row whose
    key is ``key`` (4,) uint64 (read only). ``k`` in [0, 2^40), ``stream`` in [0, 2^24).

    Same (key, k, stream): the same state; any other triple: an unrelated one (SplitMix64 chain, see the
    module docstring). Callers draw from ``out`` as from any row state.
    """
    x = _mix64(key[3] ^ np.uint64(k) ^ (np.uint64(stream) << _U40))
    x = _mix64(key[2] ^ x)
    x = _mix64(key[1] ^ x)
    x = key[0] ^ x
    nonzero = False
    for j in range(4):
        x = x + _GOLDEN
        out[j] = _mix64(x)
        nonzero = nonzero or out[j] != np.uint64(0)
    if not nonzero:  # xoshiro's one fixed point (probability 2^-256)
        out[0] = np.uint64(1)


__all__ = [
    "STATE_WORDS",
    "next_u64",
    "normal_fill",
    "seed_state",
    "seed_states",
    "standard_normal",
    "substream",
    "uniform",
]
