"""Per-row piecewise-Chebyshev ephemeris tables, evaluated inside compiled (numba) kernels.

Why: the Python environment stores every body position at every half step of an episode (~200 kB per
row); a batch of N = 4096 rows would need ~800 MB. Here each row holds instead, for each of its C
*channels* (a channel is any 3-vector function of time in km: a planet's heliocentric position, a
perturber relative to the central body, the central body relative to the Solar-system barycentre, ...;
the caller decides which), a piecewise Chebyshev fit over the episode's span.

Layout of one row: ``coeffs[s, c, k, j]`` (float64, shape ``(S, C, 3, D + 1)``) is the coefficient of
``T_j`` for component ``k`` of channel ``c`` on segment ``s``, which covers
``[t0 + s * segment_s, t0 + (s + 1) * segment_s]`` mapped onto ``x in [-1, 1]``. A batch holds
``coeffs`` of shape ``(N, S, C, 3, D + 1)`` and ``t0`` of shape ``(N,)`` (every row shares S, C, D and
``segment_s``; only the epochs differ). Units km, s; frame ICRF; time TDB seconds since J2000.

Fit: interpolation at the Chebyshev-Lobatto points (the extrema ``cos(pi k / D)``, Chebyshev points of
the second kind) of each segment, coefficients by a DCT-I. Lobatto points include both ends of a segment,
so adjacent segments interpolate the *same* sample at their common boundary: the table is continuous
across boundaries (up to rounding), not merely within the fit error. Interpolation at these points is
within a factor ``~2 + (2/pi) log D`` of the best polynomial approximation.

Defaults (:data:`SEGMENT_S` = 5 days, :data:`DEGREE` = 12, i.e. 13 coefficients): measured against DE421
(:class:`planetnav_env.astro.ephemeris.DEEphemeris`) at random epochs 1990-2030, the error of Mercury, Venus,
Earth, Moon, Mars, Jupiter (heliocentric), Earth and Jupiter relative to Mars and the Sun-barycentre
offset is at most ~1e-5 km (1 cm), which is the floor set by rounding of the time argument (one ulp of
``t ~ 1e9 s`` is 1.2e-7 s, i.e. ~6e-6 km at 47 km/s). The hardest channel (the Moon, heliocentric) reaches
1e-4 km at D = 10 and 1e-5 km at D = 11 with 5-day segments: D = 12 leaves two orders of magnitude of
margin below the 1 m (1e-3 km) requirement. A 5-day segment holds a whole cruise episode (1 day) or Mars
approach (95 h plus a step) in one segment; longer episodes take more segments (60 days: 12).

Bytes per row (``S * C * 3 * (D + 1) * 8``; 312 B per channel and segment):

* cruise, 3 planets, 1 day: S = 1, C = 3 -> 936 B (the half-step table: ~200 kB);
* Mars approach, 95 h: Mars heliocentric + Sun/Earth/Jupiter relative to Mars + Mars relative to the
  barycentre: S = 1, C = 5 -> 1560 B;
* 60 days, 3 planets: S = 12, C = 3 -> 11232 B.

At N = 4096 rows a 5-channel table takes 6.4 MB.

Kernels (``@njit(cache=True, nogil=True)``) take one row's arrays and scalars, allocate nothing and
return ``False`` instead of raising (a time outside ``[t0, t0 + S * segment_s]`` beyond
:data:`SPAN_TOL_S`, a NaN time, or a channel out of range), so that they can be called from a
batch loop, on threads, and later ported to one-row-per-thread GPU code.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from planetnav_env.errors import InvalidParameterError, NonFiniteError
from planetnav_env.numerics import portable_math as pm
from planetnav_env.numerics.jit import row_kernel

#: Default segment length [s]: 5 days (see the module docstring for the accuracy it gives).
SEGMENT_S = 5.0 * 86400.0
#: Default polynomial degree per segment (D + 1 = 13 coefficients).
DEGREE = 12
#: How far [s] a time may lie outside ``[t0, t0 + S * segment_s]`` and still be evaluated (the polynomial
#: is extrapolated by that much). Several ulps of ``t`` near 2050 (2.4e-7 s): absorbs the rounding of
#: ``t0 + k * step`` computed by callers, and at 50 km/s it moves a position by at most 5e-5 km.
SPAN_TOL_S = 1e-6


# --------------------------------------------------------------------------------------------------------
# Layout
# --------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TableSpec:
    """Layout of one row's table: ``n_segments`` segments of ``segment_s`` [s], ``n_channels`` 3-vector
    channels, polynomials of degree ``degree``. Shared by every row of a batch."""

    segment_s: float
    degree: int
    n_segments: int
    n_channels: int

    def __post_init__(self) -> None:
        _check_positive_finite("segment_s", self.segment_s)
        _check_int("degree", self.degree, 1)
        _check_int("n_segments", self.n_segments, 1)
        _check_int("n_channels", self.n_channels, 1)

    @classmethod
    def for_duration(
        cls, duration_s: float, n_channels: int, segment_s: float = SEGMENT_S, degree: int = DEGREE
    ) -> TableSpec:
        """The layout that covers ``[t0, t0 + duration_s]``: ``ceil(duration_s / segment_s)`` segments
        (at least one)."""
        _check_positive_finite("duration_s", duration_s)
        _check_positive_finite("segment_s", segment_s)
        return cls(float(segment_s), int(degree), max(1, math.ceil(duration_s / segment_s)), int(n_channels))

    @property
    def n_coeffs(self) -> int:
        """Coefficients per component and segment (``degree + 1``)."""
        return self.degree + 1

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """Shape of one row's coefficients ``(S, C, 3, D + 1)``."""
        return (self.n_segments, self.n_channels, 3, self.n_coeffs)

    @property
    def span_s(self) -> float:
        """Length [s] of the time span a row covers (``S * segment_s``, at least the requested duration)."""
        return self.n_segments * self.segment_s

    @property
    def nbytes(self) -> int:
        """Bytes of one row's coefficients (float64), not counting its ``t0``."""
        return 8 * self.n_segments * self.n_channels * 3 * self.n_coeffs

    def allocate(self, n_rows: int) -> tuple[np.ndarray, np.ndarray]:
        """Zeroed batch storage: ``coeffs`` ``(n_rows, S, C, 3, D + 1)`` and ``t0`` ``(n_rows,)``,
        both C-contiguous float64 (a row ``coeffs[i]`` is then a contiguous block for the kernels)."""
        _check_int("n_rows", n_rows, 0)
        return np.zeros((int(n_rows), *self.shape)), np.zeros(int(n_rows))


