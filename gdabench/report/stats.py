"""Statistics over seeds: bootstrap intervals, censored first-passage times, best-so-far curves.

* Confidence intervals are percentile bootstraps over seeds (resample the seeds with
  replacement, recompute the statistic).  With ten seeds the sampling distribution of a median is
  neither normal nor known, and the bootstrap assumes neither.  The resampling uses a fixed seed,
  so the same table always gets the same interval.
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
import warnings
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


def bootstrap_ci(
    values: Sequence[float] | np.ndarray,
    statistic: Callable[..., np.ndarray] = np.median,
    *,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``statistic`` (called with ``axis=1``) over ``values``.

    Quantiles are taken with the inverted-CDF rule (no interpolation), so +inf values from
    censored runs give +inf bounds instead of NaN.
    """
    v = np.asarray(values, dtype=float)
    if len(v) == 0:
        return math.nan, math.nan
    if len(v) == 1:
        return float(v[0]), float(v[0])
    rng = np.random.default_rng(seed)
    stats = statistic(v[rng.integers(0, len(v), size=(resamples, len(v)))], axis=1)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(stats, [alpha, 1.0 - alpha], method="inverted_cdf")
    return float(low), float(high)


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
    curves: np.ndarray,
    *,
    confidence: float = CONFIDENCE,
    resamples: int = 1000,
    seed: int = BOOTSTRAP_SEED,
    chunk: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column of ``curves`` (runs x points): median over runs and its bootstrap interval.

    Runs are resampled as whole curves, so the band respects that one run's points are
    correlated.  NaN (a run that has not got that far) is left out of the median.
    """
    runs, points = curves.shape
    median_of = np.nanmedian if np.isnan(curves).any() else np.median  # same result; np.median is much faster
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns give NaN, as they should
        median = median_of(curves, axis=0) if runs else np.full(points, np.nan)
        if runs < 2:
            return median, median.copy(), median.copy()
        rng = np.random.default_rng(seed)
        draws = np.empty((resamples, points))
        for start in range(0, resamples, chunk):
            idx = rng.integers(0, runs, size=(min(chunk, resamples - start), runs))
            draws[start : start + len(idx)] = median_of(curves[idx], axis=1)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.nanquantile(draws, [alpha, 1.0 - alpha], axis=0, method="inverted_cdf")
    return median, low, high


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
