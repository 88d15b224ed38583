"""Statistics over seeds: bootstrap intervals, censored first-passage times, best-so-far curves.

* The interval of a median over seeds is the exact, distribution-free one from order statistics:
  with n seeds sorted, ``[x_(l), x_(n+1-l)]`` covers the true median with probability
  ``1 - 2 P(B <= l - 1)``, B ~ Binomial(n, 1/2), whatever the distribution (continuous; ties only
  widen it).  The largest ``l`` whose coverage reaches the nominal level is used, and that coverage
  is reported with the interval: with 5 seeds no interval reaches 95% (the seeds' range covers
  93.75%), so the range is given with its 93.75%, never called a 95% interval.  A percentile
  bootstrap of a median over 5 seeds gives about the same range but states a coverage it lacks.
* "Evaluations to reach a threshold" is a first-passage time that is *censored* for a run that
  never got there: all we know is that it would need more than its budget.  Such runs are coded
  ``+inf``, which orders correctly, so medians and bootstrap quantiles stay honest (a median of
  ``inf`` reads "not reached by at least half of the seeds") instead of flattering a designer by
  dropping its failures.
* The area under the best-so-far curve is reported divided by the number of evaluations, i.e.
  the mean best-so-far reward over the run, in reward units: two designers that end at the same
  best reward differ in it when one got there sooner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from ..statuses import COUNTED, OK

CONFIDENCE = 0.95
RESAMPLES = 2000
#: bootstrap resampling is seeded, so a report is a pure function of its tables
BOOTSTRAP_SEED = 0
#: rewards within this distance of a threshold count as reaching it (float round-off)
TOLERANCE = 1e-9

RUN_KEYS = ["designer", "seed"]


def censored(values: Sequence[float] | np.ndarray) -> np.ndarray:
    """First-passage times with "never reached" (NaN) coded as +inf."""
    v = np.asarray(values, dtype=float)
    return np.where(np.isnan(v), np.inf, v)


def censored_median(values: Sequence[float] | np.ndarray) -> float:
    """Median where NaN means "never reached" (+inf); inf when half or more never reached."""
    v = censored(values)
    return float(np.median(v)) if len(v) else math.nan


@lru_cache(maxsize=1024)
def order_statistic_ranks(n: int, confidence: float = CONFIDENCE) -> tuple[int, float]:
    """``(l, coverage)``: the interval ``[x_(l), x_(n+1-l)]`` of the median of ``n`` values and its exact coverage.

    ``l`` is the largest rank whose coverage is at least ``confidence``; when even the range
    (``l = 1``) falls short, ``l = 1`` and its coverage (``1 - 2^(1-n)``) is below ``confidence``.
    """
    if n < 1:
        return 0, math.nan
    pmf = [math.comb(n, i) / 2.0**n for i in range(n + 1)]
    best = 1
    for rank in range(1, (n + 1) // 2 + 1):
        if 1.0 - 2.0 * sum(pmf[:rank]) >= confidence - 1e-12:
            best = rank
        else:
            break
    return best, 1.0 - 2.0 * sum(pmf[:best])


def fewest_for(confidence: float = CONFIDENCE) -> int:
    """The fewest values whose median has an order-statistic interval of at least ``confidence`` (6 at 95%)."""
    return next(n for n in range(1, 64) if order_statistic_ranks(n, confidence)[1] >= confidence - 1e-12)


@dataclass(frozen=True)
class Interval:
    """A median and its order-statistic interval, with the interval's exact coverage."""

    median: float
    low: float
    high: float
    level: float
    n: int


def median_interval(values: Sequence[float] | np.ndarray, confidence: float = CONFIDENCE) -> Interval:
    """The median of ``values`` with its exact order-statistic interval (see the module docstring).

    +inf values (censored runs) sort last, so they give +inf bounds; NaN values are left out.
    """
    v = np.sort(np.asarray(values, dtype=float))
    v = v[~np.isnan(v)]
    n = len(v)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, math.nan, 0)
    rank, level = order_statistic_ranks(n, confidence)
    return Interval(float(np.median(v)), float(v[rank - 1]), float(v[n - rank]), level, n)