def _check_positive_finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a positive finite number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise InvalidParameterError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _check_int(name: str, value: int, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InvalidParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


# --------------------------------------------------------------------------------------------------------
# Fit
# --------------------------------------------------------------------------------------------------------
def lobatto_nodes(degree: int) -> np.ndarray:
    """The ``degree + 1`` Chebyshev-Lobatto points on [-1, 1] in ascending order (-1 and 1 included)."""
    _check_int("degree", degree, 1)
    # cos(pi (D - m) / D) ascending; the ends are set exactly so that adjacent segments share them.
    y = pm.cos(np.pi * np.arange(degree, -1, -1) / degree)
    y[0], y[-1] = -1.0, 1.0
    return y


def _values_to_coeffs(degree: int) -> np.ndarray:
    """Matrix ``M`` (D+1, D+1): Chebyshev coefficients ``c = M @ f`` of the interpolant of values ``f`` at
    the ascending Lobatto points (a DCT-I: ``c_j = (2/D) sum''_k f(x_k) cos(pi j k / D)``, the double prime
    halving the k = 0 and k = D terms, and ``c_0``, ``c_D`` halved)."""
    d = degree
    j = np.arange(d + 1)
    k = d - j  # ascending node m sits at x = cos(pi (D - m) / D)
    m = (2.0 / d) * pm.cos(np.pi * np.outer(j, k) / d)
    m[:, 0] *= 0.5
    m[:, -1] *= 0.5
    m[0] *= 0.5
    m[-1] *= 0.5
    return m


def fit_times(t0: float, spec: TableSpec) -> np.ndarray:
    """The ``S * D + 1`` distinct sample times [TDB s] of a fit: the Lobatto points of every segment
    (ascending; a segment's last point is the next one's first)."""
    y = lobatto_nodes(spec.degree)
    u = (np.arange(spec.n_segments)[:, None] + 0.5 * (1.0 + y[None, :-1])).ravel()
    u = np.append(u, float(spec.n_segments))
    return float(t0) + spec.segment_s * u


def fit_table(
    positions: Callable[[np.ndarray], np.ndarray],
    t0: float,
    duration_s: float,
    n_channels: int,
    segment_s: float = SEGMENT_S,
    degree: int = DEGREE,
) -> np.ndarray:
    """Chebyshev coefficients ``(S, C, 3, D + 1)`` of ``n_channels`` position channels over
    ``[t0, t0 + duration_s]``, ``S = max(1, ceil(duration_s / segment_s))``.

    ``positions(times)`` takes TDB times [s since J2000] of shape ``(T,)`` and returns ``(T, C, 3)`` [km];
    it is called once, for all ``S * D + 1`` sample times. Raises :class:`InvalidParameterError` for a
    non-finite ``t0``, a non-positive or non-finite ``duration_s`` / ``segment_s``, ``degree < 1``,
    ``n_channels < 1`` or a wrongly shaped result, :class:`NonFiniteError` for a non-finite result.
    """
    try:
        t0f = float(t0)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"t0 must be a finite time [s], got {t0!r}") from None
    if not math.isfinite(t0f):
        raise InvalidParameterError(f"t0 must be a finite time [s], got {t0!r}")
    _check_int("degree", degree, 1)
    _check_int("n_channels", n_channels, 1)
    spec = TableSpec.for_duration(duration_s, n_channels, segment_s, degree)
    times = fit_times(t0f, spec)
    values = np.asarray(positions(times), dtype=float)
    if values.shape != (len(times), spec.n_channels, 3):
        raise InvalidParameterError(
            f"positions(times) must return shape {(len(times), spec.n_channels, 3)}, got {values.shape}"
        )
    if not np.all(np.isfinite(values)):
        bad = np.argwhere(~np.isfinite(values))[0]
        raise NonFiniteError(f"positions(times) is non-finite at t = {times[bad[0]]!r}, channel {bad[1]}")
    d = spec.degree
    # (S, D+1, C, 3): segment s uses samples s*D .. s*D + D (the shared boundary sample twice).
    idx = np.arange(spec.n_segments)[:, None] * d + np.arange(d + 1)[None, :]
    per_seg = values[idx]
    coeffs = np.einsum("jm,smck->sckj", _values_to_coeffs(d), per_seg)
    return np.ascontiguousarray(coeffs)


