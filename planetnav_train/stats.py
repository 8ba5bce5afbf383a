"""Small, pure statistics for comparing agents on held-out seeds (no environment, no SB3).

* :func:`mean_ci`: the mean of per-episode values with a two-sided Student-t confidence interval
  (``mean +- t_{1-a/2, n-1} * s / sqrt(n)``, ``s`` the sample standard deviation with ``n - 1``).
* :func:`paired_difference`: the same interval for the per-seed differences ``a_i - b_i`` of two agents
  run on the *same* seeds (the paired t-interval): the initial estimate error of a seed is shared, so
  the pairing removes most of the seed-to-seed scatter from the comparison.

The t-interval assumes roughly normal episode means; with 20 seeds it is the usual choice and is what the
reports state. Units are whatever the values carry (km in ``train.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats as _sps


@dataclass(frozen=True)
class MeanCI:
    """A mean with its two-sided confidence interval.

    mean: sample mean; low, high: interval bounds (NaN when ``n < 2``); n: sample size; std: sample
    standard deviation (ddof=1; NaN when ``n < 2``); confidence: the interval's level (e.g. 0.95).
    """

    mean: float
    low: float
    high: float
    n: int
    std: float
    confidence: float

    @property
    def half_width(self) -> float:
        """Half the interval's width (NaN when undefined)."""
        return 0.5 * (self.high - self.low)

    def excludes_zero(self) -> bool:
        """True when the whole interval lies on one side of 0 (the difference is outside the noise)."""
        return bool(self.low > 0.0 or self.high < 0.0)

    def to_dict(self) -> dict[str, float | int]:
        return {
            "mean": self.mean,
            "ci_low": self.low,
            "ci_high": self.high,
            "n": self.n,
            "std": self.std,
            "confidence": self.confidence,
        }

    def format(self, fmt: str = "{:.1f}") -> str:
        """``"mean [low, high]"``, or just the mean when the interval is undefined."""
        if not math.isfinite(self.low):
            return fmt.format(self.mean)
        return f"{fmt.format(self.mean)} [{fmt.format(self.low)}, {fmt.format(self.high)}]"


def _values(values: Sequence[float] | np.ndarray, what: str) -> np.ndarray:
    x = np.asarray(values, dtype=float).reshape(-1)
    if x.size == 0:
        raise ValueError(f"{what}: no values")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{what}: values must be finite, got {x.tolist()}")
    return x


def mean_ci(values: Sequence[float] | np.ndarray, confidence: float = 0.95) -> MeanCI:
    """Mean and two-sided Student-t interval of ``values`` (bounds NaN for a single value)."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    x = _values(values, "mean_ci")
    n = int(x.size)
    mean = float(np.mean(x))
    if n < 2:
        return MeanCI(mean, math.nan, math.nan, n, math.nan, confidence)
    std = float(np.std(x, ddof=1))
    half = float(_sps.t.ppf(0.5 + 0.5 * confidence, n - 1)) * std / math.sqrt(n)
    return MeanCI(mean, mean - half, mean + half, n, std, confidence)


def paired_difference(
    a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray, confidence: float = 0.95
) -> MeanCI:
    """Mean of ``a_i - b_i`` with its paired t-interval; ``a`` and ``b`` must come from the same seeds."""
    xa, xb = _values(a, "paired_difference a"), _values(b, "paired_difference b")
    if xa.shape != xb.shape:
        raise ValueError(f"paired_difference needs equal lengths (same seeds), got {xa.size} and {xb.size}")
    return mean_ci(xa - xb, confidence)
