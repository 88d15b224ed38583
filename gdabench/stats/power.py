"""How many seeds a comparison needs: power of the paired Wilcoxon signed-rank test.

The effect is given as Vargha-Delaney's A12 (the probability that designer A's run beats
designer B's), the effect size the pairwise tables report.  The model behind the estimate:

* the per-seed differences A - B are normal.  For two independent normal outcomes of equal
  spread, A12 = Phi(delta / (sigma * sqrt 2)) and the differences have standardised mean
  ``d = delta / (sigma * sqrt 2) = Phi^-1(A12)``.  Seeds that make the two runs alike (the
  shared first generation of ga, gda and random) shrink the differences' spread, so with paired
  seeds the true power is higher: the estimate is conservative;
* the test is the exact two-sided signed-rank test at level ``alpha / comparisons`` (the level
  Holm's procedure applies to the smallest p-value of ``comparisons`` tests, so a bound for all);
* its power at n seeds is estimated by simulation: ``draws`` samples of n differences (fixed
  random seed), each rejected when its signed-rank statistic falls in the exact critical region.

The smallest n with power at least ``power`` is found by bisection around Noether's normal
approximation (power grows with n up to the simulation's noise, so the answer is good to a seed
or two).  Below ``minimum_seeds(alpha)`` no
outcome at all can be significant.
"""

from __future__ import annotations

import math
from functools import lru_cache
from statistics import NormalDist

import numpy as np

ALPHA = 0.05
POWER = 0.8
DRAWS = 2000
POWER_SEED = 0
MAX_SEEDS = 1000
EXACT_UP_TO = 100
#: the standard normal (the standard library's: a run's pre-flight warnings then need no scipy import,
#: which was half of a small ``compare``'s time)
NORMAL = NormalDist()
#: A12 at the Vargha-Delaney thresholds of a small, medium and large effect, and a very large one
REFERENCE_EFFECTS = ((0.56, "small"), (0.64, "medium"), (0.71, "large"), (0.9, "very large"))


@lru_cache(maxsize=256)
def _null_cdf(n: int) -> np.ndarray:
    """P(W+ <= w) for w = 0..n(n+1)/2 under the null (no ties): the exact signed-rank distribution."""
    pmf = np.zeros(n * (n + 1) // 2 + 1)
    pmf[0] = 1.0
    for k in range(1, n + 1):  # rank k is positive or negative with probability 1/2
        shifted = np.zeros_like(pmf)
        shifted[k:] = pmf[:-k]
        pmf = (pmf + shifted) / 2.0
    return np.cumsum(pmf)


def critical_value(n: int, alpha: float) -> int:
    """Largest c with P(W+ <= c) <= alpha / 2: the two-sided exact test rejects when W+ <= c or
    W+ >= n(n+1)/2 - c.  -1 when no outcome is significant at ``alpha``.

    Exact up to :data:`EXACT_UP_TO` pairs; beyond, the normal approximation with continuity
    correction (what scipy's ``wilcoxon`` switches to as well), which is then within a rank or two.
    """
    if n > EXACT_UP_TO:
        mean, sd = n * (n + 1) / 4.0, math.sqrt(n * (n + 1) * (2 * n + 1) / 24.0)
        return math.floor(mean + NORMAL.inv_cdf(alpha / 2.0) * sd - 0.5)
    cdf = _null_cdf(n)
    below = np.nonzero(cdf <= alpha / 2.0 + 1e-12)[0]
    return int(below[-1]) if len(below) else -1


def minimum_seeds(alpha: float = ALPHA) -> int:
    """Fewest pairs with which the exact two-sided signed-rank test can reach p <= alpha (2 / 2^n)."""
    return max(1, math.ceil(math.log2(2.0 / alpha)))


def power(n: int, a12: float, *, alpha: float = ALPHA, draws: int = DRAWS, seed: int = POWER_SEED) -> float:
    """Simulated power of the exact two-sided signed-rank test with ``n`` pairs at effect ``a12``."""
    c = critical_value(n, alpha)
    if c < 0:
        return 0.0
    d = NORMAL.inv_cdf(a12)
    diffs = np.random.default_rng(seed).standard_normal((draws, n)) + d
    by_size = np.take_along_axis(diffs > 0, np.argsort(np.abs(diffs), axis=1), axis=1)
    w_plus = by_size @ np.arange(1, n + 1)  # sum of the ranks of the positive differences
    top = n * (n + 1) // 2
    return float(np.mean((w_plus <= c) | (w_plus >= top - c)))


def noether(a12: float, *, alpha: float = ALPHA, target_power: float = POWER) -> float:
    """Noether's (1987) normal approximation of the pairs the signed-rank test needs."""
    p = NORMAL.cdf(math.sqrt(2.0) * NORMAL.inv_cdf(a12))  # P(D1 + D2 > 0)
    return (NORMAL.inv_cdf(1.0 - alpha / 2.0) + NORMAL.inv_cdf(target_power)) ** 2 / (3.0 * (p - 0.5) ** 2)


@lru_cache(maxsize=1024)
def seeds_needed(
    a12: float,
    *,
    alpha: float = ALPHA,
    target_power: float = POWER,
    comparisons: int = 1,
    max_seeds: int = MAX_SEEDS,
) -> int | None:
    """Seeds (pairs) for the paired test to detect effect ``a12`` with ``target_power`` at
    ``alpha / comparisons``; None when even ``max_seeds`` would not do or there is no effect."""
    if not 0.0 < a12 < 1.0 or abs(a12 - 0.5) < 1e-9:
        return None
    a12 = max(a12, 1.0 - a12)  # the test is two-sided
    level = alpha / max(1, comparisons)
    fewest = minimum_seeds(level)
    guess = min(noether(a12, alpha=level, target_power=target_power), max_seeds)  # bracket the answer around it
    lo, hi = max(fewest, int(0.7 * guess)), min(max_seeds, max(fewest, math.ceil(1.3 * guess) + 2))
    if lo > fewest and power(lo, a12, alpha=level) >= target_power:
        lo = fewest
    while power(hi, a12, alpha=level) < target_power:
        if hi >= max_seeds:
            return None
        lo, hi = hi + 1, min(2 * hi, max_seeds)
    while lo < hi:
        mid = (lo + hi) // 2
        if power(mid, a12, alpha=level) >= target_power:
            hi = mid
        else:
            lo = mid + 1
    return lo