def counted_rows(run: pd.DataFrame) -> pd.DataFrame:
    """The rows of one run that used an evaluation, in evaluation order."""
    return run[run["status"].isin(COUNTED)].sort_values("n_evals", kind="stable")


def first_reach(run: pd.DataFrame, threshold: float, tol: float = TOLERANCE) -> float:
    """Evaluations the run used until its first body scoring at least ``threshold``; NaN if never."""
    ok = run[(run["status"] == OK) & (run["reward"] >= threshold - tol)]
    return float(ok["n_evals"].min()) if len(ok) else math.nan


def best_so_far_curve(run: pd.DataFrame, horizon: int) -> np.ndarray:
    """Best reward after ``n`` evaluations for ``n = 1..horizon``; NaN before the first success
    and beyond the evaluations the run has made so far."""
    rows = counted_rows(run)
    curve = np.full(horizon, np.nan)
    if rows.empty:
        return curve
    n = rows["n_evals"].to_numpy(dtype=np.int64)
    best = np.fmax.accumulate(rows["reward"].to_numpy(dtype=float))  # failed evaluations (NaN) never lower it
    grid = np.arange(1, horizon + 1)
    pos = np.searchsorted(n, grid, side="right") - 1
    done = (pos >= 0) & (grid <= n[-1])
    curve[done] = best[pos[done]]
    return curve


def mean_best_so_far(curve: np.ndarray) -> float:
    """Area under the best-so-far curve divided by the evaluations it covers (NaN parts skipped)."""
    finite = curve[~np.isnan(curve)]
    return float(finite.mean()) if len(finite) else math.nan


def median_band(
    curves: np.ndarray, *, confidence: float = CONFIDENCE
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per column of ``curves`` (runs x points): median over runs, its order-statistic interval and
    that interval's coverage (see :func:`median_interval`).

    NaN (a run that has not got that far) is left out of the column; a column without values is NaN.
    """
    runs, points = curves.shape
    ordered = np.sort(curves, axis=0)  # NaN sorts last
    counts = (~np.isnan(curves)).sum(axis=0)
    median, low, high, level = (np.full(points, np.nan) for _ in range(4))
    for n in np.unique(counts[counts > 0]):
        cols = np.flatnonzero(counts == n)
        rank, cover = order_statistic_ranks(int(n), confidence)
        part = ordered[:n, cols]
        median[cols] = np.median(part, axis=0)
        low[cols], high[cols], level[cols] = part[rank - 1], part[n - rank], cover
    return median, low, high, level


def generation_rewards(evaluations: pd.DataFrame) -> pd.DataFrame:
    """Min / mean / max reward of the bodies evaluated in each generation of each run.

    Only bodies scored in that generation count (``ok`` rows): duplicates were scored earlier,
    invalid bodies and failed evaluations have no reward.
    """
    ok = evaluations[evaluations["status"] == OK]
    keys = ["env", *RUN_KEYS, "generation"]
    if ok.empty:
        return pd.DataFrame(columns=keys + ["evaluated", "min", "mean", "max"])
    grouped = ok.groupby(keys, sort=False)["reward"]
    out = grouped.agg(evaluated="count", min="min", mean="mean", max="max").reset_index()
    return out.sort_values(keys, kind="stable", key=_designer_order(evaluations)).reset_index(drop=True)


def _designer_order(evaluations: pd.DataFrame) -> Callable[[pd.Series], pd.Series]:
    """Sort key that keeps designers in the order they appear in the run (the user's order)."""
    order = {name: i for i, name in enumerate(pd.unique(evaluations["designer"]))}

    def key(column: pd.Series) -> pd.Series:
        return column.map(order) if column.name == "designer" else column

    return key


def with_run_id(frame: pd.DataFrame) -> pd.DataFrame:
    """The table with ``run_id`` as text ('' for tables written before it existed)."""
    return frame.assign(run_id=frame["run_id"].astype(str) if "run_id" in frame.columns else "")
