"""Intervals whose coverage is stated: the exact order-statistic interval of a median over seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from gdabench.report.tables import with_interval
from gdabench.stats.core import fewest_for, median_band, median_interval, order_statistic_ranks


@pytest.mark.parametrize("n", [1, 2, 5, 6, 7, 10, 15, 20, 40])
def test_ranks_and_coverage_are_the_binomial_ones(n):
    rank, level = order_statistic_ranks(n)
    assert level == pytest.approx(1 - 2 * binom.cdf(rank - 1, n, 0.5))
    if level >= 0.95:  # the largest rank that keeps 95%: one more would fall short
        assert 1 - 2 * binom.cdf(rank, n, 0.5) < 0.95 or rank == (n + 1) // 2
    else:  # too few seeds: the range, with its own coverage
        assert rank == 1 and level == pytest.approx(1 - 2.0 ** (1 - n))


def test_five_seeds_cannot_have_a_95_percent_interval():
    assert order_statistic_ranks(5) == (1, 0.9375)
    assert fewest_for(0.95) == 6 and fewest_for(0.99) == 8


@pytest.mark.parametrize("n", [5, 10])
def test_stated_coverage_holds_by_simulation(n):
    """10,000 draws of n seeds from a skewed distribution: the share of intervals that hold the true median
    is the stated coverage within 1 point (the simulation's standard error is about 0.2 points)."""
    rng = np.random.default_rng(12345)
    draws = rng.lognormal(0.0, 1.0, size=(10_000, n))  # true median exp(0) = 1
    stated = order_statistic_ranks(n)[1]
    hits = [(iv.low <= 1.0 <= iv.high) for iv in map(median_interval, draws)]
    assert abs(np.mean(hits) - stated) < 0.01


def test_band_is_the_interval_of_every_column_and_skips_missing_runs():
    curves = np.array([[1.0, 5.0], [2.0, 4.0], [3.0, np.nan], [4.0, 2.0], [5.0, 1.0], [6.0, 3.0]])
    median, low, high, level = median_band(curves)
    for col in range(2):
        expected = median_interval(curves[:, col])
        assert (median[col], low[col], high[col], level[col]) == (expected.median, expected.low, expected.high,
                                                                  expected.level)  # fmt: skip
    assert level[0] == pytest.approx(0.96875) and level[1] == 0.9375  # 6 runs, then 5 (one had not got there)


def test_a_short_interval_says_its_coverage():
    assert with_interval(3.0, 1.0, 5.0, level=0.9375) == "3 [1, 5] 93.8%"
    assert with_interval(3.0, 1.0, 5.0, level=0.96875) == "3 [1, 5]"
    assert with_interval(3.0, 1.0, math.inf) == "3 [1, not reached]"