def fit_batch(
    positions: Callable[[int, np.ndarray], np.ndarray],
    t0: np.ndarray,
    duration_s: float,
    n_channels: int,
    segment_s: float = SEGMENT_S,
    degree: int = DEGREE,
) -> tuple[np.ndarray, np.ndarray, TableSpec]:
    """Tables of a batch: ``positions(row, times) -> (T, C, 3)`` for each row ``row`` with epoch ``t0[row]``.

    Returns ``coeffs`` ``(N, S, C, 3, D + 1)``, ``t0`` ``(N,)`` (float64 copies) and the shared
    :class:`TableSpec`.
    """
    t0 = np.atleast_1d(np.asarray(t0, dtype=float))
    if t0.ndim != 1:
        raise InvalidParameterError(f"t0 must be a 1-D array of epochs, got shape {t0.shape}")
    spec = TableSpec.for_duration(duration_s, n_channels, segment_s, degree)
    coeffs, t0_out = spec.allocate(len(t0))
    for i, ti in enumerate(t0):
        coeffs[i] = fit_table(lambda t, i=i: positions(i, t), ti, duration_s, n_channels, segment_s, degree)
        t0_out[i] = ti
    return coeffs, t0_out, spec


def body_positions(ephemeris, channels: Sequence[tuple[str, str]]) -> Callable[[np.ndarray], np.ndarray]:
    """A ``positions`` callable for :func:`fit_table` from an ephemeris (e.g. ``DEEphemeris``).

    Each channel is ``(target, origin)``: the position of ``target`` relative to ``origin`` [km], where
    ``origin`` is ``"sun"`` (heliocentric), another body, or ``"ssb"`` (the Solar-system barycentre;
    needs ``ephemeris.sun_barycentric_position``). E.g. the approach's
    ``[("mars", "sun"), ("sun", "mars"), ("earth", "mars"), ("jupiter", "mars"), ("mars", "ssb")]``.
    """
    chans = [(str(a).lower(), str(b).lower()) for a, b in channels]
    if not chans:
        raise InvalidParameterError("channels must name at least one (target, origin) pair")

    def positions(times: np.ndarray) -> np.ndarray:
        cache: dict[str, np.ndarray] = {}

        def helio(name: str) -> np.ndarray:
            if name not in cache:
                if name == "sun":
                    cache[name] = np.zeros((len(times), 3))
                elif name == "ssb":  # barycentre relative to the Sun
                    cache[name] = -np.asarray(ephemeris.sun_barycentric_position(times))
                else:
                    cache[name] = np.asarray(ephemeris.position(name, times))
            return cache[name]

        return np.stack([helio(a) - helio(b) for a, b in chans], axis=1)

    return positions


