"""planetnav_train.stats against scipy.stats: the t-interval of a mean and the paired t-interval."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from planetnav_train.stats import mean_ci, paired_difference


@pytest.mark.parametrize("n", [2, 5, 20])
@pytest.mark.parametrize("confidence", [0.9, 0.95])
def test_mean_ci_equals_scipy_t_interval(n: int, confidence: float) -> None:
    x = np.random.default_rng(n).lognormal(4.0, 0.5, n)
    ci = mean_ci(x, confidence)
    low, high = stats.t.interval(confidence, n - 1, loc=np.mean(x), scale=stats.sem(x))
    assert ci.mean == pytest.approx(np.mean(x), rel=1e-12)
    assert (ci.low, ci.high) == pytest.approx((low, high), rel=1e-12)
    assert ci.n == n and ci.std == pytest.approx(np.std(x, ddof=1), rel=1e-12)
    assert ci.half_width == pytest.approx(0.5 * (high - low), rel=1e-12)


def test_paired_difference_equals_scipy_ttest_rel() -> None:
    rng = np.random.default_rng(7)
    shared = rng.lognormal(5.0, 0.6, 20)  # the seed's own difficulty, common to both agents
    a, b = shared + rng.normal(0, 5, 20), 1.3 * shared + rng.normal(0, 5, 20)
    d = paired_difference(a, b)
    ref = stats.ttest_rel(a, b).confidence_interval(0.95)
    assert d.mean == pytest.approx(np.mean(a - b), rel=1e-12)
    assert (d.low, d.high) == pytest.approx((ref.low, ref.high), rel=1e-12)
    assert d.excludes_zero() and d.high < 0.0
    # Pairing is what makes the comparison tight: the unpaired intervals of a and b overlap.
    ca, cb = mean_ci(a), mean_ci(b)
    assert ca.high > cb.low


def test_degenerate_and_bad_input() -> None:
    one = mean_ci([3.0])
    assert one.mean == 3.0 and math.isnan(one.low) and one.format() == "3.0"
    same = mean_ci([1.0, 1.0])  # no scatter: a zero-width interval at the mean
    assert (same.low, same.high) == (1.0, 1.0) and same.excludes_zero()
    with pytest.raises(ValueError, match="no values"):
        mean_ci([])
    with pytest.raises(ValueError, match="finite"):
        mean_ci([1.0, math.nan])
    with pytest.raises(ValueError, match="confidence"):
        mean_ci([1.0, 2.0], confidence=95)
    with pytest.raises(ValueError, match="same seeds"):
        paired_difference([1.0, 2.0], [1.0, 2.0, 3.0])
    assert mean_ci([1.0, 3.0]).format("{:.0f}").startswith("2 [")