# --------------------------------------------------------------------------------------------------------
# Compiled evaluation
# --------------------------------------------------------------------------------------------------------
@row_kernel
def _locate(t0, segment_s, n_segments, t):
    """Segment index and local coordinate x of ``t``; index -1 if ``t`` is outside the span (or NaN)."""
    dt = t - t0  # exact (Sterbenz) when t and t0 are within a factor 2, as epochs of one episode are
    span = n_segments * segment_s
    # Written so that a NaN fails the test (every comparison with NaN is False).
    if not (dt >= -SPAN_TOL_S and dt <= span + SPAN_TOL_S):
        return -1, 0.0
    i = int(dt / segment_s) if dt > 0.0 else 0  # truncation is the floor for dt >= 0
    # The end point itself (and the tolerance band) belongs to the last / first segment.
    if i >= n_segments:
        i = n_segments - 1
    return i, 2.0 * ((dt - i * segment_s) / segment_s) - 1.0


@row_kernel
def _clenshaw3(c, x, out):
    """``out[k] = sum_j c[k, j] T_j(x)`` for k = 0, 1, 2 by Clenshaw's recurrence (stable, one pass).

    The three components run in one loop: three independent dependency chains keep the FPU busy (about
    twice as fast as one component after the other)."""
    x2 = 2.0 * x
    a1 = a2 = b1 = b2 = d1 = d2 = 0.0
    for j in range(c.shape[1] - 1, 0, -1):
        a0 = c[0, j] + x2 * a1 - a2
        b0 = c[1, j] + x2 * b1 - b2
        d0 = c[2, j] + x2 * d1 - d2
        a2 = a1
        a1 = a0
        b2 = b1
        b1 = b0
        d2 = d1
        d1 = d0
    out[0] = c[0, 0] + x * a1 - a2
    out[1] = c[1, 0] + x * b1 - b2
    out[2] = c[2, 0] + x * d1 - d2


@row_kernel
def position_kernel(coeffs_row, t0, segment_s, t, channel, out):
    """Position [km] of ``channel`` at ``t`` [TDB s] into ``out`` (3,), from one row's ``coeffs_row``
    ``(S, C, 3, D + 1)`` with epoch ``t0`` and segment length ``segment_s`` [s].

    Returns ``False`` (``out`` untouched) if ``t`` is outside ``[t0, t0 + S * segment_s]`` by more than
    :data:`SPAN_TOL_S` (the end point is inside), NaN, or ``channel`` is out of range.
    """
    if channel < 0 or channel >= coeffs_row.shape[1]:
        return False
    seg, x = _locate(t0, segment_s, coeffs_row.shape[0], t)
    if seg < 0:
        return False
    _clenshaw3(coeffs_row[seg, channel], x, out)
    return True


@row_kernel
def velocity_kernel(coeffs_row, t0, segment_s, t, channel, out):
    """Velocity [km/s] of ``channel`` at ``t`` [TDB s] into ``out`` (3,): the time derivative of the
    table's polynomial, ``d/dt sum_j c_j T_j(x) = (2 / segment_s) sum_j j c_j U_{j-1}(x)`` (Chebyshev
    polynomials of the second kind, summed by Clenshaw's recurrence). Same conventions and failures as
    :func:`position_kernel`; within a segment it is the exact derivative of what ``position_kernel``
    returns, not a finite difference."""
    if channel < 0 or channel >= coeffs_row.shape[1]:
        return False
    seg, x = _locate(t0, segment_s, coeffs_row.shape[0], t)
    if seg < 0:
        return False
    c = coeffs_row[seg, channel]
    x2 = 2.0 * x
    scale = 2.0 / segment_s
    for k in range(3):
        b1 = b2 = 0.0
        for j in range(c.shape[1] - 1, 0, -1):  # coefficient of U_{j-1} is j c_j
            b0 = j * c[k, j] + x2 * b1 - b2
            b2 = b1
            b1 = b0
        out[k] = scale * b1
    return True


@row_kernel
def positions_kernel(coeffs_row, t0, segment_s, t, c_lo, c_hi, out):
    """Positions [km] of channels ``c_lo .. c_hi - 1`` at ``t`` into ``out`` ``(c_hi - c_lo, 3)``.

    Same conventions as :func:`position_kernel`; also ``False`` if the channel range is invalid or ``out``
    has too few rows.
    """
    if c_lo < 0 or c_hi > coeffs_row.shape[1] or c_lo > c_hi or out.shape[0] < c_hi - c_lo:
        return False
    seg, x = _locate(t0, segment_s, coeffs_row.shape[0], t)
    if seg < 0:
        return False
    for c in range(c_lo, c_hi):
        _clenshaw3(coeffs_row[seg, c], x, out[c - c_lo])
    return True


@njit(cache=True, nogil=True)
def positions_batch_kernel(coeffs, t0, segment_s, t, c_lo, c_hi, out, ok):
    """Every row of a batch: ``out[i]`` ``(c_hi - c_lo, 3)`` = channels of row ``i`` at ``t[i]``,
    ``ok[i]`` its :func:`positions_kernel` result. Returns whether all rows succeeded."""
    all_ok = True
    for i in range(coeffs.shape[0]):
        ok[i] = positions_kernel(coeffs[i], t0[i], segment_s, t[i], c_lo, c_hi, out[i])
        all_ok = all_ok and ok[i]
    return all_ok


@njit(cache=True, nogil=True)
def _evaluate_many(coeffs_row, t0, segment_s, times, out):
    c = coeffs_row.shape[1]
    for i in range(times.shape[0]):
        if not positions_kernel(coeffs_row, t0, segment_s, times[i], 0, c, out[i]):
            return i
    return -1


def evaluate(coeffs_row: np.ndarray, t0: float, segment_s: float, times: np.ndarray) -> np.ndarray:
    """Python-side evaluation of one row: positions ``times.shape + (C, 3)`` [km] of every channel.

    Raises :class:`InvalidParameterError` naming the first time outside the row's span.
    """
    coeffs_row = np.ascontiguousarray(coeffs_row, dtype=float)
    if coeffs_row.ndim != 4 or coeffs_row.shape[2] != 3:
        raise InvalidParameterError(f"coeffs_row must have shape (S, C, 3, D + 1), got {coeffs_row.shape}")
    times = np.asarray(times, dtype=float)
    flat = np.ascontiguousarray(times.ravel())
    out = np.empty((flat.size, coeffs_row.shape[1], 3))
    bad = _evaluate_many(coeffs_row, float(t0), float(segment_s), flat, out)
    if bad >= 0:
        end = float(t0) + coeffs_row.shape[0] * float(segment_s)
        raise InvalidParameterError(f"time {flat[bad]!r} s is outside the table span [{t0!r}, {end!r}] s")
    return out.reshape(times.shape + (coeffs_row.shape[1], 3))


__all__ = [
    "DEGREE",
    "SEGMENT_S",
    "SPAN_TOL_S",
    "TableSpec",
    "body_positions",
    "evaluate",
    "fit_batch",
    "fit_table",
    "fit_times",
    "lobatto_nodes",
    "position_kernel",
    "positions_batch_kernel",
    "positions_kernel",
]
